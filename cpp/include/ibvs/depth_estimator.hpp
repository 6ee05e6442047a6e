// Online depth of tracked image points from successive frames and the
// camera's motion between them (odometry): one extended Kalman filter per
// point on s = (x, y, rho), its normalised image coordinates and inverse
// depth rho = 1/z.
//
// Predict: the point (x, y, 1) / rho of the previous camera frame, seen from
// the current one, M = (R, t) the current camera's pose in the previous
// camera frame (previous <- current):
//   Q = R^T (P - t),  s' = (Q_x / Q_z, Q_y / Q_z, 1 / Q_z)
// exact for any motion (integrating the interaction matrix, eq. 3 in rho, over
// the period is not), with its Jacobian F = d s' / d s; covariance F P F^T
// plus process noise (position_noise^2 on x and y, (process_noise rho)^2 on rho).
// Update: the measured point (x, y) (H = [I2 0]) with variance
// point_noise^2 + 1e-10 per coordinate (the floor, (1e-5)^2, is about 0.01 px
// at f = 1000 px: what a model leaves out, e.g. rounding); the covariance in
// Joseph form, which keeps it positive semi-definite.
// Filtering the point's position rather than differencing raw frames is what
// keeps the estimate unbiased under noise: a twist computed from the previous
// noisy frame carries noise correlated with the frame difference it would be
// divided by.
//
// The first update() after construction or reset() initialises each filter
// from its measured point and the prior depth, with rho's standard deviation
// prior_uncertainty * rho. A prediction that lands behind the camera (a depth
// estimate far too small), or a filter that turns non-finite or loses a
// positive variance to rounding, restarts that point from the prior. rho is kept within [1 / (max_depth_ratio * prior), 1 / min_depth].
//
// Frames and units: normalised image coordinates (unit focal length; pixels
// go through CameraModel::normalize first), depths in metres along the
// optical axis, the motion a rigid transform in metres.
// Construction allocates; update() is noexcept and allocation-free.
#pragma once

#include "ibvs/layout.hpp"
#include "ibvs/se3.hpp"

#include <Eigen/Core>

#include <vector>

namespace ibvs {

// Limits (ibvs/limits.hpp): noises of points within max_normalized_coordinate, of rho and the prior's
// uncertainty within max_estimator_noise, min_depth within [min_depth, max_depth] of limits.hpp.
struct DepthEstimatorOptions {
  double point_noise = 0.0;        ///< std of a measured point, normalised units (pixel noise / focal length), in [0, 10]
  double prior_uncertainty = 1.0;  ///< std of the prior inverse depth relative to it, in (0, 1e6] (1 = 100 %)
  double process_noise = 1e-4;     ///< std added to rho per update, relative to rho, in [0, 1e6]
  double position_noise = 1e-6;    ///< std added to x and y per update, normalised units, in [0, 10]
  double min_depth = 1e-3;         ///< metres, in [1e-6, 1e6]: depths are kept >= min_depth
  double max_depth_ratio = 100.0;  ///< in (1, 1e12]: depths are kept <= max_depth_ratio * prior (>= min_depth)
};

class DepthEstimator {
 public:
  /// prior: initial depth guess per point, metres, in [1e-6, 1e6] (N >= 1). Throws
  /// std::invalid_argument naming the bad argument.
  explicit DepthEstimator(const Eigen::Ref<const Eigen::VectorXd>& prior, DepthEstimatorOptions options = {});

  int n_points() const noexcept { return static_cast<int>(prior_.size()); }
  const DepthEstimatorOptions& options() const noexcept { return options_; }
  const Eigen::VectorXd& prior() const noexcept { return prior_; }
  /// False until the first update() after construction or reset().
  bool initialized() const noexcept { return initialized_; }

  /// Forget the state: the next update() starts again from the prior.
  void reset() noexcept { initialized_ = false; }
  /// A new prior (throws like the constructor), then reset().
  void reset(const Eigen::Ref<const Eigen::VectorXd>& prior);

  /// One frame: the measured points uv (2 x N, normalised) and the camera's
  /// motion since the previous frame, as the pose of the current camera in the
  /// previous camera frame (previous <- current, 4x4, metres), or as the camera
  /// twist (m/s, rad/s, camera frame) held for dt seconds (motion = se3_exp(twist * dt)).
  /// The first call initialises from the prior and ignores the motion.
  /// Returns false, changing nothing, for wrong sizes or non-finite input.
  bool update(const Eigen::Ref<const Points>& uv, const Pose& motion) noexcept;
  bool update(const Eigen::Ref<const Points>& uv, const Twist& twist, double dt) noexcept;

  /// Throws std::invalid_argument naming the bad argument (the checks update()
  /// makes, plus a rigid motion: orthonormal rotation, last row 0 0 0 1).
  void validate(const Eigen::Ref<const Points>& uv, const Pose& motion) const;

  const Eigen::VectorXd& depth() const noexcept { return depth_; }        ///< metres, N
  const Eigen::VectorXd& variance() const noexcept { return variance_; }  ///< of depth, m^2, N (first order)
  int restarts() const noexcept { return restarts_; }  ///< points restarted from the prior by the last update()

 private:
  void initialize(const Eigen::Ref<const Points>& uv) noexcept;
  void finish() noexcept;  // depth_ and variance_ from the state
  double measurement_variance() const noexcept;

  DepthEstimatorOptions options_;
  Eigen::VectorXd prior_;
  bool initialized_ = false;
  int restarts_ = 0;
  Eigen::Matrix3Xd state_;             // (x, y, rho) per point
  std::vector<Eigen::Matrix3d> cov_;   // its covariance per point
  Eigen::VectorXd depth_, variance_;
};

}  // namespace ibvs
