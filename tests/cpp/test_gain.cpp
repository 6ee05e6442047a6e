// Adaptive gain (ViSP's vpAdaptiveGain formula) and uniform velocity
// saturation: formula values, bounds and direction, option validation, and
// that the defaults leave the control law bit-for-bit unchanged.
#include "check.hpp"
#include "scene.hpp"

using namespace ibvs;

namespace {

void adaptive_gain_values() {
  const AdaptiveGain g{4.0, 0.4, 30.0};
  CHECK(g.enabled() && !AdaptiveGain{}.enabled());
  CHECK(g(0.0) == 4.0);
  CHECK_NEAR(g(1e6), 0.4, 1e-15);
  // The formula, written out: a exp(-(g0'/a) x) + ginf with a = g0 - ginf.
  for (double x : {1e-3, 0.01, 0.1, 0.5}) CHECK_NEAR(g(x), 3.6 * std::exp(-(30.0 / 3.6) * x) + 0.4, 1e-14);
  // Slope at zero is -g0' (central difference on the right-hand side).
  const double h = 1e-7;
  CHECK_NEAR((g(h) - g(0.0)) / h, -30.0, 1e-4);
  // Monotone from g0 down to ginf.
  double last = g(0.0);
  for (int i = 1; i < 100; ++i) {
    const double now = g(0.01 * i);
    CHECK(now < last && now > 0.4);
    last = now;
  }
  // Degenerate cases: constant gain (g0 == ginf) and zero slope, no 0/0.
  CHECK(AdaptiveGain({2.0, 2.0, 5.0})(0.3) == 2.0);
  CHECK(AdaptiveGain({2.0, 1.0, 0.0})(0.3) == 2.0);
}

void saturation_scale_bounds() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> lim(0.01, 2.0);
  for (int i = 0; i < ibvs_test::cases; ++i) {
    Twist v;
    for (int k = 0; k < 6; ++k) v(k) = n(rng);
    const double vmax = lim(rng), wmax = lim(rng);
    const double s = saturation_scale(v, vmax, wmax);
    const Twist w = s * v;
    CHECK(s > 0.0 && s <= 1.0);
    CHECK(w.head<3>().norm() <= vmax * (1 + 1e-12) && w.tail<3>().norm() <= wmax * (1 + 1e-12));
    // Tight: one of the two limits is met with equality unless nothing binds.
    const bool binds = v.head<3>().norm() > vmax || v.tail<3>().norm() > wmax;
    CHECK(binds ? (std::abs(w.head<3>().norm() - vmax) < 1e-12 || std::abs(w.tail<3>().norm() - wmax) < 1e-12)
                : s == 1.0);
  }
  CHECK(saturation_scale(Twist::Zero(), 0.1, 0.1) == 1.0);
  CHECK(saturation_scale(Twist::Ones(), no_limit, no_limit) == 1.0);
}

struct Step {
  Layout L;
  ServoInput in;
  explicit Step(const Layout& layout) : L(layout), in(layout) {
    in.uv << 0.1, -0.12, -0.1, 0.11, 0.09, 0.1, -0.1, -0.13;
    in.uv_desired << 0.2, -0.2, -0.2, 0.2, 0.2, 0.2, -0.2, -0.2;
    in.depth << 1.0, 1.1, 1.2, 0.9;
  }
  ServoOutput run(const ServoOptions& o) {
    Servo s(L, o);
    ServoOutput out(L);
    s.update(in, out);
    return out;
  }
};

// Defaults: the same twist, bit for bit, as the law -gain J+ e.
void defaults_unchanged() {
  for (double lambda : {0.0, 0.01}) {
    Step st(Layout::stacked(4));
    ServoOptions o;
    o.gain = 0.7;
    o.damping = lambda;
    const ServoOutput out = st.run(o);
    CHECK(!out.saturated && out.saturation_scale == 1.0 && out.gain == 0.7);
    const MatrixX6 J = jacobian(st.L, st.in.uv, st.in.depth);
    const Eigen::VectorXd e = feature_error(st.L, features(st.L, st.in.uv), features(st.L, st.in.uv_desired));
    CHECK((out.velocity + 0.7 * damped_pinv(J, lambda) * e).norm() < 1e-9);
    // Explicitly "off" options give exactly the same numbers as the defaults.
    ServoOptions off = o;
    off.max_linear_speed = off.max_angular_speed = no_limit;
    off.adaptive_gain = AdaptiveGain{};
    CHECK(st.run(off).velocity == out.velocity);
  }
}

void adaptive_in_servo() {
  Step st(Layout::cartesian(4));
  ServoOptions constant;
  constant.gain = 1.0;
  const ServoOutput ref = st.run(constant);
  ServoOptions o;
  o.adaptive_gain = {4.0, 0.4, 30.0};
  const ServoOutput out = st.run(o);
  CHECK_NEAR(out.gain, o.adaptive_gain(ref.error_norm), 1e-15);
  CHECK(out.gain < 4.0 && out.gain > 0.4);
  CHECK((out.velocity - out.gain * ref.velocity).norm() < 1e-12 * ref.velocity.norm());
}

void saturation_in_servo() {
  Step st(Layout::polar(4));
  ServoOptions o;
  o.gain = 2.0;
  const ServoOutput free = st.run(o);
  for (auto [vmax, wmax] : {std::pair{0.05, no_limit}, std::pair{no_limit, 0.01}, std::pair{0.05, 0.01}}) {
    o.max_linear_speed = vmax;
    o.max_angular_speed = wmax;
    const ServoOutput out = st.run(o);
    CHECK(out.saturated && out.saturation_scale < 1.0);
    CHECK(out.velocity.head<3>().norm() <= vmax * (1 + 1e-12) && out.velocity.tail<3>().norm() <= wmax * (1 + 1e-12));
    // Same direction: parallel to and a positive multiple of the free twist.
    CHECK_NEAR(out.velocity.dot(free.velocity) / (out.velocity.norm() * free.velocity.norm()), 1.0, 1e-14);
    CHECK((out.velocity - out.saturation_scale * free.velocity).norm() < 1e-14);
  }
  o.max_linear_speed = o.max_angular_speed = 1e3;  // loose limits: untouched
  const ServoOutput loose = st.run(o);
  CHECK(!loose.saturated && loose.velocity == free.velocity);
}

void bad_options() {
  auto throws_naming = [](const ServoOptions& o, const char* what) {
    bool ok = false;
    try {
      Servo::validate(o);
    } catch (const std::invalid_argument& e) {
      ok = std::string(e.what()).find(what) != std::string::npos;
    }
    ibvs_test::report(ok, "validate names the option", __FILE__, __LINE__, what);
  };
  ServoOptions o;
  o.adaptive_gain = {-1.0, 0.5, 1.0};
  throws_naming(o, "adaptive_gain.at_zero");
  o.adaptive_gain = {1.0, 2.0, 1.0};  // ginf > g0: the gain would blow up
  throws_naming(o, "adaptive_gain.at_infinity");
  o.adaptive_gain = {1.0, 0.0, 1.0};
  throws_naming(o, "adaptive_gain.at_infinity");
  o.adaptive_gain = {1.0, 0.5, -1.0};
  throws_naming(o, "adaptive_gain.slope_at_zero");
  o.adaptive_gain = {1.0, 0.5, std::nan("")};
  throws_naming(o, "adaptive_gain.slope_at_zero");
  o.adaptive_gain = {0.0, 0.5, 1.0};  // half set: not silently "off"
  throws_naming(o, "adaptive_gain.at_zero");
  o.adaptive_gain = {};
  o.max_linear_speed = 0.0;
  throws_naming(o, "max_linear_speed");
  o.max_linear_speed = std::nan("");
  throws_naming(o, "max_linear_speed");
  o.max_linear_speed = no_limit;
  o.max_angular_speed = -1.0;
  throws_naming(o, "max_angular_speed");
}

// Closed loop with saturation and adaptive gain: converges, limits held every step.
void closed_loop_limited() {
  const auto Pw = ibvs_test::square(0.25, 3.0);
  const Layout L = Layout::polar(4);
  ServoOptions o;
  o.adaptive_gain = {4.0, 0.5, 20.0};
  o.max_linear_speed = 0.05;
  o.max_angular_speed = 0.2;
  Servo servo(L, o);
  ServoInput in(L);
  ServoOutput out(L);
  ibvs_test::look(Pose::Identity(), Pw, in.uv_desired, in.depth_desired);
  Twist start;
  start << 0.1, -0.05, -0.3, 0.05, -0.05, 2.5;
  Pose T = ibvs_test::pose(start);
  bool held = true, saturated_once = false;
  int k = 0;
  for (; k < 6000; ++k) {
    ibvs_test::look(T, Pw, in.uv, in.depth);
    servo.update(in, out);
    held = held && out.velocity.head<3>().norm() <= 0.05 + 1e-12 && out.velocity.tail<3>().norm() <= 0.2 + 1e-12;
    saturated_once = saturated_once || out.saturated;
    if (out.error_norm < 1e-9) break;
    T = T * se3_exp(out.velocity / 60.0);
  }
  ibvs_test::report(k < 6000, "limited closed loop converges", __FILE__, __LINE__, std::to_string(k));
  CHECK(held && saturated_once);
  CHECK((T.topRightCorner<3, 1>().norm() < 1e-6));
}

}  // namespace

void run_tests() {
  adaptive_gain_values();
  saturation_scale_bounds();
  defaults_unchanged();
  adaptive_in_servo();
  saturation_in_servo();
  bad_options();
  closed_loop_limited();
}
