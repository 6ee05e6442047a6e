// The simulator's measurement hook: what the episode's camera reports of the
// target each frame, in measurement units (pixels for a pixel camera).
//
// The episode computes the true projections of the target's points (camera
// model, no noise) and hands them, with the camera pose and the twist that
// moved the camera into it, to its Sensor, which writes the measured points.
// The default ProjectionSensor is the point simulator's measurement: the true
// projection plus seeded Gaussian noise. An image sensor (Python:
// ibvs.vision.ImageSensor, a subclass of ibvs.sim.Sensor) renders the frame,
// finds the dots or the tag in it and reports their pixels; it may use the
// true projections only to initialise its tracks (frames -1 and 0, as a user
// clicks on the dots), never afterwards.
//
// A point the sensor lost (left its tracking gate or the image, or not
// detected) is reported as a NaN column: the episode ends with
// Outcome::lost_feature and that point's index. measure() returning false
// (the sensor itself failed) ends it as diverged.
#pragma once

#include "ibvs/layout.hpp"
#include "ibvs/se3.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <random>

namespace ibvs::sim {

/// One frame as the sensor sees it.
struct SensorFrame {
  int frame = 0;             ///< -1: the goal (teach by showing), then 0, 1, ... for the episode's frames
  const Pose* pose = nullptr;  ///< world <- camera at this frame
  /// 2 x N true projections, measurement units (NaN where the camera model cannot map a point);
  /// an image sensor may use them to initialise its tracks (frames -1 and 0) only.
  const Points* projected = nullptr;
  /// The camera twist (camera frame) commanded at the previous frame, which moved the camera
  /// here over 1 / fps (zero at frames -1 and 0): the motion during the exposure.
  const Twist* twist = nullptr;
};

class Sensor {
 public:
  virtual ~Sensor() = default;
  /// Called once at the start of every run, before the goal frame, with the episode's seed.
  virtual void reset(std::uint64_t seed) noexcept = 0;
  /// Writes the measured points (2 x N, measurement units; a NaN column = point lost).
  /// Must not throw or allocate (the default does not); false = the sensor failed.
  virtual bool measure(const SensorFrame& frame, Eigen::Ref<Points> measured) noexcept = 0;

 protected:
  Sensor() = default;
  Sensor(const Sensor&) = default;
  Sensor& operator=(const Sensor&) = default;
};

/// The point simulator's measurement: the true projection plus Gaussian noise of std `noise`
/// (measurement units; std::mt19937_64 seeded by reset(), two draws per point, u then v, also
/// for a point the model cannot map). The goal (frame -1) is measured without noise.
class ProjectionSensor final : public Sensor {
 public:
  explicit ProjectionSensor(double noise = 0.0) : noise_(noise) {}
  void reset(std::uint64_t seed) noexcept override {
    rng_.seed(seed);
    gauss_.reset();  // normal_distribution keeps the second value of a pair
  }
  bool measure(const SensorFrame& frame, Eigen::Ref<Points> measured) noexcept override {
    measured = *frame.projected;
    if (frame.frame < 0 || !(noise_ > 0.0)) return true;
    // The expression of the former inline measurement, so that seeded runs are unchanged.
    for (Eigen::Index i = 0; i < measured.cols(); ++i)
      measured.col(i) += noise_ * Eigen::Vector2d(gauss_(rng_), gauss_(rng_));
    return true;
  }
  double noise() const noexcept { return noise_; }

 private:
  double noise_;
  std::mt19937_64 rng_{0};
  std::normal_distribution<double> gauss_{0.0, 1.0};
};

}  // namespace ibvs::sim
