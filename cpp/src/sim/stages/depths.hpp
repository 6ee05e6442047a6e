// Stage 2 of an episode's frame, estimate depths: the depth of each point given
// to the controller (see ibvs/sim/episode.hpp, step 4 and "Depth estimate"):
//   exact      the true depths of the frame the controller sees (the measure
//              stage's ring);
//   desired    the constant goal depths z*;
//   pose       from ibvs::PlanarPose on the controller's points (the image
//              alone: its homography step needs no initial guess); the last
//              estimate is kept when one is degenerate, NaN before the first;
//   estimated  ibvs::DepthEstimator (one EKF per point) fed with those points
//              and the camera's motion between the frames the controller saw,
//              as the robot's odometry knows it (odometry(), from the actuate
//              stage's poses); its prior is depth_scale z*.
// All but `estimated` are then multiplied by depth_scale (a calibration error;
// the estimate carries it in its prior only). Allocated by the constructor;
// estimate() and odometry() never allocate.
#pragma once

#include "ibvs/depth_estimator.hpp"
#include "ibvs/planar_pose.hpp"
#include "ibvs/sim/episode.hpp"

#include <Eigen/Core>

#include <optional>
#include <vector>

namespace ibvs::sim::stages {

class Depths {
 public:
  Depths() = default;
  /// options: depth, depth_scale, min_depth, latency and noise (over the camera's focal length:
  /// the estimate's point noise); target_points 3 x N in the target's frame (pose: must be
  /// planar, else throws std::invalid_argument).
  Depths(const EpisodeOptions& options, const CameraModel& camera, const Eigen::Matrix3Xd& target_points);

  /// The goal's depths z* (N): the desired depths, and the estimate's prior depth_scale z*.
  void aim(const Eigen::VectorXd& depth_desired);
  /// A new run: no pose estimate yet (the depth estimate restarts at frame 0).
  void start() noexcept { have_pose_ = false; }
  /// The depths for frame k (into depth()): uv the controller's points, true_depths
  /// (1 x N) those of the frame it sees.
  void estimate(int k, const Points& uv, const Eigen::Ref<const Eigen::RowVectorXd>& true_depths) noexcept;
  /// Frame k's camera motion, T_wc -> T_next (estimated mode: kept in a ring of
  /// latency + 1 for the frame the controller will see latency frames later).
  void odometry(int k, const Pose& T_wc, const Pose& T_next) noexcept;

  const Eigen::VectorXd& depth() const noexcept { return z_; }  ///< N, metres
  /// Motion recorded for frame k: the camera's new pose in its old frame.
  const Pose& motion(int k) const noexcept { return ring_motion_[static_cast<std::size_t>(k % slots_)]; }

 private:
  DepthMode mode_ = DepthMode::exact;
  double scale_ = 1.0;
  int latency_ = 0, slots_ = 1;
  Eigen::Matrix3Xd points_;  // target frame (pose)
  Eigen::VectorXd desired_, z_;
  std::optional<PlanarPose> pose_estimator_;      // pose
  Pose pose_ = Pose::Identity();                  // pose: last estimate, camera <- target
  bool have_pose_ = false;
  std::optional<DepthEstimator> depth_estimator_;  // estimated
  std::vector<Pose> ring_motion_;                  // estimated: latency + 1
};

}  // namespace ibvs::sim::stages
