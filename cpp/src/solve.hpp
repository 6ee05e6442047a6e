// The two pseudoinverse routes of Servo::update, x = J+ e, on a Jacobian and
// error already assembled. Internal to the library (not installed); the
// benchmark includes it too, so that "pseudoinverse alone" times exactly the
// code the servo runs.
#pragma once

#include "ibvs/features.hpp"
#include "ibvs/pinv.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>

namespace ibvs::detail {

/// Solver workspace for one row count: Rows = 8 or 16 (fully unrolled fixed
/// sizes) or Dynamic with at most MaxRows rows (a compile-time bound keeps
/// Eigen's temporaries, e.g. inside the Householder QR, on the stack). J has
/// max(M, 6) rows with rows past M zero, so the QR is always of a tall matrix
/// ([J; 0]+ = [J+, 0]: the solution is unchanged).
template <int Rows, int MaxRows = Rows>
struct Solver {
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  using Jac = Eigen::Matrix<double, Rows, 6, Eigen::ColMajor, MaxRows, 6>;
  using Vec = Eigen::Matrix<double, Rows, 1, Eigen::ColMajor, MaxRows, 1>;

  explicit Solver(Eigen::Index rows)
      : qte(Vec::Zero(rows)), A(Matrix6::Zero()), qr(rows, 6), svd(6, 6, Eigen::ComputeFullU | Eigen::ComputeFullV) {}

  Vec qte;
  Matrix6 A;
  Eigen::LLT<Matrix6> llt;
  Eigen::SelfAdjointEigenSolver<Matrix6> eig;
  Eigen::HouseholderQR<Jac> qr;
  Eigen::JacobiSVD<Matrix6> svd;

  /// A = J^T J, the normal matrix both functions below start from.
  void normal(const Jac& J) noexcept { A.noalias() = J.transpose().lazyProduct(J); }

  /// After normal(): sigma_min, sigma_max of J from the eigenvalues of J^T J;
  /// true when J is rank-deficient to what those can resolve
  /// (sigma_min <= sqrt(eps) sigma_max).
  bool diagnostics(double& smin, double& smax) noexcept {
    eig.compute(A, Eigen::EigenvaluesOnly);
    smin = std::sqrt(std::max(eig.eigenvalues()(0), 0.0));
    smax = std::sqrt(std::max(eig.eigenvalues()(5), 0.0));
    return !(smin > 1.5e-8 * smax);
  }

  /// After normal(): damped least squares, lambda > 0, by Cholesky of the 6x6
  /// normal equations (J^T J + lambda^2 I) x = J^T e (pinv.hpp's formula
  /// without forming J+). Consumes A.
  void damped(const Jac& J, const Vec& e, double lambda, Twist& x) noexcept {
    A.diagonal().array() += lambda * lambda;
    llt.compute(A);
    x.noalias() = J.transpose().lazyProduct(e);
    llt.solveInPlace(x);
  }

  /// Moore-Penrose, lambda = 0: QR of J, then an SVD of its 6x6 R factor (far
  /// cheaper than an SVD of J), singular values below rank_tolerance(m, .)
  /// dropped. Returns true when J is rank-deficient; m = rows in use.
  bool moore_penrose(const Jac& J, const Vec& e, Eigen::Index m, Twist& x, double& smin, double& smax) noexcept {
    qr.compute(J);
    const Matrix6 R = qr.matrixQR().template topRows<6>().template triangularView<Eigen::Upper>();
    svd.compute(R);
    qte = e;
    qte.applyOnTheLeft(qr.householderQ().transpose());
    const auto& s = svd.singularValues();
    smin = s(5);
    smax = s(0);
    const double tol = rank_tolerance(m, smax);
    Twist y = svd.matrixU().transpose() * qte.template head<6>();
    for (int i = 0; i < 6; ++i) y(i) *= pinv_factor(s(i), 0.0, tol);
    x.noalias() = svd.matrixV() * y;
    return !(smin > tol);
  }
};

}  // namespace ibvs::detail
