#include "ibvs/sim/robot.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs::sim {

namespace {

[[noreturn]] void fail(const std::string& s) { throw std::invalid_argument("ibvs: " + s); }

// world <- end effector and the end-effector Jacobian at q, or throws.
void checked_kinematics(const Robot& robot, const JointVector& q, Pose& T_we, RobotJacobian& J) {
  if (q.size() != robot.dof())
    fail("q must have " + std::to_string(robot.dof()) + " entries, got " + std::to_string(q.size()));
  if (!q.allFinite()) fail("q must be finite");
  if (!robot.kinematics(q, T_we, J)) fail("the robot's kinematics failed at q");
  if (J.cols() != robot.dof() || !J.allFinite() || !T_we.allFinite())
    fail("the robot's kinematics returned a non-finite pose or a Jacobian of the wrong size");
}

}  // namespace

Pose Robot::camera(const JointVector& q) const {
  Pose T_we;
  RobotJacobian J;
  checked_kinematics(*this, q, T_we, J);
  return camera_from(T_we);
}

Pose Robot::camera_from(const Pose& T_we) const noexcept {
  return eye_to_hand() ? Pose(se3_inverse(T_we) * mount) : Pose(T_we * mount);
}

RobotJacobian Robot::camera_jacobian(const JointVector& q) const {
  Pose T_we;
  RobotJacobian J, Jc;
  checked_kinematics(*this, q, T_we, J);
  JointMapping::camera_jacobian(mount, mapping.mounting, mapping.frame, J, T_we, Jc);
  return Jc;
}

JointVector Robot::joint_velocity(const JointVector& q, const Twist& v) const {
  JointMappingInput in(dof());
  JointMappingOutput out(dof());
  Pose T_we;
  checked_kinematics(*this, q, T_we, in.jacobian);
  in.twist = v;
  in.base_rotation = T_we.topLeftCorner<3, 3>();
  in.base_pose = T_we;
  JointMappingOptions o = mapping;
  o.max_joint_speed.resize(0);
  JointMapping map(dof(), mount, o);
  map.validate(in);
  map.update(in, out);
  return out.qdot;
}

int Robot::outside_limits(const JointVector& q) const noexcept {
  for (int i = 0; i < dof(); ++i)
    if (!(q(i) >= q_min(i) && q(i) <= q_max(i))) return i;
  return -1;
}

JointMappingOptions Robot::mapping_options() const {
  JointMappingOptions o = mapping;
  o.max_joint_speed = qdot_max;
  return o;
}

SecondaryTaskOptions Robot::secondary_options(double period) const {
  SecondaryTaskOptions o = secondary;
  o.q_min.resize(0);
  o.q_max.resize(0);
  if (avoid_joint_limits) {
    o.q_min = q_min;
    o.q_max = q_max;
  }
  o.max_joint_speed = qdot_max;
  o.max_joint_acceleration = qddot_max;
  o.period = period;
  return o;
}

void Robot::validate() const {
  const int n = dof();
  if (n < 1 || n > max_joints) fail("robot must have 1 to " + std::to_string(max_joints) + " joints, got " + std::to_string(n));
  if (q_max.size() != n || qdot_max.size() != n)
    fail("robot q_min, q_max and qdot_max must have the same size (" + std::to_string(n) + ")");
  for (int i = 0; i < n; ++i) {
    const std::string j = "joint " + std::to_string(i);
    if (!std::isfinite(q_min(i)) || !std::isfinite(q_max(i)) || !(q_min(i) < q_max(i)))
      fail("robot q_min < q_max must hold (finite) for " + j);
    if (!(qdot_max(i) > 0.0)) fail("robot qdot_max must be > 0 (inf = no limit) for " + j);
  }
  const JointMapping check(n, mount, mapping_options());  // throws for a bad mount or mapping option
  static_cast<void>(check);
  if (qddot_max.size() != 0 && qddot_max.size() != n)
    fail("robot qddot_max must be empty or have " + std::to_string(n) + " entries, got " +
         std::to_string(qddot_max.size()));
  if (qddot_max.size() != 0 && !secondary_task) fail("robot qddot_max needs the secondary task on");
  if (secondary_task) {
    const SecondaryTask task(n, secondary_options(1.0));  // throws for a bad option
    static_cast<void>(task);
  }
}

std::string Robot::describe() const {
  return "Robot(" + std::to_string(dof()) + " joints" + (eye_to_hand() ? ", eye_to_hand)" : ")");
}

}  // namespace ibvs::sim
