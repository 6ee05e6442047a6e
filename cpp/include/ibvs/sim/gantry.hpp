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

#include <Eigen/Core>

#include <string>

namespace ibvs::sim {

using Joints = Eigen::Matrix<double, 6, 1>;
using Matrix6 = Eigen::Matrix<double, 6, 6>;

/// Rotation from ViSP's rxyz angles: R = Rx(rx) Ry(ry) Rz(rz).
Eigen::Matrix3d rxyz(double rx, double ry, double rz) noexcept;

struct Gantry {
  Joints q_min, q_max;   ///< joint position limits (m, m, m, rad, rad, rad)
  Joints qdot_max;       ///< joint speed limits (m/s, rad/s), > 0
  Pose mount = Pose::Identity();  ///< end-effector <- camera (eMc)
  double coupling = 0.009091;     ///< q6' = q6 - coupling q5
  double offset = -0.06924;       ///< l, metres, between joints 5 and 6
  /// Damped inverse of the camera Jacobian, driven by the manipulability
  /// w = |det J| = |cos q5| (the only singularity: wrist axes 4 and 6
  /// aligned at q5 = +-pi/2): plain inverse while w >= singular_region;
  /// below, lambda^2 = (1 - (w / singular_region)^2) max_damping^2
  /// (Nakamura and Hanafusa's variable damping).
  double singular_region = 0.1;
  double max_damping = 0.1;

  /// ViSP's vpAfma6 with the distorted-camera tool (CCMOP): limits and
  /// mount from the issue; speed limits (0.2 m/s, 0.7 rad/s) are ours.
  static Gantry afma6();

  Pose end_effector(const Joints& q) const noexcept;  ///< fixed <- end-effector
  Pose camera(const Joints& q) const noexcept;        ///< fixed <- camera
  /// The camera twist (camera frame, ibvs convention) produced by joint
  /// velocities: v = J(q) qdot.
  Matrix6 jacobian(const Joints& q) const noexcept;
  /// |det jacobian(q)| = |cos q5|: the rotation blocks have determinant 1 and
  /// the prismatic joints give an identity block, leaving det[ez, a5, ze].
  double manipulability(const Joints& q) const noexcept;
  /// qdot with J(q) qdot = v: LU solve, or damped least squares
  /// (J^T J + lambda^2 I)^-1 J^T v near the singularity (see singular_region).
  Joints joint_velocity(const Joints& q, const Twist& v) const noexcept;
  /// qdot scaled by one factor <= 1 so that every |qdot_i| <= qdot_max_i
  /// (the direction, hence the camera path, is kept).
  Joints saturate(const Joints& qdot) const noexcept;
  /// Index of the first joint outside [q_min, q_max], or -1.
  int outside_limits(const Joints& q) const noexcept;

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
  std::string describe() const;
};

}  // namespace ibvs::sim
