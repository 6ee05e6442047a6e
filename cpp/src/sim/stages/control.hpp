// Stage 3 of an episode's frame, control: the camera twist from the servo
// (a Servo, paper eqs. 11-13, or a PartitionedServo, Corke & Hutchinson 2001)
// for the controller's points and depths, plus, with boundary_margin > 0 and
// boundary_gain > 0, the image-boundary potential's retreat along Tz (paper
// Section IV; the formula is in ibvs/sim/episode.hpp). A Servo of a Task with
// feature blocks is given their measurements (the sources stage) and the
// target's points only if its task has points. Both servos' update()
// are noexcept and allocation-free; so is this stage once built.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/sim/episode.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <variant>

namespace ibvs::sim::stages {

/// The image-boundary potential U of the measured points and the Tz that descends it.
class BoundaryPotential {
 public:
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
  /// task: the servo's (a PartitionedServo's: its layout); n: the target's points (-1: the task's).
  Control(const Task& task, const CameraModel& camera, const EpisodeOptions& options, int n = -1);
  void aim(const Eigen::Ref<const Points>& goal_measured) noexcept { boundary_.aim(goal_measured); }
  /// servo.update(uv, z, uv_desired, z_desired) into output() (with a task's feature blocks:
  /// also their measurements m and m_desired; no points for a task without them), then (unless
  /// the servo refused the input) the boundary potential's Tz for `measured`, the measurement
  /// uv came from.
  Status step(AnyServo& servo, const Points& uv, const Eigen::VectorXd& z, const Points& uv_desired,
              const Eigen::VectorXd& z_desired, const Eigen::Ref<const Points>& measured) noexcept;
  Status step(AnyServo& servo, const Points& uv, const Eigen::VectorXd& z, const Points& uv_desired,
              const Eigen::VectorXd& z_desired, const Eigen::VectorXd& m, const Eigen::VectorXd& m_desired,
              const Eigen::Ref<const Points>& measured) noexcept;
  const ServoOutput& output() const noexcept { return out_; }
  const BoundaryPotential& boundary() const noexcept { return boundary_; }

 private:
  ServoOutput out_;
  BoundaryPotential boundary_;
  int task_points_ = 0;  // the servo's points: the target's, or none
};

// ---------------------------------------------------------------- implementation

inline BoundaryPotential::BoundaryPotential(const CameraModel& camera, double margin, double gain, int n)
    : camera_(camera), margin_(margin), gain_(gain) {
  desired_distance_.resize(4, n);
}

inline void BoundaryPotential::aim(const Eigen::Ref<const Points>& goal_measured) noexcept {
  for (Eigen::Index i = 0; i < goal_measured.cols(); ++i) {
    const Eigen::Vector2d m = goal_measured.col(i);
    desired_distance_.col(i) << m(0) - camera_.u_min(), camera_.u_max() - m(0), m(1) - camera_.v_min(),
        camera_.v_max() - m(1);
  }
}

inline double BoundaryPotential::tz(const Eigen::Ref<const Points>& measured,
                                    const Eigen::VectorXd& z_given) const noexcept {
  const Eigen::Index n = measured.cols();
  double dU_dTz = 0.0, zbar = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto p = measured.col(i);
    const double z = z_given(i);
    zbar += z;
    // distance to each side, its derivative along u or v, and d(u or v)/dTz (the Tz column of the
    // interaction matrix in measurement units)
    const double d[4] = {p(0) - camera_.u_min(), camera_.u_max() - p(0), p(1) - camera_.v_min(),
                         camera_.v_max() - p(1)};
    const double sign[4] = {1.0, -1.0, 1.0, -1.0};
    const double rate[4] = {(p(0) - camera_.u0()) / z, (p(0) - camera_.u0()) / z, (p(1) - camera_.v0()) / z,
                            (p(1) - camera_.v0()) / z};
    for (int side = 0; side < 4; ++side) {
      const double m = std::min(margin_, desired_distance_(side, i));
      if (!(m > 0.0)) continue;
      const double s = std::max(d[side] / m, 1e-3);  // bounded: a point on the border is a finite push
      if (s >= 1.0) continue;
      const double dU_dd = -(1.0 / s - 1.0) / (s * s * m);
      dU_dTz += dU_dd * sign[side] * rate[side];
    }
  }
  zbar /= static_cast<double>(n);
  const double tz = -gain_ * zbar * zbar * dU_dTz;
  return std::isfinite(tz) ? tz : 0.0;
}

inline Control::Control(const Task& task, const CameraModel& camera, const EpisodeOptions& options, int n)
    : out_(task),
      boundary_(camera, options.boundary_margin, options.boundary_gain, n < 0 ? task.n_points() : n),
      task_points_(task.n_points()) {}

inline Status Control::step(AnyServo& servo, const Points& uv, const Eigen::VectorXd& z, const Points& uv_desired,
                            const Eigen::VectorXd& z_desired, const Eigen::Ref<const Points>& measured) noexcept {
  const Status s =
      std::visit([&](auto& law) noexcept { return law.update(uv, z, uv_desired, z_desired, out_); }, servo);
  if (s != Status::invalid_input && boundary_.active()) out_.velocity(2) += boundary_.tz(measured, z);
  return s;
}

inline Status Control::step(AnyServo& servo, const Points& uv, const Eigen::VectorXd& z, const Points& uv_desired,
                            const Eigen::VectorXd& z_desired, const Eigen::VectorXd& m,
                            const Eigen::VectorXd& m_desired, const Eigen::Ref<const Points>& measured) noexcept {
  Servo* law = std::get_if<Servo>(&servo);  // feature blocks: a Servo (the episode checked it)
  if (!law) return Status::invalid_input;
  const Eigen::Index np = task_points_;
  const Status s = law->update(uv.leftCols(np), z.head(np), uv_desired.leftCols(np), z_desired.head(np), m,
                               m_desired, out_);
  if (s != Status::invalid_input && boundary_.active()) out_.velocity(2) += boundary_.tz(measured, z);
  return s;
}

}  // namespace ibvs::sim::stages
