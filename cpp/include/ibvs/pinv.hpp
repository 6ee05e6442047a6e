// Pseudoinverses of an M x 6 image Jacobian: Moore-Penrose (damping 0) and
// damped least squares J+ = (J^T J + lambda^2 I)^-1 J^T (damping lambda > 0).
//
// Both are one formula on the SVD J = U S V^T: J+ = V diag(phi(s_i)) U^T with
//   phi(s) = s / (s^2 + lambda^2)   if s > tol, else 0
// (1 / s for lambda = 0), tol = max(M, 6) * eps * s_max: the numerical rank,
// as Eigen and numpy use. Singular values at or below tol are the rounding
// noise of zero ones, dropped for every lambda: kept, a tiny lambda would
// amplify that noise by up to 1 / (2 lambda). So damped_pinv(J, lambda) tends
// to damped_pinv(J, 0) as lambda -> 0.
#pragma once

#include "ibvs/features.hpp"
#include "ibvs/limits.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>

namespace ibvs {

/// Relative singular-value threshold of the undamped pseudoinverse.
inline double rank_tolerance(Eigen::Index rows, double sigma_max) noexcept {
  return static_cast<double>(std::max<Eigen::Index>(rows, 6)) * std::numeric_limits<double>::epsilon() * sigma_max;
}

/// Status::singular of the servos: sigma_min <= singular_tolerance(M) sigma_max,
/// sqrt(max(M, 6) eps) (6e-8 for 16 rows): J is rank-deficient to what its
/// normal matrix J^T J can resolve (its rounding is ~M eps sigma_max^2).
inline double singular_tolerance(Eigen::Index rows) noexcept {
  return std::sqrt(static_cast<double>(std::max<Eigen::Index>(rows, 6)) * std::numeric_limits<double>::epsilon());
}

/// The filter factor phi(s) above, evaluated without overflow or underflow
/// (s / (s^2 + lambda^2) on operands scaled by max(s, lambda)).
inline double pinv_factor(double sigma, double damping, double tol) noexcept {
  if (!(sigma > tol)) return 0.0;
  if (!(damping > 0.0)) return 1.0 / sigma;
  const double m = std::max(sigma, damping), a = sigma / m, b = damping / m;
  return a / ((a * a + b * b) * m);
}

/// The 6 x M (damped) pseudoinverse of J (M x 6). Allocates; throws
/// std::invalid_argument for M = 0, non-finite entries, entries above
/// max_matrix_entry, a nonzero J whose entries all lie below
/// 1 / max_matrix_entry, damping < 0 or damping > max_matrix_entry.
Eigen::Matrix<double, 6, Eigen::Dynamic> damped_pinv(const Eigen::Ref<const MatrixX6>& J, double damping = 0.0);

/// Singular values of J in decreasing order (min(M, 6) of them). Allocates;
/// throws for M = 0, non-finite entries or entries above max_matrix_entry.
Eigen::VectorXd singular_values(const Eigen::Ref<const MatrixX6>& J);

}  // namespace ibvs
