// The simulator's robot: any arm of n <= max_joints joints carrying the camera
// on its end effector. An episode asks it, once per frame, for the pose of the
// end effector and its Jacobian at the current joints (kinematics()), and
// turns the servo's camera twist into joint velocities with the one
// JointMapping of robot_mapping.hpp, scaled uniformly to qdot_max.
//
// Frames: world = the robot's base (the target's pose is given in it too),
// e = the end effector, c = the camera; mount = eMc (end-effector <- camera).
//
// Eye-to-hand (mapping.mounting = Mounting::eye_to_hand): the camera is fixed,
// mount = bMc (base <- camera), and the target rides on the end effector. The
// episode then runs in the end effector's frame, where the target is still:
// the Target's pose is eMo (end effector <- target), the camera's "pose" is
// eMc(q) = bMe(q)^-1 bMc (camera() below; History.pose records it), and a goal
// given as a pose is that eMc. The JointMapping uses eq. (5) of
// robot_mapping.hpp (Jc = -cVe(q) eJe), whose Jc is exactly the body twist of
// eMc(q) (camera_jacobian() below), so everything downstream (servo, judge,
// depth odometry, IK) sees the same relative geometry as eye-in-hand.
// Implemented in C++ by the Afma6-like Gantry and, in Python, by any subclass
// of ibvs.sim.Robot (ibvs.sim.UrdfRobot: Pinocchio).
#pragma once

#include "ibvs/robot_mapping.hpp"
#include "ibvs/secondary_task.hpp"
#include "ibvs/se3.hpp"

#include <string>

namespace ibvs::sim {

class Robot {
 public:
  JointVector q_min, q_max;  ///< joint position limits (m or rad), n entries, q_min < q_max
  JointVector qdot_max;      ///< joint speed limits (m/s or rad/s), > 0 (inf = none)
  Pose mount = Pose::Identity();  ///< end-effector <- camera (eMc); eye_to_hand: base <- camera (bMc)
  /// How the episode maps the camera twist to joint velocities: the frame of
  /// the Jacobian kinematics() returns, the damping (robot_mapping.hpp). Its
  /// max_joint_speed is ignored: qdot_max applies.
  JointMappingOptions mapping;
  /// Secondary task (secondary_task.hpp) after the mapping every frame; off by default (the
  /// mapping alone, speed-capped by qdot_max). On: the mapping runs without caps and the
  /// SecondaryTask adds the joint-limit avoidance (avoid_joint_limits: with q_min, q_max) in the
  /// null space `secondary.projector` gives, then caps at qdot_max and qddot_max (period 1 / fps).
  /// Its q_min, q_max, max_joint_speed, max_joint_acceleration and period are filled from the robot
  /// (secondary_options()).
  bool secondary_task = false;
  bool avoid_joint_limits = false;
  SecondaryTaskOptions secondary;
  JointVector qddot_max;  ///< joint acceleration caps (n, > 0, inf = none) with secondary_task; empty = none

  virtual ~Robot() = default;

  int dof() const noexcept { return static_cast<int>(q_min.size()); }
  /// world <- end effector at q and the end-effector Jacobian (6 x n, in
  /// mapping.frame). Called every frame: must not throw (return false on
  /// failure: the episode then ends as diverged).
  virtual bool kinematics(const JointVector& q, Pose& T_we, RobotJacobian& J) const noexcept = 0;
  /// world <- camera at q (kinematics() times the mount); eye_to_hand: end
  /// effector <- camera, bMe^-1 bMc (see above). Throws std::invalid_argument
  /// if kinematics() fails or q has the wrong size.
  Pose camera(const JointVector& q) const;
  /// The camera's pose in the episode's frame from the end effector's pose T_we (see camera()).
  Pose camera_from(const Pose& T_we) const noexcept;
  bool eye_to_hand() const noexcept { return mapping.mounting == Mounting::eye_to_hand; }
  /// The camera Jacobian (6 x n) at q: camera twist (camera frame) = J qdot
  /// (eq. 1 of robot_mapping.hpp; eq. 5 eye-to-hand). Throws as camera() does.
  RobotJacobian camera_jacobian(const JointVector& q) const;
  /// The joint velocities the episode would command at q for the camera twist
  /// v, before the speed limits: JointMapping with `mapping`. Throws as camera().
  JointVector joint_velocity(const JointVector& q, const Twist& v) const;
  /// Index of the first joint outside [q_min, q_max] (or not finite), or -1.
  int outside_limits(const JointVector& q) const noexcept;
  /// The JointMappingOptions an episode uses: mapping with max_joint_speed = qdot_max.
  JointMappingOptions mapping_options() const;
  /// The SecondaryTaskOptions an episode uses at control period `period` (see secondary_task).
  SecondaryTaskOptions secondary_options(double period) const;
  /// Throws std::invalid_argument naming the bad field (sizes, limits, mount, mapping).
  virtual void validate() const;
  virtual std::string describe() const;

 protected:
  Robot() = default;
  Robot(const Robot&) = default;
  Robot& operator=(const Robot&) = default;
};

}  // namespace ibvs::sim
