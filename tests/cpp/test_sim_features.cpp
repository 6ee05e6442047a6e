// Episodes of tasks with feature blocks (ibvs/sim/source.hpp): a line-only task
// and a points + lines task converge on the free camera, the gantry and a
// 7-joint robot; the simulator's line measurements are LineFeature::measure of
// the controller's points with the plane of the true (or the depth mode's)
// pose, computed here independently; a user-defined source plugs in; a source
// that cannot measure ends the episode as lost_feature; bad set-ups are refused;
// the sources stage's goal is the goal as the depth mode knows it (teach by showing), or the
// true one given (GoalPose::given), and PBVS then keeps a wrong camera model's bias.
#include "check.hpp"
#include "projected_line_source.hpp"
#include "sim_cases.hpp"
#include "sim/stages/sources.hpp"

#include "ibvs/features/line.hpp"
#include "ibvs/features/pose.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <memory>

using namespace ibvs;
using namespace ibvs::sim;
using namespace sim_cases;

namespace {

// A Task of n lines after the points of `points` (Layout::none(): none).
Task line_task(const Layout& points, int n) {
  Task t(points);
  for (int k = 0; k < n; ++k) t.add(LineFeature());
  return t;
}

Servo line_servo(const Layout& points, int n, double gain = 1.0) {
  ServoOptions o;
  o.gain = gain;
  return Servo(line_task(points, n), o);
}

// The square's four edges as lines.
Target with_edges(Target t) {
  for (int i = 0; i < 4; ++i) t.add(LineSource(i, (i + 1) % 4));
  return t;
}

// (A, B, C) of 1/Z = A x + B y + C through three camera-frame points: solved from the three
// points' (x, y, 1/Z), independently of plane_in_camera's formula.
Eigen::Vector3d plane_through(const Eigen::Matrix3d& P) {
  Eigen::Matrix3d M;
  Eigen::Vector3d rhs;
  for (int c = 0; c < 3; ++c) {
    M.row(c) << P(0, c) / P(2, c), P(1, c) / P(2, c), 1.0;
    rhs(c) = 1.0 / P(2, c);
  }
  return M.fullPivLu().solve(rhs);
}

// The target's points 0, 1, 2 in the camera frame of world <- camera T_wc.
Eigen::Matrix3d camera_points(const Target& t, const Pose& T_wc) {
  const Eigen::Matrix3Xd w = t.world_points();
  const Pose T_cw = se3_inverse(T_wc);
  return (T_cw.topLeftCorner<3, 3>() * w.leftCols<3>()).colwise() + T_cw.topRightCorner<3, 1>();
}

void tasks_converge() {
  const CameraModel cam = CameraModel::normalized(0.3);
  const Target tgt = with_edges(Target::paper());
  for (const Layout& L : {Layout::none(), Layout::cartesian(4), Layout::polar(4)}) {
    for (DepthMode d : {DepthMode::exact, DepthMode::desired, DepthMode::pose, DepthMode::estimated}) {
      EpisodeOptions o = opts(30, 1e-5);
      o.depth = d;
      const auto r = run_episode(line_servo(L, 4), cam, tgt, general_motion(), Pose::Identity(), o);
      ibvs_test::report(r.status.outcome == Outcome::converged, "free camera: lines converge", __FILE__, __LINE__,
                        L.describe() + " " + std::string(to_string(d)) + " " + to_string(r.status.outcome));
      CHECK(r.metrics.final_translation_error < 1e-3);
      CHECK(r.history.error.cols() == L.rows() + 8);
      CHECK(r.history.measurements.cols() == 20);
      CHECK(r.history.error_norm(r.history.frames - 1) < 1e-5);  // converged on the task's error
    }
  }
  // Two lines only do not fix the camera: 4 rows, the law still drives their error to 0.
  const auto r2 = run_episode(line_servo(Layout::none(), 2), cam,
                              Target(Target::paper()).add(LineSource(0, 1)).add(LineSource(1, 2)), general_motion(),
                              Pose::Identity(), opts(30, 1e-5));
  CHECK(r2.status.outcome == Outcome::converged || r2.status.outcome == Outcome::singular);
  // Gantry (paper Section III-B set-up) and a redundant 7-joint robot.
  const Gantry g = Gantry::afma6();
  for (const Layout& L : {Layout::none(), Layout::stacked(4)}) {
    const auto rg = run_episode(line_servo(L, 4, 2.0), CameraModel::afma6(), with_edges(gantry_target(g)), g,
                                gantry_start(), gantry_goal(), opts(15, 1e-5));
    ibvs_test::report(rg.status.outcome == Outcome::converged, "gantry: lines converge", __FILE__, __LINE__,
                      L.describe() + " " + to_string(rg.status.outcome));
    CHECK(rg.metrics.final_rotation_error < 0.1 * pi / 180);
    Episode e(line_servo(L, 4, 2.0), CameraModel::afma6(), with_edges(gantry_target(g)),
              std::make_shared<StackedGantry>(), opts(15, 1e-5));
    const auto& rs = e.run(stacked_start(), stacked_goal());
    ibvs_test::report(rs.status.outcome == Outcome::converged, "7-joint robot: lines converge", __FILE__, __LINE__,
                      L.describe() + " " + to_string(rs.status.outcome));
  }
}

// Each frame's line measurement is LineFeature::measure of the controller's points (noise,
// latency) with the plane of the pose the depth mode gives, scaled by depth_scale.
void measurements_are_the_lines_of_the_points() {
  const CameraModel cam = CameraModel::normalized(0.3);
  const Target tgt = with_edges(Target::paper());
  for (DepthMode d : {DepthMode::exact, DepthMode::desired}) {
    EpisodeOptions o = opts(3, 1e-5);
    o.noise = 1e-3;
    o.latency = 2;
    o.depth = d;
    o.depth_scale = d == DepthMode::exact ? 1.5 : 1.0;
    const auto r = run_episode(line_servo(Layout::none(), 4), cam, tgt, general_motion(), Pose::Identity(), o);
    const History& h = r.history;
    CHECK(h.frames > 100);
    double worst = 0.0;
    for (int k = 0; k < h.frames - 1; ++k) {
      const int seen = std::max(0, k - o.latency);
      const Pose T_wc = d == DepthMode::desired ? r.goal : row_pose(h, seen);
      const Eigen::Vector3d plane = plane_through(camera_points(tgt, T_wc)) / o.depth_scale;
      for (int b = 0; b < 4; ++b) {
        const int i = b, j = (b + 1) % 4;
        const auto m = LineFeature::measure(h.uv(k, 2 * i), h.uv(k, 2 * i + 1), h.uv(k, 2 * j), h.uv(k, 2 * j + 1),
                                            plane(0), plane(1), plane(2));
        for (int c = 0; c < 5; ++c) worst = std::max(worst, std::abs(h.measurements(k, 5 * b + c) - m[c]));
      }
    }
    ibvs_test::report(worst < 1e-12, "line measurements = LineFeature::measure", __FILE__, __LINE__,
                      std::string(to_string(d)) + " " + std::to_string(worst));
    // The goal's: the noise-free goal points and the goal's plane.
    const Eigen::Vector3d plane = plane_through(camera_points(tgt, r.goal));
    const auto md = LineFeature::measure(r.uv_desired(0, 0), r.uv_desired(1, 0), r.uv_desired(0, 1),
                                         r.uv_desired(1, 1), plane(0), plane(1), plane(2));
    for (int c = 0; c < 5; ++c) CHECK_NEAR(r.measurements_desired(c), md[c], 1e-12);
  }
}

// A source that stops measuring at frame 3.
class FlakySource final : public FeatureSource {
 public:
  std::unique_ptr<FeatureSource> clone() const override { return std::make_unique<FlakySource>(*this); }
  std::string describe() const override { return "flaky"; }
  int size() const noexcept override { return 5; }
  bool measure(const SourceFrame& f, double* m) const noexcept override {
    return f.frame < 3 && line_.measure(f, m);
  }

 private:
  LineSource line_{1, 2};
};

void user_defined_sources() {
  const CameraModel cam = CameraModel::normalized(0.3);
  Target user = Target::paper();
  for (int i = 0; i < 4; ++i) user.add(ProjectedLineSource(i, (i + 1) % 4));
  const auto r = run_episode(line_servo(Layout::none(), 4), cam, user, general_motion(), Pose::Identity(),
                             opts(30, 1e-5));
  CHECK(r.status.outcome == Outcome::converged);
  // Without noise it measures what LineSource measures: the same episode.
  const auto ref = run_episode(line_servo(Layout::none(), 4), cam, with_edges(Target::paper()), general_motion(),
                               Pose::Identity(), opts(30, 1e-5));
  CHECK(ref.history.frames == r.history.frames);
  CHECK((ref.history.measurements.topRows(5) - r.history.measurements.topRows(5)).cwiseAbs().maxCoeff() < 1e-12);
  // A block its source cannot measure ends the episode as lost_feature, naming the block.
  Target flaky = Target::paper();
  flaky.add(LineSource(0, 1)).add(FlakySource()).add(LineSource(2, 3)).add(LineSource(3, 0));
  const auto rf = run_episode(line_servo(Layout::none(), 4), cam, flaky, general_motion(), Pose::Identity(),
                              opts(30, 1e-5));
  CHECK(rf.status.outcome == Outcome::lost_feature);
  CHECK(rf.status.frame == 3);
  CHECK(rf.status.feature == 1);
  CHECK(rf.status.point == -1);
  CHECK(std::isnan(rf.history.measurements(3, 0)));
  CHECK(std::isfinite(rf.history.measurements(2, 9)));
}

void bad_set_ups_refused() {
  const CameraModel cam = CameraModel::normalized(0.3);
  const Target edges = with_edges(Target::paper());
  const auto episode = [&](AnyServo s, const Target& t, EpisodeOptions o = {}) { Episode e(std::move(s), cam, t, o); };
  CHECK_THROWS(LineSource(0, 0));
  CHECK_THROWS(LineSource(-1, 2));
  CHECK_THROWS(LineSource(0, 1, 1));
  CHECK_THROWS(Target(Target::paper()).add(LineSource(0, 4)));  // no point 4
  Target tilted = Target::paper();
  tilted.points(2, 1) = 0.1;  // point 1 off the z = 0 plane: a line through it needs a plane
  CHECK_THROWS(Target(tilted).add(LineSource(0, 1)));
  Target(tilted).add(LineSource(0, 1, 2));  // through points 0, 1 and 2: accepted
  CHECK_THROWS(Target(Target::paper()).add(LineSource(0, 2, 2)));
  Target collinear = Target::paper();
  collinear.points.col(2) = 2.0 * collinear.points.col(1) - collinear.points.col(0);
  CHECK_THROWS(Target(collinear).add(LineSource(0, 1, 2)));  // the third point is on the line
  CHECK_THROWS(episode(line_servo(Layout::none(), 3), edges));   // 4 sources, 3 blocks
  CHECK_THROWS(episode(line_servo(Layout::none(), 4), Target::paper()));  // no sources
  CHECK_THROWS(episode(line_servo(Layout::cartesian(3), 4), edges));  // 3 points, the target has 4
  CHECK_THROWS(episode(PartitionedServo(4), edges));
  Task wrong(Layout::none());
  for (int k = 0; k < 4; ++k) wrong.add(LineFeature());
  Target other = Target::paper();
  for (int k = 0; k < 4; ++k) other.add(FlakySource());  // fits any block of 5 values ...
  episode(Servo(wrong), other);
  Target misfit = Target::paper();
  misfit.add(LineSource(0, 1));
  struct Two final : Feature {  // ... LineSource only a LineFeature
    std::unique_ptr<Feature> clone() const override { return std::make_unique<Two>(*this); }
    std::string describe() const override { return "two"; }
    int rows() const noexcept override { return 2; }
    int size() const noexcept override { return 5; }
    const char* check(const double*, int&) const noexcept override { return nullptr; }
    void value(const double* m, double* s) const noexcept override { s[0] = m[0], s[1] = m[1]; }
    void interaction(const double*, Eigen::Ref<MatrixX6> L) const noexcept override { L.setIdentity(); }
  };
  CHECK_THROWS(episode(Servo(Task().add(Two())), misfit));
  // The estimated mode fits a pose to the target's points: 3 non-collinear points needed.
  Target two(Eigen::Matrix3Xd(Target::paper().points.leftCols<2>()), Target::paper().pose);
  two.add(LineSource(0, 1));
  EpisodeOptions est;
  est.depth = DepthMode::estimated;
  CHECK_THROWS(episode(line_servo(Layout::none(), 1), two, est));
  episode(line_servo(Layout::none(), 1), two);  // exact: fine
  // A goal from which a line cannot be measured: the run throws, naming the source.
  Episode e(line_servo(Layout::none(), 4), cam, edges, opts(1, 1e-5));
  Pose edge_on = Pose::Identity();  // a goal camera in the target's plane z = 3, looking along +x at it
  edge_on.topLeftCorner<3, 3>() << 0, 0, 1, 1, 0, 0, 0, 1, 0;
  edge_on.topRightCorner<3, 1>() << -2.0, 0.0, 3.0;
  CHECK_THROWS(e.run(general_motion(), edge_on));
}

// fit_pose (the estimated mode's depth pose): recovers a rigid transform exactly; refuses collinear points.
void fit_pose_recovers() {
  std::mt19937 rng(ibvs_test::seed);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int c = 0; c < 50; ++c) {
    Eigen::Matrix3Xd P(3, 5);
    for (int i = 0; i < P.size(); ++i) P.data()[i] = g(rng);
    const Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
    Pose T = Pose::Identity();
    T.topLeftCorner<3, 3>() = q.normalized().toRotationMatrix();
    T.topRightCorner<3, 1>() << g(rng), g(rng), g(rng);
    const Eigen::Matrix3Xd Q = (T.topLeftCorner<3, 3>() * P).colwise() + T.topRightCorner<3, 1>();
    Pose F;
    CHECK(stages::fit_pose(P, Q, F));
    CHECK((F - T).cwiseAbs().maxCoeff() < 1e-10);
  }
  Eigen::Matrix3Xd line(3, 3);
  line << 0, 1, 2, 0, 1, 2, 0, 1, 2;
  Pose F;
  CHECK(!stages::fit_pose(line, line, F));
}


// The sources stage's goal (SourceFrame::goal) is the goal as the depth mode knows it: exact and
// desired the true one whatever the depth stage estimated; pose the depth stage's estimate of the
// goal's image, translation times depth_scale; estimated the fit to the goal's image at the goal
// depths given. A frame whose depth pose equals that goal measures PBVS zero (its equilibrium),
// and 2.5-D measures Z = Z* at the goal's image; the pose mode without a goal estimate is refused.
void sources_aim_at_the_goal_as_known() {
  Target t = Target::square(0.2, make_pose(0.02, -0.01, 1.0, 0.2, -0.1, 0.3));
  t.add(PbvsSource(PbvsTarget::desired_camera)).add(Point25DSource(2));
  Task task;
  task.add(PbvsFeature(PbvsTarget::desired_camera)).add(Point25DFeature());
  const Pose goal = make_pose(0.05, 0.03, -0.1, -0.05, 0.1, 0.2);  // world <- camera
  const Pose true_cMo = se3_inverse(goal) * t.pose;
  // the goal's image and depths
  Points uv(2, 4);
  Eigen::VectorXd z(4);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d p = true_cMo.topLeftCorner<3, 3>() * t.points.col(i) + true_cMo.topRightCorner<3, 1>();
    uv.col(i) << p(0) / p(2), p(1) / p(2);
    z(i) = p(2);
  }
  const Pose wrong = make_pose(0.1, 0.0, 0.2, 0.0, 0.05, 0.0) * true_cMo;  // an estimate of the goal, off
  const Pose T_cw = se3_inverse(goal);
  for (DepthMode mode : {DepthMode::exact, DepthMode::desired, DepthMode::pose, DepthMode::estimated}) {
    EpisodeOptions o;
    o.depth = mode;
    o.depth_scale = 1.5;
    stages::Sources s(t, &task, o);
    const bool given = mode == DepthMode::exact || mode == DepthMode::desired;  // the goal given, not estimated
    const Eigen::VectorXd zg = 1.5 * z;  // the goal depths the depth stage gave (pose, estimated: scaled)
    s.teach(goal, uv, given ? z : zg, &wrong);
    Pose known = true_cMo;
    if (mode == DepthMode::pose) {
      known = wrong;
      known.topRightCorner<3, 1>() *= 1.5;
    } else if (mode == DepthMode::estimated) {  // the true pose with its translation times 1.5
      known.topRightCorner<3, 1>() *= 1.5;
    }
    // at the goal: PBVS zero, 2.5-D's Z* the goal depth given
    for (int r = 0; r < 6; ++r) CHECK_NEAR(s.desired()(r), 0.0, 1e-9);
    CHECK_NEAR(s.desired()(8), given ? z(2) : 1.5 * z(2), 1e-12);
    // a frame seeing the goal's image: exact and desired take the true pose times depth_scale as
    // its depth pose, pose and estimated the same estimate as at the goal (PBVS zero)
    CHECK(s.measure(3, T_cw, &wrong, uv, given ? z : zg) < 0);
    const Eigen::VectorXd m = s.measurements();
    Pose scaled = true_cMo;
    scaled.topRightCorner<3, 1>() *= 1.5;
    const auto want = PbvsFeature::measure(given ? scaled : known, known, PbvsTarget::desired_camera);
    for (int r = 0; r < 6; ++r)
      ibvs_test::report(std::abs(m(r) - want[static_cast<std::size_t>(r)]) < 1e-9,
                        "PBVS measured against the goal as the depth mode knows it", __FILE__, __LINE__,
                        std::string(to_string(mode)) + " entry " + std::to_string(r) + ": " + std::to_string(m(r)));
    if (mode == DepthMode::pose) {
      stages::Sources refused(t, &task, o);
      CHECK_THROWS(refused.teach(goal, uv, zg, nullptr));  // the goal's image gave no estimate
    }
  }
  // goal_pose given: the goal is the true pose in every mode (not times depth_scale), the same frame
  // measures PBVS against it from the mode's depth pose; 2.5-D's Z* stays the depth stage's; the pose
  // mode needs no estimate of the goal's image.
  for (DepthMode mode : {DepthMode::exact, DepthMode::desired, DepthMode::pose, DepthMode::estimated}) {
    EpisodeOptions o;
    o.depth = mode;
    o.depth_scale = 1.5;
    o.goal_pose = GoalPose::given;
    stages::Sources s(t, &task, o);
    const bool given = mode == DepthMode::exact || mode == DepthMode::desired;
    const Eigen::VectorXd zg = given ? z : Eigen::VectorXd(1.5 * z);
    s.teach(goal, uv, zg, mode == DepthMode::pose ? nullptr : &wrong);
    for (int r = 0; r < 6; ++r) CHECK_NEAR(s.desired()(r), 0.0, 1e-12);
    CHECK_NEAR(s.desired()(8), zg(2), 1e-12);
    CHECK(s.measure(3, T_cw, &wrong, uv, zg) < 0);
    const Eigen::VectorXd m = s.measurements();
    // the mode's depth pose, translation times 1.5: the true one (exact, desired: the goal's, this
    // frame's), the estimate (pose), the fit to the points at 1.5 z (estimated; the square's centroid is 0)
    Pose depth_pose = mode == DepthMode::pose ? wrong : true_cMo;
    depth_pose.topRightCorner<3, 1>() *= 1.5;
    const auto want = PbvsFeature::measure(depth_pose, true_cMo, PbvsTarget::desired_camera);
    for (int r = 0; r < 6; ++r)
      ibvs_test::report(std::abs(m(r) - want[static_cast<std::size_t>(r)]) < 1e-9,
                        "PBVS measured against the goal given", __FILE__, __LINE__,
                        std::string(to_string(mode)) + " entry " + std::to_string(r) + ": " + std::to_string(m(r)));
  }
  EpisodeOptions bad;
  bad.goal_pose = static_cast<GoalPose>(2);
  CHECK_THROWS(bad.validate());
  CHECK(std::string(to_string(GoalPose::given)) == "given" && std::string(to_string(GoalPose::taught)) == "taught");
}

// A camera whose controller believes the focal length s f and the principal point (u0 + du, v0 + dv):
// it normalises every true pixel with that model, x' = (u - u0 - du) / (s f). The episode normalises the
// measurement with the true model, so this sensor reports u0 + f x' = u0 + (u - u0 - du) / s (as
// Python's sim.MiscalibratedCamera does for a pinhole believed model), the goal's pixels included.
class BelievedPinhole final : public Sensor {
 public:
  BelievedPinhole(double u0, double v0, double s, double du, double dv) : u0_(u0), v0_(v0), s_(s), du_(du), dv_(dv) {}
  void reset(std::uint64_t) noexcept override {}
  bool measure(const SensorFrame& f, Eigen::Ref<Points> m) noexcept override {
    for (Eigen::Index i = 0; i < m.cols(); ++i) {
      m(0, i) = u0_ + ((*f.projected)(0, i) - u0_ - du_) / s_;
      m(1, i) = v0_ + ((*f.projected)(1, i) - v0_ - dv_) / s_;
    }
    return true;
  }

 private:
  double u0_, v0_, s_, du_, dv_;
};

// PBVS with the pose depth mode and a wrong camera model (docs/compare.md, "Calibration errors"), the
// goal fronto-parallel at Z* = 3 m. Taught, the goal's estimate has the current one's bias and PBVS ends
// at the goal. Given, PBVS ends where the estimate equals the true goal pose: a planar target seen
// fronto-parallel through focal length s f looks like the true one at s times its depth (x' = X / (s Z)),
// so the camera stops at Z* / s from it, Z* (1/s - 1) behind the goal along the optical axis; a principal
// point off by d (px) shifts every normalised point by -d / f, which the estimate reads as the target
// shifted by -Z d / f, so the camera stops Z* d / f to the side (world x, y = -Z* du / f, -Z* dv / f; the
// goal camera is the world frame). With the exact depth mode the depth pose is the true one: given or
// taught, PBVS ends at the goal, bit for bit the same run.
void given_goal_pose_keeps_the_calibration_bias() {
  const double f = 800.0, Z = 3.0;
  const CameraModel cam = CameraModel::pinhole(f, f, 320, 320, 640, 640);
  Eigen::Matrix3Xd quad(3, 4);  // an asymmetric planar quadrilateral, about 0.5 m across
  quad << 0.30, -0.22, -0.27, 0.16, 0.18, 0.26, -0.20, -0.24, 0.0, 0.0, 0.0, 0.0;
  Pose at = Pose::Identity();
  at(2, 3) = Z;
  Target t(quad, at);
  t.add(PbvsSource(PbvsTarget::desired_camera));
  Task task;
  task.add(PbvsFeature(PbvsTarget::desired_camera));
  const Pose start = make_pose(0.1, -0.05, -0.3, 0.05, -0.08, 0.6);
  ServoOptions gain1;
  gain1.gain = 1.0;
  struct Case {
    double s, du, dv;
  };
  for (const Case c : {Case{0.8, 0, 0}, Case{1.25, 0, 0}, Case{1.0, 24, -16}}) {
    for (GoalPose gp : {GoalPose::taught, GoalPose::given}) {
      EpisodeOptions o = opts(30, 1e-6);
      o.depth = DepthMode::pose;
      o.goal_pose = gp;
      Episode e(Servo(task, gain1), cam, t, o);
      e.set_sensor(std::make_shared<BelievedPinhole>(320, 320, c.s, c.du, c.dv));
      const EpisodeResult& r = e.run(start, Pose::Identity());
      const std::string what = "s " + std::to_string(c.s) + " d (" + std::to_string(c.du) + ", " +
                               std::to_string(c.dv) + ") " + to_string(gp) + ": " + to_string(r.status.outcome);
      ibvs_test::report(r.status.outcome == Outcome::converged, "PBVS converges with a wrong camera model", __FILE__,
                        __LINE__, what);
      const Eigen::Vector3d p = row_pose(r.history, r.history.frames - 1).topRightCorner<3, 1>();
      // Where it stops: the error norm's tolerance (1e-6, m and rad) leaves the estimate within 1e-6 m of
      // its goal, i.e. the camera within 1e-6 / s <= 1.25 um in depth and 1e-6 rad x Z* = 3 um sideways
      // of the predicted pose: 20 um covers both with margin.
      const Eigen::Vector3d want = gp == GoalPose::taught
                                       ? Eigen::Vector3d::Zero()
                                       : Eigen::Vector3d(-Z * c.du / f, -Z * c.dv / f, -Z * (1.0 / c.s - 1.0));
      ibvs_test::report((p - want).norm() < 2e-5, "PBVS ends at the goal (taught) or where the estimate is the goal (given)",
                        __FILE__, __LINE__,
                        what + " at (" + std::to_string(p(0)) + ", " + std::to_string(p(1)) + ", " +
                            std::to_string(p(2)) + ")");
      CHECK(r.metrics.final_rotation_error < 1e-5);
    }
  }
  // The exact depth mode: the same run, taught or given.
  EpisodeOptions o = opts(30, 1e-6);
  Episode taught(Servo(task, gain1), cam, t, o);
  taught.set_sensor(std::make_shared<BelievedPinhole>(320, 320, 0.8, 0, 0));
  o.goal_pose = GoalPose::given;
  Episode given(Servo(task, gain1), cam, t, o);
  given.set_sensor(std::make_shared<BelievedPinhole>(320, 320, 0.8, 0, 0));
  const EpisodeResult& a = taught.run(start, Pose::Identity());
  const EpisodeResult& b = given.run(start, Pose::Identity());
  CHECK(a.status.outcome == Outcome::converged && a.history.frames == b.history.frames);
  CHECK(a.history.pose.topRows(a.history.frames) == b.history.pose.topRows(b.history.frames));
  CHECK(a.metrics.final_translation_error < 1e-5);
}

}  // namespace

void run_tests() {
  tasks_converge();
  measurements_are_the_lines_of_the_points();
  user_defined_sources();
  bad_set_ups_refused();
  fit_pose_recovers();
  sources_aim_at_the_goal_as_known();
  given_goal_pose_keeps_the_calibration_bias();
}
