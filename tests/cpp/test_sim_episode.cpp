// Closed-loop episodes: the paper's claims (Section III-A, Figs. 1-3; Section V,
// Fig. 5; Section III-B on the gantry), the partitioned law of Corke & Hutchinson
// 2001 in the loop, the reported events, reproducibility.
// Also prints the time of a 600-frame gantry episode (information, not a check).
#include "check.hpp"
#include "sim_cases.hpp"

#include <chrono>
#include <cstdio>

using namespace ibvs;
using namespace ibvs::sim;
using namespace sim_cases;

namespace {

EpisodeOptions opts(double duration, double tolerance) {
  EpisodeOptions o;
  o.duration = duration;
  o.tolerance = tolerance;
  return o;
}

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

  // Behind the camera: with 20 frames of latency the controller keeps sending
  // its first large command towards a close goal and the camera passes through
  // the tilted target; a huge field of view so that no point leaves the image first.
  const Target tilted{Target::paper().points, make_pose(0, 0, 3, -0.3, 0, 0)};
  const Pose goal = make_pose(0, 0, 2.4, 0, 0, 0);
  EpisodeOptions ol = opts(10, 1e-4);
  ol.latency = 20;
  r = run_episode(servo(Layout::cartesian(4), 4.0), CameraModel::normalized(1e3), tilted, Pose::Identity(), goal, ol);
  CHECK(r.status.outcome == Outcome::behind_camera);
  CHECK(r.status.point >= 0 && r.status.point < 4);
  {  // the reported point is indeed at or behind the camera plane at the reported frame, and was not before
    const auto depth_at = [&](int k, int i) {
      Pose T;
      for (int j = 0; j < 16; ++j) T(j / 4, j % 4) = r.history.pose(k, j);
      return (se3_inverse(T) * tilted.pose * tilted.points.col(i).homogeneous())(2);
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

void noise_latency_depth_modes() {
  const Gantry g = Gantry::afma6();
  EpisodeOptions o = opts(15, 1e-5);
  o.noise = 0.5;
  o.seed = 7;
  Episode e(servo(Layout::stacked(4), 2.0), CameraModel::afma6(), gantry_target(g), g, o);
  const EpisodeResult a = e.run(gantry_start(), gantry_goal());
  const EpisodeResult b = e.run(gantry_start(), gantry_goal());
  CHECK(a.history.frames == b.history.frames && a.history.uv == b.history.uv);  // seeded: identical
  CHECK(a.status.outcome == Outcome::timeout);  // noise keeps the error above 1e-5
  CHECK(a.metrics.final_translation_error < 2e-2);
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
  CHECK(e.run(half_turn_z(), Pose::Identity()).history.twist == r.history.twist);

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
  noise_latency_depth_modes();
  partitioned_episodes();
  timing();
}
