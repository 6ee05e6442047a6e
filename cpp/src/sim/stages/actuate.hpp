// Stage 4 of an episode's frame, actuate: the commanded camera twist moves the
// camera until the next frame (period dt = 1 / fps; ibvs/sim/episode.hpp, step 6).
//   free flight  T_wc <- T_wc exp(v dt), the exact SE(3) integration of a twist
//                held constant over the period;
//   robot        the robot's JointMapping (ibvs/robot_mapping.hpp: the damped
//                inverse of its camera Jacobian at this frame's joints, scaled
//                uniformly to its speed limits) gives qdot; q <- q + dt qdot,
//                unless a joint would leave its range (then nothing moves: the
//                judge ends the episode at joint_limit); the robot's kinematics()
//                at the new q gives the next pose, T_we mount, and the Jacobian
//                of the next frame's mapping (one call per frame).
// Allocated by the constructor and attach(); start() and step() never allocate.
#pragma once

#include "ibvs/robot_mapping.hpp"
#include "ibvs/sim/robot.hpp"

#include <optional>

namespace ibvs::sim::stages {

class Actuate {
 public:
  explicit Actuate(double dt) : dt_(dt) {}  ///< a free-flying camera
  /// Drive `robot` (not owned: it must outlive this stage, and not move).
  void attach(const Robot& robot);
  bool has_robot() const noexcept { return robot_ != nullptr; }

  /// A new run: on a robot from the joints q_start (its kinematics there); free: q_start is null.
  void start(const JointVector* q_start) noexcept;
  /// Moves by the twist v from T_wc: the next camera pose into T_next, or, on a robot, the
  /// index of the joint that would leave its range (T_next, q unchanged). -1 = moved.
  int step(const Twist& v, const Pose& T_wc, Pose& T_next) noexcept;

  /// Robot: the joints of the current frame, whether kinematics() succeeded at them (free: true),
  /// and the last step's mapping (qdot, manipulability).
  const JointVector& q() const noexcept { return q_; }
  bool kinematics_ok() const noexcept { return kinematics_ok_; }
  const JointMappingOutput& joints() const noexcept { return out_; }
  double dt() const noexcept { return dt_; }

 private:
  double dt_ = 0.0;
  const Robot* robot_ = nullptr;
  std::optional<JointMapping> mapping_;  // the robot's, sized for its n joints
  JointMappingInput in_{1};
  JointMappingOutput out_{1};
  JointVector q_;
  Pose T_we_ = Pose::Identity();  // world <- end effector at q_ (its Jacobian is in in_)
  bool kinematics_ok_ = true;
};

// ---------------------------------------------------------------- implementation

inline void Actuate::attach(const Robot& robot) {
  const int n = robot.dof();
  robot_ = &robot;
  mapping_.emplace(n, robot.mount, robot.mapping_options());
  in_ = JointMappingInput(n);
  out_ = JointMappingOutput(n);
  q_.resize(n);
}

inline void Actuate::start(const JointVector* q_start) noexcept {
  kinematics_ok_ = true;
  if (!robot_) return;
  q_ = *q_start;
  kinematics_ok_ = robot_->kinematics(q_, T_we_, in_.jacobian);
}

inline int Actuate::step(const Twist& v, const Pose& T_wc, Pose& T_next) noexcept {
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
