// Lost points (ServoInput::valid): a lost point's rows are out of the law (the twist is that of
// a servo of the remaining points), NaN is accepted where a point is lost and refused where it
// is valid, the task degrades while 2 x valid points >= its DOF and otherwise ramps the twist to
// zero over stop_time (Status::features_lost), all valid is the plain step bit for bit, and an
// episode with keep_lost rides out a point hidden for 10 frames (and ends as lost_feature when
// too many are lost for good).
#include "check.hpp"
#include "scene.hpp"
#include "sim_cases.hpp"

#include <limits>
#include <memory>

using namespace ibvs;

namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

// 4 points of the paper's square seen from a general pose, with point `lost` removed.
void lost_rows_are_out_of_the_law() {
  const auto Pw = ibvs_test::square(0.25, 3.0);
  Twist start;
  start << 0.1, -0.08, -0.3, 0.1, -0.08, 1.2;
  for (const Layout& L4 : {Layout::cartesian(4), Layout::polar(4), Layout::stacked(4)}) {
    ServoOptions o;
    o.gain = 0.7;
    Servo servo(L4, o);
    ServoInput in(L4);
    ServoOutput out(L4), plain(L4);
    ibvs_test::look(Pose::Identity(), Pw, in.uv_desired, in.depth_desired);
    ibvs_test::look(ibvs_test::pose(start), Pw, in.uv, in.depth);
    // All valid: the plain step, bit for bit.
    servo.update(in.uv, in.depth, in.uv_desired, in.depth_desired, plain);
    servo.reset();
    CHECK(servo.update(in, out) == Status::ok && out.velocity == plain.velocity && out.error == plain.error);
    for (int lost = 0; lost < 4; ++lost) {
      // The same layout on the other three points.
      std::vector<int> keep;
      for (int i = 0; i < 4; ++i)
        if (i != lost) keep.push_back(i);
      const Layout L3 = L4 == Layout::cartesian(4) ? Layout::cartesian(3)
                        : L4 == Layout::polar(4)   ? Layout::polar(3)
                                                   : Layout::stacked(3);
      Servo three(L3, o);
      ServoInput in3(L3);
      ServoOutput out3(L3);
      for (int j = 0; j < 3; ++j) {
        in3.uv.col(j) = in.uv.col(keep[j]);
        in3.depth(j) = in.depth(keep[j]);
        in3.uv_desired.col(j) = in.uv_desired.col(keep[j]);
        in3.depth_desired(j) = in.depth_desired(keep[j]);
      }
      CHECK(three.update(in3, out3) == Status::ok);
      ServoInput masked = in;
      masked.valid(lost) = false;
      masked.uv.col(lost).setConstant(nan);  // not read
      masked.depth(lost) = nan;
      servo.reset();
      CHECK(servo.update(masked, out) == Status::ok);
      CHECK(out.lost_points == 1);
      CHECK((out.velocity - out3.velocity).norm() <= 1e-10 * out3.velocity.norm());
      CHECK(std::abs(out.error_norm - out3.error_norm) <= 1e-12);
      CHECK(out.jacobian.allFinite() && out.error.allFinite());
      servo.validate(masked);  // NaN where lost is accepted
      // ... and refused where the point is valid, naming it.
      ServoInput bad = masked;
      bad.uv(0, (lost + 1) % 4) = nan;
      CHECK(servo.update(bad, out) == Status::invalid_input && out.velocity.isZero(0.0));
      try {
        servo.validate(bad);
        CHECK(false);
      } catch (const std::invalid_argument& e) {
        CHECK(std::string(e.what()).find("uv[" + std::to_string((lost + 1) % 4) + "]") != std::string::npos);
      }
    }
    ServoInput wrong = in;
    wrong.valid = PointMask::Constant(3, true);
    CHECK(servo.update(wrong, out) == Status::invalid_input);
    CHECK_THROWS(servo.validate(wrong));
  }
}

// Two valid points of four: too few for 6 DOF, the twist ramps to zero over stop_time; enough for
// a 4-DOF task; the law resumes, continuous with smoothing, when the points come back.
void too_few_ramp_to_zero() {
  const auto Pw = ibvs_test::square(0.25, 3.0);
  Twist start;
  start << 0.1, -0.08, -0.3, 0.1, -0.08, 0.5;
  const double dt = 0.01, stop_time = 0.2;
  ServoOptions o;
  o.gain = 1.0;
  o.stop_time = stop_time;
  o.smoothing.period = dt;
  o.smoothing.decay_rate = 10.0;
  Servo servo(Layout::cartesian(4), o);
  ServoInput in(Layout::cartesian(4));
  ServoOutput out(Layout::cartesian(4));
  ibvs_test::look(Pose::Identity(), Pw, in.uv_desired, in.depth_desired);
  ibvs_test::look(ibvs_test::pose(start), Pw, in.uv, in.depth);
  for (int k = 0; k < 30; ++k) servo.update(in, out);  // the continuous law has reached the plain one
  const Twist before = out.velocity;
  CHECK(before.norm() > 0.1);
  in.valid << true, false, true, false;
  for (int k = 1; k <= 30; ++k) {
    CHECK(servo.update(in, out) == Status::features_lost);
    CHECK(out.lost_points == 2);
    const double left = std::max(0.0, 1.0 - k * dt / stop_time);
    CHECK((out.velocity - left * before).norm() <= 1e-12 * before.norm());
  }
  CHECK(out.velocity.isZero(0.0));
  // Back: the law resumes from rest (the ramp's end), continuously.
  in.valid.setConstant(true);
  CHECK(servo.update(in, out) == Status::ok && out.velocity.isZero(0.0) && out.law_switched);
  servo.update(in, out);
  CHECK(out.velocity.norm() > 0.0 && out.velocity.norm() < 0.2 * before.norm());
  // stop_time 0: at once.
  ServoOptions now;
  now.gain = 1.0;
  Servo abrupt(Layout::cartesian(4), now);
  in.valid << false, false, false, true;
  CHECK(abrupt.update(in, out) == Status::features_lost && out.velocity.isZero(0.0));
  // A task of 4 DOF (Tx, Ty, Tz, wz) is served by two points.
  Task t(Layout::cartesian(4));
  t.set_dof({true, true, true, false, false, true});
  Servo four(t, now);
  ServoInput in4(four.task());
  in4.uv = in.uv;
  in4.depth = in.depth;
  in4.uv_desired = in.uv_desired;
  in4.depth_desired = in.depth_desired;
  in4.valid << true, false, true, false;
  CHECK(four.update(in4, out) == Status::ok && out.velocity.norm() > 0.0 && out.lost_points == 2);
  in4.valid << true, false, false, false;
  CHECK(four.update(in4, out) == Status::features_lost);
}

// Projections, with points `drop` lost (NaN) over frames [from, to).
class Occluding final : public sim::Sensor {
 public:
  std::vector<int> drop;
  int from = 0, to = 0;
  void reset(std::uint64_t) noexcept override {}
  bool measure(const sim::SensorFrame& f, Eigen::Ref<Points> m) noexcept override {
    m = *f.projected;
    if (f.frame >= from && f.frame < to)
      for (int i : drop) m.col(i).setConstant(nan);
    return true;
  }
};

void episode_keeps_lost_points() {
  using namespace ibvs::sim;
  EpisodeOptions eo;
  eo.duration = 30.0;
  eo.tolerance = 1e-6;
  ServoOptions o;
  o.gain = 1.0;
  o.stop_time = 0.5;
  o.smoothing.period = 1.0;  // the episode replaces it by its frame period
  const CameraModel cam = CameraModel::normalized(0.3);
  // A point hidden for 10 frames: the default ends the episode, keep_lost converges.
  auto hide = std::make_shared<Occluding>();
  hide->drop = {2};
  hide->from = 20;
  hide->to = 30;
  Episode plain(Servo(Layout::cartesian(4), o), cam, Target::paper(), eo);
  plain.set_sensor(hide);
  const EpisodeResult& p = plain.run(sim_cases::general_motion(), Pose::Identity());
  CHECK(p.status.outcome == Outcome::lost_feature && p.status.frame == 20 && p.status.point == 2);
  eo.keep_lost = true;
  for (int latency : {0, 2}) {
    eo.latency = latency;
    Episode keep(Servo(Layout::cartesian(4), o), cam, Target::paper(), eo);
    keep.set_sensor(hide);
    const EpisodeResult& r = keep.run(sim_cases::general_motion(), Pose::Identity());
    ibvs_test::report(r.status.outcome == Outcome::converged, "converges through the occlusion", __FILE__, __LINE__,
                      to_string(r.status.outcome));
    CHECK(std::isnan(r.history.uv(20 + latency, 4)) && std::isfinite(r.history.uv(30 + latency, 4)));
    CHECK(r.history.twist.topRows(r.history.frames).allFinite());
  }
  // Three of four lost for good: the twist ramps down over stop_time, then lost_feature.
  auto gone = std::make_shared<Occluding>();
  gone->drop = {0, 1, 3};
  gone->from = 20;
  gone->to = 1 << 30;
  eo.latency = 0;
  Episode keep(Servo(Layout::cartesian(4), o), cam, Target::paper(), eo);
  keep.set_sensor(gone);
  const EpisodeResult& r = keep.run(sim_cases::general_motion(), Pose::Identity());
  const int ramp = static_cast<int>(std::lround(0.5 * cam.fps()));
  CHECK(r.status.outcome == Outcome::lost_feature && r.status.point == 0);
  ibvs_test::report(std::abs(r.status.frame - (20 + ramp - 1)) <= 1, "ends when the ramp does", __FILE__, __LINE__,
                    std::to_string(r.status.frame));
  const double n19 = r.history.twist.row(19).norm(), n30 = r.history.twist.row(30).norm();
  CHECK(n30 < n19 && n30 > 0.0);
  // keep_lost refuses what cannot leave points out.
  eo.depth = DepthMode::pose;
  CHECK_THROWS(Episode(Servo(Layout::cartesian(4), o), cam, Target::paper(), eo));
  eo.depth = DepthMode::exact;
  CHECK_THROWS(Episode(PartitionedServo(4), cam, Target::paper(), eo));
}

}  // namespace

void run_tests() {
  lost_rows_are_out_of_the_law();
  too_few_ramp_to_zero();
  episode_keeps_lost_points();
}
