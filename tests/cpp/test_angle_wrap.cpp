// The consistent angle wrap (angle_wrap.hpp): its exact rules, a split-sign
// error made consistent, the floating-point half-turn that moves only about z,
// frame-to-frame continuity with reset(), and noisy half-turn episodes without
// a translation spike.
#include "check.hpp"
#include "scene.hpp"
#include "sim_cases.hpp"

#include <algorithm>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

using namespace ibvs;

namespace {

// Rotation about z by a, built from cos/sin as a user would (rotz(pi) is not diag(-1, -1, 1)).
Pose rotz(double a) {
  Pose T = Pose::Identity();
  T(0, 0) = std::cos(a);
  T(0, 1) = -std::sin(a);
  T(1, 0) = std::sin(a);
  T(1, 1) = std::cos(a);
  return T;
}

// Desired and current points of the paper's target seen from the goal (identity) and from T.
void paper_points(const Pose& T, Points& uv, Points& uvd, Eigen::VectorXd& z) {
  const auto P = ibvs_test::square(0.25, 3.0);
  Eigen::VectorXd zd(4);
  uv.resize(2, 4);
  uvd.resize(2, 4);
  z.resize(4);
  ibvs_test::look(Pose::Identity(), P, uvd, zd);
  ibvs_test::look(T, P, uv, z);
}

void rules() {
  // wrap_about: d itself inside (c - pi, c + pi], else d -/+ 2 pi; the lower end maps to the upper.
  CHECK(wrap_about(0.3, 0.0) == 0.3);
  CHECK(wrap_about(-3.0, 3.0) == -3.0 + 2 * pi);
  CHECK(wrap_about(3.0, -3.0) == 3.0 - 2 * pi);
  CHECK(wrap_about(pi, 0.0) == pi);                // exactly c + pi: kept
  CHECK(wrap_about(-pi / 2, pi / 2) == 3 * pi / 2);  // exactly c - pi: taken as c + pi
  CHECK(wrap_about(pi / 2, -pi / 2) == pi / 2);      // exactly c + pi: kept
  // The mean is in (-pi, pi]: a sum along -x with a -0 sine is +pi.
  AngleResultant s;
  s.add(-1.0, -0.0);
  CHECK(s.defined() && s.mean() == pi);
  // Undefined below wrap_min_resultant (and without any angle).
  AngleResultant none;
  CHECK(!none.defined());
  AngleResultant opposite;
  opposite.add(0.0, 1.0);
  opposite.add(0.0, -1.0);
  CHECK(!opposite.defined());
  // Continuity: the mean unwrapped against the previous centre within pi + wrap_hysteresis of 0.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK(continued_centre(-3.1, nan) == -3.1);
  CHECK_NEAR(continued_centre(-3.1, 3.1), -3.1 + 2 * pi, 1e-15);
  CHECK(continued_centre(0.2, 3.1) == 0.2);
  CHECK(continued_centre(-pi / 2, pi) == -pi / 2);  // 3 pi / 2 is past pi + pi / 4: principal value
}

// A deliberately split-sign error: per point (+pi - e, -pi + e, +pi - e, +pi - e); consistent: all near +pi.
void split_sign_error() {
  const double eps = 1e-9;
  for (const Layout& L : {Layout::polar(4), Layout::cylindrical(4), Layout::stacked(4)}) {
    Eigen::VectorXd f(L.rows()), fd(L.rows());
    const double th[4] = {0.3, 1.4, -2.0, 2.9};
    const double d[4] = {pi - eps, -pi + eps, pi - eps, pi - eps};
    int row = 0;
    for (const Block& b : L.blocks()) {
      const int i = b.point;
      const double rd = 0.1 + 0.01 * i, r = 0.12 + 0.01 * i;
      const double a = wrap_angle(th[i] + d[i]);
      if (b.representation == Representation::cartesian) {
        f.segment<2>(row) << r * std::cos(a), r * std::sin(a);
        fd.segment<2>(row) << rd * std::cos(th[i]), rd * std::sin(th[i]);
      } else if (b.representation == Representation::polar) {
        f.segment<2>(row) << r, a;
        fd.segment<2>(row) << rd, th[i];
      } else {
        f.segment<2>(row) << r, r * a;
        fd.segment<2>(row) << rd, rd * th[i];
      }
      row += 2;
    }
    const Eigen::VectorXd pp = feature_error(L, f, fd, AngleWrap::per_point);
    const Eigen::VectorXd cs = feature_error(L, f, fd);  // consistent by default
    CHECK((feature_error(L, f, fd, AngleWrap::consistent) - cs).norm() == 0.0);
    int neg_pp = 0, neg_cs = 0;
    row = 0;
    for (const Block& b : L.blocks()) {
      if (b.representation != Representation::cartesian) {
        const double scale = b.representation == Representation::cylindrical ? f(row) : 1.0;
        neg_pp += pp(row + 1) < 0;
        neg_cs += cs(row + 1) < 0;
        // consistent: pi - eps or pi + eps (the second point taken the same way round)
        CHECK_NEAR(cs(row + 1) / scale, b.point == 1 ? pi + eps : pi - eps, 1e-12);
        CHECK(cs(row) == pp(row));
      } else {
        CHECK(cs.segment<2>(row) == pp.segment<2>(row));  // Cartesian rows untouched
      }
      row += 2;
    }
    CHECK(neg_pp == 1 && neg_cs == 0);
  }
  // Resultant 0 (differences +pi/2 and -pi/2): the per-point wrap is kept.
  const Layout L2 = Layout::polar(2);
  const Eigen::Vector4d f(0.1, pi / 2, 0.1, -pi / 2), fd(0.1, 0.0, 0.1, 0.0);
  CHECK((feature_error(L2, f, fd) - feature_error(L2, f, fd, AngleWrap::per_point)).norm() == 0.0);
  // Bad enum value: refused.
  CHECK_THROWS(feature_error(L2, f, fd, static_cast<AngleWrap>(7)));
  ServoOptions o;
  o.angle_wrap = static_cast<AngleWrap>(7);
  CHECK_THROWS(Servo(L2, o));
}

// Servo and feature_error agree (random inputs, every layout with angles); the
// cylindrical rows use the consistent angle as alpha.
void servo_matches_feature_error() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> c(-0.3, 0.3), a(-pi, pi);
  const Layout mixed({{0, Representation::cylindrical}, {0, Representation::polar}, {1, Representation::cartesian},
                      {2, Representation::polar}, {3, Representation::cylindrical}});
  for (int k = 0; k < ibvs_test::cases; ++k) {
    for (const Layout& L : {Layout::polar(4), Layout::stacked(4), Layout::cylindrical(4), mixed}) {
      Points uv(2, 4), uvd(2, 4);
      const double turn = a(rng);  // a rotation plus per-point scatter
      for (int i = 0; i < 4; ++i) {
        uvd.col(i) << c(rng), c(rng);
        const double s = 0.3 * c(rng);
        uv.col(i) = Eigen::Rotation2Dd(turn + s) * uvd.col(i) + Eigen::Vector2d(0.1 * c(rng), 0.1 * c(rng));
      }
      const Eigen::VectorXd z = Eigen::VectorXd::Constant(4, 1.5);
      ServoOptions o;
      o.polar_min_radius = 0.0;  // no Cartesian fallback: feature_error has none
      Servo servo(L, o);
      ServoOutput out(L);
      servo.update(uv, z, uvd, z, out);
      const Eigen::VectorXd e = feature_error(L, features(L, uv), features(L, uvd));
      ibvs_test::report((out.error - e).norm() < 1e-12, "Servo error == feature_error (consistent)", __FILE__,
                        __LINE__, L.describe());
      int row = 0;
      for (const Block& b : L.blocks()) {
        if (b.representation == Representation::cylindrical) {
          const double u = uv(0, b.point), v = uv(1, b.point), r = std::hypot(u, v);
          const Matrix26 J = cylindrical_jacobian(r, u / r, v / r, out.error(row + 1) / r, 1.5);
          CHECK((out.jacobian.middleRows<2>(row) - J).norm() < 1e-12);
        }
        row += 2;
      }
    }
  }
}

// The half-turn built with cos/sin (a rotation of pi up to rounding): under the
// consistent wrap IBVS-P commands a pure rotation about z and every law the same
// twist as for the exact diag(-1, -1, 1); the per-point wrap splits the signs.
void floating_point_half_turn() {
  Points uv, uvd, uv_exact;
  Eigen::VectorXd z;
  paper_points(rotz(pi), uv, uvd, z);
  paper_points(sim_cases::half_turn_z(), uv_exact, uvd, z);
  CHECK(uv != uv_exact);  // not the exact mirror image
  for (const Layout& L : {Layout::polar(4), Layout::stacked(4), Layout::cylindrical(4)}) {
    ServoOptions o;
    o.gain = 1.0;
    Servo exact(L, o);
    ServoOutput ref(L);
    exact.update(uv_exact, z, uvd, z, ref);
    for (AngleWrap w : {AngleWrap::consistent, AngleWrap::per_point}) {
      o.angle_wrap = w;
      Servo servo(L, o);
      ServoOutput out(L);
      servo.update(uv, z, uvd, z, out);
      const double T = out.velocity.head<3>().norm(), wxy = out.velocity.segment<2>(3).norm();
      const double diff = (out.velocity - ref.velocity).norm();
      if (w == AngleWrap::consistent) {
        ibvs_test::report(diff < 1e-9, "rotz(pi) twist == exact half-turn twist", __FILE__, __LINE__,
                          L.describe() + " " + std::to_string(diff));
        if (L == Layout::polar(4))
          ibvs_test::report(T < 1e-9 && wxy < 1e-9 && std::abs(out.velocity(5)) > 0.5, "pure wz", __FILE__,
                            __LINE__, "|T| " + std::to_string(T));
      } else {
        CHECK(diff > 0.1);  // the split signs of eq. (13) read point by point
        if (L == Layout::polar(4)) CHECK(T > 1.0);  // the 28.7 m/s
      }
    }
  }
  // Closed loop: IBVS-P from rotz(pi) converges with the camera centre still (no
  // path) under the consistent wrap; the per-point wrap travels metres.
  using namespace sim_cases;
  for (const Layout& L : {Layout::polar(4)}) {
    for (AngleWrap w : {AngleWrap::consistent, AngleWrap::per_point}) {
      ServoOptions so;
      so.gain = 1.0;
      so.angle_wrap = w;
      EpisodeOptions eo;
      eo.duration = 30.0;
      eo.tolerance = 1e-5;
      const EpisodeResult r = run_episode(Servo(L, so), Camera::normalized(0.3), Target::paper(), rotz(pi),
                                          Pose::Identity(), eo);
      if (w == AngleWrap::consistent) {
        CHECK(r.status.outcome == Outcome::converged);
        ibvs_test::report(r.metrics.path_length < 1e-9, "rotz(pi) moves only about z", __FILE__, __LINE__,
                          L.describe() + " path " + std::to_string(r.metrics.path_length));
      } else {
        CHECK(r.metrics.path_length > 1.0);
      }
    }
  }
}

// Continuity: inputs alternating either side of the half-turn keep the first frame's
// branch; reset() forgets it; the per-point wrap follows each frame's principal value.
void continuity() {
  Points a, b, uvd;
  Eigen::VectorXd z;
  paper_points(rotz(pi - 0.01), a, uvd, z);
  paper_points(rotz(pi + 0.01), b, uvd, z);
  const Layout L = Layout::polar(4);
  ServoOptions o;
  Servo servo(L, o);
  ServoOutput out(L);
  // The camera turned by pi -/+ 0.01 sees the points turned by -(pi -/+ 0.01).
  for (int k = 0; k < 6; ++k) {
    servo.update(k % 2 ? b : a, z, uvd, z, out);
    for (int i = 0; i < 4; ++i) CHECK_NEAR(out.error(2 * i + 1), k % 2 ? -pi - 0.01 : -pi + 0.01, 1e-9);
  }
  servo.reset();
  servo.update(b, z, uvd, z, out);
  CHECK_NEAR(out.error(1), pi - 0.01, 1e-9);
  o.angle_wrap = AngleWrap::per_point;
  servo.set_options(o);
  for (int k = 0; k < 4; ++k) {
    servo.update(k % 2 ? b : a, z, uvd, z, out);
    CHECK_NEAR(out.error(1), k % 2 ? pi - 0.01 : -pi + 0.01, 1e-9);
  }
  // Far from the half-turn the branch is the principal one again (no memory of it).
  o.angle_wrap = AngleWrap::consistent;
  servo.set_options(o);
  Points c;
  servo.update(a, z, uvd, z, out);  // -pi + 0.01
  paper_points(rotz(-pi / 2 - 0.2), c, uvd, z);
  servo.update(c, z, uvd, z, out);  // pi / 2 + 0.2, not -3 pi / 2 + 0.2
  CHECK_NEAR(out.error(1), pi / 2 + 0.2, 1e-9);
  // A frame whose angles are all small leaves its centre's atan2 for later (Servo's WrapCentre):
  // the next frame still continues from it. Points turned by +1.45 (centre 1.45), then by
  // -(pi - 0.01): continued, pi + 0.01 (1.7 rad from 1.45), not the principal -pi + 0.01.
  servo.reset();
  paper_points(rotz(-1.45), c, uvd, z);
  servo.update(c, z, uvd, z, out);
  for (int i = 0; i < 4; ++i) CHECK_NEAR(out.error(2 * i + 1), 1.45, 1e-9);
  servo.update(a, z, uvd, z, out);
  for (int i = 0; i < 4; ++i) CHECK_NEAR(out.error(2 * i + 1), pi + 0.01, 1e-9);
}

// continue_turn: an exact half-turn whose direction the image noise decides (the points nudged
// one way or the other) goes the way continue_turn(+pi / -pi) chooses, whatever the noise; NaN and
// reset() leave it to the noise again; values beyond pi + wrap_hysteresis are refused.
void chosen_turn() {
  Points uv, uvd;
  Eigen::VectorXd z;
  paper_points(rotz(pi), uv, uvd, z);
  const Layout L = Layout::polar(4);
  Servo servo(L, ServoOptions{});
  ServoOutput out(L);
  for (double nudge : {1e-4, -1e-4}) {  // every point turned a little more, or less, than pi
    Points seen = uv;
    for (int i = 0; i < 4; ++i) {
      const double c = std::cos(nudge), s = std::sin(nudge);
      seen.col(i) = Eigen::Vector2d(c * uv(0, i) - s * uv(1, i), s * uv(0, i) + c * uv(1, i));
    }
    servo.reset();
    servo.update(seen, z, uvd, z, out);
    const double by_noise = out.error(1);
    for (int i = 0; i < 4; ++i) CHECK_NEAR(out.error(2 * i + 1), by_noise, 1e-6);
    CHECK(std::abs(std::abs(by_noise) - pi) < 1e-3);
    for (double centre : {pi, -pi}) {
      servo.continue_turn(centre);
      servo.update(seen, z, uvd, z, out);
      for (int i = 0; i < 4; ++i) CHECK_NEAR(out.error(2 * i + 1), centre + nudge, 1e-6);
      servo.update(seen, z, uvd, z, out);  // the next frame continues on the chosen branch
      CHECK_NEAR(out.error(1), centre + nudge, 1e-6);
    }
    servo.continue_turn(std::numeric_limits<double>::quiet_NaN());
    servo.update(seen, z, uvd, z, out);
    CHECK_NEAR(out.error(1), by_noise, 1e-12);
    servo.continue_turn(-by_noise);
    servo.reset();
    servo.update(seen, z, uvd, z, out);
    CHECK_NEAR(out.error(1), by_noise, 1e-12);
  }
  for (double bad : {pi + wrap_hysteresis + 1e-9, -4.0, std::numeric_limits<double>::infinity(), 1e300}) {
    bool threw = false;
    try {
      servo.continue_turn(bad);
    } catch (const std::invalid_argument&) {
      threw = true;
    }
    CHECK(threw);
  }
}

// Noisy starts within 0.5 deg of the half-turn, both signs, latency 0-2: no translation
// spike under the consistent wrap (peak |T| within 3x what the law does 10 deg away);
// the per-point wrap, on the same runs, has one.
void noisy_half_turn_has_no_spike() {
  using namespace sim_cases;
  for (const Layout& L : {Layout::polar(4), Layout::stacked(4)}) {
    double worst[2] = {0.0, 0.0}, reference = 0.0;
    for (int k = 0; k < 12; ++k) {
      const double sign = k % 2 ? 1.0 : -1.0, near = 0.001 + 0.0075 * (k / 2) / 5.0;  // 0.06 to 0.49 deg
      for (double off : {0.0, 10.0 * pi / 180.0}) {
        for (AngleWrap w : {AngleWrap::consistent, AngleWrap::per_point}) {
          if (off > 0.0 && w == AngleWrap::per_point) continue;
          ServoOptions so;
          so.gain = 1.0;
          so.angle_wrap = w;
          EpisodeOptions eo;
          eo.duration = 1.0;  // the spike, when there is one, comes in the first frames
          eo.noise = 1e-3;
          eo.latency = k % 3;
          eo.seed = 100 + k;
          eo.stop_on_singular = false;
          const EpisodeResult r = run_episode(Servo(L, so), Camera::normalized(0.3), Target::paper(),
                                              rotz(pi + sign * (near + off)), Pose::Identity(), eo);
          double peak = 0.0;
          for (int f = 0; f < r.history.frames; ++f)
            if (r.history.twist.row(f).allFinite()) peak = std::max(peak, r.history.twist.row(f).head<3>().norm());
          if (off > 0.0)
            reference = std::max(reference, peak);
          else
            worst[static_cast<int>(w)] = std::max(worst[static_cast<int>(w)], peak);
        }
      }
    }
    const std::string detail = L.describe() + " peak |T| " + std::to_string(worst[0]) + " m/s consistent, " +
                               std::to_string(worst[1]) + " per point, " + std::to_string(reference) + " 10 deg away";
    ibvs_test::report(worst[0] < 3.0 * reference, "noisy half-turn: no translation spike", __FILE__, __LINE__, detail);
    ibvs_test::report(worst[1] > 3.0 * reference, "noisy half-turn: per-point spike", __FILE__, __LINE__, detail);
    if (std::getenv("IBVS_VERBOSE")) std::printf("%s\n", detail.c_str());
  }
}

}  // namespace

void run_tests() {
  rules();
  split_sign_error();
  servo_matches_feature_error();
  floating_point_half_turn();
  continuity();
  chosen_turn();
  noisy_half_turn_has_no_spike();
}
