// Scale limits of the inputs: the ranges within which every function of ibvs
// answers with finite numbers. Inputs outside them are refused (validate()
// and the allocating functions throw std::invalid_argument naming the
// argument, Servo::update returns Status::invalid_input). Each limit is where
// the arithmetic needs one, with a wide margin around any physical use.
#pragma once

namespace ibvs {

/// |u|, |v| of an image point in normalised coordinates (unit focal length):
/// 10 is 84 degrees off the optical axis, beyond any pinhole and the useful
/// field of undistorted wide-angle lenses. Larger values are almost always
/// pixels passed by mistake (convert them with CameraModel::normalize,
/// ibvs.CameraModel.normalize in Python).
inline constexpr double max_normalized_coordinate = 10.0;

/// Depths of image points, metres: [1 um, 1000 km]. Keeps 1/z and the
/// Jacobian's products within range.
inline constexpr double min_depth = 1e-6;
inline constexpr double max_depth = 1e6;

/// A polar block nearer than this to the principal point always uses its
/// Cartesian rows, whatever polar_min_radius says: the polar rows grow as
/// 1/r and would overflow the normal matrix as r -> 0.
inline constexpr double polar_radius_floor = 1e-12;

/// Points of a layout (and its largest point index + 1).
inline constexpr int max_points = 1000000;

/// Servo / PartitionedServo gains (and AdaptiveGain::at_zero), 1/s: the
/// twist is at most ~1e20 times the gain, so it stays finite.
inline constexpr double max_gain = 1e250;

/// Entries of a matrix given to damped_pinv / singular_values, and damping
/// values: their squares stay finite. damped_pinv also refuses a nonzero J
/// whose entries are all below 1 / max_matrix_entry in magnitude (its
/// pseudoinverse would overflow).
inline constexpr double max_matrix_entry = 1e150;

/// Entries of a twist given to se3_exp (the motion it returns stays finite).
inline constexpr double max_twist_entry = 1e300;

/// Camera models (CameraModel::validate): focal lengths in [1e-3, 1e7] px,
/// principal point and image bounds within +-1e7 px, distortion coefficients
/// within +-1e4, frame rates up to 1 MHz. Real cameras sit orders of
/// magnitude inside; outside them normalize() would overflow or lose every
/// digit of a pixel.
inline constexpr double min_focal_length = 1e-3;
inline constexpr double max_focal_length = 1e7;
inline constexpr double max_pixel_coordinate = 1e7;
inline constexpr double max_distortion_coefficient = 1e4;
inline constexpr double max_frame_rate = 1e6;

/// Estimator noise and uncertainty settings (DepthEstimatorOptions): their
/// squares and products with 1/z^2 stay finite.
inline constexpr double max_estimator_noise = 1e6;

/// Largest layout (rows) whose update() is guaranteed allocation-free on every
/// route: 256 rows = 64 points stacked. Larger layouts work, but the
/// damping = 0 (QR/SVD) route may then use the heap.
inline constexpr int max_realtime_rows = 256;

/// Weights of a Task's blocks (task.hpp): in [1/max_task_weight, max_task_weight]. A weight
/// scales its rows against the others; beyond 1e6 the weighted J^T J of the damped route
/// can overflow with rows at the other limits (found by the fuzz driver: weights of 1e192).
inline constexpr double max_task_weight = 1e6;

/// Rows of the feature blocks of one Task (task.hpp), beside its points.
inline constexpr int max_feature_rows = 100000;

}  // namespace ibvs
