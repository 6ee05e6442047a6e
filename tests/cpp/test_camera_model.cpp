// CameraModel: ViSP's formulas, the OpenCV models' round trips over the whole
// image (the agreement with OpenCV itself is tests/python/test_camera_model.py),
// the radius where each distortion folds, and the per-point refusals.
#include "check.hpp"

#include "ibvs/camera_model.hpp"

#include <cmath>
#include <limits>
#include <random>

using namespace ibvs;

namespace {

const double inf = std::numeric_limits<double>::infinity();

Eigen::Matrix3d K_of(double f, double cx, double cy) {
  Eigen::Matrix3d K;
  K << f, 0, cx, 0, 1.002 * f, cy, 0, 0, 1;
  return K;
}

void visp_model() {
  const CameraModel c = CameraModel::afma6();
  CHECK(c.distortion() == Distortion::visp);
  CHECK(c.px() == 1090.6 && c.py() == 1090.0 && c.u0() == 310.1 && c.v0() == 260.8 && c.fps() == 60.0);
  CHECK(c.coefficients() == Eigen::Vector2d(-0.2114, 0.2217));
  Eigen::Vector2d p, n;
  // The principal point maps to itself both ways.
  CHECK(c.project(0, 0, p) && p == Eigen::Vector2d(310.1, 260.8));
  CHECK(c.normalize(310.1, 260.8, n) && n.norm() < 1e-15);
  // ViSP's formulas, evaluated as ViSP writes them (bit for bit).
  const double x = 0.2, y = -0.1;
  CHECK(c.project(x, y, p));
  const double k = 1.0 + -0.2114 * (x * x + y * y);
  CHECK(p(0) == 310.1 + 1090.6 * x * k && p(1) == 260.8 + 1090.0 * y * k);
  const double xu = (600.0 - 310.1) / 1090.6, yu = (20.0 - 260.8) / 1090.0, kd = 1.0 + 0.2217 * (xu * xu + yu * yu);
  CHECK(c.normalize(600.0, 20.0, n) && n == Eigen::Vector2d(xu * kd, yu * kd));
  // kud and kdu are separate calibrations: the round trip is close, not exact.
  double worst = 0;
  for (double u = 0; u <= 640; u += 40)
    for (double v = 0; v <= 480; v += 40) {
      CHECK(c.normalize(u, v, n) && c.project(n(0), n(1), p));
      worst = std::max(worst, (p - Eigen::Vector2d(u, v)).norm());
    }
  ibvs_test::report(worst > 1e-3 && worst < 1.0, "kud/kdu round trip under 1 px", __FILE__, __LINE__,
                    std::to_string(worst));
  CHECK(c.contains(0, 0) && c.contains(640, 480) && !c.contains(-0.1, 10) && !c.contains(10, 480.1));
  // kud < 0 folds at 1 + 3 kud r^2 = 0.
  CHECK_NEAR(c.max_radius(), 1.0 / std::sqrt(3 * 0.2114), 1e-15);
  CHECK(!c.project(1.001 * c.max_radius(), 0.0, p) && std::isnan(p(0)));
  CHECK(c.project(0.999 * c.max_radius(), 0.0, p));
  // The normalised camera of paper Table I: identity both ways.
  const CameraModel nc = CameraModel::normalized(0.3);
  CHECK(nc.distortion() == Distortion::none && nc.max_radius() == inf);
  CHECK(nc.project(0.1, -0.2, p) && p == Eigen::Vector2d(0.1, -0.2));
  CHECK(nc.normalize(0.1, -0.2, n) && n == Eigen::Vector2d(0.1, -0.2));
  CHECK(nc.contains(0.3, -0.3) && !nc.contains(0.31, 0));
  CHECK_THROWS(CameraModel::normalized(-1));
  CHECK(CameraModel::from_visp(1000, 1000, 320, 240, 0, 0, 640, 480).distortion() == Distortion::none);
}

// Pixels -> normalised -> pixels over the whole sensor, to 1e-6 px (the
// contract; the Newton tolerance is 1e-9 px), and normalised -> pixels -> back.
double round_trip(const CameraModel& c) {
  double worst = 0;
  Eigen::Vector2d n, p;
  for (double u = 0; u <= c.width(); u += 4)
    for (double v = 0; v <= c.height(); v += 4) {
      const bool ok = c.normalize(u, v, n) && c.project(n(0), n(1), p);
      worst = std::max(worst, ok ? (p - Eigen::Vector2d(u, v)).norm() : inf);
    }
  return worst;
}

void opencv_models() {
  Eigen::VectorXd barrel(5), pincushion(5), fisheye(4);
  barrel << -0.28, 0.07, 0.001, -0.0005, 0.01;
  pincushion << 0.12, -0.3, 0.002, 0.001, 0.2;
  fisheye << -0.013, 0.021, -0.012, 0.003;
  const CameraModel b = CameraModel::from_opencv(K_of(600, 320, 240), barrel, 640, 480);
  const CameraModel q = CameraModel::from_opencv(K_of(600, 320, 240), pincushion, 640, 480);
  const CameraModel f = CameraModel::from_opencv(K_of(285, 322, 238), fisheye, 640, 480, true);
  CHECK(b.distortion() == Distortion::plumb_bob && f.distortion() == Distortion::equidistant);
  for (const CameraModel* c : {&b, &q, &f}) {
    const double w = round_trip(*c);
    ibvs_test::report(w < 1e-6, "round trip over the whole image < 1e-6 px", __FILE__, __LINE__,
                      c->describe() + ": " + std::to_string(w));
  }
  // The plumb_bob formula at one point (OpenCV's, written out).
  const double x = 0.3, y = -0.2, r2 = x * x + y * y, R = 1 + r2 * (-0.28 + r2 * (0.07 + r2 * 0.01));
  const double xd = x * R + 2 * 0.001 * x * y + -0.0005 * (r2 + 2 * x * x);
  const double yd = y * R + 0.001 * (r2 + 2 * y * y) + 2 * -0.0005 * x * y;
  Eigen::Vector2d p;
  CHECK(b.project(x, y, p));
  CHECK_NEAR(p(0), 320 + 600 * xd, 1e-12);
  CHECK_NEAR(p(1), 240 + 1.002 * 600 * yd, 1e-12);
  // Equidistant: theta_d along the same direction.
  const double r = std::hypot(x, y), th = std::atan(r), t2 = th * th;
  const double thd = th * (1 + t2 * (-0.013 + t2 * (0.021 + t2 * (-0.012 + t2 * 0.003))));
  CHECK(f.project(x, y, p));
  CHECK_NEAR(p(0), 322 + 285 * x * thd / r, 1e-12);
  // Only 4/5 (or zero-padded 8/12/14) plumb_bob coefficients, 4 fisheye ones, no skew.
  Eigen::VectorXd three(3), eight = Eigen::VectorXd::Zero(8);
  three << 0.1, 0.0, 0.0;
  CHECK_THROWS(CameraModel::from_opencv(K_of(600, 320, 240), three, 640, 480));
  CHECK(CameraModel::from_opencv(K_of(600, 320, 240), eight, 640, 480).distortion() == Distortion::none);
  eight(6) = 0.1;
  CHECK_THROWS(CameraModel::from_opencv(K_of(600, 320, 240), eight, 640, 480));
  CHECK_THROWS(CameraModel::from_opencv(K_of(600, 320, 240), barrel, 640, 480, true));
  Eigen::Matrix3d skew = K_of(600, 320, 240);
  skew(0, 1) = 1.0;
  CHECK_THROWS(CameraModel::from_opencv(skew, barrel, 640, 480));
  CHECK_THROWS(CameraModel::from_opencv(K_of(600, 320, 240), barrel, 640, -480));
  // Scale limits (ibvs/limits.hpp): focal lengths, principal point, image size, coefficients, frame rate.
  CHECK_THROWS(CameraModel::from_opencv(K_of(1e-300, 320, 240), barrel, 640, 480));
  CHECK_THROWS(CameraModel::from_opencv(K_of(1e300, 320, 240), barrel, 640, 480));
  CHECK_THROWS(CameraModel::from_opencv(K_of(600, 1e300, 240), barrel, 640, 480));
  CHECK_THROWS(CameraModel::from_opencv(K_of(600, 320, 240), barrel, 1e12, 480));
  CHECK_THROWS(CameraModel::from_opencv(K_of(600, 320, 240), Eigen::VectorXd::Constant(5, 1e300), 640, 480));
  CHECK_THROWS(CameraModel::from_opencv(K_of(600, 320, 240), barrel, 640, 480, false, 1e9));
  CHECK_THROWS(CameraModel::from_visp(1e300, 600, 320, 240, 0.0, 0.0, 640, 480));
  CHECK(CameraModel::from_opencv(K_of(max_focal_length / 1.002, 320, 240), barrel, max_pixel_coordinate, 480).py() ==
        max_focal_length);  // the limits themselves are accepted
  CHECK(CameraModel::from_opencv(b.K(), b.opencv_coefficients(), 640, 480) == b);
}

// The fold: d rd / dr > 0 inside max_radius, 0 at it; beyond it project()
// refuses, and pixels beyond its image have no inverse.
void fold_radius() {
  Eigen::VectorXd k1(4), fe(4);
  k1 << -0.3, 0, 0, 0;
  fe << -0.3, 0, 0, 0;
  const CameraModel c = CameraModel::from_opencv(K_of(600, 320, 240), k1, 640, 480);
  const CameraModel f = CameraModel::from_opencv(K_of(285, 322, 238), fe, 640, 480, true);
  CHECK_NEAR(c.max_radius(), 1.0 / std::sqrt(0.9), 1e-14);
  CHECK_NEAR(f.max_radius(), std::tan(1.0 / std::sqrt(0.9)), 1e-12);
  for (const CameraModel* m : {&c, &f}) {
    const double rm = m->max_radius();
    Eigen::Vector2d a, b, n;
    const auto du = [&](double r) {
      const double h = 1e-7 * r;
      m->project(r + h, 0, a);
      m->project(r - h, 0, b);
      return (a(0) - b(0)) / (2 * h);
    };
    CHECK(du(0.99 * rm) > 0 && du(0.5 * rm) > du(0.99 * rm) && std::abs(du(0.999999 * rm)) < 1e-2 * du(0.0 + 1e-3));
    CHECK(!m->project(rm, 0, a) && !m->project(1.5 * rm, 0, a));
    CHECK(m->project(0.9999 * rm, 0, a));
    CHECK(m->normalize(a(0), a(1), n) && std::abs(n(0) - 0.9999 * rm) < 1e-9);
    CHECK(!m->normalize(a(0) + 50.0, a(1), n) && std::isnan(n(0)));  // past the fold's image: no inverse
  }
  // No fold: every radius is one-to-one.
  Eigen::VectorXd soft(5);
  soft << 0.1, 0.01, 0, 0, 0.001;
  CHECK(CameraModel::from_opencv(K_of(600, 320, 240), soft, 640, 480).max_radius() == inf);
}

// Batched calls, per-point flags, NaN and non-finite input, never a throw.
void batched_and_refusals() {
  const CameraModel c = CameraModel::afma6();
  Points uv(2, 4), px(2, 4), back(2, 4);
  uv << 0.1, -0.2, 2.0, std::numeric_limits<double>::quiet_NaN(),  //
      0.05, 0.1, 0.0, 0.0;
  CHECK(c.project(uv, px) == 2);
  CHECK(px.col(0).allFinite() && px.col(1).allFinite() && std::isnan(px(0, 2)) && std::isnan(px(0, 3)));
  CHECK(c.normalize(px.leftCols(2), back.leftCols(2)) == 0);
  CHECK(c.normalize(px, back) == 2);
  Points wrong(2, 3);
  CHECK(c.project(uv, wrong) == 3 && std::isnan(wrong(0, 0)));
  Eigen::Vector2d p;
  CHECK(!c.normalize(std::numeric_limits<double>::infinity(), 0, p));
  // Random finite input: finite output or a refusal, for every model.
  std::mt19937 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> U(-1, 1);
  Eigen::VectorXd d5(5), d4(4);
  int refused = 0, mapped = 0;
  for (int n = 0; n < ibvs_test::cases; ++n) {
    for (int i = 0; i < 5; ++i) d5(i) = 0.4 * U(rng);
    for (int i = 0; i < 4; ++i) d4(i) = 0.1 * U(rng);
    const CameraModel m[3] = {CameraModel::from_opencv(K_of(800, 320, 240), d5, 640, 480),
                              CameraModel::from_opencv(K_of(300, 320, 240), d4, 640, 480, true),
                              CameraModel::from_visp(900, 900, 320, 240, 0.4 * U(rng), 0.4 * U(rng), 640, 480)};
    for (const CameraModel& cm : m) {
      const double s = std::pow(10.0, 4 * U(rng));
      for (int way = 0; way < 2; ++way) {
        const bool ok = way == 0 ? cm.project(s * U(rng), s * U(rng), p)
                                 : cm.normalize(320 + s * U(rng), 240 + s * U(rng), p);
        if (ok) {
          ++mapped;
          CHECK(p.allFinite());
        } else {
          ++refused;
          CHECK(std::isnan(p(0)) && std::isnan(p(1)));
        }
      }
    }
  }
  CHECK(mapped > 0 && refused > 0);
}

}  // namespace

void run_tests() {
  visp_model();
  opencv_models();
  fold_radius();
  batched_and_refusals();
}
