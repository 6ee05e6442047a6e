// Stage 2 of an episode's frame, estimate depths: the depth of each point given
// to the controller (see ibvs/sim/episode.hpp, step 4 and "Depth estimate"):
//   exact      the true depths of the frame the controller sees (the measure
//              stage's ring);
//   desired    the constant goal depths z*;
//   pose       from ibvs::PlanarPose on the controller's points (the image
//              alone: its homography step needs no initial guess); the last
//              estimate is kept when one is degenerate, NaN before the first.
//              A task of feature blocks only through a wide lens (bearings:
//              Measure's bearings_only and sim::wide_lens) takes it from the
//              points' bearings (PlanarPose::estimate_bearings), which exist
//              beyond 90 degrees off the axis where normalised points do not;
//   estimated  ibvs::DepthEstimator (one EKF per point) fed with those points
//              and the camera's motion between the frames the controller saw,
//              as the robot's odometry knows it (odometry(), from the actuate
//              stage's poses); its prior is depth_scale z*.
// All but `estimated` are then multiplied by depth_scale (a calibration error;
// the estimate carries it in its prior only). At the goal (teach(), frame -1,
// teach by showing) the depth mode knows: exact and desired the given z* (and
// the goal's true pose, for the sources); pose ibvs::PlanarPose's estimate from
// the goal's image, as from every frame's (depths times depth_scale); estimated
// its prior depth_scale z* (one image: nothing moved yet). Allocated by the
// constructor; estimate() and odometry() never allocate.
#pragma once

#include "ibvs/depth_estimator.hpp"
#include "ibvs/limits.hpp"
#include "ibvs/planar_pose.hpp"
#include "ibvs/sim/episode.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ibvs::sim::stages {

class Depths {
 public:
  /// options: depth, depth_scale, min_depth, latency and noise (over the camera's focal length:
  /// the estimate's point noise); target_points 3 x N in the target's frame (pose: must be
  /// planar, else throws std::invalid_argument); bearings: the pose mode estimates from the
  /// points' bearings (teach() and estimate() are then given them).
  Depths(const EpisodeOptions& options, const CameraModel& camera, const Eigen::Matrix3Xd& target_points,
         bool bearings = false);

  /// The goal's depths z* (N): the desired depths, and the estimate's prior depth_scale z*.
  void aim(const Eigen::VectorXd& depth_desired);
  /// After aim(): what the depth mode knows at the goal from its image uv_desired (2 x N, the
  /// controller's points there), into goal_depth() and goal_pose_estimate() (pose: null, and
  /// goal_depth() z*, when the goal's image is degenerate; the sources stage then refuses the goal).
  /// bearings_desired: the goal's bearings (3 x N; used, and needed, when constructed with bearings).
  void teach(const Points& uv_desired, const Bearings* bearings_desired = nullptr);
  /// A new run: no pose estimate yet (the depth estimate restarts at frame 0).
  void start() noexcept { have_pose_ = false; }
  /// The depths for frame k (into depth()): uv the controller's points, true_depths
  /// (1 x N) those of the frame it sees, bearings its points' bearings (3 x N; used, and needed,
  /// when constructed with bearings).
  void estimate(int k, const Points& uv, const Eigen::Ref<const Eigen::RowVectorXd>& true_depths,
                const Bearings* bearings = nullptr) noexcept;
  /// Frame k's camera motion, T_wc -> T_next (estimated mode: kept in a ring of
  /// latency + 1 for the frame the controller will see latency frames later).
  void odometry(int k, const Pose& T_wc, const Pose& T_next) noexcept;

  const Eigen::VectorXd& depth() const noexcept { return z_; }  ///< N, metres
  /// The pose mode's last estimate (camera <- target, before depth_scale), or null before the first.
  const Pose* pose_estimate() const noexcept { return have_pose_ ? &pose_ : nullptr; }
  /// The goal's depths as the depth mode knows them (N, see above; exact, desired: z* as given).
  const Eigen::VectorXd& goal_depth() const noexcept { return goal_z_; }
  /// The pose mode's estimate of the goal (camera <- target, before depth_scale), or null (other
  /// modes, or a degenerate goal image).
  const Pose* goal_pose_estimate() const noexcept { return have_goal_pose_ ? &goal_pose_ : nullptr; }
  /// Motion recorded for frame k: the camera's new pose in its old frame.
  const Pose& motion(int k) const noexcept { return ring_motion_[static_cast<std::size_t>(k % slots_)]; }

 private:
  DepthMode mode_ = DepthMode::exact;
  double scale_ = 1.0;
  int latency_ = 0, slots_ = 1;
  Eigen::Matrix3Xd points_;  // target frame (pose)
  Eigen::VectorXd desired_, z_, goal_z_;
  std::optional<PlanarPose> pose_estimator_;      // pose
  bool bearings_ = false;                         // pose: from the bearings
  Pose pose_ = Pose::Identity();                  // pose: last estimate, camera <- target
  bool have_pose_ = false;
  Pose goal_pose_ = Pose::Identity();             // pose: the goal's estimate, camera <- target
  bool have_goal_pose_ = false;
  std::optional<DepthEstimator> depth_estimator_;  // estimated
  std::vector<Pose> ring_motion_;                  // estimated: latency + 1
};

// ---------------------------------------------------------------- implementation

inline Depths::Depths(const EpisodeOptions& options, const CameraModel& camera,
                      const Eigen::Matrix3Xd& target_points, bool bearings)
    : mode_(options.depth),
      scale_(options.depth_scale),
      latency_(options.latency),
      slots_(options.latency + 1),
      points_(target_points),
      bearings_(bearings) {
  const Eigen::Index n = target_points.cols();
  desired_.resize(n);
  z_.resize(n);
  goal_z_.resize(n);
  if (mode_ == DepthMode::pose) {
    try {
      pose_estimator_.emplace(target_points);
    } catch (const std::invalid_argument& e) {  // say which option needs the planar target
      throw std::invalid_argument(std::string("ibvs: the pose depth mode: target ") + (e.what() + 6));
    }
  }
  if (mode_ == DepthMode::estimated) {  // its prior is set by aim(), from the goal
    DepthEstimatorOptions eo;
    // capped at the estimator's limit: noise of 10 normalised units (84 degrees) is no measurement at all
    eo.point_noise = std::min(options.noise / std::min(camera.px(), camera.py()), max_normalized_coordinate);
    eo.min_depth = options.min_depth;
    depth_estimator_.emplace(Eigen::VectorXd::Ones(n), eo);
    ring_motion_.assign(static_cast<std::size_t>(slots_), Pose::Identity());
  }
}

inline void Depths::aim(const Eigen::VectorXd& depth_desired) {
  desired_ = depth_desired;
  goal_z_ = depth_desired;
  if (depth_estimator_) {  // prior: the desired depths times depth_scale (z_ is scratch here: no allocation)
    z_ = scale_ * depth_desired;
    depth_estimator_->reset(z_);
  }
}

inline void Depths::teach(const Points& uv_desired, const Bearings* bearings_desired) {
  have_goal_pose_ = false;
  if (mode_ == DepthMode::estimated) goal_z_ = scale_ * desired_;
  if (mode_ != DepthMode::pose) return;
  if (bearings_) {
    have_goal_pose_ = bearings_desired && pose_estimator_->estimate_bearings(*bearings_desired, goal_pose_);
    if (have_goal_pose_)
      for (Eigen::Index i = 0; i < goal_z_.size(); ++i)
        goal_z_(i) = goal_pose_.row(2).head<3>().dot(points_.col(i)) + goal_pose_(2, 3);
  } else {
    have_goal_pose_ = pose_estimator_->estimate(uv_desired, goal_pose_, goal_z_);
  }
  if (have_goal_pose_) goal_z_ *= scale_;
}

inline void Depths::estimate(int k, const Points& uv, const Eigen::Ref<const Eigen::RowVectorXd>& true_depths,
                             const Bearings* bearings) noexcept {
  switch (mode_) {
    case DepthMode::exact: z_ = true_depths.transpose(); break;
    case DepthMode::desired: z_ = desired_; break;
    case DepthMode::estimated:
      if (k == 0) {  // from the prior, with the first frame's points
        depth_estimator_->reset();
        depth_estimator_->update(uv, Pose(Pose::Identity()));
      } else if (k > latency_) {  // a new frame reached the controller: the motion since the one before
        depth_estimator_->update(uv, motion(k - latency_ - 1));
      }
      z_ = depth_estimator_->depth();
      break;
    case DepthMode::pose: {
      have_pose_ = (bearings_ ? bearings && pose_estimator_->estimate_bearings(*bearings, pose_)
                              : pose_estimator_->estimate(uv, pose_)) ||
                   have_pose_;
      for (Eigen::Index i = 0; i < z_.size(); ++i)
        z_(i) = have_pose_ ? (pose_.row(2).head<3>().dot(points_.col(i)) + pose_(2, 3))
                           : std::numeric_limits<double>::quiet_NaN();
      break;
    }
  }
  if (scale_ != 1.0 && mode_ != DepthMode::estimated) z_ *= scale_;
}

inline void Depths::odometry(int k, const Pose& T_wc, const Pose& T_next) noexcept {
  if (mode_ != DepthMode::estimated) return;
  Pose& M = ring_motion_[static_cast<std::size_t>(k % slots_)];
  M.setIdentity();
  M.topLeftCorner<3, 3>() = T_wc.topLeftCorner<3, 3>().transpose() * T_next.topLeftCorner<3, 3>();
  M.topRightCorner<3, 1>() =
      T_wc.topLeftCorner<3, 3>().transpose() * (T_next.topRightCorner<3, 1>() - T_wc.topRightCorner<3, 1>());
}

}  // namespace ibvs::sim::stages
