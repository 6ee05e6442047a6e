// The episode's History (ibvs/sim/episode.hpp), written row by row as the
// stages produce each frame: open_frame() first (the pose, the joints, and NaN
// or zero wherever a later stage will write, so that a frame an event stopped
// keeps NaN for what it could not compute), then one record_*() per stage.
// allocate() sizes the arrays once; the record functions never allocate.
#pragma once

#include "ibvs/robot_mapping.hpp"
#include "ibvs/servo.hpp"
#include "ibvs/sim/episode.hpp"

namespace ibvs::sim::stages {

/// K frames of n points and m error rows, no robot (q, qdot: 0 x 6).
void allocate(History& h, Eigen::Index K, Eigen::Index n, Eigen::Index m);
/// The robot's columns: q, qdot (K x joints) and the manipulability.
void allocate_joints(History& h, Eigen::Index joints);

/// Frame k at time t: world <- camera pose and (q non-null) the robot's joints.
void open_frame(History& h, int k, double t, const Pose& T_wc, const JointVector* q) noexcept;
/// What the measure stage captured: the true projections and the sensor's measurement (2 x N each).
void record_sighting(History& h, int k, const Points& projected, const Eigen::Ref<const Points>& measured) noexcept;
/// What the controller was given: its points (2 x N; also in polar form) and depths (N).
void record_view(History& h, int k, const Points& uv, const Eigen::VectorXd& z) noexcept;
/// The control stage's output: error, its norm, sigma_min, the commanded twist.
void record_control(History& h, int k, const ServoOutput& out) noexcept;
/// The robot's joint velocities for this frame and the manipulability of its mapping.
void record_joints(History& h, int k, const JointMappingOutput& joints) noexcept;

}  // namespace ibvs::sim::stages
