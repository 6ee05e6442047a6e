// The image segment (features/segment.hpp), both feature sets: its interaction
// matrix against central differences of its own projection (the camera moved
// by small twists, the two 3-D end points re-projected) and against ViSP's
// closed form (vpFeatureSegment::interaction, transcribed below); measure(),
// project() and the unoriented align(); four segments close the loop from a
// general start; check(), validate() and update() refuse the same measurements.
#include "check.hpp"
#include "refusals.hpp"
#include "scene.hpp"

#include <array>
#include <limits>

using namespace ibvs;

namespace {

Eigen::Vector3d moved(const Eigen::Vector3d& P, const Twist& xi) {
  const Pose T = se3_inverse(se3_exp(xi));
  return T.topLeftCorner<3, 3>() * P + T.topRightCorner<3, 1>();
}

// ViSP's vpFeatureSegment::interaction, transcribed in its own variables (xc, yc, l its
// non-normalised values, lambda1, lambda2 of its depths). Its alpha is atan2(y1 - y2, x1 - x2),
// the direction from its second point to its first: ViSP's segment from our p2 to our p1 has
// our alpha, with Z1 and Z2 exchanged.
Eigen::Matrix<double, 4, 6> visp_segment(double xc, double yc, double l, double alpha, double Z1, double Z2,
                                         bool normalized) {
  const double l1 = (Z1 - Z2) / (Z1 * Z2), l2 = (Z1 + Z2) / (2 * Z1 * Z2), co = std::cos(alpha),
               si = std::sin(alpha);
  Eigen::Matrix<double, 4, 6> L;
  if (normalized) {
    const double xn = xc / l, yn = yc / l, ln = 1 / l, lam = -l1 * ln, zn = l2 * ln, lc = co / ln, ls = si / ln,
                 xa = xn * co + yn * si;
    L << -zn + lam * xn * co, lam * xn * si, l1 * (xn * xa - co / 4), si * co / 4 / ln - xn * xa * si / ln,
        -ln * (1 + lc * lc / 4) + xn * xa * co / ln, yn,  //
        lam * yn * co, -zn + lam * yn * si, l1 * (yn * xa - si / 4), ln * (1 + ls * ls / 4) - yn * xa * si / ln,
        -si * co / 4 / ln + yn * xa * co / ln, -xn,  //
        lam * co * ln, lam * si * ln, -(zn + lam * xa), -yn - xa * si, xn + xa * co, 0,  //
        -l1 * si * ln, l1 * co * ln, l1 * (xn * si - yn * co), (-xn * si * si + yn * co * si) / ln,
        (xn * co * si - yn * co * co) / ln, -1;
  } else {
    L << -l2, 0, l2 * xc - l1 * l * co / 4, xc * yc + l * l * co * si / 4, -(1 + xc * xc + l * l * co * co / 4), yc,
        0, -l2, l2 * yc - l1 * l * si / 4, 1 + yc * yc + l * l * si * si / 4, -xc * yc - l * l * co * si / 4, -xc,
        l1 * co, l1 * si, l2 * l - l1 * (xc * co + yc * si), l * (xc * co * si + yc * (1 + si * si)),
        -l * (xc * (1 + co * co) + yc * co * si), 0,  //
        -l1 * si / l, l1 * co / l, l1 * (xc * si - yc * co) / l, -xc * si * si + yc * co * si,
        xc * co * si - yc * co * co, -1;
  }
  return L;
}

void segment_jacobian() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> u(-0.5, 0.5), z(0.3, 5.0);
  for (bool normalized : {true, false}) {
    const SegmentFeature seg(normalized);
    int checked = 0;
    double worst_fd = 0.0, worst_visp = 0.0;
    for (int c = 0; c < ibvs_test::cases; ++c) {
      const Eigen::Vector3d P1 = ibvs_test::point(u(rng), u(rng), z(rng));
      const Eigen::Vector3d P2 = ibvs_test::point(u(rng), u(rng), z(rng));
      const std::array<double, 6> m = SegmentFeature::project(P1, P2);
      if (m[2] < 0.02) continue;  // a short segment: its 1/l rows are steep for differences of step 1e-6
      int entry = 0;
      CHECK(seg.check(m.data(), entry) == nullptr);
      MatrixX6 L(4, 6);
      seg.interaction(m.data(), L);
      const double h = 1e-6;
      Eigen::Matrix<double, 4, 6> Ln;
      for (int k = 0; k < 6; ++k) {
        Twist xi = Twist::Zero();
        xi(k) = h;
        const auto a = SegmentFeature::project(moved(P1, xi), moved(P2, xi));
        const auto b = SegmentFeature::project(moved(P1, -xi), moved(P2, -xi));
        double sa[4], sb[4];
        seg.value(a.data(), sa);
        seg.value(b.data(), sb);
        for (int i = 0; i < 3; ++i) Ln(i, k) = (sa[i] - sb[i]) / (2 * h);
        Ln(3, k) = wrap_angle(sa[3] - sb[3]) / (2 * h);
      }
      const double scale = std::max(1.0, L.cwiseAbs().maxCoeff());
      worst_fd = std::max(worst_fd, (L - Ln).cwiseAbs().maxCoeff() / scale);
      // ViSP's segment from our p2 to our p1 has our alpha and our depths swapped.
      worst_visp = std::max(worst_visp, (L - visp_segment(m[0], m[1], m[2], m[3], m[5], m[4], normalized))
                                                .cwiseAbs()
                                                .maxCoeff() /
                                            scale);
      ++checked;
    }
    std::printf("%s: %d segments, worst relative difference %.2g (finite differences), %.2g (ViSP's formula)\n",
                seg.describe().c_str(), checked, worst_fd, worst_visp);
    CHECK(checked > ibvs_test::cases / 2);
    CHECK(worst_fd < 1e-6);
    CHECK(worst_visp < 1e-12);
  }
}

void segment_measure_and_align() {
  // From (0.1, 0.2) at 1 m to (0.1, -0.2) at 2 m: centre (0.1, 0), length 0.4, alpha -pi/2.
  const auto m = SegmentFeature::measure(0.1, 0.2, 1.0, 0.1, -0.2, 2.0);
  CHECK_NEAR(m[0], 0.1, 1e-15);
  CHECK_NEAR(m[1], 0.0, 1e-15);
  CHECK_NEAR(m[2], 0.4, 1e-15);
  CHECK_NEAR(m[3], -pi / 2, 1e-15);
  CHECK(m[4] == 1.0 && m[5] == 2.0);
  const auto p = SegmentFeature::project({0.1, 0.2, 1.0}, {0.2, -0.4, 2.0});
  for (int i = 0; i < 6; ++i) CHECK_NEAR(p[static_cast<std::size_t>(i)], m[static_cast<std::size_t>(i)], 1e-15);
  CHECK_THROWS(SegmentFeature::measure(0.1, 0.1, 1.0, 0.1, 0.1, 1.0));    // zero length
  CHECK_THROWS(SegmentFeature::measure(0.1, 0.1, 1.0, 0.2, 0.1, -1.0));   // behind the camera
  CHECK_THROWS(SegmentFeature::measure(0.1, 0.1, 1.0, 12.0, 0.1, 1.0));   // pixels, not normalised
  CHECK_THROWS(SegmentFeature::project({0.1, 0.1, -1.0}, {0.2, 0.1, 1.0}));
  // The reverse segment (taken from p2 to p1) aligned to the forward one: the same features and
  // Jacobian, so the error is zero and the law does not turn the camera half a turn.
  const auto r = SegmentFeature::measure(0.1, -0.2, 2.0, 0.1, 0.2, 1.0);
  for (bool normalized : {true, false}) {
    const SegmentFeature seg(normalized);
    double a[6], e[4];
    std::copy(r.begin(), r.end(), a);
    seg.align(a, m.data());
    seg.error(a, m.data(), e);
    CHECK(std::abs(e[0]) + std::abs(e[1]) + std::abs(e[2]) + std::abs(e[3]) < 1e-14);
    MatrixX6 La(4, 6), Lm(4, 6);
    seg.interaction(a, La);
    seg.interaction(m.data(), Lm);
    CHECK((La - Lm).cwiseAbs().maxCoeff() < 1e-12);
    // A goal turned by 100 degrees: aligned, the alpha error is the 80 degrees the other way.
    double g[6] = {m[0], m[1], m[2], wrap_angle(m[3] + 100 * pi / 180), m[4], m[5]}, b[6];
    std::copy(m.begin(), m.end(), b);
    seg.align(b, g);
    seg.error(b, g, e);
    CHECK_NEAR(e[3], 80 * pi / 180, 1e-12);
    CHECK(b[4] == m[5] && b[5] == m[4]);
  }
}

void segment_refusals() {
  const SegmentFeature seg;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double good[6] = {0.1, -0.1, 0.3, 0.5, 1.0, 2.0};
  int entry = 0;
  CHECK(seg.check(good, entry) == nullptr);
  for (int i = 0; i < 6; ++i) {
    double m[6];
    std::copy(good, good + 6, m);
    m[i] = nan;
    CHECK(seg.check(m, entry) != nullptr && entry == i);
  }
  const double zero[6] = {0.1, -0.1, 0.0, 0.5, 1.0, 2.0}, tiny[6] = {0.1, -0.1, 1e-12, 0.5, 1.0, 2.0},
               negative[6] = {0.1, -0.1, -0.3, 0.5, 1.0, 2.0}, behind[6] = {0.1, -0.1, 0.3, 0.5, 1.0, -2.0},
               far[6] = {11.0, -0.1, 0.3, 0.5, 1.0, 2.0}, spun[6] = {0.1, -0.1, 0.3, 7.0, 1.0, 2.0};
  CHECK(seg.check(zero, entry) != nullptr && entry == 2);
  CHECK(seg.check(tiny, entry) != nullptr && entry == 2);
  CHECK(seg.check(negative, entry) != nullptr && entry == 2);
  CHECK(seg.check(behind, entry) != nullptr && entry == 5);
  CHECK(seg.check(far, entry) != nullptr && entry == 0);
  CHECK(seg.check(spun, entry) != nullptr && entry == 3);
  CHECK_THROWS(seg.validate(zero, "segment"));
  // The shortest accepted segment at the widest place: finite features and rows.
  for (bool normalized : {true, false}) {
    const SegmentFeature s(normalized);
    const double edge[6] = {10.0, -10.0, min_segment_length, 3.0, min_depth, max_depth};
    CHECK(s.check(edge, entry) == nullptr);
    double v[4];
    MatrixX6 L(4, 6);
    s.value(edge, v);
    s.interaction(edge, L);
    CHECK(std::isfinite(v[0] + v[1] + v[2] + v[3]) && L.allFinite());
    CHECK(L.cwiseAbs().maxCoeff() < 1e40);
  }
}

// The paper's square target, its four edges as segments, from a general start: the camera
// reaches the goal pose (both feature sets).
void four_segments_converge() {
  const Eigen::Matrix<double, 3, 4> Pw = ibvs_test::square(0.25, 3.0);
  for (bool normalized : {true, false}) {
    Task task;
    for (int i = 0; i < 4; ++i) task.add(SegmentFeature(normalized));
    ServoOptions o;
    o.gain = 1.0;
    Servo servo(task, o);
    ServoInput in(task);
    ServoOutput out(task);
    const auto segments_at = [&](const Pose& T_wc, Eigen::VectorXd& m) {
      const Pose T_cw = se3_inverse(T_wc);
      for (int i = 0; i < 4; ++i) {
        const Eigen::Vector3d A = T_cw.topLeftCorner<3, 3>() * Pw.col(i) + T_cw.topRightCorner<3, 1>(),
                              B = T_cw.topLeftCorner<3, 3>() * Pw.col((i + 1) % 4) + T_cw.topRightCorner<3, 1>();
        const auto s = SegmentFeature::project(A, B);
        for (int j = 0; j < 6; ++j) m(6 * i + j) = s[static_cast<std::size_t>(j)];
      }
    };
    segments_at(Pose::Identity(), in.measurements_desired);
    Twist start;
    start << 0.1, -0.08, -0.4, 0.1, -0.12, 0.5;
    Pose T = se3_exp(start);
    const double dt = 1.0 / 60;
    int k = 0;
    for (; k < 3000; ++k) {
      segments_at(T, in.measurements);
      if (servo.update(in, out) == Status::invalid_input) break;
      if (out.error_norm < 1e-9) break;
      T = T * se3_exp(out.velocity * dt);
    }
    const double dp = T.topRightCorner<3, 1>().norm();
    const double dr = Eigen::AngleAxisd(Eigen::Matrix3d(T.topLeftCorner<3, 3>())).angle();
    std::printf("four %s: converged at frame %d, %.2g m and %.2g rad from the goal\n",
                SegmentFeature(normalized).describe().c_str(), k, dp, dr);
    CHECK(k < 3000);
    CHECK(dp < 1e-6 && dr < 1e-6);
  }
}

// validate() throws exactly for the measurements update() refuses (a segment beside a point).
void refusals_agree() {
  Task task(Layout::cartesian(1));
  task.add(SegmentFeature());
  Servo servo(task);
  ServoInput in(task);
  ServoOutput out(task);
  in.uv_desired << 0.1, 0.1;
  const double good[6] = {0.1, -0.1, 0.3, 0.5, 1.0, 2.0};
  in.measurements = Eigen::Map<const Eigen::VectorXd>(good, 6);
  in.measurements_desired = in.measurements;
  std::mt19937_64 rng(ibvs_test::seed + 2);
  const std::initializer_list<double> bad = {
      std::numeric_limits<double>::quiet_NaN(), -std::numeric_limits<double>::infinity(), 1e300, -11.0, 0.0, 1e-12,
      7.0, 0.2, -0.3, 2e6};
  ibvs_test::check_refusals_agree(servo, in, out, rng, bad);
}

}  // namespace

void run_tests() {
  segment_jacobian();
  segment_measure_and_align();
  segment_refusals();
  four_segments_converge();
  refusals_agree();
}
