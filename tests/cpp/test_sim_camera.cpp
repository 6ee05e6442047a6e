// The planar pose estimate (the camera model is tests/cpp/test_camera_model.cpp).
#include "check.hpp"
#include "sim_cases.hpp"

#include <random>

using namespace ibvs;
using namespace ibvs::sim;

namespace {

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
  pose_estimate();
}
