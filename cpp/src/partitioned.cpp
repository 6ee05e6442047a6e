#include "ibvs/partitioned.hpp"

#include "checks.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ibvs {

using Row6 = Eigen::Matrix<double, 1, 6>;

double segment_angle(const Eigen::Ref<const Points>& uv, int i, int j) noexcept {
  const double du = uv(0, j) - uv(0, i), dv = uv(1, j) - uv(1, i);
  // Coincident points have no segment: NaN, as the Jacobian's 0 / 0 (atan2(0, 0) would say 0).
  if (du == 0.0 && dv == 0.0) return std::numeric_limits<double>::quiet_NaN();
  return std::atan2(dv, du);
}

Row6 segment_angle_jacobian(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& z, int i,
                            int j) noexcept {
  // theta = atan2(dv, du): dtheta = (du d(dv) - dv d(du)) / (du^2 + dv^2), rows of eq. (3).
  const double du = uv(0, j) - uv(0, i), dv = uv(1, j) - uv(1, i);
  const Matrix26 Ji = cartesian_jacobian(uv(0, i), uv(1, i), z(i)), Jj = cartesian_jacobian(uv(0, j), uv(1, j), z(j));
  return (du * (Jj.row(1) - Ji.row(1)) - dv * (Jj.row(0) - Ji.row(0))) / (du * du + dv * dv);
}

namespace {
double signed_area(const Eigen::Ref<const Points>& uv) noexcept {
  const Eigen::Index n = uv.cols();
  double a = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index l = (k + 1) % n;
    a += uv(0, k) * uv(1, l) - uv(0, l) * uv(1, k);
  }
  return 0.5 * a;
}
}  // namespace

double area_scale(const Eigen::Ref<const Points>& uv) noexcept { return std::sqrt(std::abs(signed_area(uv))); }

Row6 area_scale_jacobian(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& z) noexcept {
  // Shoelace: dA/du_m = (v_{m+1} - v_{m-1}) / 2, dA/dv_m = (u_{m-1} - u_{m+1}) / 2;
  // sigma = sqrt(|A|): dsigma = sign(A) dA / (2 sigma).
  const Eigen::Index n = uv.cols();
  Row6 dA = Row6::Zero();
  for (Eigen::Index m = 0; m < n; ++m) {
    const Eigen::Index next = (m + 1) % n, prev = (m + n - 1) % n;
    const Matrix26 J = cartesian_jacobian(uv(0, m), uv(1, m), z(m));
    dA += 0.5 * (uv(1, next) - uv(1, prev)) * J.row(0) + 0.5 * (uv(0, prev) - uv(0, next)) * J.row(1);
  }
  const double A = signed_area(uv);
  return (A < 0 ? -1.0 : 1.0) * dA / (2.0 * std::sqrt(std::abs(A)));
}

// Workspace bounded at compile time (max_realtime_rows rows): no heap in update().
struct PartitionedServo::Work {
  using Jac = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::ColMajor, max_realtime_rows, 6>;
  using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, max_realtime_rows, 1>;
  explicit Work(Eigen::Index m) : J(Jac::Zero(m, 6)), e(Vec::Zero(m)), b(Vec::Zero(m)) {}
  Jac J;
  Vec e, b;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig;
};

namespace {
// n_points checked before the layout is built (a huge n is refused at once).
int checked_points(int n_points) {
  if (n_points < 3)
    throw std::invalid_argument("ibvs: n_points must be >= 3 for the partitioned law (the polygon needs an area), got " +
                                std::to_string(n_points));
  if (n_points > max_realtime_rows / 2)
    throw std::invalid_argument("ibvs: n_points must be <= " + std::to_string(max_realtime_rows / 2) + ", got " +
                                std::to_string(n_points));
  return n_points;
}
}  // namespace

PartitionedServo::PartitionedServo(int n_points, PartitionedOptions options)
    : layout_(Layout::cartesian(checked_points(n_points))) {
  set_options(options);
  work_ = std::make_unique<Work>(layout_.rows());
}

PartitionedServo::~PartitionedServo() = default;
PartitionedServo::PartitionedServo(PartitionedServo&&) noexcept = default;
PartitionedServo& PartitionedServo::operator=(PartitionedServo&&) noexcept = default;

void PartitionedServo::validate(const PartitionedOptions& o) const {
  detail::check_gain(o.gain, "gain");
  detail::check_nonnegative(o.damping, "damping");
  if (o.damping > max_matrix_entry)
    throw std::invalid_argument("ibvs: damping = " + detail::number(o.damping) + " is above the limit " +
                                detail::number(max_matrix_entry));
  const int n = layout_.n_points();
  if (o.segment_first < 0 || o.segment_first >= n || o.segment_second < 0 || o.segment_second >= n ||
      o.segment_first == o.segment_second)
    throw std::invalid_argument("ibvs: segment must be two distinct point indices in [0, " + std::to_string(n) +
                                "), got (" + std::to_string(o.segment_first) + ", " + std::to_string(o.segment_second) +
                                ")");
  if (!(o.max_linear_speed > 0.0)) throw std::invalid_argument("ibvs: max_linear_speed must be > 0 (inf = no limit)");
  if (!(o.max_angular_speed > 0.0)) throw std::invalid_argument("ibvs: max_angular_speed must be > 0 (inf = no limit)");
}

void PartitionedServo::set_options(const PartitionedOptions& options) {
  validate(options);
  options_ = options;
}

void PartitionedServo::validate(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                                const Eigen::Ref<const Points>& uv_desired) const {
  const int n = layout_.n_points();
  detail::check_points(uv, "uv", n);
  detail::check_depth(depth, "depth", n);
  detail::check_points(uv_desired, "uv_desired", n);
  const int i = options_.segment_first, j = options_.segment_second;
  for (const auto* p : {&uv, &uv_desired}) {
    const char* name = p == &uv ? "uv" : "uv_desired";
    if (((*p).col(i) - (*p).col(j)).squaredNorm() == 0.0)
      throw std::invalid_argument(std::string("ibvs: ") + name + ": the segment points coincide (theta_z undefined)");
    if (signed_area(*p) == 0.0)
      throw std::invalid_argument(std::string("ibvs: ") + name + ": the points enclose no area (sigma = 0)");
  }
}

Status PartitionedServo::update(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                                const Eigen::Ref<const Points>& uv_desired,
                                const Eigen::Ref<const Eigen::VectorXd>& /*depth_desired*/, ServoOutput& out) noexcept {
  out.pixel_error = std::numeric_limits<double>::quiet_NaN();  // set by update_pixels() after this
  const int n = layout_.n_points(), i = options_.segment_first, j = options_.segment_second;
  const Eigen::Index m = layout_.rows();
  // Exactly what validate() refuses.
  bool ok = uv.cols() == n && uv_desired.cols() == n && depth.size() == n && out.error.size() == m &&
            out.jacobian.rows() == m && detail::valid_points(uv) && detail::valid_points(uv_desired) &&
            detail::valid_depths(depth);
  ok = ok && signed_area(uv) != 0.0 && signed_area(uv_desired) != 0.0 && (uv.col(i) - uv.col(j)).squaredNorm() > 0.0 &&
       (uv_desired.col(i) - uv_desired.col(j)).squaredNorm() > 0.0;
  if (!ok) return detail::refuse(out);
  const double sigma = area_scale(uv), sigma_d = area_scale(uv_desired);
  Work& w = *work_;
  const double g = options_.gain;
  for (int k = 0; k < n; ++k) {
    w.J.middleRows<2>(2 * k) = cartesian_jacobian(uv(0, k), uv(1, k), depth(k));
    w.e.segment<2>(2 * k) = uv.col(k) - uv_desired.col(k);
  }
  // The two decoupled DOF.
  const double wz = g * wrap_angle(segment_angle(uv, i, j) - segment_angle(uv_desired, i, j));
  const double tz = g * std::log(sigma_d / sigma);
  // The other four: J_xy x = -(g e + J_z v_z) in the least-squares sense.
  w.b.noalias() = -(g * w.e + w.J.col(2) * tz + w.J.col(5) * wz);
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::ColMajor, max_realtime_rows, 4> Jxy(m, 4);
  Jxy << w.J.col(0), w.J.col(1), w.J.col(3), w.J.col(4);
  Eigen::Matrix4d A;
  A.noalias() = Jxy.transpose().lazyProduct(Jxy);  // lazy: no GEMM blocking workspace
  Eigen::Vector4d rhs;
  rhs.noalias() = Jxy.transpose().lazyProduct(w.b);
  w.eig.compute(A);
  const Eigen::Vector4d lam = w.eig.eigenvalues().cwiseMax(0.0);
  const double smax = std::sqrt(lam(3)), smin = std::sqrt(lam(0));
  const double tol = 1.5e-8 * smax, l2 = options_.damping * options_.damping;
  // Moore-Penrose (damping 0: directions below tol dropped) or damped least squares.
  Eigen::Vector4d y = w.eig.eigenvectors().transpose() * rhs;
  for (int k = 0; k < 4; ++k) {
    const double s = std::sqrt(lam(k));
    y(k) = l2 > 0.0 ? y(k) / (lam(k) + l2) : (s > tol ? y(k) / lam(k) : 0.0);
  }
  const Eigen::Vector4d x = w.eig.eigenvectors() * y;
  out.velocity << x(0), x(1), tz, x(2), x(3), wz;
  out.error = w.e.head(m);
  out.error_norm = out.error.norm();
  out.jacobian = w.J.topRows(m);
  out.set_singular_values(smin, smax);
  out.polar_fallbacks = 0;
  out.gain = g;
  out.saturation_scale = saturation_scale(out.velocity, options_.max_linear_speed, options_.max_angular_speed);
  out.saturated = out.saturation_scale < 1.0;
  if (out.saturated) out.velocity *= out.saturation_scale;
  return out.status = smin > tol ? Status::ok : Status::singular;
}

}  // namespace ibvs
