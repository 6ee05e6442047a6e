#include "ibvs/features/pose.hpp"

#include "ibvs/features.hpp"
#include "ibvs/finite.hpp"
#include "ibvs/limits.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs {

Eigen::Vector3d theta_u(const Eigen::Matrix3d& R) noexcept {
  Eigen::Quaterniond q(R);
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // the same rotation with w >= 0: theta in [0, pi]
  const Eigen::Vector3d v = q.vec();
  const double n = v.norm(), w = q.w();
  // theta = 2 atan2(n, w) and u = v / n; theta / n -> 2 / w as n -> 0 (error below 1e-16 under 1e-8).
  Eigen::Vector3d tu = (n > 1e-8 ? 2.0 * std::atan2(n, w) / n : 2.0 / w) * v;
  if (w < 1e-12) {  // theta = pi (to 2e-12): +u and -u are the same rotation; the largest component positive
    Eigen::Index i = 0;
    tu.cwiseAbs().maxCoeff(&i);
    if (tu(i) < 0.0) tu = -tu;
  }
  return tu;
}

// The rotation block of se3_exp((0, theta u)) (se3.hpp), the same arithmetic without the
// translation's (PBVS evaluates it every frame: half the instructions, the same bits).
Eigen::Matrix3d rotation_of(const Eigen::Vector3d& w) noexcept {
  double th = w.norm();
  if (std::isinf(th)) th = w.stableNorm();
  if (th < 1e-4) {
    Eigen::Matrix3d W;
    W << 0, -w(2), w(1), w(2), 0, -w(0), -w(1), w(0), 0;
    const Eigen::Matrix3d W2 = W * W;
    const double t2 = th * th;
    const double a = 1.0 - t2 / 6.0, b = 0.5 - t2 / 24.0;
    return Eigen::Matrix3d::Identity() + a * W + b * W2;
  }
  const Eigen::Vector3d k = w / th;
  Eigen::Matrix3d K;
  K << 0, -k(2), k(1), k(2), 0, -k(0), -k(1), k(0), 0;
  const Eigen::Matrix3d K2 = K * K;
  const double s = std::sin(th), c = std::cos(th);
  return Eigen::Matrix3d::Identity() + s * K + (1.0 - c) * K2;
}

Eigen::Vector3d principal_theta_u(const Eigen::Vector3d& tu) noexcept {
  const double th = tu.norm();
  return th > pi ? Eigen::Vector3d(tu * ((th - 2.0 * pi) / th)) : tu;  // (2 pi - theta)(-u)
}

Eigen::Matrix3d theta_u_interaction(const Eigen::Vector3d& tu_any) noexcept {
  const Eigen::Vector3d tu = principal_theta_u(tu_any);
  const double th = tu.norm();
  Eigen::Matrix3d W;  // [theta u]x
  W << 0, -tu(2), tu(1), tu(2), 0, -tu(0), -tu(1), tu(0), 0;
  // (1 - sinc(theta) / sinc^2(theta/2)) / theta^2 = (1 - (theta/2) cot(theta/2)) / theta^2, the
  // coefficient of [theta u]x^2; its series below 1e-2 (next term theta^6 / 1209600).
  const double t2 = th * th;
  const double b = th < 1e-2 ? 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
                             : (1.0 - 0.5 * th * std::cos(0.5 * th) / std::sin(0.5 * th)) / t2;
  return Eigen::Matrix3d::Identity() + 0.5 * W + b * W * W;
}

namespace {

// The rotation vector's angle: at most 2 pi (principal form taken by value() and interaction()).
const char* check_theta_u(const double* tu, int& entry) noexcept {
  entry = -1;
  if (!(Eigen::Map<const Eigen::Vector3d>(tu).norm() <= 2.0 * pi))
    return "theta u's angle |theta u| must be at most 2 pi (a rotation vector)";
  return nullptr;
}

const char* check_finite(const double* m, int n, int& entry) noexcept {
  for (entry = 0; entry < n; ++entry)
    if (!std::isfinite(m[entry])) return "is not finite";
  return nullptr;
}

void check_pose(const Pose& T, const char* name) {
  if (!T.allFinite()) throw std::invalid_argument(std::string("ibvs: ") + name + " must be finite");
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if (!finite_within(R.transpose() * R - Eigen::Matrix3d::Identity(), 1e-6) || !(R.determinant() > 0.0))
    throw std::invalid_argument(std::string("ibvs: ") + name + "'s upper-left 3x3 block must be a rotation (to 1e-6)");
  if (T.row(3).cwiseAbs().sum() != 1.0 || T(3, 3) != 1.0)
    throw std::invalid_argument(std::string("ibvs: ") + name + "'s last row must be (0, 0, 0, 1)");
}

// c*Rc = c*Ro (cRo)^T, as theta u.
Eigen::Vector3d relative_theta_u(const Pose& cMo, const Pose& cdMo) {
  return theta_u(cdMo.topLeftCorner<3, 3>() * cMo.topLeftCorner<3, 3>().transpose());
}

}  // namespace

// ---- PBVS ----

std::array<double, 6> PbvsFeature::measure(const Pose& cMo, const Pose& cdMo, PbvsTarget target) {
  check_pose(cMo, "pose");
  check_pose(cdMo, "pose_desired");
  const Eigen::Vector3d tu = relative_theta_u(cMo, cdMo);
  Eigen::Vector3d t = cMo.topRightCorner<3, 1>();  // c t_o
  if (target == PbvsTarget::desired_camera) {      // c*t_c = c*t_o - c*Rc c t_o
    const Eigen::Matrix3d Rdc = cdMo.topLeftCorner<3, 3>() * cMo.topLeftCorner<3, 3>().transpose();
    t = cdMo.topRightCorner<3, 1>() - Rdc * t;
  }
  return {t(0), t(1), t(2), tu(0), tu(1), tu(2)};
}

std::string PbvsFeature::describe() const {
  return target_ == PbvsTarget::desired_camera ? "pbvs(desired_camera)" : "pbvs(object)";
}

const char* PbvsFeature::check(const double* m, int& entry) const noexcept {
  if (const char* why = check_finite(m, 6, entry)) return why;
  for (entry = 0; entry < 3; ++entry)
    if (std::abs(m[entry]) > max_depth) return "the translation must be within max_depth (1e6 m)";
  return check_theta_u(m + 3, entry);
}

void PbvsFeature::value(const double* m, double* s) const noexcept {
  const Eigen::Vector3d tu = principal_theta_u(Eigen::Map<const Eigen::Vector3d>(m + 3));
  for (int i = 0; i < 3; ++i) {
    s[i] = m[i];
    s[3 + i] = tu(i);
  }
}

void PbvsFeature::interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept {
  const Eigen::Map<const Eigen::Vector3d> t(m), tu(m + 3);
  auto top = L.topRows(6);
  if (target_ == PbvsTarget::desired_camera) {
    top.topLeftCorner<3, 3>() = rotation_of(tu);  // d(c*t_c)/dt = c*Rc v
    top.topRightCorner<3, 3>().setZero();
  } else {  // d(c t_o)/dt = -v - w x c t_o = -v + [c t_o]x w
    top.topLeftCorner<3, 3>() = -Eigen::Matrix3d::Identity();
    top.topRightCorner<3, 3>() << 0, -t(2), t(1), t(2), 0, -t(0), -t(1), t(0), 0;
  }
  top.bottomLeftCorner<3, 3>().setZero();
  top.bottomRightCorner<3, 3>() = theta_u_interaction(tu);
}

// ---- 2.5-D ----

std::array<double, 6> Point25DFeature::measure(const Pose& cMo, const Pose& cdMo, const Eigen::Vector3d& P) {
  check_pose(cMo, "pose");
  check_pose(cdMo, "pose_desired");
  if (!P.allFinite()) throw std::invalid_argument("ibvs: point must be finite");
  const Eigen::Vector3d X = cMo.topLeftCorner<3, 3>() * P + cMo.topRightCorner<3, 1>();
  if (!(X.z() >= min_depth)) throw std::invalid_argument("ibvs: point: the reference point is behind the camera");
  const Eigen::Vector3d tu = relative_theta_u(cMo, cdMo);
  return {X.x() / X.z(), X.y() / X.z(), X.z(), tu(0), tu(1), tu(2)};
}

const char* Point25DFeature::check(const double* m, int& entry) const noexcept {
  if (const char* why = check_finite(m, 6, entry)) return why;
  for (entry = 0; entry < 2; ++entry)
    if (std::abs(m[entry]) > max_normalized_coordinate) return "is beyond the normalised-coordinate limit";
  entry = 2;
  if (!(m[2] >= min_depth && m[2] <= max_depth)) return "the depth Z must be within [min_depth, max_depth]";
  return check_theta_u(m + 3, entry);
}

void Point25DFeature::value(const double* m, double* s) const noexcept {
  const Eigen::Vector3d tu = principal_theta_u(Eigen::Map<const Eigen::Vector3d>(m + 3));
  s[0] = m[0];
  s[1] = m[1];
  s[2] = std::log(m[2]);  // the error's log Z - log Z* = log(Z / Z*)
  for (int i = 0; i < 3; ++i) s[3 + i] = tu(i);
}

void Point25DFeature::interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept {
  const double x = m[0], y = m[1], Z = m[2];
  auto top = L.topRows(6);
  top.topRows<2>() = cartesian_jacobian(x, y, Z);
  top.row(2) << 0.0, 0.0, -1.0 / Z, -y, x, 0.0;  // d(log Z)/dt = dZ/dt / Z
  top.bottomLeftCorner<3, 3>().setZero();
  top.bottomRightCorner<3, 3>() = theta_u_interaction(Eigen::Map<const Eigen::Vector3d>(m + 3));
}

}  // namespace ibvs
