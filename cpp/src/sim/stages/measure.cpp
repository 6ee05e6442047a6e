#include "measure.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace ibvs::sim::stages {

Measure::Measure(const CameraModel& camera, const Eigen::Matrix3Xd& world_points, int latency, double min_depth)
    : camera_(camera),
      world_points_(world_points),
      n_(static_cast<int>(world_points.cols())),
      latency_(latency),
      slots_(latency + 1),
      min_depth_(min_depth) {
  pc_.resize(3, n_);
  projected_.resize(2, n_);
  measured_.resize(2, static_cast<Eigen::Index>(n_) * slots_);
  ring_depth_.resize(slots_, n_);
  uv_.resize(2, n_);
  goal_.setZero(2, n_);
}

void Measure::teach(const Pose& goal, Sensor& sensor, Points& uv_desired, Eigen::VectorXd& depth_desired) {
  const auto fail = [](int i, const char* what) {
    throw std::invalid_argument("ibvs: goal: target point " + std::to_string(i) + what);
  };
  const Pose T_cw = se3_inverse(goal);
  for (int i = 0; i < n_; ++i) {
    const Eigen::Vector3d p = T_cw.topLeftCorner<3, 3>() * world_points_.col(i) + T_cw.topRightCorner<3, 1>();
    if (!(p(2) >= min_depth_)) fail(i, " is behind the camera");
    Eigen::Vector2d m;
    if (!camera_.project(p(0) / p(2), p(1) / p(2), m) || !camera_.contains(m(0), m(1))) fail(i, " is outside the image");
    projected_.col(i) = m;
    depth_desired(i) = p(2);
  }
  // What the sensor measures there (frame -1; ProjectionSensor: the projections, without noise).
  const Twist still = Twist::Zero();
  SensorFrame f;
  f.frame = -1;
  f.pose = &goal;
  f.projected = &projected_;
  f.twist = &still;
  auto measured = measured_.leftCols(n_);
  if (!sensor.measure(f, measured)) throw std::invalid_argument("ibvs: goal: the sensor failed to measure the goal image");
  for (int i = 0; i < n_; ++i) {
    const Eigen::Vector2d m = measured.col(i);
    Eigen::Vector2d uv;
    if (!m.allFinite())
      throw std::invalid_argument("ibvs: goal: the sensor did not find target point " + std::to_string(i));
    if (!camera_.normalize(m(0), m(1), uv)) fail(i, " is outside the image");
    uv_desired.col(i) = uv;
  }
  goal_ = measured;
}

Sighting Measure::capture(int k, const Pose& T_wc, const Eigen::Matrix3d& Rcw, const Eigen::Vector3d& tcw,
                          const Twist& moved, Sensor& sensor) noexcept {
  Sighting s;
  pc_.noalias() = Rcw * world_points_;
  pc_.colwise() += tcw;
  for (int i = 0; i < n_ && s.behind < 0; ++i)
    if (!(pc_(2, i) >= min_depth_)) s.behind = i;
  if (s.behind >= 0) return s;  // no projection through the camera centre
  const int at = slot(k);
  for (int i = 0; i < n_; ++i) {
    // A point the model cannot map (beyond the radius where its distortion folds) has left the
    // camera's usable field of view, like a point outside the sensor.
    Eigen::Vector2d p;
    const bool mapped = camera_.project(pc_(0, i) / pc_(2, i), pc_(1, i) / pc_(2, i), p);
    if (s.outside < 0 && !(mapped && camera_.contains(p(0), p(1)))) s.outside = i;
    projected_.col(i) = p;
    ring_depth_(at, i) = pc_(2, i);
  }
  SensorFrame f;
  f.frame = k;
  f.pose = &T_wc;
  f.projected = &projected_;
  f.twist = &moved;
  auto measured = measured_.middleCols(static_cast<Eigen::Index>(at) * n_, n_);
  s.sensed = sensor.measure(f, measured);
  double worst = 0.0;
  for (int i = 0; i < n_; ++i) {
    if (!measured.col(i).allFinite()) {
      if (s.missing < 0) s.missing = i;
    } else {
      worst = std::max(worst, (measured.col(i) - goal_.col(i)).norm());
    }
  }
  if (s.missing < 0 && s.sensed) s.pixel_error = worst;
  return s;
}

int Measure::view(int k) noexcept {
  // A noisy pixel the model cannot invert (past the image of its fold radius) is lost to the controller.
  const int s = seen(k);
  int lost = -1;
  for (int i = 0; i < n_; ++i) {
    const auto m = measured_.col(static_cast<Eigen::Index>(s) * n_ + i);
    Eigen::Vector2d q;
    if (!camera_.normalize(m(0), m(1), q) && lost < 0) lost = i;
    uv_.col(i) = q;
  }
  return lost;
}

}  // namespace ibvs::sim::stages
