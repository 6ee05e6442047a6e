// The one finiteness check of user and measured data (validate(), update(),
// the bindings): every entry finite, NaN and +-inf refused wherever they sit,
// and, separately, every magnitude within a bound. A comparison such as
// `x.cwiseAbs().maxCoeff() <= bound` alone is not such a check: a comparison
// with NaN is false, and which entry maxCoeff() returns when one is NaN depends
// on where it sits (Eigen leaves NaN propagation unspecified by default), so a
// NaN in the second entry can pass. tests/python/test_finite_checks.py forbids
// that pattern everywhere else in cpp/ and python/. Allocation-free, noexcept.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>

namespace ibvs {

/// Every entry of x finite and |x_ij| <= bound (true for an empty x).
template <class Derived>
bool finite_within(const Eigen::DenseBase<Derived>& x, double bound) noexcept {
  if (!x.derived().allFinite()) return false;
  for (Eigen::Index j = 0; j < x.cols(); ++j)
    for (Eigen::Index i = 0; i < x.rows(); ++i)
      if (!(std::abs(x.derived().coeff(i, j)) <= bound)) return false;
  return true;
}

/// A scalar finite and |x| <= bound.
inline bool finite_within(double x, double bound) noexcept { return std::isfinite(x) && std::abs(x) <= bound; }

/// The largest |x_ij| of a matrix already known finite (0 for an empty one): a scale, not a check.
template <class Derived>
double largest_magnitude(const Eigen::DenseBase<Derived>& x) noexcept {
  double m = 0.0;
  for (Eigen::Index j = 0; j < x.cols(); ++j)
    for (Eigen::Index i = 0; i < x.rows(); ++i) m = std::max(m, std::abs(x.derived().coeff(i, j)));
  return m;
}

}  // namespace ibvs
