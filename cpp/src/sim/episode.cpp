#include "ibvs/sim/episode.hpp"

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
  if (!(depth_scale > 0.0) || !std::isfinite(depth_scale)) fail("depth_scale must be finite and > 0");
  if (!(boundary_margin >= 0.0) || !std::isfinite(boundary_margin)) fail("boundary_margin must be finite and >= 0");
  if (!(boundary_gain >= 0.0) || !std::isfinite(boundary_gain)) fail("boundary_gain must be finite and >= 0");
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

Episode::Episode(AnyServo servo, Camera camera, Target target, EpisodeOptions options)
    : servo_(std::move(servo)),
      out_(layout_of(servo_)),
      camera_(camera),
      target_(std::move(target)),
      options_(options) {
  camera_.validate();
  target_.validate();
  options_.validate();
  const int n = target_.size();
  if (layout_of(servo_).n_points() != n)
    throw std::invalid_argument("ibvs: servo layout has " + std::to_string(layout_of(servo_).n_points()) +
                                " points but the target has " + std::to_string(n));
  if (options_.depth == DepthMode::pose) estimator_.emplace(target_.points);
  world_points_ = target_.world_points();
  centroid_ = target_.points.rowwise().mean();
  const int slots = options_.latency + 1;
  pc_.resize(3, n);
  measured_.resize(2, static_cast<Eigen::Index>(n) * slots);
  ring_depth_.resize(slots, n);
  uv_.resize(2, n);
  z_.resize(n);
  desired_distance_.resize(4, n);
  rho_.resize(n);
  rho_var_.resize(n);
  uv_prev_.resize(2, n);
  ring_twist_.resize(slots, 6);
  const long frames = std::lround(options_.duration * camera_.fps);
  if (frames < 1 || frames > 10'000'000) throw std::invalid_argument("ibvs: duration * fps must be in [1, 1e7] frames");
  const Eigen::Index K = frames, m = layout_of(servo_).rows();
  History& h = result_.history;
  h.time.resize(K);
  h.pose.resize(K, 16);
  h.twist.resize(K, 6);
  h.uv.resize(K, 2 * n);
  h.rtheta.resize(K, 2 * n);
  h.depth.resize(K, n);
  h.error.resize(K, m);
  h.error_norm.resize(K);
  h.sigma_min.resize(K);
  h.q.resize(0, 6);
  h.qdot.resize(0, 6);
  h.manipulability.resize(0);
  result_.uv_desired.resize(2, n);
  result_.depth_desired.resize(n);
}

Episode::Episode(AnyServo servo, Camera camera, Target target, Gantry gantry, EpisodeOptions options)
    : Episode(std::move(servo), camera, std::move(target), options) {
  gantry.validate();
  gantry_ = gantry;
  History& h = result_.history;
  h.q.resize(h.time.size(), 6);
  h.qdot.resize(h.time.size(), 6);
  h.manipulability.resize(h.time.size());
}

// Desired features as the camera measures them at the goal (teach by showing).
void Episode::prepare(const Pose& goal) {
  check_rigid(goal, "goal");
  result_.goal = goal;
  const Pose T_cw = se3_inverse(goal);
  for (int i = 0; i < target_.size(); ++i) {
    const Eigen::Vector3d p = T_cw.topLeftCorner<3, 3>() * world_points_.col(i) + T_cw.topRightCorner<3, 1>();
    if (!(p(2) >= options_.min_depth))
      throw std::invalid_argument("ibvs: goal: target point " + std::to_string(i) + " is behind the camera");
    const Eigen::Vector2d m = camera_.project(p(0) / p(2), p(1) / p(2));
    if (!camera_.contains(m(0), m(1)))
      throw std::invalid_argument("ibvs: goal: target point " + std::to_string(i) + " is outside the image");
    result_.uv_desired.col(i) = camera_.normalize(m(0), m(1));
    desired_distance_.col(i) << m(0) - camera_.u_min, camera_.u_max - m(0), m(1) - camera_.v_min, camera_.v_max - m(1);
    result_.depth_desired(i) = p(2);
  }
}

const EpisodeResult& Episode::run(const Pose& start, const Pose& goal) {
  if (gantry_) throw std::invalid_argument("ibvs: start: this episode has a gantry; give joint positions");
  check_rigid(start, "start");
  prepare(goal);
  loop(start, nullptr);
  return result_;
}

const EpisodeResult& Episode::run(const Joints& q_start, const Pose& goal) {
  if (!gantry_) throw std::invalid_argument("ibvs: start: joint positions need a gantry");
  if (!q_start.allFinite()) throw std::invalid_argument("ibvs: start joints must be finite");
  const int j = gantry_->outside_limits(q_start);
  if (j >= 0)
    throw std::invalid_argument("ibvs: start: joint " + std::to_string(j + 1) + " = " + std::to_string(q_start(j)) +
                                " is outside its limits");
  prepare(goal);
  loop(gantry_->camera(q_start), &q_start);
  return result_;
}

const EpisodeResult& Episode::run(const Joints& q_start, const Joints& q_goal) {
  if (!gantry_) throw std::invalid_argument("ibvs: goal: joint positions need a gantry");
  if (!q_goal.allFinite()) throw std::invalid_argument("ibvs: goal joints must be finite");
  return run(q_start, gantry_->camera(q_goal));
}

void Episode::loop(Pose T_wc, const Joints* q_start) noexcept {
  const int n = target_.size();
  const int K = capacity();
  const int slots = options_.latency + 1;
  const double dt = 1.0 / camera_.fps;
  const bool gantry = q_start != nullptr;
  Joints q = gantry ? *q_start : Joints::Zero();
  std::mt19937_64 rng(options_.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Eigen::Vector3d centroid_w = target_.pose.topLeftCorner<3, 3>() * centroid_ + target_.pose.topRightCorner<3, 1>();

  History& h = result_.history;
  Metrics& mt = result_.metrics;
  EpisodeStatus& st = result_.status;
  mt = Metrics{};
  st = EpisodeStatus{};
  Pose T_est = Pose::Identity();
  bool have_est = false;
  double depth0 = 0.0, error0 = 0.0;

  int k = 0;
  for (;; ++k) {
    // 1. Pose and bookkeeping of this frame.
    h.time(k) = k * dt;
    Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(h.pose.row(k).data()) = T_wc;
    if (gantry) h.q.row(k) = q.transpose();
    h.twist.row(k).setZero();
    h.uv.row(k).setConstant(nan);
    h.rtheta.row(k).setConstant(nan);
    h.depth.row(k).setConstant(nan);
    h.error.row(k).setConstant(nan);
    h.error_norm(k) = h.sigma_min(k) = nan;
    if (gantry) {
      h.qdot.row(k).setZero();
      h.manipulability(k) = nan;
    }
    const Eigen::Matrix3d Rcw = T_wc.topLeftCorner<3, 3>().transpose();
    const Eigen::Vector3d tcw = -Rcw * T_wc.topRightCorner<3, 1>();
    const double target_depth = (Rcw * centroid_w + tcw)(2);
    if (k == 0) depth0 = target_depth;
    mt.camera_retreat = std::max(mt.camera_retreat, target_depth - depth0);
    if (!T_wc.allFinite() || target_depth > options_.max_depth_ratio * std::abs(depth0)) {
      st = {Outcome::diverged, k, -1, -1};
      break;
    }

    // 2. True points in the camera frame; physical events.
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
      const Eigen::Vector2d p = camera_.project(pc_(0, i) / pc_(2, i), pc_(1, i) / pc_(2, i));
      if (outside < 0 && !camera_.contains(p(0), p(1))) outside = i;
      Eigen::Vector2d noisy = p;
      if (options_.noise > 0.0) noisy += options_.noise * Eigen::Vector2d(gauss(rng), gauss(rng));
      measured_.col(static_cast<Eigen::Index>(slot) * n + i) = noisy;
      ring_depth_(slot, i) = pc_(2, i);
    }
    if (outside >= 0) {
      st = {Outcome::left_image, k, outside, -1};
      break;
    }
    // Before t = 0 the camera sat at its start pose: frame 0 stands for those frames.
    const int seen = k >= options_.latency ? (k - options_.latency) % slots : 0;

    // 4. What the controller sees: undistorted points and depths.
    for (int i = 0; i < n; ++i) {
      const auto mm = measured_.col(static_cast<Eigen::Index>(seen) * n + i);
      uv_.col(i) = camera_.normalize(mm(0), mm(1));
    }
    switch (options_.depth) {
      case DepthMode::exact: z_ = ring_depth_.row(seen).transpose(); break;
      case DepthMode::desired: z_ = result_.depth_desired; break;
      case DepthMode::estimated:
        if (k == 0) {
          for (int i = 0; i < n; ++i) {
            rho_(i) = 1.0 / (options_.depth_scale * result_.depth_desired(i));
            rho_var_(i) = rho_(i) * rho_(i);  // 100 % prior uncertainty
          }
          uv_prev_ = uv_;
        } else if (k > options_.latency) {  // a new frame reached the controller
          estimate_depth(k - options_.latency);
          uv_prev_ = uv_;
        }
        z_ = rho_.cwiseInverse();
        break;
      case DepthMode::pose: {
        // From the image alone (the homography step needs no initial guess);
        // on failure the last estimate is kept.
        have_est = estimator_->estimate(uv_, T_est) || have_est;
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
    h.sigma_min(k) = out_.sigma_min;
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
    if (gantry) {
      const Joints qdot = gantry_->saturate(gantry_->joint_velocity(q, out_.velocity));
      h.manipulability(k) = gantry_->manipulability(q);
      h.qdot.row(k) = qdot.transpose();
      const Joints q_next = q + dt * qdot;
      const int j = gantry_->outside_limits(q_next);
      if (j >= 0) {
        st = {Outcome::joint_limit, k, -1, j};
        break;
      }
      if (options_.depth == DepthMode::estimated)  // the camera twist the joints really produce
        ring_twist_.row(k % slots) = (gantry_->jacobian(q) * qdot).transpose();
      q = q_next;
      T_next = gantry_->camera(q);
    } else {
      ring_twist_.row(k % slots) = out_.velocity.transpose();
      T_next = T_wc * se3_exp(out_.velocity * dt);  // exact SE(3) integration of the twist
    }
    mt.path_length += (T_next.topRightCorner<3, 1>() - T_wc.topRightCorner<3, 1>()).norm();
    T_wc = T_next;
  }
  h.frames = k + 1;
  const Pose& goal = result_.goal;
  mt.final_translation_error = (T_wc.topRightCorner<3, 1>() - goal.topRightCorner<3, 1>()).norm();
  mt.final_rotation_error = rotation_angle(goal.topLeftCorner<3, 3>(), T_wc.topLeftCorner<3, 3>());
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
    const double d[4] = {p(0) - camera_.u_min, camera_.u_max - p(0), p(1) - camera_.v_min, camera_.v_max - p(1)};
    const double sign[4] = {1.0, -1.0, 1.0, -1.0};
    const double rate[4] = {(p(0) - camera_.u0) / z, (p(0) - camera_.u0) / z, (p(1) - camera_.v0) / z,
                            (p(1) - camera_.v0) / z};
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

// One step of the per-point inverse-depth Kalman filter (see episode.hpp)
// between the previous controller points uv_prev_ (frame `seen` - 1) and uv_
// (frame `seen`), with the camera twist applied in between.
void Episode::estimate_depth(int seen) noexcept {
  const int slots = options_.latency + 1;
  const double dt = 1.0 / camera_.fps;
  const auto v = ring_twist_.row((seen - 1) % slots);
  const double Tx = v(0), Ty = v(1), Tz = v(2), wx = v(3), wy = v(4), wz = v(5);
  const double sigma = options_.noise / std::min(camera_.px, camera_.py);  // normalised units
  const double R = 2.0 * sigma * sigma / (dt * dt) + 1e-6;  // image-velocity variance, + discretisation floor
  for (int i = 0; i < target_.size(); ++i) {
    const double x0 = uv_prev_(0, i), y0 = uv_prev_(1, i), x1 = uv_(0, i), y1 = uv_(1, i);
    const double x = 0.5 * (x0 + x1), y = 0.5 * (y0 + y1);
    // prediction by the depth dynamics (midpoint rule): rho_dot = rho^2 Tz + rho (wx y - wy x)
    double rho = rho_(i);
    const double rho_mid = rho + 0.5 * dt * (rho * rho * Tz + rho * (wx * y0 - wy * x0));
    rho += dt * (rho_mid * rho_mid * Tz + rho_mid * (wx * y - wy * x));
    const double P = rho_var_(i) + 1e-8 * rho * rho;  // 0.01 % relative process noise per frame
    // measurement: image velocity minus its rotational part = rho * a
    const double bx = (x1 - x0) / dt - (x * y * wx - (1.0 + x * x) * wy + y * wz);
    const double by = (y1 - y0) / dt - ((1.0 + y * y) * wx - x * y * wy - x * wz);
    const double ax = -Tx + x * Tz, ay = -Ty + y * Tz;
    const double aa = ax * ax + ay * ay;
    const double S = R + P * aa;
    // the measurement sees the midpoint's inverse depth
    rho += P * (ax * (bx - ax * rho_mid) + ay * (by - ay * rho_mid)) / S;
    rho_var_(i) = P * R / S;
    const double lo = 1.0 / (100.0 * result_.depth_desired(i)), hi = 1.0 / options_.min_depth;
    rho_(i) = std::isfinite(rho) ? std::clamp(rho, lo, hi) : 1.0 / result_.depth_desired(i);
  }
}

EpisodeResult run_episode(AnyServo servo, const Camera& camera, const Target& target, const Pose& start,
                          const Pose& goal, const EpisodeOptions& options) {
  Episode e(std::move(servo), camera, target, options);
  return e.run(start, goal);
}

EpisodeResult run_episode(AnyServo servo, const Camera& camera, const Target& target, const Gantry& gantry,
                          const Joints& q_start, const Joints& q_goal, const EpisodeOptions& options) {
  Episode e(std::move(servo), camera, target, gantry, options);
  return e.run(q_start, q_goal);
}

}  // namespace ibvs::sim
