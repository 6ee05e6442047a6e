#include "ibvs/sim/gantry.hpp"

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
  g.q_min.resize(6);
  g.q_max.resize(6);
  g.qdot_max.resize(6);
  g.q_min << -0.7501, -0.6501, -0.5001, -2.7301, -0.3001, -1.5901;
  g.q_max << 0.6001, 0.6701, 0.4601, 2.7301, 2.4801, 1.5901;
  g.qdot_max << 0.2, 0.2, 0.2, 0.7, 0.7, 0.7;
  const double deg = pi / 180.0;
  g.mount.topLeftCorner<3, 3>() = rxyz(33.54 * deg, 89.34 * deg, 57.83 * deg);
  g.mount.topRightCorner<3, 1>() << 0.0373, 0.0024, 0.2286;
  g.mapping.frame = JacobianFrame::base;
  g.mapping.damping = 0.1;
  g.mapping.singular_region = 0.1;
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

Matrix6 Gantry::base_jacobian(const Joints& q) const noexcept {
  const double c1 = std::cos(q(3)), s1 = std::sin(q(3));
  const Eigen::Vector3d ze = end_effector(q).topLeftCorner<3, 3>().col(2);
  // Fixed-frame linear velocity of the end-effector origin (rows 0-2) and angular velocity (rows 3-5).
  Matrix6 J = Matrix6::Zero();
  J(0, 0) = J(1, 1) = J(2, 2) = 1.0;
  J(0, 3) = -offset * s1;
  J(1, 3) = offset * c1;
  J.block<3, 1>(3, 3) = Eigen::Vector3d::UnitZ();
  J.block<3, 1>(3, 4) = Eigen::Vector3d(c1, s1, 0.0) - coupling * ze;
  J.block<3, 1>(3, 5) = ze;
  return J;
}

Matrix6 Gantry::jacobian(const Joints& q) const noexcept {
  const RobotJacobian J = base_jacobian(q);
  RobotJacobian Jc;
  JointMapping::camera_jacobian(mount, mapping.mounting, JacobianFrame::base, J, end_effector(q), Jc);
  return Jc;
}

double Gantry::manipulability(const Joints& q) const noexcept { return std::abs(std::cos(q(4))); }

bool Gantry::kinematics(const JointVector& q, Pose& T_we, RobotJacobian& J) const noexcept {
  if (q.size() != 6) return false;
  const Joints q6 = q;
  T_we = end_effector(q6);
  J = base_jacobian(q6);
  return true;
}

void Gantry::validate() const {
  if (dof() != 6) throw std::invalid_argument("ibvs: gantry must have 6 joints, got " + std::to_string(dof()));
  Robot::validate();
  if (!std::isfinite(coupling) || !std::isfinite(offset))
    throw std::invalid_argument("ibvs: gantry coupling and offset must be finite");
  if (mapping.frame != JacobianFrame::base) throw std::invalid_argument("ibvs: gantry mapping.frame must be base");
}

std::string Gantry::describe() const {
  char buf[200];
  std::snprintf(buf, sizeof buf, "Gantry(afma6-like%s, coupling=%g, offset=%g, qdot_max=(%g, %g, %g, %g, %g, %g))",
                eye_to_hand() ? ", eye_to_hand" : "", coupling, offset, qdot_max(0), qdot_max(1), qdot_max(2), qdot_max(3), qdot_max(4), qdot_max(5));
  return buf;
}

}  // namespace ibvs::sim
