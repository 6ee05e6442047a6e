#include "ibvs/sim/episode.hpp"

#include "stages/actuate.hpp"
#include "stages/control.hpp"
#include "stages/depths.hpp"
#include "stages/judge.hpp"
#include "stages/measure.hpp"
#include "stages/record.hpp"
#include "stages/sources.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <variant>

namespace ibvs::sim {

const char* to_string(Outcome o) noexcept {
  switch (o) {
    case Outcome::converged: return "converged";
    case Outcome::left_image: return "left_image";
    case Outcome::behind_camera: return "behind_camera";
    case Outcome::joint_limit: return "joint_limit";
    case Outcome::singular: return "singular";
    case Outcome::diverged: return "diverged";
    case Outcome::timeout: return "timeout";
    case Outcome::target_backside: return "target_backside";
    case Outcome::collision: return "collision";
    case Outcome::lost_feature: return "lost_feature";
  }
  return "unknown";
}

const char* to_string(DepthMode d) noexcept {
  switch (d) {
    case DepthMode::exact: return "exact";
    case DepthMode::pose: return "pose";
    case DepthMode::desired: return "desired";
    case DepthMode::estimated: return "estimated";
  }
  return "unknown";
}

const char* to_string(GoalPose g) noexcept {
  switch (g) {
    case GoalPose::taught: return "taught";
    case GoalPose::given: return "given";
  }
  return "unknown";
}

void EpisodeOptions::validate() const {
  const auto fail = [](const std::string& s) { throw std::invalid_argument("ibvs: " + s); };
  if (!(duration > 0.0) || !std::isfinite(duration)) fail("duration must be finite and > 0");
  if (!(noise >= 0.0) || !std::isfinite(noise)) fail("noise must be finite and >= 0");
  if (latency < 0 || latency > 1000) fail("latency must be in [0, 1000] frames");
  if (depth != DepthMode::exact && depth != DepthMode::pose && depth != DepthMode::desired &&
      depth != DepthMode::estimated)
    fail("depth must be exact, pose, desired or estimated");
  if (!(tolerance_px >= 0.0) || !std::isfinite(tolerance_px)) fail("tolerance_px must be finite and >= 0");
  if (!(tolerance >= 0.0) || (std::isinf(tolerance) && !(tolerance_px > 0.0)))
    fail("tolerance must be finite and >= 0 (inf, no error-norm test, only with a tolerance_px > 0)");
  if (!(min_depth > 0.0) || !std::isfinite(min_depth)) fail("min_depth must be finite and > 0");
  if (!(max_depth_ratio > 1.0)) fail("max_depth_ratio must be > 1");
  if (!(max_error_ratio > 1.0)) fail("max_error_ratio must be > 1");
  // a factor of 1000 either way is already no depth at all; beyond it the servo would refuse every frame
  if (!(depth_scale >= 1e-3 && depth_scale <= 1e3)) fail("depth_scale must be in [0.001, 1000]");
  if (!(boundary_margin >= 0.0) || !std::isfinite(boundary_margin)) fail("boundary_margin must be finite and >= 0");
  if (!(boundary_gain >= 0.0) || !std::isfinite(boundary_gain)) fail("boundary_gain must be finite and >= 0");
  if (!(standoff_ratio >= 0.0) || !std::isfinite(standoff_ratio)) fail("standoff_ratio must be finite and >= 0");
  if (goal_pose != GoalPose::taught && goal_pose != GoalPose::given) fail("goal_pose must be taught or given");
  if (keep_lost && depth != DepthMode::exact && depth != DepthMode::desired)
    fail("keep_lost needs depth exact or desired (the pose and estimated depths need every point)");
  if (!std::isnan(turn) && !(std::abs(turn) <= pi + wrap_hysteresis))
    fail("turn must be NaN or within pi + pi/4 of 0 (radians: which way a half-turn goes)");
}

namespace {

void check_rigid(const Pose& T, const char* name) {
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if (!T.allFinite() || !(R.transpose() * R).isIdentity(1e-9) || std::abs(R.determinant() - 1.0) > 1e-9 ||
      T(3, 0) != 0.0 || T(3, 1) != 0.0 || T(3, 2) != 0.0 || T(3, 3) != 1.0)
    throw std::invalid_argument(std::string("ibvs: ") + name + " must be a rigid transform (orthonormal R, last row 0 0 0 1)");
}

// Rotation angle of R_a^T R_b, accurate near 0 and pi.
double rotation_angle(const Eigen::Matrix3d& Ra, const Eigen::Matrix3d& Rb) noexcept {
  const Eigen::Matrix3d R = Ra.transpose() * Rb;
  const Eigen::Vector3d w(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  return std::atan2(0.5 * w.norm(), 0.5 * (R.trace() - 1.0));
}

const Layout& layout_of(const AnyServo& servo) noexcept {
  return std::visit([](const auto& s) -> const Layout& { return s.layout(); }, servo);
}

// What the servo drives to zero: a Servo's task; a PartitionedServo's layout (its Cartesian error rows).
Task task_of(const AnyServo& servo) {
  if (const Servo* s = std::get_if<Servo>(&servo)) return s->task();
  return Task(layout_of(servo));
}

}  // namespace

// The loop's stages, one of each (see their headers for what each does). The stages are
// header-only and included here alone (and by their tests): the loop stays one translation unit,
// compiled once. On the heap, so that moving an Episode moves none of them (Actuate keeps a
// pointer to the robot, which the Episode shares).
struct Episode::Stages {
  stages::Measure measure;
  stages::Depths depths;
  stages::Sources sources;
  stages::Control control;
  stages::Actuate actuate;
  stages::Judge judge;
};

// Special members out of line: the buffers are allocated and freed by the library's code only.
History::History(const History&) = default;
History::History(History&&) noexcept = default;
History& History::operator=(const History&) = default;
History& History::operator=(History&&) noexcept = default;
History::~History() = default;
EpisodeResult::EpisodeResult(const EpisodeResult&) = default;
EpisodeResult::EpisodeResult(EpisodeResult&&) noexcept = default;
EpisodeResult& EpisodeResult::operator=(const EpisodeResult&) = default;
EpisodeResult& EpisodeResult::operator=(EpisodeResult&&) noexcept = default;
EpisodeResult::~EpisodeResult() = default;
Episode::Episode(Episode&&) noexcept = default;
Episode& Episode::operator=(Episode&&) noexcept = default;
Episode::~Episode() = default;

Episode::Episode(AnyServo servo, CameraModel camera, Target target, EpisodeOptions options)
    : servo_(std::move(servo)), camera_(camera), target_(std::move(target)), options_(options) {
  sensor_ = std::make_shared<ProjectionSensor>(options_.noise);
  camera_.validate();
  target_.validate();
  options_.validate();
  const int n = target_.size();
  const Task task = task_of(servo_);
  const bool blocks = task.n_features() > 0;
  if (task.n_points() != n && !(blocks && task.n_points() == 0))
    throw std::invalid_argument("ibvs: servo layout has " + std::to_string(task.n_points()) +
                                " points but the target has " + std::to_string(n) +
                                (blocks ? " (a task of feature blocks has the target's points or none)" : ""));
  if (options_.keep_lost && !std::holds_alternative<Servo>(servo_))
    throw std::invalid_argument("ibvs: keep_lost needs a Servo (a PartitionedServo cannot leave points out)");
  if (options_.keep_lost && blocks)
    throw std::invalid_argument("ibvs: keep_lost needs a task of points only (feature blocks cannot be left out)");
  if (!std::isnan(options_.turn) && !std::holds_alternative<Servo>(servo_))
    throw std::invalid_argument("ibvs: turn needs a Servo (a PartitionedServo has no angle wrap)");
  // The smooth law's clock (smoothing.hpp) is the frame period.
  if (Servo* s = std::get_if<Servo>(&servo_)) {
    ServoOptions so = s->options();
    if (so.smoothing.enabled() || so.stop_time > 0.0) {
      so.smoothing.period = 1.0 / camera_.fps();
      s->set_options(so);
    }
  }
  const long frames = std::lround(options_.duration * camera_.fps());
  stages_.reset(new Stages{stages::Measure(camera_, target_.world_points(), options_.latency, options_.min_depth,
                                           task.n_points() == 0),
                           // pose: throws unless planar; from the bearings when the measure stage gives no
                           // normalised points beyond 90 degrees (feature blocks only, a wide lens)
                           stages::Depths(options_, camera_, target_.points, task.n_points() == 0 && wide_lens(camera_)),
                           stages::Sources(target_, std::holds_alternative<Servo>(servo_) ? &task : nullptr, options_),
                           stages::Control(task, camera_, options_, n), stages::Actuate(1.0 / camera_.fps()),
                           stages::Judge(target_, options_, static_cast<int>(std::min(frames, 10'000'000L)),
                                         wide_lens(camera_))});
  if (frames < 1 || frames > 10'000'000) throw std::invalid_argument("ibvs: duration * fps must be in [1, 1e7] frames");
  stages::allocate(result_.history, frames, n, task.rows(), task.measurement_size());
  result_.uv_desired.resize(2, n);
  result_.measured_desired.resize(2, n);
  result_.depth_desired.resize(n);
  result_.measurements_desired.resize(task.measurement_size());
}

Episode::Episode(AnyServo servo, CameraModel camera, Target target, std::shared_ptr<Robot> robot,
                 EpisodeOptions options)
    : Episode(std::move(servo), camera, std::move(target), options) {
  if (!robot) throw std::invalid_argument("ibvs: robot must not be null");
  robot->validate();
  robot_ = std::move(robot);
  stages_->actuate.attach(*robot_);
  stages::allocate_joints(result_.history, robot_->dof());
}

Episode::Episode(AnyServo servo, CameraModel camera, Target target, const Gantry& gantry, EpisodeOptions options)
    : Episode(std::move(servo), camera, std::move(target), std::make_shared<Gantry>(gantry), options) {}

// The goal: the desired features as the camera measures them there (teach by showing), the
// depth estimate's prior, the boundary potential's margins and the target's faces.
void Episode::prepare(const Pose& goal) {
  check_rigid(goal, "goal");
  result_.goal = goal;
  Stages& s = *stages_;
  s.measure.teach(goal, *sensor_, result_.uv_desired, result_.depth_desired);
  result_.measured_desired = s.measure.goal_measured();
  s.depths.aim(result_.depth_desired);
  s.depths.teach(result_.uv_desired, &s.measure.goal_bearings());
  s.sources.teach(goal, result_.uv_desired, s.depths.goal_depth(), s.depths.goal_pose_estimate(),
                  &s.measure.goal_bearings());
  result_.measurements_desired = s.sources.desired();
  s.control.aim(s.measure.goal_measured());
  s.judge.aim(goal);
}

const EpisodeResult& Episode::run(const Pose& start, const Pose& goal) {
  if (robot_) throw std::invalid_argument("ibvs: start: this episode has a robot; give joint positions");
  check_rigid(start, "start");
  sensor_->reset(options_.seed);
  prepare(goal);
  loop(start, nullptr);
  return result_;
}

const EpisodeResult& Episode::run(const JointVector& q_start, const Pose& goal) {
  if (!robot_) throw std::invalid_argument("ibvs: start: joint positions need a robot");
  const int n = robot_->dof();
  if (q_start.size() != n)
    throw std::invalid_argument("ibvs: start must have " + std::to_string(n) + " joint positions, got " +
                                std::to_string(q_start.size()));
  if (!q_start.allFinite()) throw std::invalid_argument("ibvs: start joints must be finite");
  const int j = robot_->outside_limits(q_start);
  if (j >= 0)
    throw std::invalid_argument("ibvs: start: joint " + std::to_string(j + 1) + " = " + std::to_string(q_start(j)) +
                                " is outside its limits");
  const Pose T_wc = robot_->camera(q_start);  // throws if the kinematics fail
  sensor_->reset(options_.seed);
  prepare(goal);
  loop(T_wc, &q_start);
  return result_;
}

const EpisodeResult& Episode::run(const JointVector& q_start, const JointVector& q_goal) {
  if (!robot_) throw std::invalid_argument("ibvs: goal: joint positions need a robot");
  if (q_goal.size() != robot_->dof())
    throw std::invalid_argument("ibvs: goal must have " + std::to_string(robot_->dof()) + " joint positions, got " +
                                std::to_string(q_goal.size()));
  if (!q_goal.allFinite()) throw std::invalid_argument("ibvs: goal joints must be finite");
  return run(q_start, robot_->camera(q_goal));
}

// One frame after another until the judge ends the episode: measure, estimate depths,
// control, actuate, with the judge's verdict after each stage and the history recorded
// as the stages produce it.
void Episode::loop(Pose T_wc, const JointVector* q_start) noexcept {
  stages::Measure& measure = stages_->measure;
  stages::Depths& depths = stages_->depths;
  stages::Sources& sources = stages_->sources;
  stages::Control& control = stages_->control;
  stages::Actuate& actuate = stages_->actuate;
  stages::Judge& judge = stages_->judge;
  History& h = result_.history;
  Metrics& mt = result_.metrics;
  EpisodeStatus& st = result_.status;
  mt = Metrics{};
  st = EpisodeStatus{};
  if (Servo* s = std::get_if<Servo>(&servo_)) {
    s->reset();  // a new task: no angle-wrap branch from the last run
    if (!std::isnan(options_.turn)) s->continue_turn(options_.turn);  // validated: cannot throw
  }
  actuate.start(q_start);
  depths.start();
  judge.start();
  const JointVector* q = q_start ? &actuate.q() : nullptr;
  Twist moved = Twist::Zero();  // the twist commanded at the previous frame (the sensor's exposure)

  int k = 0;
  for (;; ++k) {
    stages::open_frame(h, k, k * actuate.dt(), T_wc, q);
    const Eigen::Matrix3d Rcw = T_wc.topLeftCorner<3, 3>().transpose();  // camera <- world, for judge and measure
    const Eigen::Vector3d tcw = -Rcw * T_wc.topRightCorner<3, 1>();
    if (judge.camera(k, T_wc, Rcw, tcw, actuate.kinematics_ok(), st)) break;

    // Measure: this frame into the latency ring, then the frame the controller sees.
    const stages::Sighting sighting = measure.capture(k, T_wc, Rcw, tcw, moved, *sensor_);
    if (sighting.behind < 0)  // else nothing was projected or measured
      stages::record_sighting(h, k, measure.projected(), measure.measured(measure.slot(k)));
    if (judge.sighting(k, sighting, st)) break;
    if (judge.view(k, measure.view(k), st)) break;
    const int seen = measure.seen(k);

    // Estimate depths, then control.
    depths.estimate(k, measure.uv(), measure.true_depths(seen), &measure.bearings());
    stages::record_view(h, k, measure.uv(), depths.depth());

    // Measure the feature blocks (a task's lines, ellipses...) on the frame the controller sees.
    if (sources.active()) {
      const int lost = sources.measure(k, measure.camera_from_world(seen), depths.pose_estimate(), measure.uv(),
                                       depths.depth(), &measure.bearings());
      if (lost < 0) stages::record_measurements(h, k, sources.measurements());
      if (judge.features(k, lost, st)) break;
    }
    const Status s =
        sources.active()
            ? control.step(servo_, measure.uv(), depths.depth(), result_.uv_desired, result_.depth_desired,
                           sources.measurements(), sources.desired(), measure.measured(seen))
            : control.step(servo_, measure.uv(), depths.depth(), result_.uv_desired, result_.depth_desired,
                           measure.measured(seen), &measure.valid());
    if (s != Status::invalid_input) stages::record_control(h, k, control.output());
    if (judge.control(k, s, control.output(), sighting.pixel_error, st, measure.first_lost())) break;

    // Actuate: the motion until the next frame.
    const Twist& v = control.output().velocity;
    Pose T_next;
    const int joint = actuate.step(v, &control.output(), T_wc, T_next);
    if (q) stages::record_joints(h, k, actuate.joints());
    if (judge.motion(k, joint, st)) break;
    depths.odometry(k, T_wc, T_next);  // the camera's motion as the odometry knows it
    mt.path_length += (T_next.topRightCorner<3, 1>() - T_wc.topRightCorner<3, 1>()).norm();
    T_wc = T_next;
    moved = v;
  }
  h.frames = k + 1;
  if (st.outcome == Outcome::converged) mt.frames_to_converge = k;
  mt.camera_retreat = judge.retreat();
  const Pose& goal = result_.goal;
  mt.final_translation_error = (T_wc.topRightCorner<3, 1>() - goal.topRightCorner<3, 1>()).norm();
  mt.final_rotation_error = rotation_angle(goal.topLeftCorner<3, 3>(), T_wc.topLeftCorner<3, 3>());
}

void Episode::set_sensor(std::shared_ptr<Sensor> sensor) {
  sensor_ = sensor ? std::move(sensor) : std::make_shared<ProjectionSensor>(options_.noise);
}

EpisodeResult run_episode(AnyServo servo, const CameraModel& camera, const Target& target, const Pose& start,
                          const Pose& goal, const EpisodeOptions& options) {
  Episode e(std::move(servo), camera, target, options);
  return e.run(start, goal);
}

EpisodeResult run_episode(AnyServo servo, const CameraModel& camera, const Target& target, const Gantry& gantry,
                          const Joints& q_start, const Joints& q_goal, const EpisodeOptions& options) {
  Episode e(std::move(servo), camera, target, gantry, options);
  return e.run(q_start, q_goal);
}

}  // namespace ibvs::sim
