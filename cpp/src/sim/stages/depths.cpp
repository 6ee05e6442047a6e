#include "depths.hpp"

#include "ibvs/limits.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

namespace ibvs::sim::stages {

Depths::Depths(const EpisodeOptions& options, const CameraModel& camera, const Eigen::Matrix3Xd& target_points)
    : mode_(options.depth),
      scale_(options.depth_scale),
      latency_(options.latency),
      slots_(options.latency + 1),
      points_(target_points) {
  const Eigen::Index n = target_points.cols();
  desired_.resize(n);
  z_.resize(n);
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

void Depths::aim(const Eigen::VectorXd& depth_desired) {
  desired_ = depth_desired;
  if (depth_estimator_) {  // prior: the desired depths times depth_scale (z_ is scratch here: no allocation)
    z_ = scale_ * depth_desired;
    depth_estimator_->reset(z_);
  }
}

void Depths::estimate(int k, const Points& uv, const Eigen::Ref<const Eigen::RowVectorXd>& true_depths) noexcept {
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
      have_pose_ = pose_estimator_->estimate(uv, pose_) || have_pose_;
      for (Eigen::Index i = 0; i < z_.size(); ++i)
        z_(i) = have_pose_ ? (pose_.row(2).head<3>().dot(points_.col(i)) + pose_(2, 3))
                           : std::numeric_limits<double>::quiet_NaN();
      break;
    }
  }
  if (scale_ != 1.0 && mode_ != DepthMode::estimated) z_ *= scale_;
}

void Depths::odometry(int k, const Pose& T_wc, const Pose& T_next) noexcept {
  if (mode_ != DepthMode::estimated) return;
  Pose& M = ring_motion_[static_cast<std::size_t>(k % slots_)];
  M.setIdentity();
  M.topLeftCorner<3, 3>() = T_wc.topLeftCorner<3, 3>().transpose() * T_next.topLeftCorner<3, 3>();
  M.topRightCorner<3, 1>() =
      T_wc.topLeftCorner<3, 3>().transpose() * (T_next.topRightCorner<3, 1>() - T_wc.topRightCorner<3, 1>());
}

}  // namespace ibvs::sim::stages
