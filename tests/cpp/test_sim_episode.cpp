// Closed-loop episodes: the paper's claims (Section III-A, Figs. 1-3; Section V,
// Fig. 5; Section III-B on the gantry), the partitioned law of Corke & Hutchinson
// 2001 in the loop, the reported events, reproducibility.
// Also prints the time of a 600-frame gantry episode (information, not a check).
#include "check.hpp"
#include "sim_cases.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>

using namespace ibvs;
using namespace ibvs::sim;
using namespace sim_cases;

namespace {

Servo servo(const Layout& L, double gain = 1.0) {
  ServoOptions o;
  o.gain = gain;
  return Servo(L, o);
}

// Largest |twist component| over the recorded frames.
Twist max_abs_twist(const History& h) {
  Twist m = Twist::Zero();
  for (int k = 0; k < h.frames; ++k)
    for (int j = 0; j < 6; ++j)
      if (std::isfinite(h.twist(k, j))) m(j) = std::max(m(j), std::abs(h.twist(k, j)));
  return m;
}

void z_rotation_pi() {
  const CameraModel cam = CameraModel::normalized(0.3);
  const Target tgt = Target::paper();
  // Polar: pure wz (Fig. 2).
  auto r = run_episode(servo(Layout::polar(4)), cam, tgt, half_turn_z(), Pose::Identity(), opts(20, 1e-3));
  CHECK(r.status.outcome == Outcome::converged);
  const Twist m = max_abs_twist(r.history);
  CHECK(m(5) > 3.0);
  CHECK(m.head<5>().maxCoeff() < 1e-9 * m(5));
  CHECK(r.metrics.camera_retreat < 1e-9);
  CHECK(r.metrics.final_rotation_error < 1e-3);
  // Cartesian: pure retreat along the optical axis, flagged as diverged ([3], Section I).
  r = run_episode(servo(Layout::cartesian(4)), cam, tgt, half_turn_z(), Pose::Identity(), opts(20, 1e-3));
  CHECK(r.status.outcome == Outcome::diverged);
  CHECK(r.metrics.camera_retreat > 10.0);
  const Twist mc = max_abs_twist(r.history);
  CHECK((mc.head<2>().maxCoeff() < 1e-9 * mc(2)) && (mc.tail<3>().maxCoeff() < 1e-9 * mc(2)));
  CHECK(r.history.twist(0, 2) < 0.0);  // backwards
  // Stacked hybrid (Section V): converges.
  r = run_episode(servo(Layout::stacked(4)), cam, tgt, half_turn_z(), Pose::Identity(), opts(20, 1e-3));
  CHECK(r.status.outcome == Outcome::converged);
  CHECK(r.metrics.final_rotation_error < 1e-3);
  // turn: the exact half-turn goes the way chosen (Servo::continue_turn after the run's reset), both converge;
  // without it the exact tie keeps +pi (angle_wrap.hpp), the same way as turn = +pi.
  double first_wz[3];
  const double turns[3] = {pi, -pi, std::numeric_limits<double>::quiet_NaN()};
  for (int i = 0; i < 3; ++i) {
    EpisodeOptions o = opts(20, 1e-3);
    o.turn = turns[i];
    r = run_episode(servo(Layout::polar(4)), cam, tgt, half_turn_z(), Pose::Identity(), o);
    CHECK(r.status.outcome == Outcome::converged);
    first_wz[i] = r.history.twist(0, 5);
  }
  CHECK(first_wz[0] * first_wz[1] < 0.0 && std::abs(first_wz[0] + first_wz[1]) < 1e-9 * std::abs(first_wz[0]));
  CHECK(first_wz[2] == first_wz[0]);
  EpisodeOptions bad = opts(20, 1e-3);
  for (double t : {pi + wrap_hysteresis + 1e-9, -4.0, std::numeric_limits<double>::infinity()}) {
    bad.turn = t;
    CHECK_THROWS(bad.validate());
  }
  bad.turn = -pi;
  CHECK_THROWS(Episode refused(PartitionedServo(4), cam, tgt, bad));
}

void x_translation_case() {
  const CameraModel cam = CameraModel::normalized(0.3);
  const Target tgt = Target::paper();
  auto r = run_episode(servo(Layout::cartesian(4)), cam, tgt, sim_cases::x_translation(), Pose::Identity(),
                       opts(20, 1e-4));
  CHECK(r.status.outcome == Outcome::converged);
  Twist m = max_abs_twist(r.history);
  CHECK(m(0) > 0.1);
  CHECK(m.tail<5>().maxCoeff() < 1e-12 * m(0));  // x only
  CHECK(r.history.twist(0, 0) < 0.0);
  CHECK_NEAR(r.metrics.path_length, 0.2, 1e-3);
  // Polar (Fig. 1): Tx coupled with Tz and wy; Ty, wx, wz stay zero.
  r = run_episode(servo(Layout::polar(4)), cam, tgt, sim_cases::x_translation(), Pose::Identity(), opts(20, 1e-4));
  CHECK(r.status.outcome == Outcome::converged);
  m = max_abs_twist(r.history);
  CHECK(m(2) > 0.05 * m(0) && m(4) > 0.05 * m(0));
  CHECK(m(1) < 1e-12 * m(0) && m(3) < 1e-12 * m(0) && m(5) < 1e-12 * m(0));
}

void general_motion_all_converge() {
  for (const Layout& L : {Layout::cartesian(4), Layout::polar(4), Layout::stacked(4)}) {
    const auto r = run_episode(servo(L), CameraModel::normalized(0.3), Target::paper(), sim_cases::general_motion(),
                               Pose::Identity(), opts(30, 1e-5));
    ibvs_test::report(r.status.outcome == Outcome::converged, "general motion converges", __FILE__, __LINE__,
                      L.describe() + " " + to_string(r.status.outcome));
    CHECK(r.metrics.final_translation_error < 1e-3);
  }
}

void gantry_general_motion() {
  const Gantry g = Gantry::afma6();
  for (const Layout& L : {Layout::cartesian(4), Layout::polar(4), Layout::stacked(4)}) {
    const auto r = run_episode(servo(L, 2.0), CameraModel::afma6(), gantry_target(g), g, gantry_start(), gantry_goal(),
                               opts(15, 1e-5));
    ibvs_test::report(r.status.outcome == Outcome::converged, "gantry general motion converges", __FILE__, __LINE__,
                      L.describe() + " " + to_string(r.status.outcome));
    CHECK(r.metrics.final_translation_error < 1e-3);
    CHECK(r.metrics.final_rotation_error < 0.1 * pi / 180);
    for (int k = 0; k < r.history.frames; ++k) CHECK(g.outside_limits(r.history.q.row(k).transpose()) < 0);
  }
}

void events_are_reported() {
  const Gantry g = Gantry::afma6();
  // Joint limit: polar drives joint 5 (index 4) to its lower limit; the robot stops inside.
  auto r = run_episode(servo(Layout::polar(4), 2.0), CameraModel::afma6(), gantry_target(g), g, gantry_joint_limit_start(),
                       gantry_goal(), opts(15, 1e-5));
  CHECK(r.status.outcome == Outcome::joint_limit);
  CHECK(r.status.joint == 4);
  const int last = r.history.frames - 1;
  CHECK(r.status.frame == last && last > 0);
  const Joints q = r.history.q.row(last).transpose(), qd = r.history.qdot.row(last).transpose();
  CHECK(g.outside_limits(q) < 0);
  CHECK(q(4) + qd(4) / 60.0 < g.q_min(4));
  // Tighter limits on joint 1 stop the converging Cartesian run on joint 1 instead.
  Gantry tight = g;
  tight.q_min(0) = 0.05;  // q1 goes from 0.188 to 0
  r = run_episode(servo(Layout::cartesian(4), 2.0), CameraModel::afma6(), gantry_target(g), tight, gantry_start(),
                  gantry_goal(), opts(15, 1e-5));
  CHECK(r.status.outcome == Outcome::joint_limit && r.status.joint == 0);

  // Left image (Section IV): polar moves points along circles that cross the
  // image border; Cartesian straight lines stay inside.
  Eigen::Matrix3Xd pts(3, 4);
  pts << -0.8, 0.8, 0.8, -0.8, -0.8, -0.8, 0.8, 0.8, 0, 0, 0, 0;
  const Target big{pts, make_pose(0, 0, 3, 0, 0, 0)};
  const CameraModel cam = CameraModel::normalized(0.3);
  const Pose start = make_pose(0, 0, 0, 0, 0, pi / 2);
  r = run_episode(servo(Layout::polar(4)), cam, big, start, Pose::Identity(), opts(20, 1e-4));
  CHECK(r.status.outcome == Outcome::left_image && r.status.frame > 0);
  CHECK(r.status.point >= 0 && r.status.point < 4);
  {  // the reported point is indeed outside at the reported frame
    const int k = r.status.frame;
    Pose T;
    for (int i = 0; i < 16; ++i) T(i / 4, i % 4) = r.history.pose(k, i);
    const Eigen::Vector3d p = se3_inverse(T).topLeftCorner<3, 3>() * (big.pose.topLeftCorner<3, 3>() * pts.col(r.status.point) + big.pose.topRightCorner<3, 1>()) + se3_inverse(T).topRightCorner<3, 1>();
    CHECK(!cam.contains(p(0) / p(2), p(1) / p(2)));
  }
  r = run_episode(servo(Layout::cartesian(4)), cam, big, start, Pose::Identity(), opts(20, 1e-4));
  CHECK(r.status.outcome == Outcome::converged);

  // Through the target: with 20 frames of latency the controller keeps sending its
  // first large command towards a close goal and the camera goes through the tilted
  // plate (a collision); a huge field of view so that no point leaves the image first.
  const Target tilted{Target::paper().points, make_pose(0, 0, 3, -0.3, 0, 0)};
  const Pose goal = make_pose(0, 0, 2.4, 0, 0, 0);
  EpisodeOptions ol = opts(10, 1e-4);
  ol.latency = 20;
  r = run_episode(servo(Layout::cartesian(4), 4.0), CameraModel::normalized(1e3), tilted, Pose::Identity(), goal, ol);
  CHECK(r.status.outcome == Outcome::collision && r.status.frame > 0);
  // Behind the camera: the same with a non-planar target (no faces) and no standoff.
  Target bumpy = tilted;
  bumpy.points(2, 0) = 0.01;
  ol.standoff_ratio = 0.0;
  r = run_episode(servo(Layout::cartesian(4), 4.0), CameraModel::normalized(1e3), bumpy, Pose::Identity(), goal, ol);
  CHECK(r.status.outcome == Outcome::behind_camera);
  CHECK(r.status.point >= 0 && r.status.point < 4);
  {  // the reported point is indeed at or behind the camera plane at the reported frame, and was not before
    const auto depth_at = [&](int k, int i) {
      Pose T;
      for (int j = 0; j < 16; ++j) T(j / 4, j % 4) = r.history.pose(k, j);
      return (se3_inverse(T) * bumpy.pose * bumpy.points.col(i).homogeneous())(2);
    };
    CHECK(depth_at(r.status.frame, r.status.point) < 1e-3);
    for (int i = 0; i < 4; ++i) CHECK(depth_at(r.status.frame - 1, i) > 1e-3);
  }
  CHECK(r.status.frame > 0);

  // Bad input throws before the loop.
  CHECK_THROWS(run_episode(servo(Layout::polar(3)), cam, Target::paper(), start, Pose::Identity()));
  CHECK_THROWS(run_episode(servo(Layout::polar(4)), cam, Target::paper(), start, make_pose(0, 0, 5, 0, 0, 0)));
  Joints outside = gantry_start();
  outside(2) = 1.0;
  CHECK_THROWS(run_episode(servo(Layout::polar(4)), CameraModel::afma6(), gantry_target(g), g, outside, gantry_goal()));
}

Pose pose_at(const EpisodeResult& r, int k) {
  Pose T;
  for (int j = 0; j < 16; ++j) T(j / 4, j % 4) = r.history.pose(k, j);
  return T;
}

// Target faces: constructed cases of target_backside and collision; never on the paper's cases.
void target_faces() {
  const CameraModel cam = CameraModel::normalized(0.3);
  // A camera that starts behind the plate, looking back at it: target_backside at frame 0.
  Pose behind = make_pose(0, 0, 6, 0, pi, 0);  // at z = 6, optical axis along -z: sees the points (depth 3)
  auto r = run_episode(servo(Layout::cartesian(4)), cam, Target::paper(), behind, Pose::Identity(), opts(5, 1e-4));
  CHECK(r.status.outcome == Outcome::target_backside && r.status.frame == 0);
  // Round the plate's edge in one frame (issue 11's six points, IBVS-P): target_backside at frame 1,
  // the camera centre behind the plane and the crossing outside the plate's disc.
  Eigen::Matrix3Xd six(3, 6);
  for (int i = 0; i < 6; ++i) six.col(i) << 0.04 * std::cos(pi * i / 3), 0.04 * std::sin(pi * i / 3), 0.0;
  const Target plate{six, make_pose(0, 0, 0.5, 0, 0, 0)};
  const Pose start = make_pose(-0.012, 0.031, -0.097, -0.134, 0.124, 2 * pi / 3);
  ServoOptions so;
  so.gain = 1.0;
  so.damping = 0.01;
  for (const Layout& L : {Layout::polar(6), Layout::stacked(6)}) {
    r = run_episode(Servo(L, so), CameraModel::normalized(0.3, 30.0), plate, start, Pose::Identity(), opts(30, 1e-4));
    CHECK(r.status.outcome == Outcome::target_backside && r.status.frame == 1);
    const Eigen::Vector3d c0 = pose_at(r, 0).col(3).head<3>(), c1 = pose_at(r, 1).col(3).head<3>();
    CHECK(c0(2) < 0.5 && c1(2) > 0.5);
    const Eigen::Vector3d x = c0 + (0.5 - c0(2)) / (c1(2) - c0(2)) * (c1 - c0);
    CHECK(x.head<2>().norm() > 0.04);
  }
  r = run_episode(Servo(Layout::cartesian(6), so), CameraModel::normalized(0.3, 30.0), plate, start, Pose::Identity(),
                  opts(30, 1e-4));
  CHECK(r.status.outcome == Outcome::converged);
  // The standoff: a goal 0.5 m from the paper's plate is reached with the default 5 % of 0.5 m
  // and ends as a collision when the standoff is larger than the goal's own distance.
  const Pose near_goal = make_pose(0, 0, 2.5, 0, 0, 0);
  EpisodeOptions o = opts(20, 1e-4);
  r = run_episode(servo(Layout::cartesian(4)), CameraModel::normalized(1.0), Target::paper(), Pose::Identity(), near_goal, o);
  CHECK(r.status.outcome == Outcome::converged);
  o.standoff_ratio = 1.2;  // 0.6 m
  r = run_episode(servo(Layout::cartesian(4)), CameraModel::normalized(1.0), Target::paper(), Pose::Identity(), near_goal, o);
  CHECK(r.status.outcome == Outcome::collision && r.status.point == -1);
  CHECK_NEAR(3.0 - pose_at(r, r.status.frame)(2, 3), 0.6, 0.02);  // stopped at the standoff
  // A non-planar target: the standoff around each point (the point is reported).
  Target bumpy = Target::paper();
  bumpy.points(2, 2) = 0.05;
  r = run_episode(servo(Layout::cartesian(4)), CameraModel::normalized(1.0), bumpy, Pose::Identity(), near_goal, o);
  CHECK(r.status.outcome == Outcome::collision && r.status.point >= 0);
  // Bad option.
  o.standoff_ratio = -1.0;
  CHECK_THROWS(run_episode(servo(Layout::cartesian(4)), cam, Target::paper(), Pose::Identity(), near_goal, o));
  // The paper's cases, every scheme: never a face event.
  const Layout hybrid({{0, Representation::cartesian}, {1, Representation::cartesian}, {2, Representation::polar},
                       {3, Representation::polar}});
  for (const Layout& L : {Layout::cartesian(4), Layout::polar(4), hybrid, Layout::stacked(4)}) {
    for (const Pose& s : {half_turn_z(), x_translation(), general_motion()}) {
      r = run_episode(servo(L), cam, Target::paper(), s, Pose::Identity(), opts(30, 1e-5));
      CHECK(r.status.outcome != Outcome::target_backside && r.status.outcome != Outcome::collision);
    }
    const Gantry g = Gantry::afma6();
    r = run_episode(servo(L, 2.0), CameraModel::afma6(), gantry_target(g), g, gantry_start(), gantry_goal(), opts(15, 1e-5));
    CHECK(r.status.outcome == Outcome::converged);
  }
}

void noise_latency_depth_modes() {
  const Gantry g = Gantry::afma6();
  EpisodeOptions o = opts(15, 1e-5);
  o.noise = 0.5;
  o.seed = 7;
  Episode e(servo(Layout::stacked(4), 2.0), CameraModel::afma6(), gantry_target(g), g, o);
  const EpisodeResult a = e.run(gantry_start(), gantry_goal());
  const EpisodeResult b = e.run(gantry_start(), gantry_goal());
  CHECK(a.history.frames == b.history.frames &&
        a.history.uv.topRows(a.history.frames) == b.history.uv.topRows(a.history.frames));  // seeded: identical
  CHECK(a.status.outcome == Outcome::timeout);  // noise keeps the error above 1e-5
  CHECK(a.metrics.final_translation_error < 2e-2);
  // ... but every measured point comes within 1 px of its goal: converged by tolerance_px alone
  // (tolerance inf), at the first frame whose worst point is within 1 px, as a tracker sees it.
  EpisodeOptions op = o;
  op.tolerance = std::numeric_limits<double>::infinity();
  op.tolerance_px = 1.0;
  const EpisodeResult p = run_episode(servo(Layout::stacked(4), 2.0), CameraModel::afma6(), gantry_target(g), g,
                                      gantry_start(), gantry_goal(), op);
  CHECK(p.status.outcome == Outcome::converged && p.metrics.frames_to_converge == p.status.frame);
  CHECK(p.measured_desired.isApprox(a.measured_desired, 0.0));
  const auto worst = [&](int k) {
    double w = 0.0;
    for (int i = 0; i < 4; ++i)
      w = std::max(w, std::hypot(p.history.measured(k, 2 * i) - p.measured_desired(0, i),
                                 p.history.measured(k, 2 * i + 1) - p.measured_desired(1, i)));
    return w;
  };
  CHECK(worst(p.status.frame) <= 1.0);
  for (int k = 0; k < p.status.frame; ++k) CHECK(worst(k) > 1.0);
  // both tests: the pixels and an error norm of 1e-5, which the noise never lets pass
  op.tolerance = 1e-5;
  CHECK(run_episode(servo(Layout::stacked(4), 2.0), CameraModel::afma6(), gantry_target(g), g, gantry_start(),
                    gantry_goal(), op).status.outcome == Outcome::timeout);
  // refused: no test at all (tolerance inf without tolerance_px), a negative or NaN tolerance_px
  op.tolerance = std::numeric_limits<double>::infinity();
  op.tolerance_px = 0.0;
  CHECK_THROWS(op.validate());
  op.tolerance_px = -1.0;
  CHECK_THROWS(op.validate());
  op.tolerance_px = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS(op.validate());
  op.tolerance = 1e-5;
  op.tolerance_px = std::numeric_limits<double>::infinity();
  CHECK_THROWS(op.validate());
  // Latency: the controller's first `latency` frames all see frame 0's image.
  o.noise = 0;
  o.latency = 5;
  Episode el(servo(Layout::cartesian(4), 2.0), CameraModel::afma6(), gantry_target(g), g, o);
  const EpisodeResult& l = el.run(gantry_start(), gantry_goal());
  CHECK(l.history.uv.row(5) == l.history.uv.row(0));
  CHECK(l.history.uv.row(6) != l.history.uv.row(0));
  CHECK(l.status.outcome == Outcome::converged);
  // Depth modes on the gantry: pose estimate and constant desired depth both converge.
  for (DepthMode d : {DepthMode::pose, DepthMode::desired}) {
    EpisodeOptions od = opts(15, 1e-5);
    od.depth = d;
    const auto r = run_episode(servo(Layout::polar(4), 2.0), CameraModel::afma6(), gantry_target(g), g, gantry_start(),
                               gantry_goal(), od);
    ibvs_test::report(r.status.outcome == Outcome::converged, "depth mode converges", __FILE__, __LINE__,
                      to_string(d) + std::string(" ") + to_string(r.status.outcome));
    if (d == DepthMode::pose) {  // the estimated depths track the true ones (kud/kdu residue only)
      const Target t = gantry_target(g);
      const Pose Tcw = se3_inverse(g.camera(gantry_start()));
      for (int i = 0; i < 4; ++i) {
        const double z = (Tcw * t.pose * t.points.col(i).homogeneous())(2);
        CHECK_NEAR(r.history.depth(0, i), z, 2e-3);
      }
    }
  }
}

PartitionedServo partitioned(double gain, int n = 4) {
  PartitionedOptions o;
  o.gain = gain;
  return PartitionedServo(n, o);
}

// PartitionedServo in the episode: the z-rotation pi is a pure wz with no camera
// retreat (what the partitioning is for); general motion converges in free flight
// and on the gantry; the history holds its Cartesian error and the sigma_min of
// its four (Tx, Ty, wx, wy) columns.
void partitioned_episodes() {
  const CameraModel cam = CameraModel::normalized(0.3);
  const Target tgt = Target::paper();
  Episode e(partitioned(1.0), cam, tgt, opts(20, 1e-5));
  CHECK(std::holds_alternative<PartitionedServo>(e.servo()));
  const EpisodeResult r = e.run(half_turn_z(), Pose::Identity());
  ibvs_test::report(r.status.outcome == Outcome::converged, "partitioned z-rotation pi converges", __FILE__, __LINE__,
                    to_string(r.status.outcome));
  const Twist m = max_abs_twist(r.history);
  CHECK_NEAR(m(5), pi, 1e-9);  // the first wz = gain * pi
  CHECK(m.head<5>().maxCoeff() < 1e-9 * m(5));
  CHECK(r.metrics.camera_retreat < 1e-9);
  CHECK(r.metrics.path_length < 1e-9);
  CHECK(r.metrics.final_rotation_error < 1e-4);
  CHECK(r.history.error.cols() == 8);
  bool sigma_ok = true;
  for (int k = 0; k < r.history.frames; ++k) sigma_ok = sigma_ok && r.history.sigma_min(k) > 0.0;
  CHECK(sigma_ok);
  // The Episode runs again with the same result (the servo holds no state between runs).
  const EpisodeResult again = e.run(half_turn_z(), Pose::Identity());
  CHECK(again.history.frames == r.history.frames);
  CHECK(again.history.twist.topRows(r.history.frames) == r.history.twist.topRows(r.history.frames));

  const auto f = run_episode(partitioned(1.0), cam, tgt, sim_cases::general_motion(), Pose::Identity(), opts(30, 1e-5));
  ibvs_test::report(f.status.outcome == Outcome::converged, "partitioned general motion converges", __FILE__, __LINE__,
                    to_string(f.status.outcome));
  CHECK(f.metrics.final_translation_error < 1e-3);
  const Gantry g = Gantry::afma6();
  const auto q = run_episode(partitioned(2.0), CameraModel::afma6(), gantry_target(g), g, gantry_start(), gantry_goal(),
                             opts(15, 1e-5));
  ibvs_test::report(q.status.outcome == Outcome::converged, "partitioned gantry general motion converges", __FILE__,
                    __LINE__, to_string(q.status.outcome));
  CHECK(q.metrics.final_translation_error < 1e-3);

  // Its point count must match the target's.
  CHECK_THROWS(run_episode(partitioned(1.0, 3), cam, tgt, half_turn_z(), Pose::Identity()));
}

// A moved Episode (its stages stay where they are, the robot shared) runs as before, and so does
// one moved into an Episode that had run another set-up.
void moved_episodes() {
  const Gantry g = Gantry::afma6();
  EpisodeOptions o = opts(15, 1e-5);
  o.depth = DepthMode::estimated;
  o.latency = 2;
  Episode e(servo(Layout::stacked(4), 2.0), CameraModel::afma6(), gantry_target(g), g, o);
  const EpisodeResult first = e.run(gantry_start(), gantry_goal());
  const int K = first.history.frames;
  // the frames recorded (the rows after them are not written)
  const auto same = [&](const EpisodeResult& r) {
    return r.history.frames == K && r.status.outcome == first.status.outcome &&
           r.history.q.topRows(K) == first.history.q.topRows(K) &&
           r.history.depth.topRows(K) == first.history.depth.topRows(K) &&
           r.history.twist.topRows(K) == first.history.twist.topRows(K);
  };
  Episode moved(std::move(e));
  CHECK(same(moved.run(gantry_start(), gantry_goal())));
  Episode other(servo(Layout::polar(4)), CameraModel::normalized(0.3), Target::paper(), opts(5, 1e-4));
  other.run(half_turn_z(), Pose::Identity());
  other = std::move(moved);
  CHECK(other.has_robot() && same(other.run(gantry_start(), gantry_goal())));
  CHECK(first.status.outcome == Outcome::converged);
}

void timing() {
  const Gantry g = Gantry::afma6();
  EpisodeOptions o = opts(10, 0.0);  // tolerance 0: all 600 frames
  Episode e(servo(Layout::stacked(4), 2.0), CameraModel::afma6(), gantry_target(g), g, o);
  double best = 1e9;
  for (int i = 0; i < 20; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    e.run(gantry_start(), gantry_goal());
    best = std::min(best, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  CHECK(e.result().history.frames == 600);
  std::printf("600-frame gantry episode (stacked 16x6): best of 20 = %.3f ms\n", best);
}

}  // namespace

void run_tests() {
  z_rotation_pi();
  x_translation_case();
  general_motion_all_converge();
  gantry_general_motion();
  events_are_reported();
  target_faces();
  noise_latency_depth_modes();
  partitioned_episodes();
  moved_episodes();
  timing();
}
