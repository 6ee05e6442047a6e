// The estimators: DepthEstimator (per-point inverse-depth EKF) and PlanarPose
// (homography + Gauss-Newton), on synthetic scenes with known depths.
#include "check.hpp"
#include "sim_cases.hpp"

#include "ibvs/ibvs.hpp"

#include <cmath>
#include <limits>
#include <random>

using namespace ibvs;

namespace {

// Normalised points of world points seen from camera pose T_wc, and their depths.
void look(const Eigen::Matrix3Xd& Pw, const Pose& T_wc, Points& uv, Eigen::VectorXd& z) {
  const Pose T_cw = se3_inverse(T_wc);
  for (Eigen::Index i = 0; i < Pw.cols(); ++i) {
    const Eigen::Vector3d p = T_cw.topLeftCorner<3, 3>() * Pw.col(i) + T_cw.topRightCorner<3, 1>();
    uv.col(i) = p.head<2>() / p(2);
    z(i) = p(2);
  }
}

Eigen::Matrix3Xd scene() {
  Eigen::Matrix3Xd P(3, 5);
  P << 0.2, -0.2, -0.2, 0.2, 0.05,  //
      0.2, 0.2, -0.2, -0.2, 0.1,    //
      1.0, 1.2, 0.9, 1.5, 0.7;
  return P;
}

// A camera translating sideways and rotating: the filter, started 50 % off,
// converges to the true depths noise-free, and to within a few % under noise.
void depth_converges() {
  const Eigen::Matrix3Xd P = scene();
  const int n = static_cast<int>(P.cols());
  Twist v;
  v << 0.3, -0.1, 0.05, 0.05, 0.1, 0.2;  // m/s, rad/s
  const double dt = 1.0 / 60.0;
  std::mt19937 rng(ibvs_test::seed);
  std::normal_distribution<double> N(0, 1);
  for (double noise : {0.0, 0.5 / 600.0}) {  // normalised: half a pixel at f = 600 px
    DepthEstimatorOptions o;
    o.point_noise = noise;
    DepthEstimator est(Eigen::VectorXd::Constant(n, 1.5), o);  // prior 1.5 m: off by up to 114 %
    CHECK(!est.initialized() && est.depth() == Eigen::VectorXd::Constant(n, 1.5));
    Pose T = Pose::Identity();
    Points uv(2, n);
    Eigen::VectorXd z(n);
    double first_var = 0;
    for (int k = 0; k < 120; ++k) {
      look(P, T, uv, z);
      for (int i = 0; i < n && noise > 0; ++i) uv.col(i) += noise * Eigen::Vector2d(N(rng), N(rng));
      CHECK(est.update(uv, v, dt));  // the motion since the previous frame (ignored at k = 0)
      if (k == 0) first_var = est.variance()(0);
      T = T * se3_exp(v * dt);
    }
    look(P, T * se3_inverse(se3_exp(v * dt)), uv, z);  // true depths at the last update's pose
    const double err = ((est.depth() - z).array() / z.array()).abs().maxCoeff();
    ibvs_test::report(err < (noise > 0 ? 0.03 : 1e-6), "depth estimate converges", __FILE__, __LINE__,
                      "noise " + std::to_string(noise) + ": " + std::to_string(err));
    CHECK(est.variance()(0) < 1e-3 * first_var && est.restarts() == 0);
  }
}

// The two motion forms agree; bad input changes nothing; reset() returns to the prior.
void motion_forms_and_refusals() {
  const Eigen::Matrix3Xd P = scene();
  const int n = static_cast<int>(P.cols());
  Points uv0(2, n), uv1(2, n);
  Eigen::VectorXd z(n);
  Twist d;
  d << 0.01, 0.0, -0.02, 0.0, 0.01, 0.03;  // twist * dt: the twist d / 0.5 held for 0.5 s
  const Pose Md = se3_exp(d), I = Pose::Identity();
  look(P, Pose::Identity(), uv0, z);
  look(P, se3_exp(d), uv1, z);
  DepthEstimator a(Eigen::VectorXd::Ones(n)), b(Eigen::VectorXd::Ones(n));
  CHECK(a.update(uv0, I) && b.update(uv0, I));
  CHECK(a.update(uv1, Twist(d / 0.5), 0.5) && b.update(uv1, Md));
  CHECK(a.depth() == b.depth() && a.variance() == b.variance());
  const Eigen::VectorXd before = a.depth();
  Points bad = uv1;
  bad(0, 2) = std::numeric_limits<double>::quiet_NaN();
  CHECK(!a.update(bad, Md) && a.depth() == before);
  CHECK(!a.update(uv1.leftCols(n - 1), Md) && a.depth() == before);
  Twist nan_twist = d;
  nan_twist(3) = std::numeric_limits<double>::infinity();
  CHECK(!a.update(uv1, nan_twist, 1.0) && a.depth() == before);
  CHECK(!a.update(uv1, d, std::numeric_limits<double>::quiet_NaN()) && a.depth() == before);
  CHECK_THROWS(a.validate(bad, Md));
  Pose skew = Md;
  skew(0, 1) += 0.1;
  CHECK_THROWS(a.validate(uv1, skew));
  CHECK(!a.update(uv1, skew) && a.depth() == before);  // validate() and update() agree on every refusal
  Points pixels = uv1 * 600.0;                          // beyond max_normalized_coordinate: pixels by mistake
  CHECK_THROWS(a.validate(pixels, Md));
  CHECK(!a.update(pixels, Md) && a.depth() == before);
  Pose far = Md;
  far(0, 3) = 2.0 * max_depth;
  CHECK_THROWS(a.validate(uv1, far));
  CHECK(!a.update(uv1, far) && a.depth() == before);
  CHECK_THROWS(DepthEstimator(Eigen::VectorXd::Constant(n, 0.5 * min_depth)));
  CHECK_THROWS(DepthEstimator(Eigen::VectorXd::Constant(n, 2.0 * max_depth)));
  a.reset();
  CHECK(!a.initialized());
  CHECK(a.update(uv1, Md) && a.depth() == Eigen::VectorXd::Ones(n));  // initialised from the prior
  a.reset(Eigen::VectorXd::Constant(n, 2.0));
  CHECK(a.depth() == Eigen::VectorXd::Constant(n, 2.0));
  CHECK_THROWS(a.reset(Eigen::VectorXd::Constant(n + 1, 2.0)));
  CHECK_THROWS(DepthEstimator(Eigen::VectorXd::Constant(n, -1.0)));
  DepthEstimatorOptions o;
  o.max_depth_ratio = 1.0;
  CHECK_THROWS(DepthEstimator(Eigen::VectorXd::Ones(n), o));
  // A motion that puts every predicted point behind the camera restarts the filters from the prior.
  DepthEstimator c(Eigen::VectorXd::Ones(n));
  CHECK(c.update(uv0, I));
  Pose through = Pose::Identity();
  through(2, 3) = 5.0;  // the camera jumps 5 m forward, past every point
  CHECK(c.update(uv0, through) && c.restarts() == n && c.depth() == Eigen::VectorXd::Ones(n));
  // Depths stay within [min_depth, max_depth_ratio * prior] whatever the input.
  std::mt19937 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int k = 0; k < ibvs_test::cases; ++k) {
    Points r(2, n);
    for (int i = 0; i < n; ++i) r.col(i) << 3 * U(rng), 3 * U(rng);
    Twist t;
    for (int i = 0; i < 6; ++i) t(i) = 0.5 * U(rng);
    c.update(r, t, 1.0);
    CHECK(c.depth().allFinite() && c.variance().allFinite());
    CHECK(c.depth().minCoeff() >= 1e-3 * (1 - 1e-12) && c.depth().maxCoeff() <= 100.0 * (1 + 1e-12));
  }
}

void planar_pose() {
  const sim::Target t = sim::Target::square(0.1);
  const PlanarPose est(t.points);
  CHECK(est.n_points() == 4 && est.iterations() == 5);
  std::mt19937 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> U(-1, 1);
  std::normal_distribution<double> N(0, 1);
  double worst = 0, worst_depth = 0, worst_noisy = 0;
  for (int n = 0; n < ibvs_test::cases; ++n) {
    const Pose T = sim_cases::make_pose(0.1 * U(rng), 0.1 * U(rng), 0.6 + 0.3 * U(rng), 0.4 * U(rng), 0.4 * U(rng),
                                        3.0 * U(rng));
    Points uv(2, 4), noisy(2, 4);
    Eigen::Vector4d z;
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d p = T.topLeftCorner<3, 3>() * t.points.col(i) + T.topRightCorner<3, 1>();
      uv.col(i) = p.head<2>() / p(2);
      z(i) = p(2);
      noisy.col(i) = uv.col(i) + (0.5 / 1090.0) * Eigen::Vector2d(N(rng), N(rng));  // half-pixel noise
    }
    Pose E = Pose::Zero();
    Eigen::VectorXd depth(4);
    CHECK(est.estimate(uv, E, depth));
    worst = std::max(worst, (E - T).cwiseAbs().maxCoeff());
    worst_depth = std::max(worst_depth, (depth - z).cwiseAbs().maxCoeff());
    Pose En;
    CHECK(est.estimate(noisy, En));
    worst_noisy = std::max(worst_noisy, std::abs(En(2, 3) - T(2, 3)));
  }
  ibvs_test::report(worst < 1e-9, "exact points give the exact pose", __FILE__, __LINE__, std::to_string(worst));
  ibvs_test::report(worst_depth < 1e-9, "and the exact depths", __FILE__, __LINE__, std::to_string(worst_depth));
  ibvs_test::report(worst_noisy < 0.02, "half-pixel noise: depth within 2 cm", __FILE__, __LINE__,
                    std::to_string(worst_noisy));
  // Degenerate images: flagged, outputs untouched.
  Points line(2, 4);
  line << 0.0, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 0.0;
  Pose E = Pose::Identity();
  Eigen::VectorXd depth = Eigen::VectorXd::Constant(4, 7.0);
  CHECK(!est.estimate(line, E, depth) && E == Pose::Identity() && depth == Eigen::VectorXd::Constant(4, 7.0));
  Points nan = line;
  nan(0, 0) = std::numeric_limits<double>::quiet_NaN();
  CHECK(!est.estimate(nan, E) && !est.estimate(line.leftCols(3), E));
  // Bad targets: not planar, too few points, all on one line.
  Eigen::Matrix3Xd bent = t.points;
  bent(2, 0) = 0.01;
  CHECK_THROWS(PlanarPose{bent});
  CHECK_THROWS(PlanarPose(Eigen::Matrix3Xd(t.points.leftCols(3))));
  Eigen::Matrix3Xd collinear = Eigen::Matrix3Xd::Zero(3, 4);
  collinear.row(0) << 0.0, 0.1, 0.2, 0.3;
  CHECK_THROWS(PlanarPose{collinear});
  CHECK_THROWS(PlanarPose(t.points, -1));
}

}  // namespace

void run_tests() {
  depth_converges();
  motion_forms_and_refusals();
  planar_pose();
}
