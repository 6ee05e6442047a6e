// The closed loop of one episode, entirely in C++: camera -> measurement
// (distortion, noise, latency) -> undistorted normalised points -> servo (a
// Servo or a PartitionedServo) -> camera twist -> free-flying camera or the
// joints of a robot (sim/robot.hpp: the gantry, or any arm) -> next frame.
//
// Each frame k (period dt = 1 / fps):
//   1. true camera pose T_wc(k): from the exact SE(3) integration of the
//      previous command (free-flying, T_wc <- T_wc exp(v dt)) or from the
//      robot's forward kinematics at its joint positions (times its mount);
//   2. physical events: the camera against the target's faces (collision,
//      target_backside, below), then the target's points in the camera frame:
//      a point with depth below min_depth ends the episode (behind_camera);
//      one whose noise-free projection falls outside the sensor, or that the
//      camera model cannot map (beyond its max_radius), ends it as left_image
//      (a wide lens, wide_lens() below: the image circle and the sensor decide,
//      whatever the sign of the depth; behind_camera is a distance below
//      min_depth);
//   3. the measurement, by the episode's Sensor (sim/sensor.hpp) from the
//      camera model's true projections (ibvs::CameraModel: kud for the
//      paper's ViSP camera): by default those plus Gaussian noise (seeded;
//      ProjectionSensor), or e.g. dots found in a rendered image
//      (ibvs.vision); a point the sensor lost ends the episode
//      (lost_feature), or with keep_lost is left out by the servo
//      (ServoInput::valid) until too few remain and its twist has ramped to 0. Written into a latency ring buffer; the controller
//      reads the one taken `latency` frames earlier (before t = 0 the camera
//      sat at its start);
//   4. the controller's points: the delayed measurement normalised by the
//      camera model (kdu for ViSP's; a pixel it cannot invert ends the
//      episode as left_image); depths exact (of the delayed frame), from a
//      planar pose estimate, the constant desired depths, or an online
//      estimate from successive frames and the known camera motion
//      (DepthMode::estimated, below); all times depth_scale (a calibration
//      error);
//   5. Servo::update (paper eqs. 11-13) or PartitionedServo::update (Corke &
//      Hutchinson 2001) gives the camera twist; with
//      boundary_margin > 0 an image-boundary potential adds a retreat to Tz
//      (paper Section IV, below); the episode
//      ends when the error norm is under tolerance and, with tolerance_px > 0,
//      every point this frame's measurement (step 3) holds lies within
//      tolerance_px of the goal's measurement (converged), the servo
//      reports a singular J (singular) or the error / target depth blows up
//      (diverged);
//   6. the twist moves the camera (free) or, on a robot, becomes joint
//      velocities through the robot's JointMapping (robot_mapping.hpp: the
//      damped inverse of its camera Jacobian at this frame's joints, scaled
//      uniformly to its speed limits); q advances by dt qdot, and a joint
//      leaving its range ends the episode (joint_limit) with the robot stopped
//      at its last valid q. The robot's kinematics() is called once per frame,
//      at the new joints (pose of the next frame, Jacobian of its mapping).
// Desired features are measured the same way at the goal pose (teach by
// showing: the sensor's frame -1, without noise), so the goal is an exact
// equilibrium of the noise-free loop. The feature blocks' goal pose and depths
// are what the depth mode knows there (source.hpp): the true ones for exact and
// desired, estimated from the goal's image for pose and estimated (with
// goal_pose = GoalPose::given the goal pose is the true one in every mode); the
// points' desired depths z* (EpisodeResult::depth_desired) are the true ones.
//
// Target faces and collisions (step 2). A planar target (all points in its
// z = 0 plane, Target::planar) is a plate: its front is the side of its plane
// the goal camera's centre is on, its extent the disc in that plane about the
// points' centroid through the point farthest from it. Every frame, with c the
// camera centre:
//   * collision: c crossed the plane since the last frame at a point inside
//     the extent (the camera went through the plate), or c is closer to the
//     plate (the disc) than the standoff, standoff_ratio times the goal depth
//     of the target's centroid;
//   * target_backside: c is behind the plane (it crossed it outside the
//     extent, went round the plate's edge, or started there): every point is
//     then seen from behind its plate.
// A non-planar target has no single front: it is exempt from target_backside,
// and collides when c comes closer than the standoff to any of its points
// (EpisodeStatus::point says which). A goal camera in the target's own plane
// leaves the plate without a front (only the standoff applies).
//
// Image-boundary potential (paper Section IV; Corke & Hutchinson 2001, Sec. V):
// for every measured point i and every side of the sensor, d = its distance to
// that side (measurement units) and m = min(boundary_margin, d*) where d* is the
// desired point's distance to the same side (so the goal stays an exact
// equilibrium); with s = d / m,
//   U = 1/2 sum_{i, sides with s < 1} (1/s - 1)^2            (C1, 0 at s = 1)
// grows without bound as a point nears the border. Its rate of change along Tz
// follows from the Tz column of the interaction matrix in measurement units,
// du_i/dTz = (u_i - u0) / z_i, dv_i/dTz = (v_i - v0) / z_i, and the controller
// descends it with the z-translation only:
//   Tz <- Tz_servo - boundary_gain * zbar^2 * dU/dTz,   zbar = mean depth given
// to the controller, so boundary_gain is in 1/s like the servo gain. Near a side
// dU/dTz > 0 (moving forward pushes points outwards), so the camera retreats and
// the image contracts towards the principal point; far from the border U = 0
// and the control law is untouched.
//
// Depth estimate (DepthMode::estimated): ibvs::DepthEstimator (one extended
// Kalman filter per point on (x, y, 1/z), see ibvs/depth_estimator.hpp) fed
// with the controller's points and the camera's motion between its frames as
// the robot's odometry knows it (free flight: the exponential of the commanded
// twist; robot: the forward kinematics at the two joint vectors). Its prior is
// depth_scale z*, point_noise the pixel noise over min(px, py), the depths kept
// within [min_depth, 100 depth_scale z*]. Depth mode "pose": ibvs::PlanarPose
// on the controller's points (the last estimate is kept when one is degenerate);
// for a task of feature blocks only through a wide lens, on their bearings
// (PlanarPose::estimate_bearings: beyond 90 degrees off the axis too).
//
// In the code (cpp/src/sim/episode.cpp) each frame is a sequence of named
// stages, each in its own internal header under cpp/src/sim/stages/ and tested
// on its own (tests/cpp/test_sim_stages.cpp): measure (steps 2-4: the points in
// the camera frame, their projections, the sensor, the latency ring, the
// controller's points), estimate depths (step 4), control (step 5: the servo
// and the boundary potential), actuate (step 6: free flight or the robot's
// joints) and judge (every outcome above, asked after each stage in the order
// given here); record writes the History.
//
// Feature blocks (a Servo of a Task with lines, ellipses, moments, poses...,
// task.hpp): the target carries one FeatureSource per block, in the Task's
// order (ibvs/sim/source.hpp says what each is given and which pose each depth
// mode gives for its depth inputs). After the depth stage, every source
// writes its block's measurement for the frame the controller sees (the
// sources stage) and the servo runs on the task: its points (if any: a Task
// with points has exactly the target's points, in order) and its blocks. A
// source that cannot measure, or a measurement its block refuses, ends the
// episode as lost_feature (EpisodeStatus::feature). Everything else holds for
// any task: the error is the task's (weighted) f (-) f*, converged compares its
// norm with tolerance, and the target's points (the geometry the features are
// made of) decide left_image, behind_camera, the faces and tolerance_px.
//
// Episode preallocates everything; run() does not touch the heap.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/depth_estimator.hpp"
#include "ibvs/partitioned.hpp"
#include "ibvs/planar_pose.hpp"
#include "ibvs/servo.hpp"
#include "ibvs/sim/gantry.hpp"
#include "ibvs/sim/robot.hpp"
#include "ibvs/sim/sensor.hpp"
#include "ibvs/sim/target.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <variant>
#include <vector>

namespace ibvs::sim {

/// The simulator's camera is the core's CameraModel (one class for users and
/// the simulator); the name is kept for code written against ibvs::sim::Camera.
using Camera = CameraModel;

/// The control laws an episode can run: the layout-based law (Cartesian, polar,
/// hybrid, stacked, cylindrical, automatic hybrid; any ServoOptions) or the
/// partitioned law. Both fill a ServoOutput; the episode calls whichever it holds.
using AnyServo = std::variant<Servo, PartitionedServo>;

/// Depth given to the controller.
enum class DepthMode : std::uint8_t {
  exact = 0,    ///< true depth of each point (paper Section III-A)
  pose = 1,     ///< from a planar pose estimate of the measured points (Section III-B)
  desired = 2,  ///< the constant desired depths z*
  estimated = 3,  ///< online estimate from successive frames and the known camera motion (see above)
};

/// The goal pose c*Mo (camera <- target at the goal) of the feature blocks that compare the current
/// pose with the goal's (SourceFrame::goal: PBVS, 2.5-D's rotation, the moments' a* and Z*; source.hpp).
enum class GoalPose : std::uint8_t {
  /// as the depth mode knew it at the goal (teach by showing): estimated from the goal's image like
  /// every frame's pose in the pose and estimated depth modes, the true one in exact and desired
  taught = 0,
  /// the goal's true c*Mo whatever the depth mode (a goal pose measured and given, not taught; the
  /// current pose is still the depth mode's). The same as taught for the exact and desired depths.
  given = 1,
};

/// A lens that sees beyond 90 degrees off its axis (distortion equidistant or omnidir: a fisheye or
/// an omnidirectional camera). For it the episode judges a point in the image when
/// CameraModel::from_bearing maps it inside the lens's image circle (max_angle) and onto the sensor,
/// whatever the sign of its depth; behind_camera only when it is closer than min_depth to the
/// camera centre; and max_depth_ratio bounds the target centroid's distance (the camera retreat
/// stays the rise of its depth z).
inline bool wide_lens(const CameraModel& camera) noexcept {
  return camera.distortion() == Distortion::equidistant || camera.distortion() == Distortion::omnidir;
}

/// How an episode ended.
enum class Outcome : std::uint8_t {
  converged = 0,      ///< error norm < tolerance (and every measured point within tolerance_px of its goal)
  left_image = 1,     ///< a point left the sensor or the camera model's domain (EpisodeStatus::point)
  behind_camera = 2,  ///< a point's depth fell below min_depth (EpisodeStatus::point)
  joint_limit = 3,    ///< the next step would leave a joint's range (EpisodeStatus::joint)
  singular = 4,       ///< the servo reported a rank-deficient interaction matrix
  diverged = 5,       ///< non-finite state, error or target depth beyond its bound, or the robot's kinematics failed
  timeout = 6,        ///< duration elapsed
  target_backside = 7,  ///< the camera centre went behind the planar target's plane (see above)
  collision = 8,        ///< the camera went through the target or within the standoff of it (see above)
  /// the sensor lost a point (tracking gate, image border, not detected; EpisodeStatus::point), or a
  /// feature block could not be measured (EpisodeStatus::feature; source.hpp); with keep_lost: too
  /// few points left and the twist ramped to zero
  lost_feature = 9,
};
const char* to_string(Outcome o) noexcept;
const char* to_string(DepthMode d) noexcept;
const char* to_string(GoalPose g) noexcept;

struct EpisodeOptions {
  double duration = 10.0;   ///< seconds; the history holds lround(duration * fps) frames
  double noise = 0.0;       ///< std of the Gaussian measurement noise, measurement units (pixels)
  int latency = 0;          ///< frames between capture and control, >= 0
  DepthMode depth = DepthMode::exact;
  std::uint64_t seed = 0;   ///< std::mt19937_64 seed of the noise
  /// Converged when the servo's error norm is below this (and the pixel test below passes);
  /// +inf: no test of the error norm, only the pixel test (then tolerance_px must be > 0).
  double tolerance = 1e-4;
  /// > 0: converged also needs every point of the frame's measurement (as the sensor or a
  /// tracker reports it, before latency) within this distance of the goal's measurement,
  /// measurement units (pixels); 0 = no pixel test.
  double tolerance_px = 0.0;
  double min_depth = 1e-3;  ///< metres; behind_camera below it
  double max_depth_ratio = 10.0;   ///< diverged when the target's depth exceeds this times its start depth
  double max_error_ratio = 100.0;  ///< diverged when the error norm exceeds this times its first value
  bool stop_on_singular = true;    ///< end with `singular` when the servo reports it
  double depth_scale = 1.0;        ///< in [1e-3, 1e3]: multiplies the depth given to the controller (estimated: its initial guess)
  double boundary_margin = 0.0;    ///< >= 0, measurement units; 0 = no image-boundary potential
  double boundary_gain = 0.1;      ///< >= 0, 1/s; weight of the boundary potential's Tz retreat
  /// >= 0: collision when the camera centre comes closer to the target than this times the
  /// goal depth of the target's centroid (0: only going through a planar target collides).
  double standoff_ratio = 0.05;
  /// Lost points (a tracker's): false (default) ends the episode as lost_feature at the first
  /// frame the sensor loses a point. True: the servo (a Servo; depth exact or desired) is given
  /// the lost points as invalid (ServoInput::valid) and runs on the others while enough remain
  /// (degraded, not converged while a point is lost); with too few it ramps the twist to zero
  /// over its stop_time (Status::features_lost) and the episode ends as lost_feature when the
  /// twist has reached zero, unless the points come back first.
  bool keep_lost = false;
  /// The feature blocks' goal pose (SourceFrame::goal): taught (default) from the goal's image as the
  /// depth mode knows it, or given, the goal's true c*Mo (not times depth_scale: it is given). With a
  /// wrong camera model a taught goal carries the current pose's bias and PBVS ends at the goal; a given
  /// one does not, and PBVS ends where the estimate equals it (docs/compare.md, "Calibration errors").
  GoalPose goal_pose = GoalPose::taught;
  /// Which way a half-turn about the optical axis goes (radians, Servo::continue_turn after the run's
  /// reset): +pi or -pi instead of the first frame's image noise; NaN (default): the noise decides. A
  /// Servo only; NaN or |turn| <= pi + pi/4.
  double turn = std::numeric_limits<double>::quiet_NaN();

  void validate() const;  ///< throws std::invalid_argument naming the field
};

struct EpisodeStatus {
  Outcome outcome = Outcome::timeout;
  int frame = -1;  ///< frame of the event (last frame for timeout)
  int point = -1;  ///< point index for left_image / behind_camera / lost_feature (and collision with a non-planar target)
  int joint = -1;  ///< joint index for joint_limit
  int feature = -1;  ///< feature block index for lost_feature (a block its source could not measure)
};

struct Metrics {
  int frames_to_converge = -1;   ///< -1 unless converged
  double camera_retreat = 0.0;   ///< max over k of (target depth(k) - target depth(0)), >= 0, metres
  double path_length = 0.0;      ///< length of the camera centre's path, metres
  double final_translation_error = 0.0;  ///< |p - p_goal| at the last frame, metres
  double final_rotation_error = 0.0;     ///< angle of R_goal^T R at the last frame, radians
};

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Row k = frame k; the first `frames` rows are valid (the others hold NaN,
/// or what an earlier run of the same Episode wrote). Quantities the last
/// frame could not compute (an event stopped it) are NaN.
///
/// uv, rtheta and depth record what the controller was given, whatever the
/// servo does with it (rtheta is the points in polar form, also for a
/// Cartesian or partitioned servo). error is the servo's ServoOutput::error:
/// f (-) f* of its task (points, then feature blocks, weighted), the Cartesian
/// error (M = 2N) for a PartitionedServo. measurements: the feature blocks'
/// measurements the controller was given (S = Task::measurement_size(); 0
/// columns for a task of points only).
/// sigma_min is ServoOutput::sigma_min: for a Servo the smallest singular value
/// of its interaction matrix (NaN, "not computed", when its diagnostics are off
/// on the damped route), for a PartitionedServo that of the four (Tx, Ty, wx, wy)
/// columns of its Cartesian Jacobian.
struct History {
  History() = default;
  // Special members defined in the library (which allocates the arrays), for consumers built with other flags.
  History(const History&);
  History(History&&) noexcept;
  History& operator=(const History&);
  History& operator=(History&&) noexcept;
  ~History();
  int frames = 0;
  Eigen::VectorXd time;    ///< s
  RowMatrix pose;          ///< K x 16: world <- camera, 4x4 row-major
  RowMatrix q, qdot;       ///< K x n (robot only; 0 columns otherwise): qdot applied after frame k
  RowMatrix twist;         ///< K x 6: commanded camera twist
  RowMatrix uv;            ///< K x 2N: controller's (u, v) per point, normalised
  RowMatrix rtheta;        ///< K x 2N: the same points as (r, theta), theta in (-pi, pi]
  RowMatrix depth;         ///< K x N: depths given to the controller
  RowMatrix measured;      ///< K x 2N: the sensor's (u, v) per point at frame k (measurement units, before latency)
  RowMatrix projected;     ///< K x 2N: the true projections at frame k (measurement units)
  RowMatrix error;         ///< K x M: f (-) f* (the servo's error: M = Task::rows(), 2N for a PartitionedServo)
  RowMatrix measurements;  ///< K x S: the feature blocks' measurements given to the controller
  Eigen::VectorXd error_norm, sigma_min;
  /// product of the camera Jacobian's singular values (JointMappingOutput::manipulability;
  /// |det J| = |cos q5| on the gantry), robot only
  Eigen::VectorXd manipulability;
};

struct EpisodeResult {
  EpisodeResult() = default;
  EpisodeResult(const EpisodeResult&);
  EpisodeResult(EpisodeResult&&) noexcept;
  EpisodeResult& operator=(const EpisodeResult&);
  EpisodeResult& operator=(EpisodeResult&&) noexcept;
  ~EpisodeResult();
  EpisodeStatus status;
  Metrics metrics;
  History history;
  Points uv_desired;              ///< 2 x N, what the controller aims at
  /// 2 x N, the goal as the sensor measured it (measurement units, pixels): what tolerance_px
  /// compares each frame's measurement with.
  Points measured_desired;
  Eigen::VectorXd depth_desired;  ///< N
  Eigen::VectorXd measurements_desired;  ///< S, the feature blocks' measurements at the goal
  Pose goal = Pose::Identity();   ///< world <- camera at the goal
};

/// One simulated set-up, run as often as wanted. The constructor validates
/// (throws std::invalid_argument) and allocates; run() only checks its start
/// and goal (throws) and then loops without allocating. The servo (a Servo or a
/// PartitionedServo, moved in) must have as many points as the target, or (a Servo of a
/// Task of feature blocks only) none, and one source in Target::sources per feature block.
class Episode {
 public:
  /// Free-flying camera.
  Episode(AnyServo servo, CameraModel camera, Target target, EpisodeOptions options = {});
  /// Camera on a robot (validated here; shared, not copied: run() calls its
  /// kinematics(), so a robot must not be run by two episodes at once).
  Episode(AnyServo servo, CameraModel camera, Target target, std::shared_ptr<Robot> robot, EpisodeOptions options = {});
  /// Camera on the gantry (a copy of it).
  Episode(AnyServo servo, CameraModel camera, Target target, const Gantry& gantry, EpisodeOptions options = {});
  // Special members defined in the library (which allocates the workspaces), for consumers built with other flags.
  Episode(Episode&&) noexcept;
  Episode& operator=(Episode&&) noexcept;
  ~Episode();

  /// Free-flying: start and goal are world <- camera poses.
  const EpisodeResult& run(const Pose& start, const Pose& goal);
  /// Robot: start joints (n); goal joints or a world <- camera pose.
  const EpisodeResult& run(const JointVector& q_start, const JointVector& q_goal);
  const EpisodeResult& run(const JointVector& q_start, const Pose& goal);
  const EpisodeResult& run(const Joints& q_start, const Joints& q_goal) {
    return run(JointVector(q_start), JointVector(q_goal));
  }
  const EpisodeResult& run(const Joints& q_start, const Pose& goal) { return run(JointVector(q_start), goal); }

  const EpisodeResult& result() const noexcept { return result_; }
  int capacity() const noexcept { return static_cast<int>(result_.history.time.size()); }
  bool has_robot() const noexcept { return robot_ != nullptr; }
  Robot* robot() const noexcept { return robot_.get(); }
  /// The servo run by this episode (std::get<Servo> or std::get<PartitionedServo>).
  AnyServo& servo() noexcept { return servo_; }
  /// The measurement (default: ProjectionSensor(options.noise)); shared, not copied: a sensor
  /// must not be run by two episodes at once. Null restores the default.
  void set_sensor(std::shared_ptr<Sensor> sensor);
  Sensor& sensor() const noexcept { return *sensor_; }

 private:
  struct Stages;  // the loop's stages (cpp/src/sim/stages/), built by the constructors
  void prepare(const Pose& goal);
  void loop(Pose T_wc, const JointVector* q_start) noexcept;

  AnyServo servo_;
  CameraModel camera_;
  Target target_;
  std::shared_ptr<Robot> robot_;
  std::shared_ptr<Sensor> sensor_;
  EpisodeOptions options_;
  std::unique_ptr<Stages> stages_;
  EpisodeResult result_;
};

/// One call per episode (allocates its Episode; for repeated runs keep an Episode).
EpisodeResult run_episode(AnyServo servo, const CameraModel& camera, const Target& target, const Pose& start,
                          const Pose& goal, const EpisodeOptions& options = {});
EpisodeResult run_episode(AnyServo servo, const CameraModel& camera, const Target& target, const Gantry& gantry,
                          const Joints& q_start, const Joints& q_goal, const EpisodeOptions& options = {});

}  // namespace ibvs::sim
