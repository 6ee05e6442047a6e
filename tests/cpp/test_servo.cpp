// Servo: the wrapped error, the control law against the pseudoinverse, the
// r -> 0 policy, both error channels, and closed-loop convergence with exact
// SE(3) integration for every kind of layout and interaction matrix.
#include "check.hpp"
#include "scene.hpp"

using namespace ibvs;

namespace {

const Layout per_point_hybrid({{0, Representation::cartesian}, {1, Representation::cartesian},
                               {2, Representation::polar}, {3, Representation::polar}});

void wrap() {
  CHECK(wrap_angle(pi) == pi);
  CHECK(wrap_angle(-pi) == pi);
  CHECK(wrap_angle(3 * pi) == pi);
  CHECK(wrap_angle(-3 * pi) == pi);
  CHECK(wrap_angle(2 * pi) == 0.0);
  CHECK(wrap_angle(0.0) == 0.0);
  CHECK_NEAR(wrap_angle(pi + 1e-9), -pi + 1e-9, 1e-15);
  CHECK_NEAR(wrap_angle(-pi + 1e-9), -pi + 1e-9, 1e-15);
  CHECK_NEAR(wrap_angle(7.0), 7.0 - 2 * pi, 1e-15);
  // theta across the cut: 179 deg - (-179 deg) is -2 deg, not 358 deg.
  const Layout L = Layout::polar(1);
  const Eigen::Vector2d f(0.2, pi - 0.01), fd(0.25, -pi + 0.01);
  const Eigen::VectorXd e = feature_error(L, f, fd);
  CHECK_NEAR(e(0), -0.05, 1e-15);
  CHECK_NEAR(e(1), -0.02, 1e-12);
  // Cartesian rows are never wrapped.
  CHECK_NEAR(feature_error(Layout::cartesian(1), Eigen::Vector2d(0, 4.0), Eigen::Vector2d(0, -4.0))(1), 8.0, 0);
}

// velocity == -gain * pinv(J) * e, for every kernel size and both routes.
void law_matches_pinv() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> c(-0.3, 0.3), d(0.5, 3.0);
  for (int n : {1, 2, 3, 4, 5, 8}) {
    for (const Layout& L : {Layout::cartesian(n), Layout::polar(n), Layout::stacked(n)}) {
      for (double lambda : {0.0, 0.05}) {
        for (auto mode : {InteractionMatrix::current, InteractionMatrix::desired, InteractionMatrix::mean}) {
          ServoOptions o;
          o.gain = 0.7;
          o.damping = lambda;
          o.jacobian = mode;
          Servo servo(L, o);
          ServoOutput out(L);
          ServoInput in(L);
          for (int i = 0; i < n; ++i) {
            in.uv.col(i) << c(rng), c(rng);
            in.uv_desired.col(i) << c(rng), c(rng);
            in.depth(i) = d(rng);
            in.depth_desired(i) = d(rng);
          }
          const Status st = servo.update(in, out);
          ibvs_test::report(st == Status::ok || (st == Status::singular && n < 3), "status", __FILE__,
                            __LINE__, L.describe() + " " + std::to_string(out.sigma_min()) + " " + std::to_string(out.sigma_max()));
          MatrixX6 J = jacobian(L, in.uv, in.depth);
          if (mode == InteractionMatrix::desired) J = jacobian(L, in.uv_desired, in.depth_desired);
          if (mode == InteractionMatrix::mean) J = 0.5 * (J + jacobian(L, in.uv_desired, in.depth_desired));
          const Eigen::VectorXd e = feature_error(L, features(L, in.uv), features(L, in.uv_desired));
          const Twist v = -0.7 * damped_pinv(J, lambda) * e;
          CHECK((out.jacobian - J).norm() < 1e-12);
          CHECK((out.error - e).norm() < 1e-12);
          CHECK_NEAR(out.error_norm, e.norm(), 1e-12);
          ibvs_test::report((out.velocity - v).norm() < 1e-8 * std::max(1.0, v.norm()), "velocity = -gain J+ e",
                            __FILE__, __LINE__, L.describe() + " lambda=" + std::to_string(lambda));
          const Eigen::VectorXd s = singular_values(J);
          if (L.rows() >= 6) CHECK_NEAR(out.sigma_min(), s(5), 1e-7 * s(0));
          CHECK_NEAR(out.sigma_max(), s(0), 1e-7 * s(0));
        }
      }
    }
  }
}

// The Cartesian pi-rotation: the mean interaction matrix loses wz (rank 5):
// flagged singular, the twist stays finite and equals the min-norm solution.
void singular_mean() {
  ServoOptions o;
  o.jacobian = InteractionMatrix::mean;
  const Layout L = Layout::cartesian(4);
  Servo servo(L, o);
  ServoOutput out(L);
  ServoInput in(L);
  in.uv_desired << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  in.uv = -in.uv_desired;
  in.depth.setConstant(2.0);
  in.depth_desired.setConstant(2.0);
  CHECK(servo.update(in, out) == Status::singular);
  CHECK(out.velocity.allFinite());
  CHECK(out.sigma_min() < 1e-12);
  const Twist v = -o.gain * damped_pinv(out.jacobian, 0.0) * out.error;
  CHECK((out.velocity - v).norm() < 1e-9);
  // Fewer than 3 points is rank-deficient too: still finite.
  const Layout L2 = Layout::cartesian(2);
  Servo s2(L2, {});
  ServoOutput o2(L2);
  CHECK(s2.update(in.uv.leftCols(2), in.depth.head(2), in.uv_desired.leftCols(2), in.depth_desired.head(2), o2) ==
        Status::singular);
  CHECK(o2.velocity.allFinite() && o2.velocity.norm() > 0);
}

// Diagnostics off: the same twist as with them on, but sigma_min / sigma_max are
// NaN (not computed) and the singular case is not flagged, on every route.
void diagnostics_off() {
  const Layout L = Layout::cartesian(4);
  ServoInput in(L);
  in.uv_desired << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  in.uv = -in.uv_desired;  // the Cartesian pi-rotation: J at the mean is rank 5
  in.depth.setConstant(2.0);
  in.depth_desired.setConstant(2.0);
  ServoOptions on;
  on.damping = 0.01;
  on.jacobian = InteractionMatrix::mean;
  ServoOptions off = on;
  off.diagnostics = false;
  Servo s_on(L, on), s_off(L, off);
  ServoOutput o_on(L), o_off(L);
  CHECK(s_on.update(in, o_on) == Status::singular);
  CHECK(s_off.update(in, o_off) == Status::ok);
  CHECK(std::isnan(o_off.sigma_min()) && std::isnan(o_off.sigma_max()));
  CHECK(std::isfinite(o_on.sigma_min()) && o_on.sigma_max() > 0);
  CHECK((o_on.velocity - o_off.velocity).norm() <= 1e-15 * (1 + o_on.velocity.norm()));
  // Undamped (the robust route here: J is rank-deficient): the same.
  off.damping = on.damping = 0.0;
  Servo s_svd_off(L, off), s_svd_on(L, on);
  CHECK(s_svd_off.update(in, o_off) == Status::ok);
  CHECK(std::isnan(o_off.sigma_min()) && std::isnan(o_off.sigma_max()));
  CHECK(s_svd_on.update(in, o_on) == Status::singular);
  CHECK(std::isfinite(o_on.sigma_min()) && o_on.sigma_min() < 1e-12);
  CHECK(o_on.velocity == o_off.velocity);
}

// A point on the optical axis (r = 0) in a polar layout: finite, counted,
// and the block uses its Cartesian rows and Cartesian error.
void principal_point() {
  const Layout L = Layout::polar(4);
  for (double lambda : {0.0, 0.01}) {
    ServoOptions o;
    o.damping = lambda;
    Servo servo(L, o);
    ServoOutput out(L);
    ServoInput in(L);
    in.uv << 0.0, 0.1, -0.1, 0.1, 0.0, 0.1, -0.1, -0.1;
    in.uv_desired << 0.01, 0.12, -0.12, 0.12, 0.0, 0.12, -0.12, -0.12;
    in.depth.setConstant(1.0);
    CHECK(servo.update(in, out) == Status::ok);
    CHECK(out.velocity.allFinite() && out.error.allFinite() && out.jacobian.allFinite());
    CHECK(out.polar_fallbacks == 1);
    CHECK(out.jacobian.topRows<2>() == MatrixX6(cartesian_jacobian(0.0, 0.0, 1.0)));
    CHECK_NEAR(out.error(0), -0.01, 1e-15);
    CHECK_NEAR(out.error(1), 0.0, 1e-15);
  }
}

// polar_min_radius = 0 still never divides by r = 0: the principal point itself falls back.
void zero_policy_radius() {
  const Layout L = Layout::polar(4);
  ServoOptions o;
  o.polar_min_radius = 0.0;
  Servo servo(L, o);
  ServoOutput out(L);
  ServoInput in(L);
  in.uv << 0.0, 0.1, -0.1, 0.1, 0.0, 0.1, -0.1, -0.1;
  in.uv_desired << 1e-9, 0.12, -0.12, 0.12, 0.0, 0.12, -0.12, -0.12;
  CHECK(servo.update(in, out) == Status::ok);
  CHECK(out.velocity.allFinite() && out.jacobian.allFinite() && out.polar_fallbacks == 1);
  Points uv = in.uv;
  CHECK(jacobian(L, uv, Eigen::Vector4d::Ones(), 0.0).allFinite());
}

void bad_input() {
  CHECK_THROWS(Servo(Layout::cartesian(4), ServoOptions{-1.0}));
  CHECK_THROWS(Servo(Layout::cartesian(4), ServoOptions{0.0}));
  CHECK_THROWS(Servo(Layout::cartesian(4), ServoOptions{std::nan("")}));
  CHECK_THROWS(Servo(Layout::cartesian(4), ServoOptions{1.0, -0.1}));
  const Layout L = Layout::stacked(4);
  Servo servo(L, {});
  ServoInput in(L);
  in.uv.setConstant(0.1);
  in.uv_desired.setConstant(0.2);
  ServoOutput out(L);
  CHECK(servo.update(in, out) != Status::invalid_input);
  servo.validate(in.uv, in.depth, in.uv_desired, in.depth_desired);  // must not throw

  auto expect_invalid = [&](ServoInput bad, const char* what) {
    out.velocity.setOnes();
    const Status st = servo.update(bad, out);
    ibvs_test::report(st == Status::invalid_input && out.velocity.isZero(0.0), "update flags", __FILE__, __LINE__, what);
    bool thrown = false;
    try {
      servo.validate(bad.uv, bad.depth, bad.uv_desired, bad.depth_desired);
    } catch (const std::invalid_argument& e) {
      thrown = std::string(e.what()).find(what) != std::string::npos;
    }
    ibvs_test::report(thrown, "validate names the argument", __FILE__, __LINE__, what);
  };
  ServoInput b = in;
  b.uv(0, 2) = std::nan("");
  expect_invalid(b, "uv[2]");
  b = in;
  b.uv_desired(1, 3) = std::numeric_limits<double>::infinity();
  expect_invalid(b, "uv_desired[3]");
  b = in;
  b.depth(1) = 0.0;
  expect_invalid(b, "depth[1]");
  b = in;
  b.depth(0) = -2.0;  // behind the camera
  expect_invalid(b, "depth[0]");
  b = in;
  b.uv.conservativeResize(2, 3);
  expect_invalid(b, "uv must hold 4 points");
  b = in;
  b.depth.conservativeResize(5);
  b.depth(4) = 1.0;
  expect_invalid(b, "depth must hold 4");
  // An output sized for another layout is refused without touching memory.
  ServoOutput wrong(Layout::cartesian(4));
  CHECK(servo.update(in, wrong) == Status::invalid_input);
}

void closed_loop() {
  Twist easy;
  easy << 0.03, -0.02, -0.2, 0.02, -0.02, 0.3;  // every scheme and mode converges from here
  for (const Layout& L : {Layout::cartesian(4), Layout::polar(4), per_point_hybrid, Layout::stacked(4)})
    for (auto mode : {InteractionMatrix::current, InteractionMatrix::desired, InteractionMatrix::mean})
      for (double lambda : {0.0, 0.001}) {
        const int k = ibvs_test::converge(L, mode, lambda, easy).frames;
        ibvs_test::report(k > 0, "closed loop converges", __FILE__, __LINE__,
                          L.describe() + " mode=" + std::to_string(int(mode)) + " lambda=" + std::to_string(lambda) +
                              " -> " + std::to_string(k));
      }
}

}  // namespace

void run_tests() {
  wrap();
  law_matches_pinv();
  singular_mean();
  diagnostics_off();
  principal_point();
  zero_policy_radius();
  bad_input();
  closed_loop();
}
