#include "ibvs/depth_estimator.hpp"

#include "checks.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs {

namespace {

using detail::fail;

using detail::number;

void check_prior(const Eigen::Ref<const Eigen::VectorXd>& prior) {
  if (prior.size() < 1) fail("prior must hold at least one depth");
  for (Eigen::Index i = 0; i < prior.size(); ++i)
    if (!detail::valid_depth(prior(i)))
      fail("prior[" + std::to_string(i) + "] = " + number(prior(i)) + " m must be in [" + number(min_depth) + ", " +
           number(max_depth) + "] m");
}

void check_options(const DepthEstimatorOptions& o) {
  const auto in = [](double x, double lo, double hi, const char* name) {
    if (!(x >= lo && x <= hi))
      fail(std::string(name) + " must be in [" + number(lo) + ", " + number(hi) + "], got " + number(x));
  };
  in(o.point_noise, 0.0, max_normalized_coordinate, "point_noise");
  in(o.position_noise, 0.0, max_normalized_coordinate, "position_noise");
  in(o.process_noise, 0.0, max_estimator_noise, "process_noise");
  in(o.prior_uncertainty, 0.0, max_estimator_noise, "prior_uncertainty");
  if (!(o.prior_uncertainty > 0.0)) fail("prior_uncertainty must be > 0, got 0");
  in(o.min_depth, min_depth, max_depth, "min_depth");
  if (!(o.max_depth_ratio > 1.0 && o.max_depth_ratio <= max_depth / min_depth))
    fail("max_depth_ratio must be in (1, " + number(max_depth / min_depth) + "], got " + number(o.max_depth_ratio));
}

// The camera's motion between frames: rigid, its translation within max_depth (the same test for
// validate() and update()).
bool valid_motion(const Pose& motion) noexcept {
  if (!motion.allFinite() || !finite_within(motion.topRightCorner<3, 1>(), max_depth)) return false;
  const Eigen::Matrix3d R = motion.topLeftCorner<3, 3>();
  return (R.transpose() * R).isIdentity(1e-9) && std::abs(R.determinant() - 1.0) <= 1e-9 && motion(3, 0) == 0.0 &&
         motion(3, 1) == 0.0 && motion(3, 2) == 0.0 && motion(3, 3) == 1.0;
}

}  // namespace

DepthEstimator::DepthEstimator(const Eigen::Ref<const Eigen::VectorXd>& prior, DepthEstimatorOptions options)
    : options_(options), prior_(prior) {
  check_prior(prior);
  check_options(options);
  const Eigen::Index n = prior_.size();
  state_.resize(3, n);
  cov_.assign(static_cast<std::size_t>(n), Eigen::Matrix3d::Zero());
  depth_ = prior_;
  variance_.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {  // the prior's, to first order: var z = var rho / rho^4 = (u z)^2
    const double s = options_.prior_uncertainty * prior_(i);
    variance_(i) = s * s;
  }
}

void DepthEstimator::reset(const Eigen::Ref<const Eigen::VectorXd>& prior) {
  check_prior(prior);
  if (prior.size() != prior_.size())
    fail("prior must hold " + std::to_string(prior_.size()) + " depths (this estimator's points), got " +
         std::to_string(prior.size()));
  prior_ = prior;
  for (Eigen::Index i = 0; i < prior_.size(); ++i) {
    depth_(i) = prior_(i);
    const double s = options_.prior_uncertainty * prior_(i);
    variance_(i) = s * s;
  }
  reset();
}

// Variance of a measured coordinate: the point noise plus a floor (see the header).
double DepthEstimator::measurement_variance() const noexcept {
  return options_.point_noise * options_.point_noise + 1e-10;
}

void DepthEstimator::initialize(const Eigen::Ref<const Points>& uv) noexcept {
  const double r = measurement_variance();
  for (Eigen::Index i = 0; i < prior_.size(); ++i) {
    const double rho = 1.0 / prior_(i), s = options_.prior_uncertainty * rho;
    state_.col(i) << uv.col(i), rho;
    cov_[static_cast<std::size_t>(i)] = Eigen::Vector3d(r, r, s * s).asDiagonal();
  }
  initialized_ = true;
}

void DepthEstimator::finish() noexcept {
  for (Eigen::Index i = 0; i < prior_.size(); ++i) {
    const double rho = state_(2, i);
    depth_(i) = 1.0 / rho;
    variance_(i) = cov_[static_cast<std::size_t>(i)](2, 2) / (rho * rho * rho * rho);
  }
}

bool DepthEstimator::update(const Eigen::Ref<const Points>& uv, const Twist& twist, double dt) noexcept {
  if (!twist.allFinite() || !std::isfinite(dt)) return false;
  return update(uv, Pose(se3_exp(twist * dt)));
}

bool DepthEstimator::update(const Eigen::Ref<const Points>& uv, const Pose& motion) noexcept {
  restarts_ = 0;
  if (uv.cols() != prior_.size() || !detail::valid_points(uv) || !valid_motion(motion)) return false;
  if (!initialized_) {
    initialize(uv);
    finish();
    return true;
  }
  const Eigen::Matrix3d Rt = motion.topLeftCorner<3, 3>().transpose();
  const Eigen::Vector3d t = motion.topRightCorner<3, 1>();
  const double r = measurement_variance();
  const double qxy = options_.position_noise * options_.position_noise;
  const double qrho = options_.process_noise * options_.process_noise;
  for (Eigen::Index i = 0; i < prior_.size(); ++i) {
    Eigen::Matrix3d& Pi = cov_[static_cast<std::size_t>(i)];
    const Eigen::Vector3d s0 = state_.col(i);
    const double x = s0(0), y = s0(1), rho = s0(2);
    // predict: the point (x, y, 1) / rho in the previous frame, seen from the current one
    const Eigen::Vector3d P = Eigen::Vector3d(x, y, 1.0) / rho;
    const Eigen::Vector3d Q = Rt * (P - t);
    const double iz = 1.0 / Q(2);
    Eigen::Vector3d s(Q(0) * iz, Q(1) * iz, iz);
    // its Jacobian d s / d s0 = d s / d Q * R^T * d P / d s0
    Eigen::Matrix3d dP;
    dP << 1.0 / rho, 0.0, -x / (rho * rho),  //
        0.0, 1.0 / rho, -y / (rho * rho),     //
        0.0, 0.0, -1.0 / (rho * rho);
    Eigen::Matrix3d dS;
    dS << iz, 0.0, -Q(0) * iz * iz,  //
        0.0, iz, -Q(1) * iz * iz,     //
        0.0, 0.0, -iz * iz;
    const Eigen::Matrix3d F = dS * Rt * dP;
    Eigen::Matrix3d C = F * Pi * F.transpose();
    C(0, 0) += qxy;
    C(1, 1) += qxy;
    C(2, 2) += qrho * rho * rho;
    // update with the measured point (H = [I2 0])
    const Eigen::Matrix2d S = C.topLeftCorner<2, 2>() + r * Eigen::Matrix2d::Identity();
    const Eigen::Matrix<double, 3, 2> K = C.leftCols<2>() * S.inverse();
    s += K * (uv.col(i) - s.head<2>());
    // Joseph form, (I - K H) C (I - K H)^T + K R K^T: positive semi-definite by construction. The
    // short form C - K H C subtracts nearly equal numbers when a precise measurement brings a large
    // predicted variance down by eight orders of magnitude, and can come out negative (it did, at
    // the first update of the simulator's noise-free general-motion case).
    Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
    A.leftCols<2>() -= K;
    C = (A * C * A.transpose() + r * K * K.transpose()).eval();
    C = 0.5 * (C + C.transpose()).eval();  // keep it symmetric
    // A prediction behind the camera, or a filter that turns non-finite or loses a positive variance,
    // carries no information: restart from the prior.
    if (!(Q(2) > 0.0) || !s.allFinite() || !C.allFinite() || !(C(0, 0) > 0.0 && C(1, 1) > 0.0 && C(2, 2) > 0.0)) {
      const double rho0 = 1.0 / prior_(i), sd = options_.prior_uncertainty * rho0;
      s << uv.col(i), rho0;
      C = Eigen::Vector3d(r, r, sd * sd).asDiagonal();
      ++restarts_;
    }
    // depth within [min_depth, max_depth_ratio * prior]; a prior so small that this range is empty keeps min_depth
    const double rho_max = 1.0 / options_.min_depth;
    s(2) = std::clamp(s(2), std::min(1.0 / (options_.max_depth_ratio * prior_(i)), rho_max), rho_max);
    state_.col(i) = s;
    Pi = C;
  }
  finish();
  return true;
}

void DepthEstimator::validate(const Eigen::Ref<const Points>& uv, const Pose& motion) const {
  if (uv.cols() != prior_.size())
    fail("uv must hold " + std::to_string(prior_.size()) + " points (this estimator's), got " +
         std::to_string(uv.cols()));
  detail::check_points(uv, "uv", static_cast<int>(uv.cols()));
  if (!valid_motion(motion))
    fail("motion must be a rigid transform (orthonormal rotation, last row 0 0 0 1) moving at most " +
         number(max_depth) + " m");
}

}  // namespace ibvs
