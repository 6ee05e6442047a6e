// The episode on a generic robot (sim/robot.hpp) with n = 7 joints: a
// redundant gantry (two stacked z slides) moves the camera exactly as the
// gantry does, splits the z motion equally (minimum norm), records n columns,
// and a robot whose kinematics fails ends the episode as diverged.
#include "check.hpp"
#include "sim_cases.hpp"

#include <memory>

using namespace sim_cases;

namespace {

EpisodeOptions options() {
  EpisodeOptions o;
  o.duration = 15.0;
  o.tolerance = 1e-5;
  return o;
}

Servo cartesian() {
  ServoOptions so;
  so.gain = 2.0;
  return Servo(Layout::cartesian(4), so);
}

void redundant_robot_moves_the_camera_as_the_gantry() {
  const Gantry g = Gantry::afma6();
  const auto robot = std::make_shared<StackedGantry>();
  robot->qdot_max.setConstant(no_limit);  // no saturation: the same twist, hence the same camera path
  Gantry free = g;
  free.qdot_max.setConstant(no_limit);
  Episode e7(cartesian(), CameraModel::afma6(), gantry_target(g), robot, options());
  Episode e6(cartesian(), CameraModel::afma6(), gantry_target(g), free, options());
  const EpisodeResult& a = e7.run(stacked_start(), stacked_goal());
  const EpisodeResult& b = e6.run(gantry_start(), gantry_goal());
  CHECK(a.status.outcome == Outcome::converged && b.status.outcome == Outcome::converged);
  CHECK(a.history.frames == b.history.frames);
  CHECK(a.history.q.cols() == 7 && a.history.qdot.cols() == 7);
  double pose = 0.0, split = 0.0, fold = 0.0;
  for (int k = 0; k < a.history.frames; ++k) {
    pose = std::max(pose, (a.history.pose.row(k) - b.history.pose.row(k)).cwiseAbs().maxCoeff());
    split = std::max(split, std::abs(a.history.qdot(k, 2) - a.history.qdot(k, 6)));
    fold = std::max(fold, std::abs(a.history.q(k, 2) + a.history.q(k, 6) - b.history.q(k, 2)));
  }
  ibvs_test::report(pose < 1e-9, "camera path of the 7-joint robot = the gantry's", __FILE__, __LINE__,
                    std::to_string(pose));
  CHECK(split < 1e-12 && fold < 1e-9);
  CHECK(a.history.manipulability.head(a.history.frames - 1).allFinite());
}

void speed_limits_and_joint_limits() {
  const Gantry g = Gantry::afma6();
  const auto robot = std::make_shared<StackedGantry>();
  ServoOptions so;
  so.gain = 2.0;
  Episode e(Servo(Layout::polar(4), so), CameraModel::afma6(), gantry_target(g), robot, options());
  const EpisodeResult& r = e.run(stacked_start(), stacked_goal());
  CHECK(r.status.outcome == Outcome::converged);
  double worst = 0.0;
  for (int k = 0; k < r.history.frames - 1; ++k)
    for (int i = 0; i < 7; ++i) worst = std::max(worst, std::abs(r.history.qdot(k, i)) / robot->qdot_max(i));
  CHECK(worst <= 1.0 + 1e-12 && worst > 0.99);  // saturated at some frame, never beyond
  // A tight range on the extra slide stops the run there.
  robot->q_max(6) = 0.01;  // the minimum-norm split gives it half of the 9 cm rise
  Episode tight(Servo(Layout::polar(4), so), CameraModel::afma6(), gantry_target(g), robot, options());
  const EpisodeResult& t = tight.run(stacked_start(), stacked_goal());
  CHECK(t.status.outcome == Outcome::joint_limit && t.status.joint == 6);
}

void failing_kinematics() {
  const Gantry g = Gantry::afma6();
  const auto robot = std::make_shared<StackedGantry>();
  Episode e(cartesian(), CameraModel::afma6(), gantry_target(g), robot, options());
  robot->fail = true;
  CHECK_THROWS(e.run(stacked_start(), stacked_goal()));  // at the start: refused
  CHECK_THROWS(e.run(gantry_start(), gantry_goal()));   // 6 joints for a 7-joint robot
  CHECK_THROWS(Episode(cartesian(), CameraModel::afma6(), gantry_target(g), std::shared_ptr<Robot>(), options()));
  StackedGantry bad;
  bad.qdot_max.resize(6);
  CHECK_THROWS(bad.validate());
}

// A robot whose kinematics fails mid-run: the episode ends as diverged.
struct FailsAfter final : Robot {
  StackedGantry inner;
  mutable int calls = 0;
  FailsAfter() {
    q_min = inner.q_min;
    q_max = inner.q_max;
    qdot_max = inner.qdot_max;
    mount = inner.mount;
    mapping = inner.mapping;
  }
  bool kinematics(const JointVector& q, Pose& T, RobotJacobian& J) const noexcept override {
    return ++calls < 10 && inner.kinematics(q, T, J);
  }
};

void failing_mid_run() {
  const Gantry g = Gantry::afma6();
  Episode e(cartesian(), CameraModel::afma6(), gantry_target(g), std::make_shared<FailsAfter>(), options());
  const EpisodeResult& r = e.run(stacked_start(), stacked_goal());
  CHECK(r.status.outcome == Outcome::diverged && r.history.frames < 12);
}

}  // namespace

void run_tests() {
  redundant_robot_moves_the_camera_as_the_gantry();
  speed_limits_and_joint_limits();
  failing_kinematics();
  failing_mid_run();
}
