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
//                of the next frame's mapping (one call per frame). With the
//                robot's secondary task on (Robot::secondary_task), the mapping
//                runs without caps and the SecondaryTask (ibvs/secondary_task.hpp)
//                adds the null-space joint-limit avoidance, with the servo's
//                L^T L and L^T e as the primary task, then applies the speed and
//                acceleration caps.
// Allocated by the constructor and attach(); start() and step() never allocate.
#pragma once

#include "ibvs/robot_mapping.hpp"
#include "ibvs/secondary_task.hpp"
#include "ibvs/servo.hpp"
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
  int step(const Twist& v, const Pose& T_wc, Pose& T_next) noexcept { return step(v, nullptr, T_wc, T_next); }
  /// The same with the servo's output (its interaction matrix and error: the primary task of the
  /// robot's secondary task; null: none, an identity Gram matrix and no error).
  int step(const Twist& v, const ServoOutput* task, const Pose& T_wc, Pose& T_next) noexcept;

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
  std::optional<SecondaryTask> secondary_;  // with Robot::secondary_task
  SecondaryTaskInput sin_{1};
  SecondaryTaskOutput sout_{1};
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
  JointMappingOptions o = robot.mapping_options();
  if (robot.secondary_task) {  // the caps come after the secondary motion
    o.max_joint_speed.resize(0);
    secondary_.emplace(n, robot.secondary_options(dt_));
    sin_ = SecondaryTaskInput(n);
    sout_ = SecondaryTaskOutput(n);
  } else {
    secondary_.reset();
  }
  mapping_.emplace(n, robot.mount, o);
  in_ = JointMappingInput(n);
  out_ = JointMappingOutput(n);
  q_.resize(n);
}

inline void Actuate::start(const JointVector* q_start) noexcept {
  kinematics_ok_ = true;
  if (!robot_) return;
  q_ = *q_start;
  sin_.qdot_previous.setZero();  // the robot starts at rest
  kinematics_ok_ = robot_->kinematics(q_, T_we_, in_.jacobian);
}

inline int Actuate::step(const Twist& v, const ServoOutput* task, const Pose& T_wc, Pose& T_next) noexcept {
  if (!robot_) {
    T_next = T_wc * se3_exp(v * dt_);  // exact SE(3) integration of the twist
    return -1;
  }
  in_.twist = v;
  in_.base_rotation = T_we_.topLeftCorner<3, 3>();
  in_.base_pose = T_we_;  // eye_to_hand: eq. (5) of robot_mapping.hpp
  mapping_->update(in_, out_);  // qdot within qdot_max; the Jacobian came with T_we_
  if (secondary_) {
    sin_.task_gram.setIdentity();
    sin_.task_gradient.setZero();
    sin_.error_norm = 0.0;
    if (task && task->jacobian.cols() == 6 && task->jacobian.rows() == task->error.size() &&
        task->jacobian.allFinite() && task->error.allFinite()) {  // G = L^T L, g = L^T e, row by row
      sin_.task_gram.setZero();
      for (Eigen::Index r = 0; r < task->jacobian.rows(); ++r) {
        const Eigen::Matrix<double, 1, 6> row = task->jacobian.row(r);
        sin_.task_gram.noalias() += row.transpose() * row;
        sin_.task_gradient.noalias() += task->error(r) * row.transpose();
      }
      sin_.error_norm = task->error.norm();
    }
    sin_.camera_jacobian = out_.camera_jacobian;
    sin_.qdot = out_.qdot;
    sin_.q = q_;
    secondary_->update(sin_, sout_);
    out_.qdot = sout_.qdot;  // what the robot does (0 if refused)
    sin_.qdot_previous = sout_.qdot;
  }
  const JointVector q_next = q_ + dt_ * out_.qdot;
  const int j = robot_->outside_limits(q_next);
  if (j >= 0) return j;
  q_ = q_next;
  kinematics_ok_ = robot_->kinematics(q_, T_we_, in_.jacobian);  // judged at the next frame
  T_next = robot_->camera_from(T_we_);  // eye_to_hand: the camera as the end effector sees it
  return -1;
}

}  // namespace ibvs::sim::stages
