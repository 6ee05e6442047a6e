// Camera model (ViSP distortion both ways) and the planar pose estimate.
#include "check.hpp"
#include "sim_cases.hpp"

#include <random>

using namespace ibvs;
using namespace ibvs::sim;

namespace {

void camera_model() {
  const Camera c = Camera::afma6();
  CHECK_NEAR(c.px, 1090.6, 0);
  CHECK_NEAR(c.v0, 260.8, 0);
  CHECK_NEAR(c.kud, -0.2114, 0);
  CHECK_NEAR(c.kdu, 0.2217, 0);
  CHECK_NEAR(c.fps, 60, 0);
  // The principal point maps to itself both ways.
  CHECK(c.project(0, 0).isApprox(Eigen::Vector2d(310.1, 260.8)));
  CHECK(c.normalize(310.1, 260.8).norm() < 1e-15);
  // ViSP's formulas at one point.
  const double x = 0.2, y = -0.1, r2 = x * x + y * y;
  CHECK_NEAR(c.project(x, y)(0), 310.1 + 1090.6 * x * (1 - 0.2114 * r2), 1e-12);
  const Eigen::Vector2d m(600.0, 20.0);
  const double xu = (600.0 - 310.1) / 1090.6, yu = (20.0 - 260.8) / 1090.0;
  CHECK_NEAR(c.normalize(m(0), m(1))(1), yu * (1 + 0.2217 * (xu * xu + yu * yu)), 1e-15);
  // kud and kdu are separate calibrations: the round trip is close, not exact
  // (under one pixel over the sensor), and distortion is really on.
  double worst = 0, effect = 0;
  for (double u = 0; u <= 640; u += 40)
    for (double v = 0; v <= 480; v += 40) {
      const Eigen::Vector2d n = c.normalize(u, v);
      worst = std::max(worst, (c.project(n(0), n(1)) - Eigen::Vector2d(u, v)).norm());
      effect = std::max(effect, 1090.6 * (n - Eigen::Vector2d((u - 310.1) / 1090.6, (v - 260.8) / 1090.0)).norm());
    }
  ibvs_test::report(worst < 1.0, "kud/kdu round trip under 1 px", __FILE__, __LINE__, std::to_string(worst));
  CHECK(effect > 5.0);  // pixels of distortion at the corners
  CHECK(c.contains(0, 0) && c.contains(640, 480) && !c.contains(-0.1, 10) && !c.contains(10, 480.1));
  const Camera nc = Camera::normalized(0.3);
  CHECK(nc.project(0.1, -0.2) == Eigen::Vector2d(0.1, -0.2));
  CHECK(nc.contains(0.3, -0.3) && !nc.contains(0.31, 0));
  CHECK_THROWS(Camera::normalized(-1));
}

void pose_estimate() {
  const Target t = Target::square(0.1);
  const PlanarPose est(t.points);
  std::mt19937 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> U(-1, 1);
  std::normal_distribution<double> N(0, 1);
  double worst = 0, worst_noisy = 0;
  for (int n = 0; n < ibvs_test::cases; ++n) {
    const Pose T = sim_cases::make_pose(0.1 * U(rng), 0.1 * U(rng), 0.6 + 0.3 * U(rng), 0.4 * U(rng), 0.4 * U(rng),
                                        3.0 * U(rng));
    Points uv(2, 4), noisy(2, 4);
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d p = T.topLeftCorner<3, 3>() * t.points.col(i) + T.topRightCorner<3, 1>();
      uv.col(i) = p.head<2>() / p(2);
      noisy.col(i) = uv.col(i) + (0.5 / 1090.0) * Eigen::Vector2d(N(rng), N(rng));  // half-pixel noise
    }
    Pose E = Pose::Zero();
    CHECK(est.estimate(uv, E));
    worst = std::max(worst, (E - T).cwiseAbs().maxCoeff());
    Pose En;
    CHECK(est.estimate(noisy, En));
    worst_noisy = std::max(worst_noisy, std::abs(En(2, 3) - T(2, 3)));
  }
  ibvs_test::report(worst < 1e-9, "exact points give the exact pose", __FILE__, __LINE__, std::to_string(worst));
  ibvs_test::report(worst_noisy < 0.02, "half-pixel noise: depth within 2 cm", __FILE__, __LINE__,
                    std::to_string(worst_noisy));
  Eigen::Matrix3Xd bent = t.points;
  bent(2, 0) = 0.01;
  CHECK_THROWS(PlanarPose{bent});
}

}  // namespace

void run_tests() {
  camera_model();
  pose_estimate();
}
