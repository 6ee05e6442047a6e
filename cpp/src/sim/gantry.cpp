#include "ibvs/sim/gantry.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace ibvs::sim {

Eigen::Matrix3d rxyz(double rx, double ry, double rz) noexcept {
  return (Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

Gantry Gantry::afma6() {
  Gantry g;
  g.q_min << -0.7501, -0.6501, -0.5001, -2.7301, -0.3001, -1.5901;
  g.q_max << 0.6001, 0.6701, 0.4601, 2.7301, 2.4801, 1.5901;
  g.qdot_max << 0.2, 0.2, 0.2, 0.7, 0.7, 0.7;
  const double deg = pi / 180.0;
  g.mount.topLeftCorner<3, 3>() = rxyz(33.54 * deg, 89.34 * deg, 57.83 * deg);
  g.mount.topRightCorner<3, 1>() << 0.0373, 0.0024, 0.2286;
  return g;
}

Pose Gantry::end_effector(const Joints& q) const noexcept {
  const double c1 = std::cos(q(3)), s1 = std::sin(q(3)), c2 = std::cos(q(4)), s2 = std::sin(q(4));
  const double q6 = q(5) - coupling * q(4), c3 = std::cos(q6), s3 = std::sin(q6);
  Pose T = Pose::Identity();
  T.topLeftCorner<3, 3>() << s1 * s2 * c3 + c1 * s3, -s1 * s2 * s3 + c1 * c3, -s1 * c2,  //
      -c1 * s2 * c3 + s1 * s3, c1 * s2 * s3 + s1 * c3, c1 * c2,                          //
      c2 * c3, -c2 * s3, s2;
  T.topRightCorner<3, 1>() << q(0) + offset * c1, q(1) + offset * s1, q(2);
  return T;
}

Pose Gantry::camera(const Joints& q) const noexcept { return end_effector(q) * mount; }

Matrix6 Gantry::jacobian(const Joints& q) const noexcept {
  const Pose Te = end_effector(q);
  const Eigen::Matrix3d Re = Te.topLeftCorner<3, 3>();
  const double c1 = std::cos(q(3)), s1 = std::sin(q(3));
  // Fixed-frame linear velocity of the end-effector origin and angular velocity.
  Eigen::Matrix<double, 3, 6> Jv = Eigen::Matrix<double, 3, 6>::Zero(), Jw = Eigen::Matrix<double, 3, 6>::Zero();
  Jv(0, 0) = Jv(1, 1) = Jv(2, 2) = 1.0;
  Jv(0, 3) = -offset * s1;
  Jv(1, 3) = offset * c1;
  const Eigen::Vector3d ze = Re.col(2);
  Jw.col(3) = Eigen::Vector3d::UnitZ();
  Jw.col(4) = Eigen::Vector3d(c1, s1, 0.0) - coupling * ze;
  Jw.col(5) = ze;
  // Camera origin: p_c = p_e + Re t, so its velocity adds w x (Re t).
  const Eigen::Vector3d r = Re * mount.topRightCorner<3, 1>();
  for (int j = 3; j < 6; ++j) Jv.col(j) += Jw.col(j).cross(r);
  // Express both in the camera frame (ibvs twist convention).
  const Eigen::Matrix3d RcT = (Re * mount.topLeftCorner<3, 3>()).transpose();
  Matrix6 J;
  J.topRows<3>().noalias() = RcT * Jv;
  J.bottomRows<3>().noalias() = RcT * Jw;
  return J;
}

double Gantry::manipulability(const Joints& q) const noexcept { return std::abs(std::cos(q(4))); }

Joints Gantry::joint_velocity(const Joints& q, const Twist& v) const noexcept {
  const Matrix6 J = jacobian(q);
  const double w = manipulability(q);
  if (w >= singular_region) return J.partialPivLu().solve(v);
  const double ratio = singular_region > 0.0 ? w / singular_region : 1.0;
  const double lambda2 = (1.0 - ratio * ratio) * max_damping * max_damping;
  Matrix6 A;
  A.noalias() = J.transpose() * J;
  A.diagonal().array() += lambda2;
  return A.ldlt().solve(J.transpose() * v);
}

Joints Gantry::saturate(const Joints& qdot) const noexcept {
  double scale = 1.0;
  for (int i = 0; i < 6; ++i) {
    const double a = std::abs(qdot(i));
    if (a * scale > qdot_max(i)) scale = qdot_max(i) / a;
  }
  return scale * qdot;
}

int Gantry::outside_limits(const Joints& q) const noexcept {
  for (int i = 0; i < 6; ++i)
    if (!(q(i) >= q_min(i) && q(i) <= q_max(i))) return i;
  return -1;
}

void Gantry::validate() const {
  for (int i = 0; i < 6; ++i) {
    const std::string j = "joint " + std::to_string(i + 1);
    if (!std::isfinite(q_min(i)) || !std::isfinite(q_max(i)) || !(q_min(i) < q_max(i)))
      throw std::invalid_argument("ibvs: gantry q_min < q_max must hold for " + j);
    if (!(qdot_max(i) > 0.0) || !std::isfinite(qdot_max(i)))
      throw std::invalid_argument("ibvs: gantry qdot_max must be finite and > 0 for " + j);
  }
  const Eigen::Matrix3d R = mount.topLeftCorner<3, 3>();
  if (!mount.allFinite() || !(R.transpose() * R).isIdentity(1e-9) || std::abs(R.determinant() - 1.0) > 1e-9)
    throw std::invalid_argument("ibvs: gantry mount must be a rigid transform");
  if (!std::isfinite(coupling) || !std::isfinite(offset))
    throw std::invalid_argument("ibvs: gantry coupling and offset must be finite");
  if (!(singular_region >= 0.0) || !(max_damping >= 0.0) || !std::isfinite(singular_region) ||
      !std::isfinite(max_damping))
    throw std::invalid_argument("ibvs: gantry singular_region and max_damping must be finite and >= 0");
}

std::string Gantry::describe() const {
  char buf[200];
  std::snprintf(buf, sizeof buf, "Gantry(afma6-like, coupling=%g, offset=%g, qdot_max=(%g, %g, %g, %g, %g, %g))",
                coupling, offset, qdot_max(0), qdot_max(1), qdot_max(2), qdot_max(3), qdot_max(4), qdot_max(5));
  return buf;
}

}  // namespace ibvs::sim
