// Pixels in, twist out: Servo and PartitionedServo with a CameraModel. The
// measured and desired pixels are normalised by the camera model into the
// servo's own buffers, then the normalised-coordinate update() runs; the
// result adds the largest point-to-goal distance in pixels.
#include "ibvs/partitioned.hpp"
#include "ibvs/servo.hpp"

#include "checks.hpp"

#include <limits>
#include <stdexcept>
#include <string>

namespace ibvs {
namespace {

void require_camera(const CameraModel* camera) {
  if (!camera)
    throw std::invalid_argument(
        "ibvs: camera: this servo has no camera model; set_camera() (Python: camera=) before update_pixels()");
}

// Throws naming the first pixel the camera cannot normalise; returns the normalised points.
// Pixels have no bound of their own: the limit is that of the normalised point they give
// (|u|, |v| <= max_normalized_coordinate, limits.hpp), which update() checks too.
Points normalized(const CameraModel& camera, const Eigen::Ref<const Points>& pixels, const char* name, int n) {
  if (pixels.cols() != n)
    throw std::invalid_argument(std::string("ibvs: ") + name + " must hold " + std::to_string(n) +
                                " points for this layout, got " + std::to_string(pixels.cols()));
  Points uv(2, pixels.cols());
  Eigen::Vector2d q;
  for (Eigen::Index i = 0; i < pixels.cols(); ++i) {
    const std::string which = std::string("ibvs: ") + name + "[" + std::to_string(i) + "]";
    if (!pixels.col(i).allFinite()) throw std::invalid_argument(which + " is not finite");
    const std::string at =
        which + " = (" + detail::number(pixels(0, i)) + ", " + detail::number(pixels(1, i)) + ")";
    if (!camera.normalize(pixels(0, i), pixels(1, i), q))
      throw std::invalid_argument(at + " has no inverse in the camera model (beyond the radius where its distortion "
                                       "stops being one-to-one)");
    if (!detail::valid_coordinate(q(0)) || !detail::valid_coordinate(q(1)))
      throw std::invalid_argument(at + " normalises to (" + detail::number(q(0)) + ", " + detail::number(q(1)) +
                                  "), outside |u|, |v| <= " + detail::number(max_normalized_coordinate) +
                                  " (84 degrees off the optical axis)");
    uv.col(i) = q;
  }
  return uv;
}

// update_pixels() of either law: normalise into the front end's buffers, run update(), add the pixel error.
template <class Law>
Status pixel_step(Law& law, detail::PixelFrontEnd& front, const Eigen::Ref<const Points>& pixels,
                  const Eigen::Ref<const Eigen::VectorXd>& depth, const Eigen::Ref<const Points>& pixels_desired,
                  const Eigen::Ref<const Eigen::VectorXd>& depth_desired, ServoOutput& out) noexcept {
  if (!front.normalize(pixels, pixels_desired)) {
    detail::refuse(out);  // zero twist, NaN error, Jacobian and diagnostics, as update()'s refusals
    out.pixel_error = std::numeric_limits<double>::quiet_NaN();
    return out.status;
  }
  const Status s = law.update(front.uv, depth, front.uv_desired, depth_desired, out);
  out.pixel_error = detail::PixelFrontEnd::max_distance(pixels, pixels_desired);
  return s;
}

}  // namespace

void Servo::set_camera(const CameraModel& camera) {
  camera.validate();
  pixels_.set(camera, task_.n_points());
}

void Servo::validate_pixels(const Eigen::Ref<const Points>& pixels, const Eigen::Ref<const Eigen::VectorXd>& depth,
                            const Eigen::Ref<const Points>& pixels_desired,
                            const Eigen::Ref<const Eigen::VectorXd>& depth_desired) const {
  require_camera(camera());
  const int n = task_.n_points();
  validate(normalized(*camera(), pixels, "pixels", n), depth, normalized(*camera(), pixels_desired, "pixels_desired", n),
           depth_desired);
}

Status Servo::update_pixels(const Eigen::Ref<const Points>& pixels, const Eigen::Ref<const Eigen::VectorXd>& depth,
                            const Eigen::Ref<const Points>& pixels_desired,
                            const Eigen::Ref<const Eigen::VectorXd>& depth_desired, ServoOutput& out) noexcept {
  return pixel_step(*this, pixels_, pixels, depth, pixels_desired, depth_desired, out);
}

void PartitionedServo::set_camera(const CameraModel& camera) {
  camera.validate();
  pixels_.set(camera, layout_.n_points());
}

void PartitionedServo::validate_pixels(const Eigen::Ref<const Points>& pixels,
                                       const Eigen::Ref<const Eigen::VectorXd>& depth,
                                       const Eigen::Ref<const Points>& pixels_desired) const {
  require_camera(camera());
  const int n = layout_.n_points();
  validate(normalized(*camera(), pixels, "pixels", n), depth, normalized(*camera(), pixels_desired, "pixels_desired", n));
}

Status PartitionedServo::update_pixels(const Eigen::Ref<const Points>& pixels,
                                       const Eigen::Ref<const Eigen::VectorXd>& depth,
                                       const Eigen::Ref<const Points>& pixels_desired,
                                       const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                                       ServoOutput& out) noexcept {
  return pixel_step(*this, pixels_, pixels, depth, pixels_desired, depth_desired, out);
}

}  // namespace ibvs
