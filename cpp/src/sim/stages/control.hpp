// Stage 3 of an episode's frame, control: the camera twist from the servo
// (a Servo, paper eqs. 11-13, or a PartitionedServo, Corke & Hutchinson 2001)
// for the controller's points and depths, plus, with boundary_margin > 0 and
// boundary_gain > 0, the image-boundary potential's retreat along Tz (paper
// Section IV; the formula is in ibvs/sim/episode.hpp). Both servos' update()
// are noexcept and allocation-free; so is this stage once built.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/sim/episode.hpp"

#include <Eigen/Core>

namespace ibvs::sim::stages {

/// The image-boundary potential U of the measured points and the Tz that descends it.
class BoundaryPotential {
 public:
  BoundaryPotential() = default;
  /// margin >= 0 (measurement units), gain >= 0 (1/s); n points.
  BoundaryPotential(const CameraModel& camera, double margin, double gain, int n);
  bool active() const noexcept { return margin_ > 0.0 && gain_ > 0.0; }
  /// The goal's measurement (2 x N, measurement units): each side's margin is capped at the
  /// desired point's distance to it, so that the goal stays an exact equilibrium.
  void aim(const Eigen::Ref<const Points>& goal_measured) noexcept;
  /// -gain zbar^2 dU/dTz for the measured points (2 x N) at depths z (N), zbar their mean;
  /// 0 when no point is within its margin, or if that is not finite.
  double tz(const Eigen::Ref<const Points>& measured, const Eigen::VectorXd& z) const noexcept;

 private:
  CameraModel camera_;
  double margin_ = 0.0, gain_ = 0.0;
  Eigen::Matrix4Xd desired_distance_;  // 4 x N: the goal points' distances to the sides
};

class Control {
 public:
  Control(const Layout& layout, const CameraModel& camera, const EpisodeOptions& options);
  void aim(const Eigen::Ref<const Points>& goal_measured) noexcept { boundary_.aim(goal_measured); }
  /// servo.update(uv, z, uv_desired, z_desired) into output(), then (unless the servo refused
  /// the input) the boundary potential's Tz for `measured`, the measurement uv came from.
  Status step(AnyServo& servo, const Points& uv, const Eigen::VectorXd& z, const Points& uv_desired,
              const Eigen::VectorXd& z_desired, const Eigen::Ref<const Points>& measured) noexcept;
  const ServoOutput& output() const noexcept { return out_; }
  const BoundaryPotential& boundary() const noexcept { return boundary_; }

 private:
  ServoOutput out_;
  BoundaryPotential boundary_;
};

}  // namespace ibvs::sim::stages
