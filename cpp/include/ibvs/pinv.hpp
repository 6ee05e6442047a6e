// Pseudoinverses of an M x 6 image Jacobian: Moore-Penrose (damping 0) and
// damped least squares J+ = (J^T J + lambda^2 I)^-1 J^T (damping lambda > 0).
//
// Both are one formula on the SVD J = U S V^T: J+ = V diag(phi(s_i)) U^T with
//   phi(s) = s / (s^2 + lambda^2)              for lambda > 0,
//   phi(s) = 1 / s if s > tol, else 0          for lambda = 0,
// tol = max(M, 6) * eps * s_max (numerical rank, as Eigen and numpy use).
#pragma once

#include "ibvs/features.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <limits>

namespace ibvs {

/// Relative singular-value threshold of the undamped pseudoinverse.
inline double rank_tolerance(Eigen::Index rows, double sigma_max) noexcept {
  return static_cast<double>(std::max<Eigen::Index>(rows, 6)) * std::numeric_limits<double>::epsilon() * sigma_max;
}

/// The filter factor phi(s) above.
inline double pinv_factor(double sigma, double damping, double tol) noexcept {
  if (damping > 0.0) return sigma / (sigma * sigma + damping * damping);
  return sigma > tol ? 1.0 / sigma : 0.0;
}

/// The 6 x M (damped) pseudoinverse of J (M x 6). Allocates; throws
/// std::invalid_argument for M = 0, non-finite entries or damping < 0.
Eigen::Matrix<double, 6, Eigen::Dynamic> damped_pinv(const Eigen::Ref<const MatrixX6>& J, double damping = 0.0);

/// Singular values of J in decreasing order (min(M, 6) of them). Allocates.
Eigen::VectorXd singular_values(const Eigen::Ref<const MatrixX6>& J);

}  // namespace ibvs
