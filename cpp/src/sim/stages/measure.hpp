// Stage 1 of an episode's frame, measure: what the camera sees of the target
// and what the controller is given of it (see ibvs/sim/episode.hpp, steps 2-4).
//
//   capture(k)  the target's points in the camera frame, their true projections
//               by the camera model, and the Sensor's measurement of them,
//               written into a latency ring of L + 1 slots (L = latency);
//   view(k)     the measurement taken L frames earlier (frame 0's before frame
//               L: the camera sat at its start), normalised by the camera model:
//               the controller's points uv(), with the true depths of that frame,
//               and their unit bearings bearings() (CameraModel::to_bearing).
//   teach()     the same at the goal (frame -1, teach by showing): the desired
//               points and depths, refused (throws) if the goal cannot be seen.
//
// A wide lens (distortion equidistant or omnidir: wide_lens(), episode.hpp) sees
// beyond 90 degrees off its axis: a point is in its image when
// CameraModel::from_bearing maps it (inside the lens's image circle,
// max_angle) onto the sensor, whatever the sign of its depth, and behind the
// camera only closer than min_depth to its centre. A perspective model keeps
// z >= min_depth and project(x/z, y/z). With bearings_only (the controller
// takes no normalised points: a task of feature blocks only), a measured
// pixel is lost to the controller when it has no bearing, not when it has no
// normalised coordinates (uv() is then NaN beyond 90 degrees).
//
// The stage reports facts (Sighting, the index of a point it could not
// normalise); the judge (judge.hpp) turns them into outcomes. Everything is
// allocated by the constructor; capture() and view() never allocate.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/servo.hpp"
#include "ibvs/sim/sensor.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace ibvs::sim::stages {

/// What capture() found at one frame; -1 = no such point.
struct Sighting {
  int behind = -1;     ///< first point with a depth below min_depth (nothing projected or measured then)
  int outside = -1;    ///< first point whose true projection is off the sensor or that the model cannot map
  bool sensed = true;  ///< Sensor::measure() succeeded
  int missing = -1;    ///< first point the sensor lost (a non-finite column)
  /// Largest distance (measurement units) of a measured point from the goal's measurement
  /// (teach()); NaN when not every point was measured.
  double pixel_error = std::numeric_limits<double>::quiet_NaN();
};

class Measure {
 public:
  /// world_points 3 x N (world frame); latency >= 0 frames; min_depth > 0 metres; bearings_only: see above.
  Measure(const CameraModel& camera, const Eigen::Matrix3Xd& world_points, int latency, double min_depth,
          bool bearings_only = false);

  /// The goal as the camera measures it (frame -1, without noise): uv_desired (2 x N,
  /// normalised), depth_desired (N, true depths) and goal_measured() (measurement units).
  /// Throws std::invalid_argument if a point is behind the camera, off the sensor, or not
  /// found by the sensor.
  void teach(const Pose& goal, Sensor& sensor, Points& uv_desired, Eigen::VectorXd& depth_desired);

  /// Frame k seen from camera pose T_wc (Rcw, tcw: its inverse, camera <- world),
  /// `moved` the twist that brought the camera here (the sensor's exposure).
  Sighting capture(int k, const Pose& T_wc, const Eigen::Matrix3d& Rcw, const Eigen::Vector3d& tcw,
                   const Twist& moved, Sensor& sensor) noexcept;
  /// The controller's points of frame k (the capture of frame k - latency) into uv();
  /// returns the first point whose pixel the model cannot normalise, or -1. A point the
  /// sensor lost (NaN) is marked in valid() (its uv NaN), not returned.
  int view(int k) noexcept;
  /// The last view's points the sensor measured (N), and the first it lost (-1: none).
  const PointMask& valid() const noexcept { return valid_; }
  int first_lost() const noexcept { return first_lost_; }

  /// Whether the camera-frame point P is in the image (see above; its depth or distance checked
  /// apart), its pixel into pixel.
  bool in_image(const Eigen::Ref<const Eigen::Vector3d>& P, Eigen::Vector2d& pixel) const noexcept {
    const bool mapped = wide_ ? camera_.from_bearing(P(0), P(1), P(2), pixel)
                              : camera_.project(P(0) / P(2), P(1) / P(2), pixel);
    return mapped && camera_.contains(pixel(0), pixel(1));
  }

  int slot(int k) const noexcept { return k % slots_; }  ///< ring slot frame k's capture went to
  int seen(int k) const noexcept { return k >= latency_ ? (k - latency_) % slots_ : 0; }  ///< slot view(k) reads
  /// 2 x N measurement in ring slot s (measurement units).
  auto measured(int s) const noexcept {
    return measured_.middleCols(static_cast<Eigen::Index>(s) * n_, n_);
  }
  const Points& projected() const noexcept { return projected_; }  ///< the last capture's true projections
  auto true_depths(int s) const noexcept { return ring_depth_.row(s); }  ///< 1 x N true depths in slot s
  /// camera <- world of the capture in slot s (the true pose of the frame it holds)
  const Pose& camera_from_world(int s) const noexcept { return ring_pose_[static_cast<std::size_t>(s)]; }
  const Points& uv() const noexcept { return uv_; }  ///< the last view: 2 x N normalised points
  const Bearings& bearings() const noexcept { return bearings_; }  ///< the last view: 3 x N unit bearings
  /// teach()'s bearings of the goal's measurement.
  const Bearings& goal_bearings() const noexcept { return goal_bearings_; }
  bool wide() const noexcept { return wide_; }
  /// teach()'s measurement of the goal (measurement units).
  const Points& goal_measured() const noexcept { return goal_; }
  int latency() const noexcept { return latency_; }

 private:
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  CameraModel camera_;
  Eigen::Matrix3Xd world_points_;
  int n_ = 0, latency_ = 0, slots_ = 1;
  double min_depth_ = 0.0;
  bool wide_ = false, bearings_only_ = false;
  Eigen::Matrix3Xd pc_;    // 3 x N points in the camera frame
  Points projected_;       // 2 x N true projections of the last capture
  Points measured_;        // 2 x N(L+1) ring of measurements
  RowMatrix ring_depth_;   // (L+1) x N ring of true depths
  std::vector<Pose> ring_pose_;  // L+1 camera <- world poses of the captures
  Points uv_;              // 2 x N the controller's points
  Bearings bearings_, goal_bearings_;  // 3 x N their bearings, the goal's
  Points goal_;            // 2 x N the goal's measurement (teach)
  PointMask valid_;        // N: the last view's measured points
  int first_lost_ = -1;
};

// ---------------------------------------------------------------- implementation

inline Measure::Measure(const CameraModel& camera, const Eigen::Matrix3Xd& world_points, int latency,
                        double min_depth, bool bearings_only)
    : camera_(camera),
      world_points_(world_points),
      n_(static_cast<int>(world_points.cols())),
      latency_(latency),
      slots_(latency + 1),
      min_depth_(min_depth),
      wide_(wide_lens(camera)),
      bearings_only_(bearings_only) {
  pc_.resize(3, n_);
  projected_.resize(2, n_);
  measured_.resize(2, static_cast<Eigen::Index>(n_) * slots_);
  ring_depth_.resize(slots_, n_);
  ring_pose_.assign(static_cast<std::size_t>(slots_), Pose::Identity());
  uv_.resize(2, n_);
  bearings_.resize(3, n_);
  goal_bearings_.resize(3, n_);
  goal_.setZero(2, n_);
  valid_ = PointMask::Constant(n_, true);
}

inline void Measure::teach(const Pose& goal, Sensor& sensor, Points& uv_desired,
                           Eigen::VectorXd& depth_desired) {
  const auto fail = [](int i, const char* what) {
    throw std::invalid_argument("ibvs: goal: target point " + std::to_string(i) + what);
  };
  const Pose T_cw = se3_inverse(goal);
  for (int i = 0; i < n_; ++i) {
    const Eigen::Vector3d p = T_cw.topLeftCorner<3, 3>() * world_points_.col(i) + T_cw.topRightCorner<3, 1>();
    if (!((wide_ ? p.norm() : p(2)) >= min_depth_)) fail(i, " is behind the camera");
    Eigen::Vector2d m;
    if (!in_image(p, m)) fail(i, " is outside the image");
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
  if (!sensor.measure(f, measured))
    throw std::invalid_argument("ibvs: goal: the sensor failed to measure the goal image");
  for (int i = 0; i < n_; ++i) {
    const Eigen::Vector2d m = measured.col(i);
    Eigen::Vector2d uv;
    if (!m.allFinite())
      throw std::invalid_argument("ibvs: goal: the sensor did not find target point " + std::to_string(i));
    Eigen::Vector3d b;
    const bool in_plane = camera_.normalize(m(0), m(1), uv);
    const bool on_sphere = camera_.to_bearing(m(0), m(1), b);
    if (!(bearings_only_ ? on_sphere : in_plane)) fail(i, " is outside the image");  // as view() loses it
    uv_desired.col(i) = uv;
    goal_bearings_.col(i) = b;
  }
  goal_ = measured;
}

inline Sighting Measure::capture(int k, const Pose& T_wc, const Eigen::Matrix3d& Rcw, const Eigen::Vector3d& tcw,
                                 const Twist& moved, Sensor& sensor) noexcept {
  Sighting s;
  pc_.noalias() = Rcw * world_points_;
  pc_.colwise() += tcw;
  Pose& T_cw = ring_pose_[static_cast<std::size_t>(slot(k))];
  T_cw.setIdentity();
  T_cw.topLeftCorner<3, 3>() = Rcw;
  T_cw.topRightCorner<3, 1>() = tcw;
  for (int i = 0; i < n_ && s.behind < 0; ++i)
    if (!((wide_ ? pc_.col(i).norm() : pc_(2, i)) >= min_depth_)) s.behind = i;
  if (s.behind >= 0) return s;  // no projection through the camera centre
  const int at = slot(k);
  for (int i = 0; i < n_; ++i) {
    // A point the model cannot map (beyond the radius where its distortion folds, or a wide lens's
    // image circle) has left the camera's usable field of view, like a point outside the sensor.
    Eigen::Vector2d p;
    if (!in_image(pc_.col(i), p) && s.outside < 0) s.outside = i;
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

inline int Measure::view(int k) noexcept {
  // A noisy pixel the model cannot invert (past the image of its fold radius) is lost to the controller.
  const int s = seen(k);
  int lost = -1;
  first_lost_ = -1;
  for (int i = 0; i < n_; ++i) {
    const auto m = measured_.col(static_cast<Eigen::Index>(s) * n_ + i);
    Eigen::Vector2d q;
    Eigen::Vector3d b;
    valid_(i) = m.allFinite();
    if (!valid_(i)) {
      q.setConstant(std::numeric_limits<double>::quiet_NaN());
      b.setConstant(std::numeric_limits<double>::quiet_NaN());
      if (first_lost_ < 0) first_lost_ = i;
    } else {
      const bool in_plane = camera_.normalize(m(0), m(1), q);
      const bool on_sphere = camera_.to_bearing(m(0), m(1), b);
      if (!(bearings_only_ ? on_sphere : in_plane) && lost < 0) lost = i;
    }
    uv_.col(i) = q;
    bearings_.col(i) = b;
  }
  return lost;
}

}  // namespace ibvs::sim::stages
