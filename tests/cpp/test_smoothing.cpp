// Smooth starts and switches (smoothing.hpp): the continuous law against its
// formula (Mansard & Chaumette 2007 eq. 17; ViSP's computeControlLaw(t) form at a
// start from rest), acceleration limits (respected, direction of the change kept),
// the automatic polar / Cartesian switch near the goal (continuous twist across
// it, convergence delayed by at most the decay time), and the refusals.
#include "check.hpp"
#include "scene.hpp"

using namespace ibvs;

namespace {

constexpr double fps = 60.0, dt = 1.0 / fps;

ServoOptions smooth_options(double mu) {
  ServoOptions o;
  o.gain = 1.0;
  o.smoothing.decay_rate = mu;
  o.smoothing.period = dt;
  return o;
}

// Closed loop of a smooth servo with a plain twin fed the same images: the smooth twist is
// the plain one plus (v(t_s-) - v_law(t_s)) exp(-mu t) (eq. 17), from rest: ViSP's
// -lambda J+ e + lambda J+(0) e(0) exp(-mu t).
void continuous_law_formula() {
  const auto Pw = ibvs_test::square(0.25, 3.0);
  Twist start;
  start << 0.1, -0.08, -0.3, 0.1, -0.08, 0.6;
  for (double mu : {1.0, 4.0, 20.0}) {
    Servo smooth(Layout::stacked(4), smooth_options(mu));
    ServoOptions po;
    po.gain = 1.0;
    Servo plain(Layout::stacked(4), po);
    ServoInput in(Layout::stacked(4));
    ServoOutput out(Layout::stacked(4)), ref(Layout::stacked(4));
    ibvs_test::look(Pose::Identity(), Pw, in.uv_desired, in.depth_desired);
    Pose T = ibvs_test::pose(start);
    Twist v0 = Twist::Zero();
    double worst = 0.0;
    for (int k = 0; k < 200; ++k) {
      ibvs_test::look(T, Pw, in.uv, in.depth);
      smooth.update(in, out);
      plain.update(in, ref);
      if (k == 0) {
        v0 = ref.velocity;
        CHECK(out.velocity.isZero(0.0));  // starts from rest, exactly
        CHECK(out.law_switched);
      } else {
        CHECK(!out.law_switched);
      }
      const Twist expect = ref.velocity - v0 * std::exp(-mu * k * dt);
      worst = std::max(worst, (out.velocity - expect).norm() / std::max(1.0, expect.norm()));
      T = T * se3_exp(out.velocity * dt);
    }
    CHECK(worst < 1e-13);
    // reset(current): the next step starts from the given twist, exactly.
    Twist current;
    current << 0.01, 0.02, -0.03, 0.004, 0.005, -0.006;
    smooth.reset(current);
    smooth.update(in, out);
    CHECK((out.velocity - current).norm() < 1e-15);
  }
}

// The smoother alone: a constant law twist reached as v (1 - exp(-mu k T)); acceleration limits
// scale the change by one factor (its direction kept) and bound it per period.
void smoother_alone() {
  Smoothing s;
  s.decay_rate = 5.0;
  s.period = 0.01;
  TwistSmoother sm;
  Twist law;
  law << 0.3, -0.2, 0.1, 0.5, -0.4, 0.2;
  for (int k = 0; k < 50; ++k) {
    Twist v = law;
    sm.apply(s, no_limit, no_limit, v);
    CHECK(((v - law * (1.0 - std::exp(-5.0 * k * 0.01))).norm()) < 1e-15);
  }
  // Acceleration limits.
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int c = 0; c < ibvs_test::cases; ++c) {
    Smoothing a;
    a.period = 0.002 + 0.05 * (u(rng) + 1.0);
    a.max_linear_acceleration = 0.1 + 2.0 * (u(rng) + 1.0);
    a.max_angular_acceleration = c % 3 == 0 ? no_limit : 0.1 + 2.0 * (u(rng) + 1.0);
    a.decay_rate = c % 2 ? 0.0 : 3.0;
    TwistSmoother t;
    Twist prev = Twist::Zero();
    for (int k = 0; k < 20; ++k) {
      Twist target = Twist::NullaryExpr([&] { return u(rng); });
      Twist v = target;
      const bool limited = t.apply(a, no_limit, no_limit, v);
      const Twist dv = v - prev;
      CHECK(dv.head<3>().norm() <= a.max_linear_acceleration * a.period * (1 + 1e-12));
      CHECK(dv.tail<3>().norm() <= a.max_angular_acceleration * a.period * (1 + 1e-12));
      if (a.decay_rate == 0.0) {  // the change keeps the direction of target - prev
        const Twist want = target - prev;
        const double k2 = dv.dot(want) / want.squaredNorm();
        CHECK((dv - k2 * want).norm() <= 1e-12 * want.norm());
        CHECK(k2 > 0.0 && k2 <= 1.0 + 1e-15);
        CHECK(limited == (k2 < 1.0));
      }
      prev = v;
    }
  }
}

// The servo with acceleration and speed limits in a closed loop: both respected every frame,
// and it still converges.
void servo_limits() {
  const auto Pw = ibvs_test::square(0.25, 3.0);
  Twist start;
  start << 0.2, -0.1, -0.4, 0.1, -0.08, 1.2;
  ServoOptions o = smooth_options(4.0);
  o.smoothing.max_linear_acceleration = 0.5;
  o.smoothing.max_angular_acceleration = 1.0;
  o.max_linear_speed = 0.2;
  o.max_angular_speed = 0.5;
  Servo servo(Layout::stacked(4), o);
  Twist prev = Twist::Zero();
  int limited = 0;
  const auto run = ibvs_test::converge(servo, Pw, start, [&](const ServoOutput& out) {
    const Twist dv = out.velocity - prev;
    CHECK(dv.head<3>().norm() <= 0.5 * dt * (1 + 1e-12));
    CHECK(dv.tail<3>().norm() <= 1.0 * dt * (1 + 1e-12));
    CHECK(out.velocity.head<3>().norm() <= 0.2 * (1 + 1e-12));
    CHECK(out.velocity.tail<3>().norm() <= 0.5 * (1 + 1e-12));
    limited += out.acceleration_limited;
    prev = out.velocity;
  });
  ibvs_test::report(run.frames > 0 && limited > 0, "limited and converged", __FILE__, __LINE__,
                    std::to_string(run.frames) + " frames, " + std::to_string(limited) + " limited");
}

struct SwitchRun {
  int frames = -1, switch_frame = -1;
  double jump_at_switch = 0.0, peak_jump_after_start = 0.0;
};

// Polar far from the goal, Cartesian near it: the switch happens, the twist is continuous across
// it with the continuous law and jumps without it.
SwitchRun switch_run(double mu, const Twist& start, double near = 0.02) {
  ServoOptions o = mu > 0.0 ? smooth_options(mu) : ServoOptions{};
  o.gain = 1.0;
  o.cartesian_near_goal = near;
  Servo servo(Layout::polar(4), o);
  SwitchRun r;
  Twist prev = Twist::Zero();
  int k = 0, last_fallbacks = 0;
  const auto run = ibvs_test::converge(servo, ibvs_test::square(0.25, 3.0), start, [&](const ServoOutput& out) {
    const double jump = (out.velocity - prev).norm();
    if (out.polar_fallbacks != last_fallbacks && r.switch_frame < 0 && k > 0) {
      r.switch_frame = k;
      r.jump_at_switch = jump;
      CHECK(out.polar_fallbacks == 4);
      if (mu > 0.0) CHECK(out.law_switched);
    }
    if (k > 0) r.peak_jump_after_start = std::max(r.peak_jump_after_start, jump);
    last_fallbacks = out.polar_fallbacks;
    prev = out.velocity;
    ++k;
  });
  r.frames = run.frames;
  return r;
}

// Delay of the convergence (error < 1e-9) caused by the continuous law. On the z-rotation the
// polar law is linear in its error (e' = -lambda e; the switch to Cartesian comes near the goal,
// where both laws are), and a start from rest gives
// e(t) = e(0) (mu e^{-lambda t} - lambda e^{-mu t}) / (mu - lambda): a delay of exactly
// ln(mu / (mu - lambda)) / lambda (~1/mu for mu >> lambda). A general 6-DOF start follows another
// path while its twist builds up: measured within 4/mu (0.73 s at mu = 4, 0.13 s at mu = 10).
void automatic_switch() {
  Twist rot, general;
  rot << 0, 0, 0, 0, 0, 1.5;
  general << 0.1, -0.08, -0.3, 0.1, -0.08, 1.2;
  const double lambda = 1.0;
  for (const Twist& start : {rot, general}) {
    const SwitchRun plain = switch_run(0.0, start), plain_polar = switch_run(0.0, start, 0.0);
    for (double mu : {4.0, 10.0}) {
      const SwitchRun smooth = switch_run(mu, start), smooth_polar = switch_run(mu, start, 0.0);
      CHECK(plain.switch_frame > 0 && smooth.switch_frame > 0);
      // Without the continuous law the twist jumps at the switch; with it the jump is a small
      // fraction of that (about one frame of the law's own change).
      ibvs_test::report(smooth.jump_at_switch < 0.1 * plain.jump_at_switch, "continuous across the switch", __FILE__,
                        __LINE__, std::to_string(smooth.jump_at_switch) + " vs " + std::to_string(plain.jump_at_switch));
      const double delay = start == rot ? std::log(mu / (mu - lambda)) / lambda : 4.0 / mu;
      const int allowed = static_cast<int>(std::ceil(delay * fps)) + 1;
      for (const auto& [a, b] : {std::pair{smooth, plain}, std::pair{smooth_polar, plain_polar}})
        ibvs_test::report(a.frames > 0 && b.frames > 0 && a.frames <= b.frames + allowed, "delay bounded", __FILE__,
                          __LINE__, std::to_string(a.frames) + " vs " + std::to_string(b.frames) + " + " +
                                        std::to_string(allowed));
    }
  }
}

void refusals() {
  const auto bad = [](auto set) {
    ServoOptions o = smooth_options(1.0);
    set(o);
    CHECK_THROWS(Servo(Layout::polar(4), o));
  };
  bad([](ServoOptions& o) { o.smoothing.decay_rate = -1.0; });
  bad([](ServoOptions& o) { o.smoothing.decay_rate = std::nan(""); });
  bad([](ServoOptions& o) { o.smoothing.period = 0.0; });
  bad([](ServoOptions& o) { o.smoothing.period = -dt; });
  bad([](ServoOptions& o) { o.smoothing.max_linear_acceleration = 0.0; });
  bad([](ServoOptions& o) { o.smoothing.max_angular_acceleration = -1.0; });
  bad([](ServoOptions& o) { o.cartesian_near_goal = -0.1; });
  bad([](ServoOptions& o) { o.stop_time = std::numeric_limits<double>::infinity(); });
  ServoOptions o;
  o.stop_time = 1.0;  // a stop ramp needs the period
  try {
    Servo s(Layout::polar(4), o);
    CHECK(false);
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("smoothing.period") != std::string::npos);
  }
}

}  // namespace

void run_tests() {
  continuous_law_formula();
  smoother_alone();
  servo_limits();
  automatic_switch();
  refusals();
}
