// The pixel side of a servo (Servo::update_pixels, PartitionedServo::
// update_pixels): its camera model and the normalised points it fills every
// frame, so that pixels go in and the twist comes out in one call without
// allocating. Not used on its own.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/layout.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <limits>

namespace ibvs::detail {

class PixelFrontEnd {
 public:
  /// Keeps the camera and sizes the buffers for n points (allocates).
  void set(const CameraModel& camera, int n_points) {
    camera_ = camera;
    has_camera_ = true;
    uv.resize(2, n_points);
    uv_desired.resize(2, n_points);
  }
  const CameraModel* camera() const noexcept { return has_camera_ ? &camera_ : nullptr; }

  /// Normalises pixels and pixels_desired (2 x N) into uv and uv_desired; false (buffers NaN
  /// where unmapped) without a camera, with the wrong size, or for a pixel the model cannot map.
  bool normalize(const Eigen::Ref<const Points>& pixels, const Eigen::Ref<const Points>& pixels_desired) noexcept {
    if (!has_camera_ || pixels.cols() != uv.cols() || pixels_desired.cols() != uv.cols()) return false;
    const int bad = camera_.normalize(pixels, uv) + camera_.normalize(pixels_desired, uv_desired);
    return bad == 0;
  }

  /// Largest distance between a point and its desired point (pixels); NaN for sizes that disagree.
  static double max_distance(const Eigen::Ref<const Points>& a, const Eigen::Ref<const Points>& b) noexcept {
    if (a.cols() != b.cols()) return std::numeric_limits<double>::quiet_NaN();
    double d = 0.0;
    for (Eigen::Index i = 0; i < a.cols(); ++i) d = std::max(d, (a.col(i) - b.col(i)).norm());
    return d;
  }

  Points uv, uv_desired;  ///< the normalised points of the last normalize()

 private:
  CameraModel camera_;
  bool has_camera_ = false;
};

}  // namespace ibvs::detail
