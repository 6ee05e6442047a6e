// Stage 2b of an episode's frame, measure the feature blocks: each source of
// the target (ibvs/sim/source.hpp) writes its block's measurement from the
// frame the controller sees, after the depth stage (its depths and, in the
// pose mode, its pose estimate). The stage gives every source the depth pose
// of the episode's depth mode:
//   exact      the true camera <- target of that frame (the measure stage's ring),
//   desired    the goal's,
//   pose       the depth stage's ibvs::PlanarPose estimate,
//   estimated  the rigid fit (fit_pose below) of the target's points onto the
//              estimated points z_i (u_i, v_i, 1),
// the translation times depth_scale but for estimated (which carries it in its
// prior). The goal (SourceFrame::goal, what PBVS and 2.5-D aim at and the
// moments' a* and Z* come from) is the same at frame -1 (teach by showing):
// exact and desired the goal's true pose; pose the estimate from the goal's
// image; estimated the fit to the goal's image at the prior depths
// depth_scale z* (Depths::teach). With EpisodeOptions::goal_pose = given the
// goal (and the depth pose at frame -1, so that a pose block's desired value is
// its value at that goal) is the goal's true pose in every mode, not times
// depth_scale: a goal pose given, while every frame's depth pose is still the
// mode's; the goal's image and the depths the mode gave its points stay the
// taught ones (2.5-D's x*, y*, Z*, the moments' desired image). Each measurement is checked by its block's Feature::check: a source
// that cannot measure, or a refused measurement, is reported as the lost
// block's index (the judge ends the episode as lost_feature). Allocated by the
// constructor; measure() never allocates.
#pragma once

#include "ibvs/sim/episode.hpp"

#include "../../svd_instances.hpp"

#include <Eigen/Core>
#include <Eigen/SVD>

#include <limits>
#include <stdexcept>
#include <string>

namespace ibvs::sim::stages {

/// The rigid transform (R, t) with Q ~ R P + t in the least-squares sense (Kabsch; Arun, Huang &
/// Blostein 1987), P and Q 3 x N, into T; false when P's points are collinear (or Q is not finite).
/// Allocation-free.
inline bool fit_pose(const Eigen::Matrix3Xd& P, const Eigen::Ref<const Eigen::Matrix3Xd>& Q, Pose& T) noexcept {
  const Eigen::Index n = P.cols();
  if (n < 3 || !Q.allFinite()) return false;
  const Eigen::Vector3d p = P.rowwise().mean(), q = Q.rowwise().mean();
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) H.noalias() += (P.col(i) - p) * (Q.col(i) - q).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d s = svd.singularValues();
  if (!(s(1) > 1e-12 * s(0))) return false;  // collinear points: the rotation about their line is free
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;  // a rotation, not a reflection
  T.setIdentity();
  T.topLeftCorner<3, 3>() = svd.matrixV() * D * svd.matrixU().transpose();
  T.topRightCorner<3, 1>() = q - T.topLeftCorner<3, 3>() * p;
  return true;
}

class Sources {
 public:
  /// Checks that the target's sources feed the task's blocks one for one (throws
  /// std::invalid_argument); task null (a PartitionedServo) takes no sources.
  Sources(const Target& target, const Task* task, const EpisodeOptions& options);

  bool active() const noexcept { return !target_.sources.empty(); }
  int size() const noexcept { return static_cast<int>(m_.size()); }  ///< Task::measurement_size()

  /// The goal's measurements (frame -1) into desired(): goal the true world <- camera, uv_desired
  /// the controller's points there, goal_depth and goal_pose_estimate what the depth stage knows
  /// there (Depths::teach), bearings_desired the goal's bearings (Measure::goal_bearings; null:
  /// none). The goal pose is the one the depth mode knows there, or with GoalPose::given the true one.
  /// Throws std::invalid_argument if the goal's pose cannot be fitted (estimated, taught), a source
  /// cannot measure there or its block refuses it.
  void teach(const Pose& goal, const Points& uv_desired, const Eigen::VectorXd& goal_depth,
             const Pose* goal_pose_estimate, const Bearings* bearings_desired = nullptr);

  /// Frame k: T_cw the camera <- world of the frame the controller sees, pose_estimate the depth
  /// stage's camera <- target (pose mode; null: none yet), uv, z and bearings the controller's
  /// points, depths and bearings (null: none). Returns the first block that could not be measured, or -1.
  int measure(int k, const Pose& T_cw, const Pose* pose_estimate, const Points& uv, const Eigen::VectorXd& z,
              const Bearings* bearings = nullptr) noexcept;

  const Eigen::VectorXd& measurements() const noexcept { return m_; }
  const Eigen::VectorXd& desired() const noexcept { return desired_; }

 private:
  int measure_all(SourceFrame& f, Eigen::VectorXd& m) const noexcept;

  Target target_;
  Task task_storage_;           // a copy of the servo's task (copies share its blocks)
  const Task* task_ = nullptr;  // &task_storage_, or null for a PartitionedServo
  DepthMode mode_ = DepthMode::exact;
  GoalPose goal_pose_ = GoalPose::taught;
  double scale_ = 1.0;
  Pose goal_cMo_ = Pose::Identity();    // the goal's true camera <- target
  Pose goal_known_ = Pose::Identity();  // the goal as the depth mode knows it (SourceFrame::goal)
  Eigen::Matrix3Xd camera_points_;  // estimated: z_i (u_i, v_i, 1)
  Eigen::VectorXd m_, desired_;
};

// ---------------------------------------------------------------- implementation

inline Sources::Sources(const Target& target, const Task* task, const EpisodeOptions& options)
    : target_(target),
      task_storage_(task ? *task : Task()),
      task_(task ? &task_storage_ : nullptr),
      mode_(options.depth),
      goal_pose_(options.goal_pose),
      scale_(options.depth_scale) {
  const int n_sources = static_cast<int>(target.sources.size());
  const int n_blocks = task ? task->n_features() : 0;
  if (!task && n_sources > 0)
    throw std::invalid_argument("ibvs: target has feature sources but a PartitionedServo servoes on points only");
  if (n_sources != n_blocks)
    throw std::invalid_argument("ibvs: target has " + std::to_string(n_sources) +
                                " feature source(s) but the servo's task has " + std::to_string(n_blocks) +
                                " feature block(s): one source per block, in the task's order");
  for (int k = 0; k < n_blocks; ++k)
    if (!target.sources[static_cast<std::size_t>(k)]->fits(task->feature(k)))
      throw std::invalid_argument("ibvs: target sources[" + std::to_string(k) + "] (" +
                                  target.sources[static_cast<std::size_t>(k)]->describe() +
                                  ") cannot measure the task's block " + std::to_string(k) + " (" +
                                  task->feature(k).describe() + ")");
  if (n_sources > 0 && mode_ == DepthMode::estimated) {
    Pose T;
    if (!fit_pose(target.points, target.points, T))
      throw std::invalid_argument(
          "ibvs: the estimated depth mode with feature sources needs 3 non-collinear target points (their pose is "
          "fitted to the estimated points)");
  }
  camera_points_.resize(3, target.size());
  m_.resize(task ? task->measurement_size() : 0);
  desired_.resize(m_.size());
}

inline int Sources::measure_all(SourceFrame& f, Eigen::VectorXd& m) const noexcept {
  f.points = &target_.points;
  for (int k = 0; k < task_->n_features(); ++k) {
    double* mk = m.data() + task_->offset(k);
    int entry = -1;
    if (!target_.sources[static_cast<std::size_t>(k)]->measure(f, mk) || task_->feature(k).check(mk, entry))
      return k;
  }
  return -1;
}

inline void Sources::teach(const Pose& goal, const Points& uv_desired, const Eigen::VectorXd& goal_depth,
                           const Pose* goal_pose_estimate, const Bearings* bearings_desired) {
  if (!active()) return;
  goal_cMo_ = se3_inverse(goal) * target_.pose;
  goal_known_ = goal_cMo_;  // exact, desired, or a goal pose given (GoalPose::given): the true one
  const bool taught = goal_pose_ == GoalPose::taught;
  if (taught && mode_ == DepthMode::pose) {  // as every frame's depth pose, from the goal's image
    if (!goal_pose_estimate)
      throw std::invalid_argument("ibvs: goal: the pose depth mode cannot estimate the goal's pose from its image");
    goal_known_ = *goal_pose_estimate;
    goal_known_.topRightCorner<3, 1>() *= scale_;
  } else if (taught && mode_ == DepthMode::estimated) {  // the fit to the goal's image at the prior depths
    for (Eigen::Index i = 0; i < uv_desired.cols(); ++i)
      camera_points_.col(i) << goal_depth(i) * uv_desired(0, i), goal_depth(i) * uv_desired(1, i), goal_depth(i);
    if (!fit_pose(target_.points, camera_points_, goal_known_))
      throw std::invalid_argument("ibvs: goal: the estimated depth mode cannot fit the goal's pose to its image");
  }
  SourceFrame f;
  f.frame = -1;
  f.cMo = goal_cMo_;
  f.depth_pose = f.goal = goal_known_;
  f.uv = &uv_desired;
  f.depth = &goal_depth;
  f.bearings = bearings_desired;
  f.points = &target_.points;
  for (int k = 0; k < task_->n_features(); ++k) {
    const auto& source = *target_.sources[static_cast<std::size_t>(k)];
    const auto name = [&] { return "goal: target sources[" + std::to_string(k) + "] (" + source.describe() + ")"; };
    double* mk = desired_.data() + task_->offset(k);
    if (!source.measure(f, mk)) throw std::invalid_argument("ibvs: " + name() + " cannot be measured at the goal");
    int entry = -1;
    if (task_->feature(k).check(mk, entry)) task_->feature(k).validate(mk, name());  // the block's own reason
  }
}

inline int Sources::measure(int k, const Pose& T_cw, const Pose* pose_estimate, const Points& uv,
                            const Eigen::VectorXd& z, const Bearings* bearings) noexcept {
  if (!active()) return -1;
  SourceFrame f;
  f.frame = k;
  f.cMo = T_cw * target_.pose;
  f.goal = goal_known_;
  f.uv = &uv;
  f.depth = &z;
  f.bearings = bearings;
  switch (mode_) {
    case DepthMode::exact: f.depth_pose = f.cMo; break;
    case DepthMode::desired: f.depth_pose = goal_cMo_; break;
    case DepthMode::pose:
      if (pose_estimate) f.depth_pose = *pose_estimate;
      else f.depth_pose.setConstant(std::numeric_limits<double>::quiet_NaN());
      break;
    case DepthMode::estimated:
      for (Eigen::Index i = 0; i < uv.cols(); ++i) camera_points_.col(i) << z(i) * uv(0, i), z(i) * uv(1, i), z(i);
      if (!fit_pose(target_.points, camera_points_, f.depth_pose))
        f.depth_pose.setConstant(std::numeric_limits<double>::quiet_NaN());
      break;
  }
  if (scale_ != 1.0 && mode_ != DepthMode::estimated) f.depth_pose.topRightCorner<3, 1>() *= scale_;
  return measure_all(f, m_);
}

}  // namespace ibvs::sim::stages
