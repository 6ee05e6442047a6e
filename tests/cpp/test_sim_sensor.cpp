// The episode's measurement hook (sim/sensor.hpp): the default ProjectionSensor
// is the former built-in measurement, a sensor's lost point ends the episode as
// lost_feature with its index, a failing sensor as diverged, the goal is
// measured by the sensor (teach by showing: a constant bias cancels), and a goal
// the sensor cannot see is refused.
#include "check.hpp"
#include "sim_cases.hpp"

#include <limits>
#include <memory>
#include <string>

using namespace ibvs;
using namespace ibvs::sim;
using namespace sim_cases;

namespace {

// Projections, shifted by `bias` pixels; drops point `drop` from frame `drop_at` on; fails at `fail_at`.
class TestSensor final : public Sensor {
 public:
  Eigen::Vector2d bias = Eigen::Vector2d::Zero();
  static constexpr int never = -100;  // frame -1 is the goal
  int drop = -1, drop_at = never, fail_at = never;
  int calls = 0, goal_calls = 0;
  void reset(std::uint64_t) noexcept override { calls = goal_calls = 0; }
  bool measure(const SensorFrame& f, Eigen::Ref<Points> m) noexcept override {
    ++calls;
    if (f.frame < 0) ++goal_calls;
    if (f.frame == fail_at) return false;
    m = *f.projected;
    m.colwise() += bias;
    if (drop >= 0 && drop_at != never && f.frame >= drop_at)
      m.col(drop).setConstant(std::numeric_limits<double>::quiet_NaN());
    return true;
  }
};

Servo servo(const Layout& L) {
  ServoOptions o;
  o.gain = 1.0;
  return Servo(L, o);
}

EpisodeOptions opts(double noise = 0.0) {
  EpisodeOptions o;
  o.duration = 4.0;
  o.tolerance = 1e-6;
  o.noise = noise;
  o.seed = 7;
  o.latency = 1;
  return o;
}

bool same(const History& a, const History& b) {
  return a.frames == b.frames && a.pose.topRows(a.frames) == b.pose.topRows(b.frames) &&
         a.twist.topRows(a.frames) == b.twist.topRows(b.frames);
}

void default_is_projection_plus_noise() {
  const Gantry g = Gantry::afma6();
  for (double noise : {0.0, 0.4}) {
    Episode a(servo(Layout::cartesian(4)), CameraModel::afma6(), gantry_target(g), g, opts(noise));
    Episode b(servo(Layout::cartesian(4)), CameraModel::afma6(), gantry_target(g), g, opts(noise));
    b.set_sensor(std::make_shared<ProjectionSensor>(noise));
    const EpisodeResult& ra = a.run(gantry_start(), gantry_goal());
    const EpisodeResult& rb = b.run(gantry_start(), gantry_goal());
    CHECK(same(ra.history, rb.history));
    // measured = projected + noise; the history keeps both
    const int k = ra.history.frames / 2;
    const double d = (ra.history.measured.row(k) - ra.history.projected.row(k)).cwiseAbs().maxCoeff();
    CHECK(noise == 0.0 ? d == 0.0 : (d > 0.0 && d < 10 * noise));
  }
  // A test sensor without bias gives the noise-free default, bit for bit.
  Episode a(servo(Layout::stacked(4)), CameraModel::normalized(0.3), Target::paper(), opts());
  Episode b(servo(Layout::stacked(4)), CameraModel::normalized(0.3), Target::paper(), opts());
  auto s = std::make_shared<TestSensor>();
  b.set_sensor(s);
  CHECK(same(a.run(general_motion(), Pose::Identity()).history, b.run(general_motion(), Pose::Identity()).history));
  CHECK(s->goal_calls == 1 && s->calls == b.result().history.frames + 1);
  b.set_sensor(nullptr);  // back to the default
  CHECK(same(a.result().history, b.run(general_motion(), Pose::Identity()).history));
}

void lost_point_is_an_outcome() {
  Episode e(servo(Layout::polar(4)), CameraModel::normalized(0.3), Target::paper(), opts());
  auto s = std::make_shared<TestSensor>();
  s->drop = 2;
  s->drop_at = 30;
  e.set_sensor(s);
  const EpisodeResult& r = e.run(half_turn_z(), Pose::Identity());
  CHECK(r.status.outcome == Outcome::lost_feature && r.status.frame == 30 && r.status.point == 2);
  CHECK(std::string(to_string(r.status.outcome)) == "lost_feature");
  CHECK(r.history.frames == 31 && std::isnan(r.history.measured(30, 4)) && std::isfinite(r.history.projected(30, 4)));
  // a failing sensor ends the episode as diverged at that frame
  s->drop = -1;
  s->drop_at = TestSensor::never;
  s->fail_at = 12;
  const EpisodeResult& f = e.run(half_turn_z(), Pose::Identity());
  CHECK(f.status.outcome == Outcome::diverged && f.status.frame == 12);
  // a goal the sensor cannot measure is refused
  s->fail_at = TestSensor::never;
  s->drop = 1;
  s->drop_at = -1;
  CHECK_THROWS(e.run(half_turn_z(), Pose::Identity()));
}

void goal_is_measured_by_the_sensor() {
  // A constant 3-pixel bias, at the goal too: the loop converges to the true goal pose.
  // Free flight with the gantry's distorted camera, start and goal poses (the gantry would saturate).
  const Gantry g = Gantry::afma6();
  EpisodeOptions o = opts();
  o.duration = 30.0;
  Episode e(servo(Layout::cartesian(4)), CameraModel::afma6(), gantry_target(g), o);
  auto s = std::make_shared<TestSensor>();
  s->bias << 3.0, -2.0;
  e.set_sensor(s);
  const EpisodeResult& r = e.run(g.camera(gantry_start()), g.camera(gantry_goal()));
  CHECK(r.status.outcome == Outcome::converged);
  // converged: the measured image is the goal's, so the projections are too (to the tolerance)
  CHECK(r.metrics.final_translation_error < 1e-4 && r.metrics.final_rotation_error < 1e-3);
}

}  // namespace

void run_tests() {
  default_is_projection_plus_noise();
  lost_point_is_an_outcome();
  goal_is_measured_by_the_sensor();
}
