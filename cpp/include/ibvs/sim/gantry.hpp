// Afma6-like 6-DOF gantry (paper Section III-B): three prismatic joints along
// the fixed frame's x, y, z and a three-revolute wrist, with the published
// model of ViSP's vpAfma6 (default parameters) and a camera on the flange.
//
// Forward kinematics (fixed <- end-effector), c1,s1 = cos/sin q4,
// c2,s2 = cos/sin q5, c3,s3 = cos/sin q6' with q6' = q6 - coupling q5:
//   R = [[s1 s2 c3 + c1 s3, -s1 s2 s3 + c1 c3, -s1 c2],
//        [-c1 s2 c3 + s1 s3, c1 s2 s3 + s1 c3,  c1 c2],
//        [c2 c3,             -c2 s3,            s2   ]]
//   p = (q1 + l c1, q2 + l s1, q3).
// Equivalently R = Rz(q4) Rx(q5) B Rz(q6') with B = [[0,1,0],[0,0,1],[1,0,0]],
// which gives the wrist's angular velocity
//   w = ez q4' + (c1, s1, 0) q5' + R ez (q6' - coupling q5').
#pragma once

#include "ibvs/features.hpp"
#include "ibvs/se3.hpp"
#include "ibvs/sim/robot.hpp"

#include <Eigen/Core>

#include <string>

namespace ibvs::sim {

using Joints = Eigen::Matrix<double, 6, 1>;
using Matrix6 = Eigen::Matrix<double, 6, 6>;

/// Rotation from ViSP's rxyz angles: R = Rx(rx) Ry(ry) Rz(rz).
Eigen::Matrix3d rxyz(double rx, double ry, double rz) noexcept;

/// The gantry as a Robot: q_min, q_max, qdot_max (m, m, m, rad, rad, rad),
/// mount = eMc; kinematics() reports the end effector's Jacobian in the fixed
/// (base) frame. Its joint mapping (Robot::mapping) is the damped inverse of
/// the camera Jacobian driven by the manipulability w = |det J| = |cos q5|
/// (the only singularity: wrist axes 4 and 6 aligned at q5 = +-pi/2): exact
/// while w >= singular_region = 0.1, below it
/// lambda^2 = (1 - (w / 0.1)^2) 0.1^2 (robot_mapping.hpp eq. 3).
struct Gantry final : Robot {
  double coupling = 0.009091;     ///< q6' = q6 - coupling q5
  double offset = -0.06924;       ///< l, metres, between joints 5 and 6

  /// ViSP's vpAfma6 with the distorted-camera tool (CCMOP): limits and
  /// mount from the issue; speed limits (0.2 m/s, 0.7 rad/s) are ours.
  static Gantry afma6();

  Pose end_effector(const Joints& q) const noexcept;  ///< fixed <- end-effector
  /// The camera twist (camera frame, ibvs convention) produced by joint
  /// velocities: v = J(q) qdot.
  Matrix6 jacobian(const Joints& q) const noexcept;
  /// |det jacobian(q)| = |cos q5|: the rotation blocks have determinant 1 and
  /// the prismatic joints give an identity block, leaving det[ez, a5, ze].
  double manipulability(const Joints& q) const noexcept;

  bool kinematics(const JointVector& q, Pose& T_we, RobotJacobian& J) const noexcept override;
  /// Throws std::invalid_argument naming the bad field.
  void validate() const override;
  std::string describe() const override;

 private:
  /// Fixed-frame Jacobian of the end effector: linear velocity of its origin, angular velocity.
  Matrix6 base_jacobian(const Joints& q) const noexcept;
};

}  // namespace ibvs::sim
