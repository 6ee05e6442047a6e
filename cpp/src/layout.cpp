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

void check_count(long long n, const char* who) {
  if (n < 1 || n > max_points)
    throw std::invalid_argument(std::string("ibvs: Layout.") + who + ": n must be in [1, " + std::to_string(max_points) +
                                "], got " + std::to_string(n));
}

Layout uniform(int n, std::initializer_list<Representation> reps, const char* who) {
  check_count(n, who);
  std::vector<Block> blocks;
  blocks.reserve(static_cast<std::size_t>(n) * reps.size());
  for (int i = 0; i < n; ++i)
    for (Representation r : reps) blocks.push_back({i, r});
  return Layout(std::move(blocks), n);
}

// The uniform layouts describe() recognises: name and representations per point, in block order.
struct Kind {
  const char* name;
  Representation reps[2];
  std::size_t per;
};
const Kind kinds[] = {{"cartesian", {Representation::cartesian}, 1},
                      {"polar", {Representation::polar}, 1},
                      {"stacked", {Representation::cartesian, Representation::polar}, 2},
                      {"cylindrical", {Representation::cylindrical}, 1}};

}  // namespace

// Linear time: a table of the (point, representation) pairs seen instead of comparing every pair.
Layout::Layout(std::vector<Block> blocks, int n_points) : blocks_(std::move(blocks)) {
  if (blocks_.empty()) throw std::invalid_argument("ibvs: Layout: blocks must not be empty");
  if (blocks_.size() > static_cast<std::size_t>(3) * max_points)
    throw std::invalid_argument("ibvs: Layout: at most " + std::to_string(3LL * max_points) + " blocks, got " +
                                std::to_string(blocks_.size()));
  if (n_points > max_points)
    throw std::invalid_argument("ibvs: Layout: n_points must be <= " + std::to_string(max_points) + ", got " +
                                std::to_string(n_points));
  int max_index = -1;
  for (std::size_t k = 0; k < blocks_.size(); ++k) {
    const Block& b = blocks_[k];
    if (b.point < 0 || b.point >= max_points)
      throw std::invalid_argument("ibvs: Layout: blocks[" + std::to_string(k) + "] has point index " +
                                  std::to_string(b.point) + ", outside [0, " + std::to_string(max_points) + ")");
    if (b.representation != Representation::cartesian && b.representation != Representation::polar &&
        b.representation != Representation::cylindrical)
      throw std::invalid_argument("ibvs: Layout: blocks[" + std::to_string(k) + "] has an unknown representation");
    max_index = std::max(max_index, b.point);
  }
  if (n_points < 0) n_points = max_index + 1;
  if (max_index >= n_points)
    throw std::invalid_argument("ibvs: Layout: point index " + std::to_string(max_index) +
                                " out of range for n_points = " + std::to_string(n_points));
  std::vector<unsigned char> seen(static_cast<std::size_t>(n_points), 0);
  for (std::size_t k = 0; k < blocks_.size(); ++k) {
    const Block& b = blocks_[k];
    const auto bit = static_cast<unsigned char>(1u << static_cast<unsigned>(b.representation));
    unsigned char& s = seen[static_cast<std::size_t>(b.point)];
    if (s & bit)
      throw std::invalid_argument("ibvs: Layout: blocks[" + std::to_string(k) + "] repeats (" +
                                  std::to_string(b.point) + ", " + name_of(b.representation) + ")");
    s = static_cast<unsigned char>(s | bit);
  }
  n_points_ = n_points;
}

// Special members out of line (the block vector is allocated and freed by the library's code).
Layout::Layout(const Layout&) = default;
Layout::Layout(Layout&&) noexcept = default;
Layout& Layout::operator=(const Layout&) = default;
Layout& Layout::operator=(Layout&&) noexcept = default;
Layout::~Layout() = default;

Layout Layout::cartesian(int n) { return uniform(n, {Representation::cartesian}, "cartesian"); }
Layout Layout::polar(int n) { return uniform(n, {Representation::polar}, "polar"); }
Layout Layout::stacked(int n) { return uniform(n, {Representation::cartesian, Representation::polar}, "stacked"); }
Layout Layout::cylindrical(int n) { return uniform(n, {Representation::cylindrical}, "cylindrical"); }
Layout Layout::none() { return Layout(); }

bool Layout::operator==(const Layout& o) const noexcept {
  if (n_points_ != o.n_points_ || blocks_.size() != o.blocks_.size()) return false;
  for (std::size_t k = 0; k < blocks_.size(); ++k)
    if (blocks_[k].point != o.blocks_[k].point || blocks_[k].representation != o.blocks_[k].representation)
      return false;
  return true;
}

std::string Layout::describe() const {
  if (blocks_.empty()) return "none";
  const auto n = static_cast<std::size_t>(n_points_);
  for (const Kind& kind : kinds) {
    bool same = blocks_.size() == n * kind.per;
    for (std::size_t k = 0; same && k < blocks_.size(); ++k)
      same = blocks_[k].point == static_cast<int>(k / kind.per) && blocks_[k].representation == kind.reps[k % kind.per];
    if (same) return std::string(kind.name) + "(" + std::to_string(n_points_) + ")";
  }
  std::string s = "[";
  s.reserve(blocks_.size() * 20);
  int max_index = -1;
  for (std::size_t k = 0; k < blocks_.size(); ++k) {
    if (k) s += ", ";
    s += "(" + std::to_string(blocks_[k].point) + ", '" + name_of(blocks_[k].representation) + "')";
    max_index = std::max(max_index, blocks_[k].point);
  }
  s += "]";
  // n_points only when the blocks do not imply it (points beyond the largest index).
  if (n_points_ != max_index + 1) s += ", n_points=" + std::to_string(n_points_);
  return s;
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
      J.middleRows<2>(row) = cylindrical_jacobian(r, c, s, polar_angle(u, v), z);
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

void validate_points(const Eigen::Ref<const Points>& uv, const char* name) {
  detail::check_points(uv, name, static_cast<int>(uv.cols()));
}

void validate_depths(const Eigen::Ref<const Eigen::VectorXd>& depth, const char* name, Eigen::Index n) {
  detail::check_depth(depth, name, static_cast<int>(n));
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

namespace {

// Feature values a layout's features() can produce (within the coordinate bound): Cartesian
// |u|, |v| <= max_normalized_coordinate; polar and cylindrical 0 <= r <= sqrt(2) of it, polar
// theta any finite angle (it is wrapped), cylindrical |r theta| <= pi r (up to rounding).
void check_feature_values(const Layout& layout, const Eigen::Ref<const Eigen::VectorXd>& f, const char* name) {
  const double rmax = std::sqrt(2.0) * max_normalized_coordinate;
  Eigen::Index row = 0;
  for (const Block& b : layout.blocks()) {
    const double a = f(row), c = f(row + 1);
    const bool ok = b.representation == Representation::cartesian
                        ? detail::valid_coordinate(a) && detail::valid_coordinate(c)
                        : a >= 0.0 && a <= rmax &&
                              (b.representation == Representation::polar || std::abs(c) <= pi * a * (1.0 + 1e-12));
    if (!ok)
      throw std::invalid_argument(std::string("ibvs: ") + name + "[" + std::to_string(row) + ":" +
                                  std::to_string(row + 2) + "] = (" + detail::number(a) + ", " + detail::number(c) +
                                  ") is not a " + name_of(b.representation) +
                                  " feature of a point within the normalised-coordinate bound " +
                                  detail::number(max_normalized_coordinate) + " (pixels? see ibvs.CameraModel.normalize)");
    row += 2;
  }
}

}  // namespace

Eigen::VectorXd feature_error(const Layout& layout, const Eigen::Ref<const Eigen::VectorXd>& f,
                              const Eigen::Ref<const Eigen::VectorXd>& f_desired, AngleWrap wrap) {
  detail::check_features(f, "f", layout.rows());
  detail::check_features(f_desired, "f_desired", layout.rows());
  check_feature_values(layout, f, "f");
  check_feature_values(layout, f_desired, "f_desired");
  detail::check_angle_wrap(wrap);
  Eigen::VectorXd e(layout.rows());
  stacked_error(layout, f, f_desired, e, wrap);
  return e;
}

}  // namespace ibvs
