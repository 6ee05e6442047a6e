#include "ibvs/sim/episode.hpp"

#include "ibvs/limits.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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

void EpisodeOptions::validate() const {
  const auto fail = [](const std::string& s) { throw std::invalid_argument("ibvs: " + s); };
  if (!(duration > 0.0) || !std::isfinite(duration)) fail("duration must be finite and > 0");
  if (!(noise >= 0.0) || !std::isfinite(noise)) fail("noise must be finite and >= 0");
  if (latency < 0 || latency > 1000) fail("latency must be in [0, 1000] frames");
  if (depth != DepthMode::exact && depth != DepthMode::pose && depth != DepthMode::desired &&
      depth != DepthMode::estimated)
    fail("depth must be exact, pose, desired or estimated");
  if (!(tolerance >= 0.0) || !std::isfinite(tolerance)) fail("tolerance must be finite and >= 0");
  if (!(min_depth > 0.0) || !std::isfinite(min_depth)) fail("min_depth must be finite and > 0");
  if (!(max_depth_ratio > 1.0)) fail("max_depth_ratio must be > 1");
  if (!(max_error_ratio > 1.0)) fail("max_error_ratio must be > 1");
  // a factor of 1000 either way is already no depth at all; beyond it the servo would refuse every frame
  if (!(depth_scale >= 1e-3 && depth_scale <= 1e3)) fail("depth_scale must be in [0.001, 1000]");
  if (!(boundary_margin >= 0.0) || !std::isfinite(boundary_margin)) fail("boundary_margin must be finite and >= 0");
  if (!(boundary_gain >= 0.0) || !std::isfinite(boundary_gain)) fail("boundary_gain must be finite and >= 0");
  if (!(standoff_ratio >= 0.0) || !std::isfinite(standoff_ratio)) fail("standoff_ratio must be finite and >= 0");
}

namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

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

}  // namespace

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
    : servo_(std::move(servo)),
      out_(layout_of(servo_)),
      camera_(camera),
      target_(std::move(target)),
      options_(options) {
  sensor_ = std::make_shared<ProjectionSensor>(options_.noise);
  camera_.validate();
  target_.validate();
  options_.validate();
  const int n = target_.size();
  if (layout_of(servo_).n_points() != n)
    throw std::invalid_argument("ibvs: servo layout has " + std::to_string(layout_of(servo_).n_points()) +
                                " points but the target has " + std::to_string(n));
  if (options_.depth == DepthMode::pose) {
    try {
      pose_estimator_.emplace(target_.points);
    } catch (const std::invalid_argument& e) {  // say which option needs the planar target
      throw std::invalid_argument(std::string("ibvs: the pose depth mode: target ") + (e.what() + 6));
    }
  }
  if (options_.depth == DepthMode::estimated) {  // its prior is set by prepare(), from the goal
    DepthEstimatorOptions eo;
    // capped at the estimator's limit: noise of 10 normalised units (84 degrees) is no measurement at all
    eo.point_noise = std::min(options_.noise / std::min(camera_.px(), camera_.py()), max_normalized_coordinate);
    eo.min_depth = options_.min_depth;
    depth_estimator_.emplace(Eigen::VectorXd::Ones(n), eo);
  }
  world_points_ = target_.world_points();
  centroid_ = target_.points.rowwise().mean();
  centroid_w_ = target_.pose.topLeftCorner<3, 3>() * centroid_ + target_.pose.topRightCorner<3, 1>();
  if (target_.planar()) extent_ = (target_.points.colwise() - centroid_).colwise().norm().maxCoeff();
  const int slots = options_.latency + 1;
  pc_.resize(3, n);
  projected_.resize(2, n);
  measured_.resize(2, static_cast<Eigen::Index>(n) * slots);
  ring_depth_.resize(slots, n);
  uv_.resize(2, n);
  z_.resize(n);
  desired_distance_.resize(4, n);
  ring_motion_.assign(static_cast<std::size_t>(slots), Pose::Identity());
  const long frames = std::lround(options_.duration * camera_.fps());
  if (frames < 1 || frames > 10'000'000) throw std::invalid_argument("ibvs: duration * fps must be in [1, 1e7] frames");
  const Eigen::Index K = frames, m = layout_of(servo_).rows();
  History& h = result_.history;
  h.time.resize(K);
  h.pose.resize(K, 16);
  h.twist.resize(K, 6);
  h.uv.resize(K, 2 * n);
  h.rtheta.resize(K, 2 * n);
  h.depth.resize(K, n);
  h.measured.resize(K, 2 * n);
  h.projected.resize(K, 2 * n);
  h.error.resize(K, m);
  h.error_norm.resize(K);
  h.sigma_min.resize(K);
  h.q.resize(0, 6);
  h.qdot.resize(0, 6);
  h.manipulability.resize(0);
  result_.uv_desired.resize(2, n);
  result_.depth_desired.resize(n);
}

Episode::Episode(AnyServo servo, CameraModel camera, Target target, std::shared_ptr<Robot> robot,
                 EpisodeOptions options)
    : Episode(std::move(servo), camera, std::move(target), options) {
  if (!robot) throw std::invalid_argument("ibvs: robot must not be null");
  robot->validate();
  robot_ = std::move(robot);
  const int n = robot_->dof();
  mapping_.emplace(n, robot_->mount, robot_->mapping_options());
  joint_in_ = JointMappingInput(n);
  joint_out_ = JointMappingOutput(n);
  History& h = result_.history;
  h.q.resize(h.time.size(), n);
  h.qdot.resize(h.time.size(), n);
  h.manipulability.resize(h.time.size());
}

Episode::Episode(AnyServo servo, CameraModel camera, Target target, const Gantry& gantry, EpisodeOptions options)
    : Episode(std::move(servo), camera, std::move(target), std::make_shared<Gantry>(gantry), options) {}

// Desired features as the camera measures them at the goal (teach by showing).
void Episode::prepare(const Pose& goal) {
  check_rigid(goal, "goal");
  result_.goal = goal;
  const Pose T_cw = se3_inverse(goal);
  for (int i = 0; i < target_.size(); ++i) {
    const Eigen::Vector3d p = T_cw.topLeftCorner<3, 3>() * world_points_.col(i) + T_cw.topRightCorner<3, 1>();
    if (!(p(2) >= options_.min_depth))
      throw std::invalid_argument("ibvs: goal: target point " + std::to_string(i) + " is behind the camera");
    Eigen::Vector2d m;
    if (!camera_.project(p(0) / p(2), p(1) / p(2), m) || !camera_.contains(m(0), m(1)))
      throw std::invalid_argument("ibvs: goal: target point " + std::to_string(i) + " is outside the image");
    projected_.col(i) = m;
    result_.depth_desired(i) = p(2);
  }
  // The desired points as the sensor measures them at the goal (frame -1; the default: the projections).
  const Twist still = Twist::Zero();
  SensorFrame f;
  f.frame = -1;
  f.pose = &goal;
  f.projected = &projected_;
  f.twist = &still;
  auto measured = measured_.leftCols(target_.size());
  if (!sensor_->measure(f, measured))
    throw std::invalid_argument("ibvs: goal: the sensor failed to measure the goal image");
  for (int i = 0; i < target_.size(); ++i) {
    const Eigen::Vector2d m = measured.col(i);
    Eigen::Vector2d uv;
    if (!m.allFinite())
      throw std::invalid_argument("ibvs: goal: the sensor did not find target point " + std::to_string(i));
    if (!camera_.normalize(m(0), m(1), uv))
      throw std::invalid_argument("ibvs: goal: target point " + std::to_string(i) + " is outside the image");
    result_.uv_desired.col(i) = uv;
    desired_distance_.col(i) << m(0) - camera_.u_min(), camera_.u_max() - m(0), m(1) - camera_.v_min(),
        camera_.v_max() - m(1);
  }
  if (depth_estimator_) {  // prior: the desired depths times depth_scale (z_ is scratch here: no allocation)
    z_ = options_.depth_scale * result_.depth_desired;
    depth_estimator_->reset(z_);
  }
  // Target faces: the front is the goal camera's side of a planar target's plane.
  const Eigen::Vector3d to_goal = goal.topRightCorner<3, 1>() - centroid_w_;
  standoff_ = options_.standoff_ratio * (T_cw.topLeftCorner<3, 3>() * centroid_w_ + T_cw.topRightCorner<3, 1>())(2);
  front_.setZero();
  if (target_.planar()) {
    const Eigen::Vector3d n = target_.pose.topLeftCorner<3, 3>().col(2);
    const double side = n.dot(to_goal);
    if (std::abs(side) > 1e-9 * std::max(1.0, to_goal.norm())) front_ = side > 0.0 ? n : Eigen::Vector3d(-n);
  }
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

void Episode::loop(Pose T_wc, const JointVector* q_start) noexcept {
  const int n = target_.size();
  const int K = capacity();
  const int slots = options_.latency + 1;
  const double dt = 1.0 / camera_.fps();
  const bool robot = q_start != nullptr;
  JointVector q = robot ? *q_start : JointVector();
  // The robot's end-effector pose and Jacobian at q (kinematics() once per frame).
  Pose T_we = Pose::Identity();
  bool kinematics_ok = !robot || robot_->kinematics(q, T_we, joint_in_.jacobian);
  Twist moved = Twist::Zero();  // the twist commanded at the previous frame (the sensor's exposure)

  History& h = result_.history;
  Metrics& mt = result_.metrics;
  EpisodeStatus& st = result_.status;
  mt = Metrics{};
  st = EpisodeStatus{};
  if (Servo* s = std::get_if<Servo>(&servo_)) s->reset();  // a new task: no angle-wrap branch from the last run
  Pose T_est = Pose::Identity();
  bool have_est = false;
  double depth0 = 0.0, error0 = 0.0;
  Eigen::Vector3d c_prev = T_wc.topRightCorner<3, 1>();  // camera centre at the last frame

  int k = 0;
  for (;; ++k) {
    // 1. Pose and bookkeeping of this frame.
    h.time(k) = k * dt;
    Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(h.pose.row(k).data()) = T_wc;
    if (robot) h.q.row(k) = q.transpose();
    h.twist.row(k).setZero();
    h.uv.row(k).setConstant(nan);
    h.rtheta.row(k).setConstant(nan);
    h.depth.row(k).setConstant(nan);
    h.measured.row(k).setConstant(nan);
    h.projected.row(k).setConstant(nan);
    h.error.row(k).setConstant(nan);
    h.error_norm(k) = h.sigma_min(k) = nan;
    if (robot) {
      h.qdot.row(k).setZero();
      h.manipulability(k) = nan;
    }
    const Eigen::Matrix3d Rcw = T_wc.topLeftCorner<3, 3>().transpose();
    const Eigen::Vector3d tcw = -Rcw * T_wc.topRightCorner<3, 1>();
    const double target_depth = (Rcw * centroid_w_ + tcw)(2);
    if (k == 0) depth0 = target_depth;
    mt.camera_retreat = std::max(mt.camera_retreat, target_depth - depth0);
    if (!kinematics_ok || !T_wc.allFinite() || target_depth > options_.max_depth_ratio * std::abs(depth0)) {
      st = {Outcome::diverged, k, -1, -1};
      break;
    }

    // 2. Physical events: the camera against the target's faces, then the points in the camera frame.
    if (target_contact(c_prev, T_wc.topRightCorner<3, 1>(), k > 0, st)) {
      st.frame = k;
      break;
    }
    pc_.noalias() = Rcw * world_points_;
    pc_.colwise() += tcw;
    int behind = -1, outside = -1;
    for (int i = 0; i < n && behind < 0; ++i)
      if (!(pc_(2, i) >= options_.min_depth)) behind = i;
    if (behind >= 0) {
      st = {Outcome::behind_camera, k, behind, -1};
      break;
    }
    // 3. Measurement into the latency ring.
    const int slot = k % slots;
    for (int i = 0; i < n; ++i) {
      // A point the model cannot map (beyond the radius where its distortion folds) has left the
      // camera's usable field of view: left_image, like a point outside the sensor.
      Eigen::Vector2d p;
      const bool mapped = camera_.project(pc_(0, i) / pc_(2, i), pc_(1, i) / pc_(2, i), p);
      if (outside < 0 && !(mapped && camera_.contains(p(0), p(1)))) outside = i;
      projected_.col(i) = p;
      ring_depth_(slot, i) = pc_(2, i);
    }
    SensorFrame f;
    f.frame = k;
    f.pose = &T_wc;
    f.projected = &projected_;
    f.twist = &moved;
    auto measured = measured_.middleCols(static_cast<Eigen::Index>(slot) * n, n);
    const bool sensed = sensor_->measure(f, measured);
    for (int i = 0; i < n; ++i) {
      h.measured(k, 2 * i) = measured(0, i);
      h.measured(k, 2 * i + 1) = measured(1, i);
      h.projected(k, 2 * i) = projected_(0, i);
      h.projected(k, 2 * i + 1) = projected_(1, i);
    }
    if (outside >= 0) {
      st = {Outcome::left_image, k, outside, -1};
      break;
    }
    if (!sensed) {  // the sensor itself failed (e.g. a Python sensor raised)
      st = {Outcome::diverged, k, -1, -1};
      break;
    }
    int missing = -1;
    for (int i = 0; i < n && missing < 0; ++i)
      if (!measured.col(i).allFinite()) missing = i;
    if (missing >= 0) {
      st = {Outcome::lost_feature, k, missing, -1};
      break;
    }
    // Before t = 0 the camera sat at its start pose: frame 0 stands for those frames.
    const int seen = k >= options_.latency ? (k - options_.latency) % slots : 0;

    // 4. What the controller sees: undistorted points and depths. A noisy pixel the model
    // cannot invert (past the image of its fold radius) also counts as left_image.
    int lost = -1;
    for (int i = 0; i < n; ++i) {
      const auto mm = measured_.col(static_cast<Eigen::Index>(seen) * n + i);
      Eigen::Vector2d q;
      if (!camera_.normalize(mm(0), mm(1), q) && lost < 0) lost = i;
      uv_.col(i) = q;
    }
    if (lost >= 0) {
      st = {Outcome::left_image, k, lost, -1};
      break;
    }
    switch (options_.depth) {
      case DepthMode::exact: z_ = ring_depth_.row(seen).transpose(); break;
      case DepthMode::desired: z_ = result_.depth_desired; break;
      case DepthMode::estimated:
        if (k == 0) {  // from the prior, with the first frame's points
          depth_estimator_->reset();
          depth_estimator_->update(uv_, Pose(Pose::Identity()));
        } else if (k > options_.latency) {  // a new frame reached the controller: the motion since the one before
          depth_estimator_->update(uv_, ring_motion_[static_cast<std::size_t>((k - options_.latency - 1) % slots)]);
        }
        z_ = depth_estimator_->depth();
        break;
      case DepthMode::pose: {
        // From the image alone (the homography step needs no initial guess);
        // on failure the last estimate is kept.
        have_est = pose_estimator_->estimate(uv_, T_est) || have_est;
        for (int i = 0; i < n; ++i)
          z_(i) = have_est ? (T_est.row(2).head<3>().dot(target_.points.col(i)) + T_est(2, 3)) : nan;
        break;
      }
    }
    if (options_.depth_scale != 1.0 && options_.depth != DepthMode::estimated) z_ *= options_.depth_scale;

    // 5. Control, by whichever law the episode holds (both update() are noexcept and allocation-free).
    const Status s = std::visit(
        [&](auto& law) noexcept { return law.update(uv_, z_, result_.uv_desired, result_.depth_desired, out_); },
        servo_);
    for (int i = 0; i < n; ++i) {
      h.uv(k, 2 * i) = uv_(0, i);
      h.uv(k, 2 * i + 1) = uv_(1, i);
      const Eigen::Vector2d rt = polar_features(uv_(0, i), uv_(1, i));
      h.rtheta(k, 2 * i) = rt(0);
      h.rtheta(k, 2 * i + 1) = rt(1);
      h.depth(k, i) = z_(i);
    }
    if (s == Status::invalid_input) {  // e.g. an estimated depth <= 0
      st = {Outcome::diverged, k, -1, -1};
      break;
    }
    if (options_.boundary_margin > 0.0 && options_.boundary_gain > 0.0) out_.velocity(2) += boundary_tz(seen);
    h.error.row(k) = out_.error.transpose();
    h.error_norm(k) = out_.error_norm;
    h.sigma_min(k) = out_.sigma_min();
    h.twist.row(k) = out_.velocity.transpose();
    if (k == 0) error0 = out_.error_norm;
    if (out_.error_norm < options_.tolerance) {
      st = {Outcome::converged, k, -1, -1};
      mt.frames_to_converge = k;
      break;
    }
    if (s == Status::singular && options_.stop_on_singular) {
      st = {Outcome::singular, k, -1, -1};
      break;
    }
    if (!out_.velocity.allFinite() || !std::isfinite(out_.error_norm) ||
        out_.error_norm > options_.max_error_ratio * error0) {
      st = {Outcome::diverged, k, -1, -1};
      break;
    }
    if (k == K - 1) {
      st = {Outcome::timeout, k, -1, -1};
      break;
    }

    // 6. Motion until the next frame.
    Pose T_next;
    if (robot) {
      joint_in_.twist = out_.velocity;
      joint_in_.base_rotation = T_we.topLeftCorner<3, 3>();
      mapping_->update(joint_in_, joint_out_);  // qdot within qdot_max; the Jacobian came with T_we
      const JointVector& qdot = joint_out_.qdot;
      h.manipulability(k) = joint_out_.manipulability;
      h.qdot.row(k) = qdot.transpose();
      const JointVector q_next = q + dt * qdot;
      const int j = robot_->outside_limits(q_next);
      if (j >= 0) {
        st = {Outcome::joint_limit, k, -1, j};
        break;
      }
      q = q_next;
      kinematics_ok = robot_->kinematics(q, T_we, joint_in_.jacobian);  // checked at the next frame
      T_next = T_we * robot_->mount;
    } else {
      T_next = T_wc * se3_exp(out_.velocity * dt);  // exact SE(3) integration of the twist
    }
    if (options_.depth == DepthMode::estimated) {  // the camera's motion over the period, as odometry knows it
      Pose& M = ring_motion_[static_cast<std::size_t>(k % slots)];
      M.setIdentity();
      M.topLeftCorner<3, 3>() = T_wc.topLeftCorner<3, 3>().transpose() * T_next.topLeftCorner<3, 3>();
      M.topRightCorner<3, 1>() =
          T_wc.topLeftCorner<3, 3>().transpose() * (T_next.topRightCorner<3, 1>() - T_wc.topRightCorner<3, 1>());
    }
    mt.path_length += (T_next.topRightCorner<3, 1>() - T_wc.topRightCorner<3, 1>()).norm();
    c_prev = T_wc.topRightCorner<3, 1>();
    T_wc = T_next;
    moved = out_.velocity;
  }
  h.frames = k + 1;
  const Pose& goal = result_.goal;
  mt.final_translation_error = (T_wc.topRightCorner<3, 1>() - goal.topRightCorner<3, 1>()).norm();
  mt.final_rotation_error = rotation_angle(goal.topLeftCorner<3, 3>(), T_wc.topLeftCorner<3, 3>());
}

// Collision or target_backside (see episode.hpp) for the camera centre moving from
// `from` (the last frame's; ignored unless `moved`) to `to`; fills st and returns true.
bool Episode::target_contact(const Eigen::Vector3d& from, const Eigen::Vector3d& to, bool moved,
                             EpisodeStatus& st) const noexcept {
  if (front_.isZero()) {  // no plate: the standoff around each point
    for (int i = 0; i < target_.size(); ++i)
      if ((to - world_points_.col(i)).norm() < standoff_) {
        st = {Outcome::collision, -1, i, -1};
        return true;
      }
    return false;
  }
  // Height above the plane (> 0 in front) and distance from the centroid within it.
  const auto height = [&](const Eigen::Vector3d& c) { return front_.dot(c - centroid_w_); };
  const auto radial = [&](const Eigen::Vector3d& c, double hc) { return (c - centroid_w_ - hc * front_).norm(); };
  const double h1 = height(to);
  if (moved) {
    const double h0 = height(from);
    if (h0 > 0.0 && h1 <= 0.0) {  // crossed the plane since the last frame: where?
      const Eigen::Vector3d x = from + (h0 / (h0 - h1)) * (to - from);
      st = {radial(x, 0.0) <= extent_ ? Outcome::collision : Outcome::target_backside, -1, -1, -1};
      return true;
    }
  }
  if (!(h1 > 0.0)) {
    st = {Outcome::target_backside, -1, -1, -1};
    return true;
  }
  if (std::hypot(h1, std::max(0.0, radial(to, h1) - extent_)) < standoff_) {
    st = {Outcome::collision, -1, -1, -1};
    return true;
  }
  return false;
}

// Tz of the image-boundary potential (see episode.hpp) for the measurement the
// controller sees (ring slot `seen`) and the depths z_ it is given.
double Episode::boundary_tz(int seen) const noexcept {
  const int n = target_.size();
  const double margin = options_.boundary_margin;
  double dU_dTz = 0.0, zbar = 0.0;
  for (int i = 0; i < n; ++i) {
    const auto p = measured_.col(static_cast<Eigen::Index>(seen) * n + i);
    const double z = z_(i);
    zbar += z;
    // distance to each side, its derivative along u or v, and d(u or v)/dTz
    const double d[4] = {p(0) - camera_.u_min(), camera_.u_max() - p(0), p(1) - camera_.v_min(),
                         camera_.v_max() - p(1)};
    const double sign[4] = {1.0, -1.0, 1.0, -1.0};
    const double rate[4] = {(p(0) - camera_.u0()) / z, (p(0) - camera_.u0()) / z, (p(1) - camera_.v0()) / z,
                            (p(1) - camera_.v0()) / z};
    for (int side = 0; side < 4; ++side) {
      const double m = std::min(margin, desired_distance_(side, i));
      if (!(m > 0.0)) continue;
      const double s = std::max(d[side] / m, 1e-3);
      if (s >= 1.0) continue;
      const double dU_dd = -(1.0 / s - 1.0) / (s * s * m);
      dU_dTz += dU_dd * sign[side] * rate[side];
    }
  }
  zbar /= n;
  const double tz = -options_.boundary_gain * zbar * zbar * dU_dTz;
  return std::isfinite(tz) ? tz : 0.0;
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
