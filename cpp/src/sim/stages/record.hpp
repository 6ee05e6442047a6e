// The episode's History (ibvs/sim/episode.hpp), written row by row as the
// stages produce each frame: open_frame() first (the pose, the joints, and NaN
// or zero wherever a later stage will write, so that a frame an event stopped
// keeps NaN for what it could not compute), then one record_*() per stage.
// allocate() sizes the arrays once; the record functions never allocate.
#pragma once

#include "ibvs/features.hpp"
#include "ibvs/robot_mapping.hpp"
#include "ibvs/servo.hpp"
#include "ibvs/sim/episode.hpp"

#include <limits>

namespace ibvs::sim::stages {

/// K frames of n points, m error rows and s feature-block measurement values, no robot (q, qdot: 0 x 6).
/// Every value NaN until a run writes its frames: the rows past History::frames are never read uninitialised.
inline void allocate(History& h, Eigen::Index K, Eigen::Index n, Eigen::Index m, Eigen::Index s = 0) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  h.time.setConstant(K, nan);
  h.pose.setConstant(K, 16, nan);
  h.twist.setConstant(K, 6, nan);
  h.uv.setConstant(K, 2 * n, nan);
  h.rtheta.setConstant(K, 2 * n, nan);
  h.depth.setConstant(K, n, nan);
  h.measured.setConstant(K, 2 * n, nan);
  h.projected.setConstant(K, 2 * n, nan);
  h.error.setConstant(K, m, nan);
  h.measurements.setConstant(K, s, nan);
  h.error_norm.setConstant(K, nan);
  h.sigma_min.setConstant(K, nan);
  h.q.resize(0, 6);
  h.qdot.resize(0, 6);
  h.manipulability.resize(0);
}

/// The robot's columns: q, qdot (K x joints) and the manipulability, NaN until written.
inline void allocate_joints(History& h, Eigen::Index joints) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  h.q.setConstant(h.time.size(), joints, nan);
  h.qdot.setConstant(h.time.size(), joints, nan);
  h.manipulability.setConstant(h.time.size(), nan);
}

/// Frame k at time t: world <- camera pose and (q non-null) the robot's joints.
inline void open_frame(History& h, int k, double t, const Pose& T_wc, const JointVector* q) noexcept {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  h.time(k) = t;
  Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(h.pose.row(k).data()) = T_wc;
  h.twist.row(k).setZero();
  h.uv.row(k).setConstant(nan);
  h.rtheta.row(k).setConstant(nan);
  h.depth.row(k).setConstant(nan);
  h.measured.row(k).setConstant(nan);
  h.projected.row(k).setConstant(nan);
  h.error.row(k).setConstant(nan);
  h.measurements.row(k).setConstant(nan);
  h.error_norm(k) = h.sigma_min(k) = nan;
  if (q) {
    h.q.row(k) = q->transpose();
    h.qdot.row(k).setZero();
    h.manipulability(k) = nan;
  }
}

/// What the measure stage captured: the true projections and the sensor's measurement (2 x N each).
inline void record_sighting(History& h, int k, const Points& projected,
                            const Eigen::Ref<const Points>& measured) noexcept {
  for (Eigen::Index i = 0; i < projected.cols(); ++i) {
    h.measured(k, 2 * i) = measured(0, i);
    h.measured(k, 2 * i + 1) = measured(1, i);
    h.projected(k, 2 * i) = projected(0, i);
    h.projected(k, 2 * i + 1) = projected(1, i);
  }
}

/// What the controller was given: its points (2 x N; also in polar form) and depths (N).
inline void record_view(History& h, int k, const Points& uv, const Eigen::VectorXd& z) noexcept {
  for (Eigen::Index i = 0; i < uv.cols(); ++i) {
    h.uv(k, 2 * i) = uv(0, i);
    h.uv(k, 2 * i + 1) = uv(1, i);
    const Eigen::Vector2d rt = polar_features(uv(0, i), uv(1, i));
    h.rtheta(k, 2 * i) = rt(0);
    h.rtheta(k, 2 * i + 1) = rt(1);
    h.depth(k, i) = z(i);
  }
}

/// The feature blocks' measurements the controller is given (S).
inline void record_measurements(History& h, int k, const Eigen::VectorXd& m) noexcept {
  h.measurements.row(k) = m.transpose();
}

/// The control stage's output: error, its norm, sigma_min, the commanded twist.
inline void record_control(History& h, int k, const ServoOutput& out) noexcept {
  h.error.row(k) = out.error.transpose();
  h.error_norm(k) = out.error_norm;
  h.sigma_min(k) = out.sigma_min();
  h.twist.row(k) = out.velocity.transpose();
}

/// The robot's joint velocities for this frame and the manipulability of its mapping.
inline void record_joints(History& h, int k, const JointMappingOutput& joints) noexcept {
  h.manipulability(k) = joints.manipulability;
  h.qdot.row(k) = joints.qdot.transpose();
}

}  // namespace ibvs::sim::stages
