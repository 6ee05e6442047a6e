#include "ibvs/task.hpp"

#include "checks.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs {

Feature::~Feature() = default;

void Feature::align(double*, const double*) const noexcept {}
std::uint64_t Feature::axis_angle_rows(const double*, const double*) const noexcept { return 0; }

void Feature::error(const double* m, const double* m_desired, double* e) const noexcept {
  double s[64], sd[64];  // the default: s - s*, for blocks of at most 64 rows (others override it)
  value(m, s);
  value(m_desired, sd);
  for (int i = 0; i < rows(); ++i) e[i] = s[i] - sd[i];
}

const char* Feature::evaluate(double* m, const double* m_desired, double* e, Eigen::Ref<MatrixX6> L) const noexcept {
  int entry = -1;
  if (const char* why = check(m, entry)) return why;
  if (const char* why = check(m_desired, entry)) return why;
  align(m, m_desired);
  error(m, m_desired, e);
  interaction(m, L);
  return nullptr;
}

void Feature::validate(const double* m, const std::string& name) const {
  int entry = -1;
  if (const char* why = check(m, entry))
    throw std::invalid_argument("ibvs: " + name + (entry >= 0 ? "[" + std::to_string(entry) + "]" : std::string()) +
                                ": " + why);
}

Task::Task(Layout points) : points_(std::move(points)) {}
Task::Task() : points_(Layout::none()) {}
Task::Task(const Task&) = default;
Task::Task(Task&&) noexcept = default;
Task& Task::operator=(const Task&) = default;
Task& Task::operator=(Task&&) noexcept = default;
Task::~Task() = default;

namespace {
void check_weight(double w, const std::string& name) {
  if (!(std::isfinite(w) && w >= 1.0 / max_task_weight && w <= max_task_weight))
    throw std::invalid_argument("ibvs: " + name + " must be finite and in [" + detail::number(1.0 / max_task_weight) +
                                ", " + detail::number(max_task_weight) + "], got " + detail::number(w));
}
}  // namespace

Task& Task::add(const Feature& feature, double weight) {
  check_weight(weight, "weight");
  const int k = feature.rows(), size = feature.size();
  if (k < 1 || size < 0) throw std::invalid_argument("ibvs: a feature block needs at least one row");
  if (feature_rows_ + k > max_feature_rows)
    throw std::invalid_argument("ibvs: a task holds at most " + std::to_string(max_feature_rows) +
                                " rows of feature blocks");
  blocks_.push_back({std::shared_ptr<const Feature>(feature.clone()), weight, points_.rows() + feature_rows_,
                     measurement_size_});
  feature_rows_ += k;
  measurement_size_ += size;
  return *this;
}

Task& Task::set_point_weights(std::vector<double> weights) {
  if (static_cast<int>(weights.size()) != static_cast<int>(points_.blocks().size()))
    throw std::invalid_argument("ibvs: point_weights must hold one weight per block of the layout (" +
                                std::to_string(points_.blocks().size()) + "), got " + std::to_string(weights.size()));
  bool all_one = true;
  for (std::size_t i = 0; i < weights.size(); ++i) {
    check_weight(weights[i], "point_weights[" + std::to_string(i) + "]");
    all_one = all_one && weights[i] == 1.0;
  }
  point_weights_ = all_one ? std::vector<double>{} : std::move(weights);
  return *this;
}

Task& Task::set_dof(const Dof& dof) {
  bool any = false;
  for (bool b : dof) any = any || b;
  if (!any) throw std::invalid_argument("ibvs: dof must select at least one of the six twist components");
  dof_ = dof;
  return *this;
}

int Task::n_dof() const noexcept {
  int n = 0;
  for (bool b : dof_) n += b;
  return n;
}

std::string Task::describe() const {
  std::string s = has_points() ? points_.describe() : std::string();
  for (const Block& b : blocks_) {
    if (!s.empty()) s += " + ";
    s += b.feature->describe();
    if (b.weight != 1.0) s += " x " + detail::number(b.weight);
  }
  if (!point_weights_.empty()) s += ", point weights";
  if (dof_ != all_dof) {
    static const char* names[6] = {"Tx", "Ty", "Tz", "wx", "wy", "wz"};
    s += ", dof ";
    bool first = true;
    for (int i = 0; i < 6; ++i)
      if (dof_[static_cast<std::size_t>(i)]) {
        s += (first ? "" : " ") + std::string(names[i]);
        first = false;
      }
  }
  return s.empty() ? "empty" : s;
}

}  // namespace ibvs
