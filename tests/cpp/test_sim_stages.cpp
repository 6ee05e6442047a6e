// The episode loop's stages (cpp/src/sim/stages/), each on its own, against
// values computed here independently of the stage: measure (projection by hand,
// the latency ring, every fact it reports, teach by showing), estimate depths
// (each mode against the true depths, what each knows at the goal, the
// odometry against se3_inverse),
// control (the servo unchanged, the boundary potential's Tz against a central
// difference of the potential written out here), actuate (free flight against
// the closed-form motion of a constant twist and an RK4 integration; a
// three-slide robot against its closed-form joint velocities, speed and joint
// limits, failed kinematics) and judge (every outcome from a hand-built
// situation, and which verdict wins when several apply).
#include "check.hpp"
#include "sim_cases.hpp"

#include "sim/stages/actuate.hpp"
#include "sim/stages/control.hpp"
#include "sim/stages/depths.hpp"
#include "sim/stages/judge.hpp"
#include "sim/stages/measure.hpp"
#include "sim/stages/record.hpp"

#include <cmath>
#include <limits>
#include <string>

using namespace ibvs;
using namespace ibvs::sim;
using namespace sim_cases;
namespace st = ibvs::sim::stages;

namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

Pose translation(double x, double y, double z) {
  Pose T = Pose::Identity();
  T.topRightCorner<3, 1>() << x, y, z;
  return T;
}

double max_abs_diff(const Pose& a, const Pose& b) { return (a - b).cwiseAbs().maxCoeff(); }

// A sensor that reports the true projections plus (frame, -frame) pixels, so that a
// measurement says which frame it was captured at; it can drop a point or fail.
class StampSensor final : public Sensor {
 public:
  int calls = 0, drop = -1, fail_at = -100;
  void reset(std::uint64_t) noexcept override { calls = 0; }
  bool measure(const SensorFrame& f, Eigen::Ref<Points> m) noexcept override {
    ++calls;
    if (f.frame == fail_at) return false;
    m = *f.projected;
    if (f.frame >= 0) m.colwise() += Eigen::Vector2d(f.frame, -f.frame);
    if (drop >= 0 && f.frame >= 0) m.col(drop).setConstant(nan);
    return true;
  }
};

// World -> camera of pose T_wc, as the loop computes it.
struct View {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  explicit View(const Pose& T) : R(T.topLeftCorner<3, 3>().transpose()), t(-R * T.topRightCorner<3, 1>()) {}
};

// ---------------------------------------------------------------- measure

// A pinhole camera (pixels by hand: u = u0 + px x / z), the camera translating
// along x by 1 cm per frame, a latency of 2 frames: the ring hands the controller
// frame k - 2's measurement (frame 0's before), its true depths, normalised.
void measure_projects_and_delays() {
  const double px = 500, py = 400, u0 = 320, v0 = 240;
  const CameraModel cam = CameraModel::pinhole(px, py, u0, v0, 640, 480);
  Eigen::Matrix3Xd world(3, 3);
  world << 0.1, -0.2, 0.05, 0.05, 0.1, -0.15, 2.0, 2.5, 3.0;
  const int L = 2;
  st::Measure m(cam, world, L, 1e-3);
  StampSensor sensor;
  const auto pose_at = [](int k) { return translation(0.01 * k, -0.02, 0.1); };
  const auto pixel = [&](int k, int i) {  // by hand: the camera has no rotation
    const Eigen::Vector3d p = world.col(i) - pose_at(k).topRightCorner<3, 1>();
    return Eigen::Vector3d(u0 + px * p(0) / p(2), v0 + py * p(1) / p(2), p(2));
  };
  for (int k = 0; k < 7; ++k) {
    const Pose T = pose_at(k);
    const View w(T);
    const st::Sighting s = m.capture(k, T, w.R, w.t, Twist::Zero(), sensor);
    CHECK(s.behind < 0 && s.outside < 0 && s.sensed && s.missing < 0);
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d e = pixel(k, i);
      CHECK_NEAR(m.projected()(0, i), e(0), 1e-9);
      CHECK_NEAR(m.projected()(1, i), e(1), 1e-9);
      CHECK_NEAR(m.measured(m.slot(k))(0, i), e(0) + k, 1e-9);  // the sensor's stamp
    }
    CHECK(m.view(k) < 0);
    const int seen_frame = k >= L ? k - L : 0;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d e = pixel(seen_frame, i);
      CHECK_NEAR(m.uv()(0, i), (e(0) + seen_frame - u0) / px, 1e-12);
      CHECK_NEAR(m.uv()(1, i), (e(1) - seen_frame - v0) / py, 1e-12);
      CHECK_NEAR(m.true_depths(m.seen(k))(i), e(2), 1e-12);
      CHECK_NEAR(m.measured(m.seen(k))(0, i), e(0) + seen_frame, 1e-9);
    }
  }
  CHECK(sensor.calls == 7);
}

// Each fact capture() and view() report, from a hand-built frame.
void measure_reports() {
  const CameraModel cam = CameraModel::pinhole(500, 500, 320, 240, 640, 480);
  Eigen::Matrix3Xd world(3, 4);
  world << 0, 0.1, -0.1, 0, 0, 0, 0.1, -0.1, 2, 2, 2, 2;
  const Pose T = Pose::Identity();
  const View w(T);
  StampSensor sensor;
  {  // behind: point 2 at depth 0 (below min_depth); nothing projected, the sensor not asked
    Eigen::Matrix3Xd p = world;
    p(2, 2) = 0.0;
    p(2, 3) = -1.0;
    st::Measure m(cam, p, 0, 1e-3);
    const st::Sighting s = m.capture(0, T, w.R, w.t, Twist::Zero(), sensor);
    CHECK(s.behind == 2 && sensor.calls == 0);
  }
  {  // outside: point 1 at x/z = 0.7 -> u = 670 > 640; the first of two
    Eigen::Matrix3Xd p = world;
    p(0, 1) = 1.4;
    p(0, 3) = -1.4;
    st::Measure m(cam, p, 0, 1e-3);
    const st::Sighting s = m.capture(0, T, w.R, w.t, Twist::Zero(), sensor);
    CHECK(s.behind < 0 && s.outside == 1 && s.sensed && s.missing < 0);
  }
  {  // beyond the model's domain: ViSP kud = -0.5 folds at r = sqrt(2/3) = 0.816; x/z = 0.9 is on a
     // 1000 px sensor (u0 + px 0.9 (1 - 0.5 0.81) = 553.5) but unmappable
    const CameraModel fold = CameraModel::from_visp(100, 100, 500, 500, -0.5, 0.0, 1000, 1000);
    Eigen::Matrix3Xd p = world;
    p(0, 3) = 1.8;
    st::Measure m(fold, p, 0, 1e-3);
    const st::Sighting s = m.capture(0, T, w.R, w.t, Twist::Zero(), sensor);
    CHECK(s.outside == 3 && std::isnan(m.projected()(0, 3)));
  }
  {  // the sensor fails; the sensor loses point 3
    st::Measure m(cam, world, 0, 1e-3);
    sensor.fail_at = 0;
    CHECK(!m.capture(0, T, w.R, w.t, Twist::Zero(), sensor).sensed);
    sensor.fail_at = -100;
    sensor.drop = 3;
    const st::Sighting s = m.capture(0, T, w.R, w.t, Twist::Zero(), sensor);
    CHECK(s.sensed && s.missing == 3 && s.outside < 0);
    sensor.drop = -1;
  }
  {  // view: a pixel the model cannot normalise (ViSP kdu = -0.5: no inverse beyond rd = 0.816)
    const CameraModel fold = CameraModel::from_visp(100, 100, 500, 500, 0.0, -0.5, 1000, 1000);
    Eigen::Matrix3Xd p = world;
    p(0, 2) = 1.8;  // x/z = 0.9: u = 590, on the sensor
    st::Measure m(fold, p, 0, 1e-3);
    const st::Sighting s = m.capture(0, T, w.R, w.t, Twist::Zero(), sensor);
    CHECK(s.outside < 0 && s.missing < 0);
    CHECK(m.view(0) == 2);
  }
}

// teach(): the goal's desired points and depths; a goal that cannot be seen is refused.
void measure_teaches() {
  const CameraModel cam = CameraModel::pinhole(500, 500, 320, 240, 640, 480);
  Eigen::Matrix3Xd world(3, 2);
  world << 0.2, -0.1, 0.1, 0.3, 3.0, 2.0;
  st::Measure m(cam, world, 1, 1e-3);
  StampSensor sensor;
  Points uvd(2, 2);
  Eigen::VectorXd zd(2);
  const Pose goal = translation(0, 0, 1);  // depths 2 and 1
  m.teach(goal, sensor, uvd, zd);
  CHECK_NEAR(zd(0), 2.0, 1e-15);
  CHECK_NEAR(zd(1), 1.0, 1e-15);
  CHECK_NEAR(uvd(0, 0), 0.1, 1e-12);
  CHECK_NEAR(uvd(1, 1), 0.3, 1e-12);
  CHECK_NEAR(m.goal_measured()(0, 0), 320 + 500 * 0.1, 1e-9);  // frame -1: no stamp
  // pixel_error: the worst measured point's distance from the goal's measurement; the goal's
  // measurement is kept when the ring's slots are overwritten.
  const View at_goal(goal);
  st::Sighting s = m.capture(0, goal, at_goal.R, at_goal.t, Twist::Zero(), sensor);
  CHECK(s.pixel_error == 0.0);  // frame 0: stamp (0, 0)
  s = m.capture(3, goal, at_goal.R, at_goal.t, Twist::Zero(), sensor);
  CHECK_NEAR(s.pixel_error, 3.0 * std::sqrt(2.0), 1e-12);  // stamp (3, -3) on every point
  CHECK_NEAR(m.goal_measured()(0, 0), 320 + 500 * 0.1, 1e-9);
  sensor.drop = 1;  // a point lost: no pixel error
  CHECK(std::isnan(m.capture(4, goal, at_goal.R, at_goal.t, Twist::Zero(), sensor).pixel_error));
  sensor.drop = -1;
  CHECK_THROWS(m.teach(translation(0, 0, 2.5), sensor, uvd, zd));  // point 1 behind
  CHECK_THROWS(m.teach(translation(-2.0, 0, 0), sensor, uvd, zd));  // point 0 at x/z = 0.73, u = 687
  sensor.fail_at = -1;
  CHECK_THROWS(m.teach(goal, sensor, uvd, zd));
  sensor.fail_at = -100;
}

// ---------------------------------------------------------------- estimate depths

EpisodeOptions depth_options(DepthMode mode, double scale = 1.0, int latency = 0) {
  EpisodeOptions o;
  o.depth = mode;
  o.depth_scale = scale;
  o.latency = latency;
  return o;
}

// Normalised points of target points (target frame) seen from camera pose T_wc (world <- camera).
Points image_of(const Target& t, const Pose& T_wc, Eigen::RowVectorXd* depths = nullptr) {
  const Pose T = se3_inverse(T_wc) * t.pose;
  Points uv(2, t.size());
  if (depths) depths->resize(t.size());
  for (int i = 0; i < t.size(); ++i) {
    const Eigen::Vector3d p = T.topLeftCorner<3, 3>() * t.points.col(i) + T.topRightCorner<3, 1>();
    uv.col(i) << p(0) / p(2), p(1) / p(2);
    if (depths) (*depths)(i) = p(2);
  }
  return uv;
}

void depth_modes() {
  const CameraModel cam = CameraModel::normalized(1.0);
  const Target t = Target::square(0.2, make_pose(0.02, -0.01, 0.8, 0.2, -0.1, 0.3));
  const Pose T_wc = make_pose(0.05, 0.03, -0.1, -0.05, 0.1, 0.2);
  Eigen::RowVectorXd z_true;
  const Points uv = image_of(t, T_wc, &z_true);
  const Eigen::VectorXd z_star = Eigen::VectorXd::Constant(4, 0.8);
  {  // exact: the true depths of the frame seen, times depth_scale
    st::Depths d(depth_options(DepthMode::exact, 1.25), cam, t.points);
    d.aim(z_star);
    d.estimate(3, uv, z_true);
    for (int i = 0; i < 4; ++i) CHECK(d.depth()(i) == 1.25 * z_true(i));
  }
  {  // desired: z*, times depth_scale
    st::Depths d(depth_options(DepthMode::desired, 0.5), cam, t.points);
    d.aim(z_star);
    d.estimate(3, uv, z_true);
    for (int i = 0; i < 4; ++i) CHECK(d.depth()(i) == 0.4);
  }
  {  // pose: the planar pose of exact points gives the true depths; a degenerate image keeps them
    st::Depths d(depth_options(DepthMode::pose), cam, t.points);
    d.aim(z_star);
    d.start();
    Points line(2, 4);
    line << 0.0, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 0.0;
    d.estimate(0, line, z_true);  // no estimate yet: NaN
    CHECK(std::isnan(d.depth()(0)) && std::isnan(d.depth()(3)));
    d.estimate(1, uv, z_true);
    for (int i = 0; i < 4; ++i) CHECK_NEAR(d.depth()(i), z_true(i), 1e-9);
    const Eigen::VectorXd kept = d.depth();
    d.estimate(2, line, z_true);
    CHECK(d.depth() == kept);
    // depth_scale multiplies the estimate
    st::Depths s(depth_options(DepthMode::pose, 2.0), cam, t.points);
    s.aim(z_star);
    s.start();
    s.estimate(0, uv, z_true);
    for (int i = 0; i < 4; ++i) CHECK_NEAR(s.depth()(i), 2.0 * z_true(i), 2e-9);
    Target bumpy = t;
    bumpy.points(2, 1) = 0.01;
    CHECK_THROWS(st::Depths refused(depth_options(DepthMode::pose), cam, bumpy.points));
  }
}

// teach(): what each depth mode knows at the goal from its image: exact and desired z* as given
// (no pose estimate), pose ibvs::PlanarPose's estimate of the goal's image (the true pose and
// depths for an exact image, depths times depth_scale; none from a degenerate image, z* kept),
// estimated its prior depth_scale z*.
void depth_modes_teach() {
  const CameraModel cam = CameraModel::normalized(1.0);
  const Target t = Target::square(0.2, make_pose(0.02, -0.01, 0.8, 0.2, -0.1, 0.3));
  const Pose goal = make_pose(0.05, 0.03, -0.1, -0.05, 0.1, 0.2);
  Eigen::RowVectorXd z_true;
  const Points uv = image_of(t, goal, &z_true);
  const Eigen::VectorXd z_star = z_true.transpose();
  for (DepthMode mode : {DepthMode::exact, DepthMode::desired, DepthMode::pose, DepthMode::estimated}) {
    st::Depths d(depth_options(mode, 1.25), cam, t.points);
    d.aim(z_star);
    d.teach(uv);
    const double scale = mode == DepthMode::pose || mode == DepthMode::estimated ? 1.25 : 1.0;
    for (int i = 0; i < 4; ++i) CHECK_NEAR(d.goal_depth()(i), scale * z_star(i), 1e-9);
    CHECK((d.goal_pose_estimate() != nullptr) == (mode == DepthMode::pose));
    if (d.goal_pose_estimate()) CHECK(max_abs_diff(*d.goal_pose_estimate(), se3_inverse(goal) * t.pose) < 1e-9);
  }
  st::Depths d(depth_options(DepthMode::pose, 1.25), cam, t.points);
  d.aim(z_star);
  Points line(2, 4);
  line << 0.0, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 0.0;
  d.teach(line);
  CHECK(d.goal_pose_estimate() == nullptr && d.goal_depth() == z_star);
}

// The odometry is the camera's new pose in its old frame; the online estimate, fed with
// the frames the controller sees (latency 0 and 3) and that odometry, starts from its
// prior depth_scale z* and converges to the true depths of a camera moving sideways.
void depth_estimate_converges() {
  const CameraModel cam = CameraModel::normalized(1.0);
  const Target t = Target::square(0.2, translation(0, 0, 1.0));
  const Eigen::VectorXd z_star = Eigen::VectorXd::Constant(4, 1.0);
  for (int L : {0, 3}) {
    st::Depths d(depth_options(DepthMode::estimated, 1.5, L), cam, t.points);
    d.aim(z_star);
    d.start();
    // a zigzag (1 cm back and forth every frame on top of a drift): a motion fed one frame
    // early or late would be the wrong way round
    const auto pose_at = [](int k) {
      return make_pose(0.004 * k + 0.01 * (k % 2), 0.001 * k, -0.002 * k, 0.0, -0.002 * k, 0.001 * k);
    };
    Eigen::RowVectorXd z_true;
    for (int k = 0; k < 120; ++k) {
      const int seen = k >= L ? k - L : 0;
      d.estimate(k, image_of(t, pose_at(seen), &z_true), z_true);
      if (k == 0)
        for (int i = 0; i < 4; ++i) CHECK_NEAR(d.depth()(i), 1.5, 1e-9);  // the prior
      d.odometry(k, pose_at(k), pose_at(k + 1));
      CHECK(max_abs_diff(d.motion(k), se3_inverse(pose_at(k)) * pose_at(k + 1)) < 1e-14);
    }
    for (int i = 0; i < 4; ++i)
      ibvs_test::report(std::abs(d.depth()(i) / z_true(i) - 1.0) < 1e-3, "estimated depth converges", __FILE__,
                        __LINE__, "latency " + std::to_string(L) + ": " + std::to_string(d.depth()(i)));
  }
}

// ---------------------------------------------------------------- control

// U of the boundary potential, written out from its definition in episode.hpp.
double potential(const CameraModel& cam, const Points& px, const Points& goal, double margin) {
  double U = 0.0;
  for (int i = 0; i < px.cols(); ++i) {
    const double d[4] = {px(0, i) - cam.u_min(), cam.u_max() - px(0, i), px(1, i) - cam.v_min(),
                         cam.v_max() - px(1, i)};
    const double ds[4] = {goal(0, i) - cam.u_min(), cam.u_max() - goal(0, i), goal(1, i) - cam.v_min(),
                          cam.v_max() - goal(1, i)};
    for (int side = 0; side < 4; ++side) {
      const double m = std::min(margin, ds[side]), s = d[side] / m;
      if (m > 0.0 && s < 1.0) U += 0.5 * (1.0 / s - 1.0) * (1.0 / s - 1.0);
    }
  }
  return U;
}

void boundary_potential() {
  const CameraModel cam = CameraModel::pinhole(500, 500, 320, 240, 640, 480);
  Points goal(2, 3), px(2, 3);
  goal << 320, 100, 600, 240, 100, 400;
  const Eigen::VectorXd z = (Eigen::VectorXd(3) << 1.0, 1.5, 0.8).finished();
  const double margin = 40.0, gain = 0.3;
  st::BoundaryPotential b(cam, margin, gain, 3);
  b.aim(goal);
  CHECK(b.tz(goal, z) == 0.0);  // the goal is an equilibrium
  px << 300, 200, 500, 250, 200, 300;  // all farther than the margin from every side
  CHECK(b.tz(px, z) == 0.0);
  // Near the right (point 2, 10 px) and top (point 1, 15 px) sides: Tz = -gain zbar^2 dU/dTz with
  // du/dTz = (u - u0) / z, dv/dTz = (v - v0) / z, against a central difference of U along Tz.
  px << 330, 110, 630, 250, 15, 260;
  const double zbar = z.mean(), h = 1e-6;
  Points plus = px, minus = px;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d rate((px(0, i) - 320) / z(i), (px(1, i) - 240) / z(i));
    plus.col(i) += h * rate;
    minus.col(i) -= h * rate;
  }
  const double dU = potential(cam, plus, goal, margin) - potential(cam, minus, goal, margin);
  const double expected = -gain * zbar * zbar * dU / (2 * h);
  const double tz = b.tz(px, z);
  CHECK(expected < 0.0);  // near the borders: retreat
  CHECK_NEAR(tz, expected, 1e-6 * std::abs(expected));
  // The margin is capped at the goal's own distance: point 0's goal is 20 px from the top side,
  // so at 20 px there is no push, at 10 px there is.
  goal(1, 0) = 20;
  b.aim(goal);
  px << 320, 320, 320, 20, 240, 240;
  CHECK(b.tz(px, z) == 0.0);
  px(1, 0) = 10;
  CHECK(b.tz(px, z) != 0.0);
  CHECK(!st::BoundaryPotential(cam, 0.0, gain, 3).active() && !st::BoundaryPotential(cam, margin, 0.0, 3).active());
}

// The control stage is the servo's update, plus the boundary's Tz when it is active and the
// servo accepted its input.
void control_step() {
  const CameraModel cam = CameraModel::normalized(0.3);
  Points uv(2, 4), uvd(2, 4);
  uvd << -0.1, 0.1, 0.1, -0.1, -0.1, -0.1, 0.1, 0.1;
  uv << -0.2, 0.29, 0.12, -0.08, -0.1, -0.05, 0.15, 0.12;  // point 1 within 0.01 of the right side
  Eigen::VectorXd z = Eigen::VectorXd::Constant(4, 1.2), zd = Eigen::VectorXd::Constant(4, 1.0);
  ServoOptions so;
  so.gain = 0.7;
  Servo reference(Layout::stacked(4), so);
  ServoOutput out(reference.layout());
  const Status s_ref = reference.update(uv, z, uvd, zd, out);
  for (double margin : {0.0, 0.05}) {
    EpisodeOptions o;
    o.boundary_margin = margin;
    AnyServo servo = Servo(Layout::stacked(4), so);
    st::Control c(Layout::stacked(4), cam, o);
    c.aim(uvd);
    const Status s = c.step(servo, uv, z, uvd, zd, uv);
    CHECK(s == s_ref && c.output().error == out.error);
    CHECK(c.output().velocity.head<2>() == out.velocity.head<2>());
    CHECK(c.output().velocity.tail<3>() == out.velocity.tail<3>());
    st::BoundaryPotential b(cam, margin, o.boundary_gain, 4);
    b.aim(uvd);
    const double tz = margin > 0.0 ? b.tz(uv, z) : 0.0;
    CHECK(margin == 0.0 || tz < 0.0);
    CHECK(c.output().velocity(2) == out.velocity(2) + tz);
    // refused input: the servo's zero twist, no boundary term
    z(2) = -1.0;
    CHECK(c.step(servo, uv, z, uvd, zd, uv) == Status::invalid_input && c.output().velocity.isZero(0.0));
    z(2) = 1.2;
  }
  // A PartitionedServo runs the same way.
  AnyServo part = PartitionedServo(4, {});
  PartitionedServo ref(4, {});
  st::Control c(ref.layout(), cam, EpisodeOptions{});
  ServoOutput pout(ref.layout());
  ref.update(uv, z, uvd, zd, pout);
  c.step(part, uv, z, uvd, zd, uv);
  CHECK(c.output().velocity == pout.velocity);
}

// ---------------------------------------------------------------- actuate

// Three slides along the base's x, y, z (end-effector Jacobian [I; 0]); the camera mounted
// turned a quarter about z and offset: camera twist = (R^T qdot, 0), so qdot = R v_lin.
struct Slides final : Robot {
  bool fail = false;
  Slides() {
    q_min = JointVector::Constant(3, -0.5);
    q_max = JointVector::Constant(3, 0.5);
    qdot_max = JointVector::Constant(3, 0.1);
    mount = make_pose(0.01, 0.02, 0.05, 0, 0, pi / 2);
  }
  bool kinematics(const JointVector& q, Pose& T_we, RobotJacobian& J) const noexcept override {
    if (fail) return false;
    T_we = translation(q(0), q(1), q(2));
    J.setZero(6, 3);
    J.topRows<3>().setIdentity();
    return true;
  }
};

// The camera's pose after moving with the constant twist xi for dt, by RK4 on dT/dt = T xi^.
Pose rk4(const Pose& T0, const Twist& xi, double dt, int steps) {
  Eigen::Matrix4d X = Eigen::Matrix4d::Zero();
  X.topLeftCorner<3, 3>() << 0, -xi(5), xi(4), xi(5), 0, -xi(3), -xi(4), xi(3), 0;
  X.topRightCorner<3, 1>() = xi.head<3>();
  Eigen::Matrix4d T = T0;
  const double h = dt / steps;
  for (int s = 0; s < steps; ++s) {
    const Eigen::Matrix4d k1 = T * X, k2 = (T + 0.5 * h * k1) * X, k3 = (T + 0.5 * h * k2) * X, k4 = (T + h * k3) * X;
    T += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return T;
}

void actuate_free() {
  const double dt = 1.0 / 30;
  st::Actuate a(dt);
  a.start(nullptr);
  CHECK(!a.has_robot() && a.kinematics_ok());
  const Pose T0 = make_pose(0.1, -0.2, 0.3, 0.2, -0.4, 0.6);
  Pose T1;
  // a screw along the optical axis: turn wz dt about it, advance vz dt along it
  Twist v;
  v << 0, 0, 0.3, 0, 0, 1.2;
  CHECK(a.step(v, T0, T1) == -1);
  Pose M = Pose::Identity();
  M.topLeftCorner<3, 3>() = Eigen::AngleAxisd(1.2 * dt, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  M(2, 3) = 0.3 * dt;
  CHECK(max_abs_diff(T1, T0 * M) < 1e-14);
  // sideways while turning: an arc of radius vx / wz
  v << 0.5, 0, 0, 0, 0, 2.0;
  a.step(v, T0, T1);
  const double th = 2.0 * dt;
  M(2, 3) = 0.0;
  M.topLeftCorner<3, 3>() = Eigen::AngleAxisd(th, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  M(0, 3) = 0.5 / 2.0 * std::sin(th);
  M(1, 3) = 0.5 / 2.0 * (1 - std::cos(th));
  CHECK(max_abs_diff(T1, T0 * M) < 1e-14);
  // any twist: against RK4
  v << 0.3, -0.2, 0.4, 0.7, -0.5, 1.1;
  a.step(v, T0, T1);
  CHECK(max_abs_diff(T1, rk4(T0, v, dt, 200)) < 1e-12);
}

void actuate_robot() {
  Slides robot;
  const double dt = 0.05;
  st::Actuate a(dt);
  a.attach(robot);
  JointVector q0(3);
  q0 << 0.1, -0.2, 0.3;
  a.start(&q0);
  CHECK(a.has_robot() && a.kinematics_ok() && a.q() == q0);
  const Eigen::Matrix3d R = robot.mount.topLeftCorner<3, 3>();
  // within the speed limits: qdot = R v_lin (the rotation is out of the slides' reach)
  Twist v;
  v << 0.04, -0.03, 0.05, 0.2, 0.0, -0.1;
  Pose T1;
  CHECK(a.step(v, robot.camera(q0), T1) == -1);
  const Eigen::Vector3d qdot = R * v.head<3>();
  for (int j = 0; j < 3; ++j) CHECK_NEAR(a.joints().qdot(j), qdot(j), 1e-12);
  for (int j = 0; j < 3; ++j) CHECK_NEAR(a.q()(j), q0(j) + dt * qdot(j), 1e-12);
  CHECK(max_abs_diff(T1, robot.camera(a.q())) < 1e-15);
  // beyond them: scaled as a whole to the fastest joint's limit, its direction kept
  v << 0.4, 0.1, -0.2, 0, 0, 0;
  const JointVector q1 = a.q();
  Pose T2;
  a.step(v, T1, T2);
  const Eigen::Vector3d fast = R * v.head<3>(), scaled = fast * (0.1 / fast.cwiseAbs().maxCoeff());
  for (int j = 0; j < 3; ++j) CHECK_NEAR(a.joints().qdot(j), scaled(j), 1e-12);
  for (int j = 0; j < 3; ++j) CHECK_NEAR(a.q()(j), q1(j) + dt * scaled(j), 1e-12);
  // a step that would take joint 2 past 0.5: reported, nothing moves
  JointVector qe(3);
  qe << 0.0, 0.0, 0.499;
  a.start(&qe);
  const Pose Te = robot.camera(qe);
  T2 = Te;
  v << 0, 0, 0.1, 0, 0, 0;  // camera z = base z (the mount turns about z)
  CHECK(a.step(v, Te, T2) == 2);
  CHECK(a.q() == qe && T2 == Te);
  // failed kinematics: reported by kinematics_ok(), for the judge
  robot.fail = true;
  a.start(&q0);
  CHECK(!a.kinematics_ok());
}

// ---------------------------------------------------------------- judge

EpisodeOptions judge_options() {
  EpisodeOptions o;
  o.tolerance = 1e-3;
  o.max_depth_ratio = 10.0;
  o.max_error_ratio = 100.0;
  o.standoff_ratio = 0.05;
  return o;
}

// The camera frame at pose T_wc, judged at frame k.
bool judge_camera(st::Judge& j, int k, const Pose& T, EpisodeStatus& s, bool kinematics_ok = true) {
  const View w(T);
  return j.camera(k, T, w.R, w.t, kinematics_ok, s);
}

// The paper's plate (the points (+-0.25, +-0.25) at z = 3), the goal camera at the origin
// looking along +z: front -z, extent 0.25 sqrt 2, standoff 5 % of 3 m.
void judge_camera_and_faces() {
  const Target plate = Target::paper();
  st::Judge j(plate, judge_options(), 100);
  j.aim(Pose::Identity());
  CHECK(j.front() == Eigen::Vector3d(0, 0, -1));
  CHECK_NEAR(j.extent(), 0.25 * std::sqrt(2.0), 1e-15);
  CHECK_NEAR(j.standoff(), 0.15, 1e-15);
  EpisodeStatus s;
  // diverged: failed kinematics, a non-finite pose, the target beyond 10 times its start depth
  j.start();
  CHECK(judge_camera(j, 0, Pose::Identity(), s, false) && s.outcome == Outcome::diverged && s.frame == 0);
  j.start();
  CHECK(!judge_camera(j, 0, Pose::Identity(), s));
  CHECK(!judge_camera(j, 1, translation(0, 0, -26.9), s));  // depth 29.9 < 30
  CHECK_NEAR(j.retreat(), 26.9, 1e-12);
  CHECK(!judge_camera(j, 2, translation(0, 0, -1), s));
  CHECK_NEAR(j.retreat(), 26.9, 1e-12);  // the maximum so far
  CHECK(judge_camera(j, 3, translation(0, 0, -27.1), s) && s.outcome == Outcome::diverged && s.frame == 3);
  Pose bad = Pose::Identity();
  bad(0, 3) = nan;
  j.start();
  CHECK(!judge_camera(j, 0, Pose::Identity(), s));
  CHECK(judge_camera(j, 1, bad, s) && s.outcome == Outcome::diverged);
  // faces, frame by frame
  const auto path = [&](const Pose& a, const Pose& b) {  // judged at frames 0 and 1; true if b ends it
    j.start();
    s = EpisodeStatus{};
    return !judge_camera(j, 0, a, s) && judge_camera(j, 1, b, s);
  };
  CHECK(!path(translation(0, 0, 0), translation(0, 0, 2.8)));  // 0.2 m in front: clear
  CHECK(path(translation(0, 0, 2.8), translation(0, 0, 2.9)) && s.outcome == Outcome::collision && s.frame == 1 &&
        s.point == -1);  // within the standoff
  CHECK(path(translation(0, 0, 2.8), translation(0.1, 0, 3.2)) && s.outcome == Outcome::collision);  // through
  CHECK(path(translation(1, 0, 2.8), translation(1, 0, 3.2)) && s.outcome == Outcome::target_backside);  // round
  // beside the plate, 5 cm in front: the distance to the disc's edge decides
  CHECK(!path(translation(0, 0, 2.0), translation(0.5, 0, 2.95)));  // hypot(0.05, 0.146) > 0.15
  CHECK(path(translation(0, 0, 2.0), translation(0.45, 0, 2.95)) && s.outcome == Outcome::collision);
  // behind the plane from the start
  j.start();
  CHECK(judge_camera(j, 0, make_pose(0, 0, 6, 0, pi, 0), s) && s.outcome == Outcome::target_backside &&
        s.frame == 0);
  // A non-planar target: no front, a standoff around each point (which is reported).
  Target bumpy = plate;
  bumpy.points(2, 2) = 0.05;
  st::Judge b(bumpy, judge_options(), 100);
  b.aim(Pose::Identity());
  CHECK(b.front().isZero(0.0));
  b.start();
  CHECK(!judge_camera(b, 0, translation(0, 0, 2.5), s));
  CHECK(judge_camera(b, 1, translation(0.25, 0.25, 2.95), s) && s.outcome == Outcome::collision && s.point == 2);
  // A goal camera in the plate's plane: no front either, so no backside.
  st::Judge e(plate, judge_options(), 100);
  e.aim(make_pose(2, 0, 3, 0, pi / 2, 0));
  CHECK(e.front().isZero(0.0));
  e.start();
  CHECK(!judge_camera(e, 0, translation(0, 0, 4), s));
}

void judge_measurement() {
  st::Judge j(Target::paper(), judge_options(), 100);
  EpisodeStatus s;
  st::Sighting seen;
  CHECK(!j.sighting(4, seen, s));
  seen.missing = 3;
  CHECK(j.sighting(4, seen, s) && s.outcome == Outcome::lost_feature && s.point == 3 && s.frame == 4);
  seen.sensed = false;
  CHECK(j.sighting(4, seen, s) && s.outcome == Outcome::diverged && s.point == -1);
  seen.outside = 1;
  CHECK(j.sighting(4, seen, s) && s.outcome == Outcome::left_image && s.point == 1);
  seen.behind = 2;
  CHECK(j.sighting(4, seen, s) && s.outcome == Outcome::behind_camera && s.point == 2);
  CHECK(!j.view(5, -1, s));
  CHECK(j.view(5, 0, s) && s.outcome == Outcome::left_image && s.point == 0 && s.frame == 5);
}

void judge_control_and_motion() {
  const int K = 50;
  st::Judge j(Target::paper(), judge_options(), K);
  EpisodeStatus s;
  ServoOutput out(Layout::cartesian(4));
  out.velocity.setConstant(0.1);
  out.error_norm = 0.5;  // the first error: the reference for max_error_ratio
  CHECK(!j.control(0, Status::ok, out, nan, s));
  CHECK(j.control(1, Status::invalid_input, out, nan, s) && s.outcome == Outcome::diverged && s.frame == 1);
  out.error_norm = 49.9;
  CHECK(!j.control(2, Status::ok, out, nan, s));
  out.error_norm = 50.1;  // 100 times the first
  CHECK(j.control(2, Status::ok, out, nan, s) && s.outcome == Outcome::diverged);
  out.error_norm = nan;
  CHECK(j.control(2, Status::ok, out, nan, s) && s.outcome == Outcome::diverged);
  out.error_norm = 0.2;
  out.velocity(4) = nan;
  CHECK(j.control(2, Status::ok, out, nan, s) && s.outcome == Outcome::diverged);
  out.velocity(4) = 0.1;
  CHECK(j.control(3, Status::singular, out, nan, s) && s.outcome == Outcome::singular && s.frame == 3);
  out.error_norm = 9e-4;  // under the tolerance: converged, singular or not
  CHECK(j.control(3, Status::singular, out, nan, s) && s.outcome == Outcome::converged);
  out.error_norm = 0.2;
  CHECK(!j.control(K - 2, Status::ok, out, nan, s));
  CHECK(j.control(K - 1, Status::ok, out, nan, s) && s.outcome == Outcome::timeout && s.frame == K - 1);
  out.error_norm = 9e-4;
  CHECK(j.control(K - 1, Status::ok, out, nan, s) && s.outcome == Outcome::converged);
  // stop_on_singular off: a singular step goes on
  EpisodeOptions o = judge_options();
  o.stop_on_singular = false;
  st::Judge g(Target::paper(), o, K);
  out.error_norm = 0.2;
  CHECK(!g.control(0, Status::singular, out, nan, s));
  // tolerance_px: converged only when the error norm is under tolerance and the worst measured
  // point within tolerance_px of its goal (a NaN pixel error, no measurement, never passes)
  EpisodeOptions px = judge_options();
  px.tolerance_px = 1.0;
  st::Judge p(Target::paper(), px, K);
  out.error_norm = 0.5;
  CHECK(!p.control(0, Status::ok, out, 0.5, s));
  out.error_norm = 9e-4;
  CHECK(!p.control(1, Status::ok, out, 1.5, s));  // the norm passes, the pixels do not
  CHECK(!p.control(1, Status::ok, out, nan, s));
  CHECK(p.control(1, Status::ok, out, 1.0, s) && s.outcome == Outcome::converged && s.frame == 1);
  out.error_norm = 0.2;
  CHECK(!p.control(2, Status::ok, out, 0.1, s));  // the pixels pass, the norm does not
  px.tolerance = std::numeric_limits<double>::infinity();  // the pixels alone
  st::Judge q(Target::paper(), px, K);
  out.error_norm = 0.5;
  CHECK(!q.control(0, Status::ok, out, 1.5, s));
  CHECK(q.control(1, Status::ok, out, 0.9, s) && s.outcome == Outcome::converged);
  out.error_norm = nan;  // a non-finite error is not converged: diverged
  CHECK(q.control(2, Status::ok, out, 0.9, s) && s.outcome == Outcome::diverged);
  out.error_norm = 0.2;
  // joint limit
  CHECK(!j.motion(7, -1, s));
  CHECK(j.motion(7, 4, s) && s.outcome == Outcome::joint_limit && s.joint == 4 && s.frame == 7 && s.point == -1);
}

// ---------------------------------------------------------------- record

// A frame opens with NaN (and a zero twist and qdot) wherever a later stage writes.
void record_rows() {
  History h;
  st::allocate(h, 5, 2, 4);
  st::allocate_joints(h, 3);
  const JointVector q = JointVector::Constant(3, 0.25);
  const Pose T = make_pose(1, 2, 3, 0.1, 0.2, 0.3);
  st::open_frame(h, 2, 0.1, T, &q);
  CHECK(h.time(2) == 0.1 && h.pose(2, 3) == 1.0 && h.pose(2, 4) == T(1, 0) && h.q(2, 1) == 0.25);
  CHECK(h.twist.row(2).isZero(0.0) && h.qdot.row(2).isZero(0.0) && std::isnan(h.manipulability(2)));
  CHECK(h.uv.row(2).array().isNaN().all() && h.error.row(2).array().isNaN().all() && std::isnan(h.sigma_min(2)));
  Points uv(2, 2);
  uv << 0.0, 0.3, -0.2, 0.4;
  st::record_view(h, 2, uv, Eigen::Vector2d(1.5, 2.5));
  CHECK(h.uv(2, 1) == -0.2 && h.depth(2, 1) == 2.5);
  CHECK_NEAR(h.rtheta(2, 2), 0.5, 1e-15);
  CHECK_NEAR(h.rtheta(2, 3), std::atan2(0.4, 0.3), 1e-15);
  CHECK_NEAR(h.rtheta(2, 1), -pi / 2, 1e-15);
}

}  // namespace

void run_tests() {
  measure_projects_and_delays();
  measure_reports();
  measure_teaches();
  depth_modes();
  depth_modes_teach();
  depth_estimate_converges();
  boundary_potential();
  control_step();
  actuate_free();
  actuate_robot();
  judge_camera_and_faces();
  judge_measurement();
  judge_control_and_motion();
  record_rows();
}
