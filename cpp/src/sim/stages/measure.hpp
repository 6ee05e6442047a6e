// Stage 1 of an episode's frame, measure: what the camera sees of the target
// and what the controller is given of it (see ibvs/sim/episode.hpp, steps 2-4).
//
//   capture(k)  the target's points in the camera frame, their true projections
//               by the camera model, and the Sensor's measurement of them,
//               written into a latency ring of L + 1 slots (L = latency);
//   view(k)     the measurement taken L frames earlier (frame 0's before t = L:
//               the camera sat at its start), normalised by the camera model:
//               the controller's points uv(), with the true depths of that frame.
//   teach()     the same at the goal (frame -1, teach by showing): the desired
//               points and depths, refused (throws) if the goal cannot be seen.
//
// The stage reports facts (Sighting, the index of a point it could not
// normalise); the judge (judge.hpp) turns them into outcomes. Everything is
// allocated by the constructor; capture() and view() never allocate.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/sim/sensor.hpp"

#include <Eigen/Core>

#include <limits>

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
  Measure() = default;
  /// world_points 3 x N (world frame); latency >= 0 frames; min_depth > 0 metres.
  Measure(const CameraModel& camera, const Eigen::Matrix3Xd& world_points, int latency, double min_depth);

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
  /// returns the first point whose pixel the model cannot normalise, or -1.
  int view(int k) noexcept;

  int slot(int k) const noexcept { return k % slots_; }  ///< ring slot frame k's capture went to
  int seen(int k) const noexcept { return k >= latency_ ? (k - latency_) % slots_ : 0; }  ///< slot view(k) reads
  /// 2 x N measurement in ring slot s (measurement units).
  auto measured(int s) const noexcept {
    return measured_.middleCols(static_cast<Eigen::Index>(s) * n_, n_);
  }
  const Points& projected() const noexcept { return projected_; }  ///< the last capture's true projections
  auto true_depths(int s) const noexcept { return ring_depth_.row(s); }  ///< 1 x N true depths in slot s
  const Points& uv() const noexcept { return uv_; }  ///< the last view: 2 x N normalised points
  /// teach()'s measurement of the goal (measurement units).
  const Points& goal_measured() const noexcept { return goal_; }
  int latency() const noexcept { return latency_; }

 private:
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  CameraModel camera_;
  Eigen::Matrix3Xd world_points_;
  int n_ = 0, latency_ = 0, slots_ = 1;
  double min_depth_ = 0.0;
  Eigen::Matrix3Xd pc_;    // 3 x N points in the camera frame
  Points projected_;       // 2 x N true projections of the last capture
  Points measured_;        // 2 x N(L+1) ring of measurements
  RowMatrix ring_depth_;   // (L+1) x N ring of true depths
  Points uv_;              // 2 x N the controller's points
  Points goal_;            // 2 x N the goal's measurement (teach)
};

}  // namespace ibvs::sim::stages
