#include "actuate.hpp"

namespace ibvs::sim::stages {

void Actuate::attach(const Robot& robot) {
  const int n = robot.dof();
  robot_ = &robot;
  mapping_.emplace(n, robot.mount, robot.mapping_options());
  in_ = JointMappingInput(n);
  out_ = JointMappingOutput(n);
  q_.resize(n);
}

void Actuate::start(const JointVector* q_start) noexcept {
  kinematics_ok_ = true;
  if (!robot_) return;
  q_ = *q_start;
  kinematics_ok_ = robot_->kinematics(q_, T_we_, in_.jacobian);
}

int Actuate::step(const Twist& v, const Pose& T_wc, Pose& T_next) noexcept {
  if (!robot_) {
    T_next = T_wc * se3_exp(v * dt_);  // exact SE(3) integration of the twist
    return -1;
  }
  in_.twist = v;
  in_.base_rotation = T_we_.topLeftCorner<3, 3>();
  mapping_->update(in_, out_);  // qdot within qdot_max; the Jacobian came with T_we_
  const JointVector q_next = q_ + dt_ * out_.qdot;
  const int j = robot_->outside_limits(q_next);
  if (j >= 0) return j;
  q_ = q_next;
  kinematics_ok_ = robot_->kinematics(q_, T_we_, in_.jacobian);  // judged at the next frame
  T_next = T_we_ * robot_->mount;
  return -1;
}

}  // namespace ibvs::sim::stages
