#include "ibvs/layout.hpp"

#include "checks.hpp"

#include <algorithm>
#include <stdexcept>

namespace ibvs {
namespace {

const char* name_of(Representation r) {
  switch (r) {
    case Representation::polar: return "polar";
    case Representation::cylindrical: return "cylindrical";
    default: return "cartesian";
  }
}

// Direction (c, s) of (u, v) at radius r; at r = 0 that of the other point
// (ua, va) at radius ra, and (1, 0) when both are at the principal point.
inline void direction(double u, double v, double r, double ua, double va, double ra, double& c, double& s) noexcept {
  if (r > 0.0) {
    c = u / r;
    s = v / r;
  } else if (ra > 0.0) {
    c = ua / ra;
    s = va / ra;
  } else {
    c = 1.0;
    s = 0.0;
  }
}

Layout uniform(int n, std::initializer_list<Representation> reps, const char* who) {
  if (n < 1) throw std::invalid_argument(std::string("ibvs: Layout.") + who + ": n must be >= 1, got " + std::to_string(n));
  std::vector<Block> blocks;
  blocks.reserve(static_cast<std::size_t>(n) * reps.size());
  for (int i = 0; i < n; ++i)
    for (Representation r : reps) blocks.push_back({i, r});
  return Layout(std::move(blocks), n);
}

}  // namespace

Layout::Layout(std::vector<Block> blocks, int n_points) : blocks_(std::move(blocks)) {
  if (blocks_.empty()) throw std::invalid_argument("ibvs: Layout: blocks must not be empty");
  int max_index = -1;
  for (std::size_t k = 0; k < blocks_.size(); ++k) {
    const Block& b = blocks_[k];
    if (b.point < 0)
      throw std::invalid_argument("ibvs: Layout: blocks[" + std::to_string(k) + "] has negative point index " +
                                  std::to_string(b.point));
    if (b.representation != Representation::cartesian && b.representation != Representation::polar &&
        b.representation != Representation::cylindrical)
      throw std::invalid_argument("ibvs: Layout: blocks[" + std::to_string(k) + "] has an unknown representation");
    for (std::size_t j = 0; j < k; ++j)
      if (blocks_[j].point == b.point && blocks_[j].representation == b.representation)
        throw std::invalid_argument("ibvs: Layout: blocks[" + std::to_string(k) + "] repeats (" +
                                    std::to_string(b.point) + ", " + name_of(b.representation) + ")");
    max_index = std::max(max_index, b.point);
  }
  if (n_points < 0) n_points = max_index + 1;
  if (max_index >= n_points)
    throw std::invalid_argument("ibvs: Layout: point index " + std::to_string(max_index) +
                                " out of range for n_points = " + std::to_string(n_points));
  n_points_ = n_points;
}

Layout Layout::cartesian(int n) { return uniform(n, {Representation::cartesian}, "cartesian"); }
Layout Layout::polar(int n) { return uniform(n, {Representation::polar}, "polar"); }
Layout Layout::stacked(int n) { return uniform(n, {Representation::cartesian, Representation::polar}, "stacked"); }
Layout Layout::cylindrical(int n) { return uniform(n, {Representation::cylindrical}, "cylindrical"); }

bool Layout::operator==(const Layout& o) const noexcept {
  if (n_points_ != o.n_points_ || blocks_.size() != o.blocks_.size()) return false;
  for (std::size_t k = 0; k < blocks_.size(); ++k)
    if (blocks_[k].point != o.blocks_[k].point || blocks_[k].representation != o.blocks_[k].representation)
      return false;
  return true;
}

std::string Layout::describe() const {
  for (const char* kind : {"cartesian", "polar", "stacked", "cylindrical"}) {
    const std::string k(kind);
    const Layout ref = k == "cartesian" ? cartesian(n_points_)
                       : k == "polar"   ? polar(n_points_)
                       : k == "stacked" ? stacked(n_points_)
                                        : cylindrical(n_points_);
    if (ref == *this) return k + "(" + std::to_string(n_points_) + ")";
  }
  std::string s = "[";
  for (std::size_t k = 0; k < blocks_.size(); ++k) {
    if (k) s += ", ";
    s += "(" + std::to_string(blocks_[k].point) + ", '" + name_of(blocks_[k].representation) + "')";
  }
  return s + "]";
}

void stacked_features(const Layout& layout, const Eigen::Ref<const Points>& uv,
                      Eigen::Ref<Eigen::VectorXd> f) noexcept {
  Eigen::Index row = 0;
  for (const Block& b : layout.blocks()) {
    const double u = uv(0, b.point), v = uv(1, b.point);
    switch (b.representation) {
      case Representation::polar: f.segment<2>(row) = polar_features(u, v); break;
      case Representation::cylindrical: f.segment<2>(row) = cylindrical_features(u, v); break;
      default: f.segment<2>(row) = Eigen::Vector2d(u, v); break;
    }
    row += 2;
  }
}

void stacked_jacobian(const Layout& layout, const Eigen::Ref<const Points>& uv,
                      const Eigen::Ref<const Eigen::VectorXd>& depth, Eigen::Ref<MatrixX6> J,
                      double polar_min_radius) noexcept {
  Eigen::Index row = 0;
  for (const Block& b : layout.blocks()) {
    const double u = uv(0, b.point), v = uv(1, b.point), z = depth(b.point);
    if (b.representation == Representation::cylindrical) {
      // Angle origin theta0 = 0: the derivative of cylindrical_features(); no fallback (bounded rows).
      const double r = std::sqrt(u * u + v * v);
      double c, s;
      direction(u, v, r, u, v, r, c, s);
      J.middleRows<2>(row) = cylindrical_jacobian(r, c, s, std::atan2(v, u), z);
      row += 2;
      continue;
    }
    const bool polar =
        b.representation == Representation::polar && !polar_falls_back(u * u + v * v, polar_min_radius);
    J.middleRows<2>(row) = polar ? polar_jacobian(u, v, z) : cartesian_jacobian(u, v, z);
    row += 2;
  }
}

void stacked_error(const Layout& layout, const Eigen::Ref<const Eigen::VectorXd>& f,
                   const Eigen::Ref<const Eigen::VectorXd>& f_desired, Eigen::Ref<Eigen::VectorXd> e,
                   AngleWrap wrap) noexcept {
  // Pass 1: plain differences; angle rows hold their difference in (-pi, pi] (eq. 13),
  // and the unit vectors of those with both radii > 0 are summed.
  AngleResultant sum;
  Eigen::Index row = 0;
  for (const Block& b : layout.blocks()) {
    e(row) = f(row) - f_desired(row);
    if (b.representation == Representation::cartesian) {
      e(row + 1) = f(row + 1) - f_desired(row + 1);
    } else {
      // theta = (r theta) / r for a cylindrical block; its angle counts only when both radii are > 0
      // (at the principal point the angle is taken to be the other point's: difference 0).
      const double r = f(row), rd = f_desired(row);
      const bool cyl = b.representation == Representation::cylindrical;
      const bool both = r > 0.0 && rd > 0.0;
      const double d = !both && cyl ? 0.0
                       : cyl        ? wrap_angle(f(row + 1) / r - f_desired(row + 1) / rd)
                                    : wrap_angle(f(row + 1) - f_desired(row + 1));
      if (both && wrap == AngleWrap::consistent) sum.add(std::cos(d), std::sin(d));
      e(row + 1) = d;
    }
    row += 2;
  }
  // Pass 2: the consistent wrap about the circular mean; cylindrical rows become arcs r d.
  const bool about_mean = wrap == AngleWrap::consistent && sum.defined();
  const double centre = sum.mean();
  row = 0;
  for (const Block& b : layout.blocks()) {
    if (b.representation != Representation::cartesian) {
      const double d = about_mean ? wrap_about(e(row + 1), centre) : e(row + 1);
      e(row + 1) = b.representation == Representation::cylindrical ? f(row) * d : d;
    }
    row += 2;
  }
}

Eigen::VectorXd features(const Layout& layout, const Eigen::Ref<const Points>& uv) {
  detail::check_points(uv, "uv", layout.n_points());
  Eigen::VectorXd f(layout.rows());
  stacked_features(layout, uv, f);
  return f;
}

MatrixX6 jacobian(const Layout& layout, const Eigen::Ref<const Points>& uv,
                  const Eigen::Ref<const Eigen::VectorXd>& depth, double polar_min_radius) {
  detail::check_points(uv, "uv", layout.n_points());
  detail::check_depth(depth, "depth", layout.n_points());
  detail::check_nonnegative(polar_min_radius, "polar_min_radius");
  MatrixX6 J(layout.rows(), 6);
  stacked_jacobian(layout, uv, depth, J, polar_min_radius);
  return J;
}

Eigen::VectorXd feature_error(const Layout& layout, const Eigen::Ref<const Eigen::VectorXd>& f,
                              const Eigen::Ref<const Eigen::VectorXd>& f_desired, AngleWrap wrap) {
  detail::check_features(f, "f", layout.rows());
  detail::check_features(f_desired, "f_desired", layout.rows());
  detail::check_angle_wrap(wrap);
  Eigen::VectorXd e(layout.rows());
  stacked_error(layout, f, f_desired, e, wrap);
  return e;
}

}  // namespace ibvs
