// Pixels in, twist out: Servo::update_pixels and PartitionedServo::update_pixels
// are CameraModel::normalize followed by update(), with the error in pixels;
// refusals (no camera, a pixel without an inverse) on both error channels.
#include "check.hpp"

#include "ibvs/ibvs.hpp"
#include "ibvs/partitioned.hpp"

#include <cmath>

using namespace ibvs;

namespace {

CameraModel lens() {
  Eigen::Matrix3d K;
  K << 600, 0, 320, 0, 601, 240, 0, 0, 1;
  Eigen::VectorXd d(5);
  d << -0.4, 0.05, 0.001, -0.0005, 0.0;  // folds at r ~ 1.04
  return CameraModel::from_opencv(K, d, 640, 480);
}

template <class Law>
void same_as_normalised(Law& law, const CameraModel& cam) {
  Points uv(2, 4), uvd(2, 4), px(2, 4), pxd(2, 4), back(2, 4), backd(2, 4);
  uvd << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  uv << 0.16, -0.05, -0.16, 0.05, 0.05, 0.16, -0.05, -0.16;
  CHECK(cam.project(uv, px) == 0 && cam.project(uvd, pxd) == 0);
  CHECK(cam.normalize(px, back) == 0 && cam.normalize(pxd, backd) == 0);
  const Eigen::VectorXd z = Eigen::VectorXd::Constant(4, 0.6);
  ServoOutput a(law.layout()), b(law.layout());
  CHECK(law.camera() == nullptr);
  CHECK(law.update_pixels(px, z, pxd, z, a) == Status::invalid_input && a.velocity.isZero());  // no camera yet
  CHECK_THROWS(law.validate_pixels(px, z, pxd, z));
  law.set_camera(cam);
  CHECK(law.camera() && *law.camera() == cam);
  const Status s = law.update_pixels(px, z, pxd, z, a);
  const Status t = law.update(back, z, backd, z, b);
  CHECK(s == t && s != Status::invalid_input && a.velocity == b.velocity && a.error == b.error);
  double d = 0;
  for (int i = 0; i < 4; ++i) d = std::max(d, (px.col(i) - pxd.col(i)).norm());
  CHECK(a.pixel_error == d && std::isnan(b.pixel_error));
  // A pixel past the image of the fold radius: refused on both channels.
  Points far = px;
  far.col(2) << 5000.0, 240.0;
  CHECK(law.update_pixels(far, z, pxd, z, a) == Status::invalid_input && a.velocity.isZero() && std::isnan(a.pixel_error));
  CHECK_THROWS(law.validate_pixels(far, z, pxd, z));
  CHECK(law.update_pixels(px.leftCols(3), z, pxd, z, a) == Status::invalid_input);
}

}  // namespace

// PartitionedServo's validate_pixels has no depth_desired: a thin adapter gives both laws one test.
struct Partitioned : PartitionedServo {
  using PartitionedServo::PartitionedServo;
  void validate_pixels(const Eigen::Ref<const Points>& p, const Eigen::Ref<const Eigen::VectorXd>& z,
                       const Eigen::Ref<const Points>& pd, const Eigen::Ref<const Eigen::VectorXd>&) const {
    PartitionedServo::validate_pixels(p, z, pd);
  }
};

void run_tests() {
  const CameraModel cam = lens();
  ServoOptions o;
  o.gain = 0.5;
  o.damping = 0.01;
  Servo stacked(Layout::stacked(4), o);
  same_as_normalised(stacked, cam);
  Servo cartesian(Layout::cartesian(4), {});
  same_as_normalised(cartesian, cam);
  Partitioned partitioned(4, PartitionedOptions{});
  same_as_normalised(partitioned, cam);
  // The camera survives a move of the servo.
  Servo moved = std::move(stacked);
  CHECK(moved.camera() && *moved.camera() == cam);
}
