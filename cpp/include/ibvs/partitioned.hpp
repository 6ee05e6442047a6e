// Partitioned IBVS (Corke & Hutchinson, IEEE T-RA 17(4), 2001): the
// optical-axis rotation wz and translation Tz come from two dedicated image
// features, the other four DOF from the Cartesian law with the wz, Tz columns
// moved to the right-hand side.
//
//   theta_z = atan2(v_j - v_i, u_j - u_i)   angle of the segment between image points i, j
//   sigma   = sqrt(|A|)                     A = polygon area of the points (shoelace, in order)
//   wz      = gain * wrap(theta_z - theta_z*)     (d theta_z / dt = -wz for a pure rotation)
//   Tz      = gain * ln(sigma* / sigma)           (d sigma / dt ~ sigma Tz / z)
//   v_xy    = -J_xy^+ (gain e + J_z v_z)         e = uv - uv* (Cartesian, eq. 3 rows)
// where J_xy holds the (Tx, Ty, wx, wy) columns of the stacked Cartesian
// Jacobian and J_z its (Tz, wz) columns. A rotation of pi about the optical
// axis is a pure wz: no camera retreat.
//
// Same contract as Servo: validate() throws naming the argument, update() is
// noexcept and allocation-free (up to max_realtime_rows / 2 points).
#pragma once

#include "ibvs/servo.hpp"

#include <memory>

namespace ibvs {

/// theta_z: angle of the image segment from point i to point j, in (-pi, pi]; NaN when the two
/// points coincide (no segment, theta_z undefined), as its Jacobian.
double segment_angle(const Eigen::Ref<const Points>& uv, int i, int j) noexcept;
/// Its 1x6 Jacobian (d theta_z / dt = J v) at depths z; NaN when points i and j coincide.
Eigen::Matrix<double, 1, 6> segment_angle_jacobian(const Eigen::Ref<const Points>& uv,
                                                   const Eigen::Ref<const Eigen::VectorXd>& z, int i, int j) noexcept;
/// sigma = sqrt(|polygon area|) of the points taken in order.
double area_scale(const Eigen::Ref<const Points>& uv) noexcept;
/// Its 1x6 Jacobian at depths z.
Eigen::Matrix<double, 1, 6> area_scale_jacobian(const Eigen::Ref<const Points>& uv,
                                                const Eigen::Ref<const Eigen::VectorXd>& z) noexcept;

struct PartitionedOptions {
  double gain = 0.5;          ///< gamma > 0, 1/s, for all three parts
  double damping = 0.0;       ///< lambda >= 0 for the 4-column least squares
  int segment_first = 0;      ///< point i of theta_z
  int segment_second = 1;     ///< point j of theta_z (!= i)
  double max_linear_speed = no_limit;   ///< uniform saturation as in ServoOptions
  double max_angular_speed = no_limit;
};

/// The partitioned control law for N >= 3 points (the polygon needs an area).
/// Fills the same ServoOutput as Servo for Layout::cartesian(N): error is the
/// Cartesian error, jacobian the stacked Cartesian Jacobian, sigma_min/max
/// those of its 4 (Tx, Ty, wx, wy) columns.
class PartitionedServo {
 public:
  PartitionedServo(int n_points, PartitionedOptions options = {});  // throws std::invalid_argument
  ~PartitionedServo();
  PartitionedServo(PartitionedServo&&) noexcept;
  PartitionedServo& operator=(PartitionedServo&&) noexcept;

  const Layout& layout() const noexcept { return layout_; }  ///< Layout::cartesian(N)
  const PartitionedOptions& options() const noexcept { return options_; }
  void set_options(const PartitionedOptions& options);
  void validate(const PartitionedOptions& options) const;
  void validate(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                const Eigen::Ref<const Points>& uv_desired) const;

  /// One control step; depth_desired is unused (kept for the Servo signature).
  Status update(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                ServoOutput& out) noexcept;

  /// Pixels in, twist out, as Servo's (cpp/src/pixels.cpp).
  void set_camera(const CameraModel& camera);
  const CameraModel* camera() const noexcept { return pixels_.camera(); }
  void validate_pixels(const Eigen::Ref<const Points>& pixels, const Eigen::Ref<const Eigen::VectorXd>& depth,
                       const Eigen::Ref<const Points>& pixels_desired) const;
  Status update_pixels(const Eigen::Ref<const Points>& pixels, const Eigen::Ref<const Eigen::VectorXd>& depth,
                       const Eigen::Ref<const Points>& pixels_desired,
                       const Eigen::Ref<const Eigen::VectorXd>& depth_desired, ServoOutput& out) noexcept;

 private:
  struct Work;
  Layout layout_;
  PartitionedOptions options_;
  std::unique_ptr<Work> work_;
  detail::PixelFrontEnd pixels_;  // camera and normalised points of update_pixels()
};

}  // namespace ibvs
