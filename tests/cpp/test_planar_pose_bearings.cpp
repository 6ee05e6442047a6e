// PlanarPose::estimate_bearings: the pose of a planar target from unit bearings, at any angle off
// the optical axis (beyond 90 degrees: z < 0). Exact recovery, agreement with estimate() where
// normalised points exist, pixel noise through a fisheye within the first-order bound, refusals.
#include "check.hpp"

#include "ibvs/ibvs.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

using namespace ibvs;

namespace {

constexpr double deg = 3.14159265358979323846 / 180.0;

Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> N(0, 1);
  return Eigen::Quaterniond(N(rng), N(rng), N(rng), N(rng)).normalized().toRotationMatrix();
}

// A planar target of n points (z = 0) spread over about +-half metres, not collinear.
Eigen::Matrix3Xd random_target(std::mt19937& rng, int n, double half) {
  std::uniform_real_distribution<double> U(-half, half);
  Eigen::Matrix3Xd P = Eigen::Matrix3Xd::Zero(3, n);
  for (int i = 0; i < n; ++i) P.block<2, 1>(0, i) << U(rng), U(rng);
  P.block<2, 4>(0, 0) << -half, half, half, -half, -half, -half, half, half;  // a square's corners: never collinear
  return P;
}

// camera <- target with the target's centre at colatitude `off` (radians from the optical axis),
// `dist` metres away, its plane turned at most 60 degrees from facing the camera (either side).
Pose random_pose(std::mt19937& rng, double off, double dist) {
  std::uniform_real_distribution<double> U(-3.14159, 3.14159);
  const double az = U(rng);
  const Eigen::Vector3d d(std::sin(off) * std::cos(az), std::sin(off) * std::sin(az), std::cos(off));
  Pose T = Pose::Identity();
  Eigen::Matrix3d R;
  do R = random_rotation(rng);
  while (std::abs(R.col(2).dot(d)) < std::cos(60 * deg));
  T.topLeftCorner<3, 3>() = R;
  T.topRightCorner<3, 1>() = dist * d;
  return T;
}

Eigen::Matrix3Xd camera_points(const Pose& T, const Eigen::Matrix3Xd& P) {
  Eigen::Matrix3Xd Q = T.topLeftCorner<3, 3>() * P;
  Q.colwise() += T.topRightCorner<3, 1>();
  return Q;
}

double max_angle_off_axis(const Eigen::Matrix3Xd& Q) {
  double a = 0;
  for (Eigen::Index i = 0; i < Q.cols(); ++i) a = std::max(a, std::acos(Q(2, i) / Q.col(i).norm()));
  return a;
}

// The size of the rigid motion T_a T_b^-1: |(translation, theta u)|, metres and radians.
double pose_distance(const Pose& Ta, const Pose& Tb) {
  const Pose D = Ta * se3_inverse(Tb);
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(D.topLeftCorner<3, 3>()));
  return std::hypot(D.topRightCorner<3, 1>().norm(), aa.angle());
}

// Noiseless bearings of poses with the target's centre 0 to 140 degrees off the axis (points up to
// ~150 degrees, many with z < 0): the exact pose and ranges, whatever the bearings' lengths.
void exact_recovery() {
  std::mt19937 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> U(0, 1);
  double worst = 0, worst_range = 0, widest = 0, worst_scaled = 0;
  int behind = 0;
  for (int c = 0; c < ibvs_test::cases; ++c) {
    const int n = 4 + c % 5;
    const Eigen::Matrix3Xd P = random_target(rng, n, 0.1 + 0.3 * U(rng));
    const PlanarPose est(P);
    const Pose T = random_pose(rng, 140 * deg * U(rng), 0.6 + 1.5 * U(rng));
    const Eigen::Matrix3Xd Q = camera_points(T, P);
    const Eigen::Matrix3Xd b = Q.colwise().normalized();
    Pose E = Pose::Zero();
    Eigen::VectorXd range(n);
    CHECK(est.estimate_bearings(b, E, range));
    worst = std::max(worst, (E - T).cwiseAbs().maxCoeff());
    worst_range = std::max(worst_range, (range - Q.colwise().norm().transpose()).cwiseAbs().maxCoeff());
    widest = std::max(widest, max_angle_off_axis(Q));
    behind += (Q.row(2).array() < 0).count() > 0;
    // Directions of any positive length give the same pose.
    Eigen::Matrix3Xd scaled = b;
    for (int i = 0; i < n; ++i) scaled.col(i) *= std::pow(10.0, 6 * U(rng) - 3);
    Pose Es = Pose::Zero();
    CHECK(est.estimate_bearings(scaled, Es));
    worst_scaled = std::max(worst_scaled, (Es - T).cwiseAbs().maxCoeff());
  }
  ibvs_test::report(worst < 1e-9, "exact bearings give the exact pose", __FILE__, __LINE__, std::to_string(worst));
  ibvs_test::report(worst_range < 1e-9, "and the exact ranges |P|", __FILE__, __LINE__, std::to_string(worst_range));
  ibvs_test::report(worst_scaled < 1e-9, "bearings of any length", __FILE__, __LINE__, std::to_string(worst_scaled));
  ibvs_test::report(widest > 140 * deg && behind > ibvs_test::cases / 4, "the cases reach beyond 140 degrees, z < 0",
                    __FILE__, __LINE__, std::to_string(widest / deg) + " deg, " + std::to_string(behind));
  std::printf("exact recovery: worst %.2e (pose entries), %.2e m (ranges); points up to %.1f deg off the axis, "
              "%d of %d cases with z < 0\n", worst, worst_range, widest / deg, behind, ibvs_test::cases);
  // Hand-picked: a target straight beside the camera (centre 90 degrees off the axis, z = 0) and
  // one behind it (150 degrees), facing the camera.
  const Eigen::Matrix3Xd P = random_target(rng, 4, 0.2);
  const PlanarPose est(P);
  for (const double off : {90.0, 150.0}) {
    Pose T = Pose::Identity();
    const Eigen::Vector3d d(std::sin(off * deg), 0, std::cos(off * deg));
    T.topLeftCorner<3, 3>() = Eigen::AngleAxisd(off * deg, Eigen::Vector3d::UnitY()).toRotationMatrix();
    T.topRightCorner<3, 1>() = d;
    Pose E = Pose::Zero();
    CHECK(est.estimate_bearings(camera_points(T, P), E));
    CHECK((E - T).cwiseAbs().maxCoeff() < 1e-9);
  }
}

// Where normalised points exist (points within 30 degrees of the axis), estimate() and
// estimate_bearings() give the same pose from noiseless points.
void agrees_with_estimate() {
  std::mt19937 rng(ibvs_test::seed + 1);
  std::uniform_real_distribution<double> U(0, 1);
  double worst = 0;
  for (int c = 0; c < ibvs_test::cases; ++c) {
    const Eigen::Matrix3Xd P = random_target(rng, 4 + c % 3, 0.1);
    const PlanarPose est(P);
    Pose T = random_pose(rng, 15 * deg * U(rng), 0.5 + U(rng));
    const Eigen::Matrix3Xd Q = camera_points(T, P);
    if (max_angle_off_axis(Q) > 30 * deg || (Q.row(2).array() <= 0).any()) continue;
    Points uv(2, Q.cols());
    for (Eigen::Index i = 0; i < Q.cols(); ++i) uv.col(i) = Q.block<2, 1>(0, i) / Q(2, i);
    Pose Eu = Pose::Zero(), Eb = Pose::Zero();
    CHECK(est.estimate(uv, Eu));
    Eigen::Matrix3Xd b(3, Q.cols());
    b.topRows<2>() = uv;
    b.row(2).setOnes();  // the homogeneous image points (x, y, 1) are bearings too
    CHECK(est.estimate_bearings(b, Eb));
    worst = std::max(worst, (Eu - Eb).cwiseAbs().maxCoeff());
  }
  ibvs_test::report(worst < 1e-9, "narrow views: the pose of estimate()", __FILE__, __LINE__, std::to_string(worst));
}

// Pixel noise through a fisheye (f = 300 px, 258 degrees across the sensor). To first order the
// Gauss-Newton minimiser of |r(xi)|^2, r(xi) ~ r0 + J xi (r the residuals (I - b b^T) s of the
// measured bearings b at the true pose's directions s, J their Jacobian for the pose's twist xi),
// is xi = -J^+ r0, so |xi| <= |r0| / sigma_min(J). J by central differences of r here. The bound
// holds up to second-order terms (|r0| ~ 2e-3 rad): checked with a factor 1.2.
void fisheye_noise() {
  Eigen::Matrix3d K;
  K << 300.0, 0.0, 640.0, 0.0, 300.5, 512.0, 0.0, 0.0, 1.0;
  const CameraModel fish =
      CameraModel::from_opencv(K, Eigen::Vector4d(-0.013, 0.02, -0.012, 0.002), 1280, 1024, true);
  std::mt19937 rng(ibvs_test::seed + 2);
  std::uniform_real_distribution<double> U(0, 1);
  std::normal_distribution<double> N(0, 0.5);  // half-pixel noise
  double worst_ratio = 0, worst_error = 0, widest = 0;
  int ran = 0;
  for (int c = 0; c < ibvs_test::cases; ++c) {
    const Eigen::Matrix3Xd P = random_target(rng, 4 + c % 5, 0.25);
    const PlanarPose est(P);
    const Pose T = random_pose(rng, 115 * deg * U(rng), 0.8 + U(rng));
    const Eigen::Matrix3Xd Q = camera_points(T, P);
    const Eigen::Index n = Q.cols();
    Points px(2, n);
    Eigen::Matrix3Xd b(3, n);
    if (fish.from_bearing(Q, px) > 0) continue;
    px += Points::NullaryExpr(2, n, [&](Eigen::Index, Eigen::Index) { return N(rng); });
    if ((px.row(0).array() < 0).any() || (px.row(0).array() > 1280).any() || (px.row(1).array() < 0).any() ||
        (px.row(1).array() > 1024).any() || fish.to_bearing(px, b) > 0)
      continue;  // off the sensor
    const auto residual = [&](const Pose& E) {
      Eigen::VectorXd r(3 * n);
      const Eigen::Matrix3Xd S = camera_points(E, P).colwise().normalized();
      for (Eigen::Index i = 0; i < n; ++i) r.segment<3>(3 * i) = S.col(i) - S.col(i).dot(b.col(i)) * b.col(i);
      return r;
    };
    Eigen::MatrixXd J(3 * n, 6);
    for (int k = 0; k < 6; ++k) {
      Twist h = Twist::Zero();
      h(k) = 1e-6;
      J.col(k) = (residual(se3_exp(-h) * T) - residual(se3_exp(h) * T)) / 2e-6;  // T <- exp(-d) T moves r by J d
    }
    const double bound = residual(T).norm() / Eigen::JacobiSVD<Eigen::MatrixXd>(J).singularValues()(5);
    Pose E;
    CHECK(est.estimate_bearings(b, E));
    const double error = pose_distance(T, E);
    worst_ratio = std::max(worst_ratio, error / bound);
    worst_error = std::max(worst_error, error);
    widest = std::max(widest, max_angle_off_axis(Q));
    ++ran;
  }
  ibvs_test::report(worst_ratio < 1.2, "half-pixel noise: within the first-order bound", __FILE__, __LINE__,
                    std::to_string(worst_ratio));
  ibvs_test::report(ran > ibvs_test::cases / 2 && widest > 110 * deg, "cases on the sensor, beyond 110 degrees",
                    __FILE__, __LINE__, std::to_string(ran) + ", " + std::to_string(widest / deg));
  std::printf("fisheye, 0.5 px noise: %d cases, points up to %.1f deg off the axis; pose error at most %.3f of the "
              "first-order bound (largest %.2e)\n", ran, widest / deg, worst_ratio, worst_error);
}

// Refused: four points whose bearings lie in one plane (the camera centre in the target's plane)
// or repeat, a bearing pointing away from its point, wrong sizes, non-finite or zero bearings; T and range unchanged. Bearings all
// reversed are consistent (the scene reflected through the camera centre): that pose.
void refusals() {
  std::mt19937 rng(ibvs_test::seed + 3);
  const Eigen::Matrix3Xd P = random_target(rng, 5, 0.2);
  const PlanarPose est(P);
  const Pose T = random_pose(rng, 100 * deg, 1.0);
  const Eigen::Matrix3Xd b = camera_points(T, P).colwise().normalized();
  const Pose keep = Pose::Constant(7.0);
  Pose E = keep;
  Eigen::VectorXd range = Eigen::VectorXd::Constant(5, 7.0);
  // The camera centre in the target's plane: every bearing in one plane through the centre, n^T H = 0
  // for its normal n (3 equations) and one equation per point within it, 9 - 1 unknowns: four points
  // leave the DLT's null space two-dimensional (refused), five determine H and the pose.
  Pose edge = T;
  edge.topRightCorner<3, 1>() = -T.topLeftCorner<3, 3>() * Eigen::Vector3d(0.6, -0.3, 0.0);
  const PlanarPose four(P.leftCols(4));
  Eigen::VectorXd range4 = Eigen::VectorXd::Constant(4, 7.0);
  CHECK(!four.estimate_bearings(camera_points(edge, P.leftCols(4)), E, range4) && E == keep && range4(0) == 7.0);
  CHECK(est.estimate_bearings(camera_points(edge, P), E) && (E - edge).cwiseAbs().maxCoeff() < 1e-9);
  E = keep;
  // Fewer than four distinct directions: three of the four bearings alike.
  Eigen::Matrix3Xd alike = camera_points(T, P.leftCols(4));
  alike.col(1) = alike.col(2) = alike.col(0);
  CHECK(!four.estimate_bearings(alike, E) && E == keep);
  for (int i = 0; i < 5; ++i) {  // one bearing pointing away from its point
    Eigen::Matrix3Xd away = b;
    away.col(i) *= -1.0;
    CHECK(!est.estimate_bearings(away, E, range) && E == keep && range(0) == 7.0);
  }
  CHECK(est.estimate_bearings(-b, E));  // all reversed: the points at -P, along their bearings
  CHECK((camera_points(E, P) + camera_points(T, P)).cwiseAbs().maxCoeff() < 1e-9);
  E = keep;
  Eigen::Matrix3Xd bad = b;
  bad(1, 2) = std::numeric_limits<double>::quiet_NaN();
  CHECK(!est.estimate_bearings(bad, E) && E == keep);
  CHECK_THROWS(est.validate_bearings(bad));
  bad.col(2).setZero();
  CHECK(!est.estimate_bearings(bad, E) && E == keep);
  CHECK_THROWS(est.validate_bearings(bad));
  bad(0, 2) = std::numeric_limits<double>::infinity();
  CHECK(!est.estimate_bearings(bad, E) && E == keep);
  CHECK(!est.estimate_bearings(b.leftCols(4), E) && E == keep);
  CHECK_THROWS(est.validate_bearings(b.leftCols(4)));
  Eigen::VectorXd short_range(4);
  CHECK(!est.estimate_bearings(b, E, short_range) && E == keep);
  est.validate_bearings(b);  // no throw
  // The messages name the argument and the column.
  try {
    est.validate_bearings(bad);
    CHECK(false);
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()) == "ibvs: bearings[2] is not finite");
  }
  bad.col(2).setZero();
  try {
    est.validate_bearings(bad);
    CHECK(false);
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("bearings[2] has zero length") != std::string::npos);
  }
  // Huge and tiny finite bearings are directions like any other.
  CHECK(est.estimate_bearings(1e300 * b, E) && (E - T).cwiseAbs().maxCoeff() < 1e-9);
  CHECK(est.estimate_bearings(1e-300 * b, E) && (E - T).cwiseAbs().maxCoeff() < 1e-9);
}

}  // namespace

void run_tests() {
  exact_recovery();
  agrees_with_estimate();
  fisheye_noise();
  refusals();
}
