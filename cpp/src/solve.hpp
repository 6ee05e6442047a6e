// The pseudoinverse routes of Servo::update, x = J+ e, on a Jacobian and error
// already assembled, and the diagnostics sigma_min / sigma_max of J. Internal
// to the library (not installed); the benchmark includes it too, so that
// "pseudoinverse alone" times exactly the code the servo runs.
//
// Two routes, one decision (Solver::solve):
//  * normal: N = J^T J + lambda^2 I (6x6), its Cholesky factor L and L^-1,
//    x = N^-1 J^T e, then one step of iterative refinement whose residual is
//    taken from J itself, r = J^T (e - J x) - lambda^2 x (the corrected
//    semi-normal equations, Bjorck 1996, Sec. 2.9): forming J^T J squares the
//    condition number, the refinement step gives the accuracy back. About 1.5k
//    flops for 16 rows.
//  * robust: QR of J, SVD of its 6x6 R factor, phi(s) of pinv.hpp on the
//    singular values (those at or below rank_tolerance dropped): the formula
//    of damped_pinv(), for any J and lambda; about 5 us.
// The normal route is taken when the Cholesky factorisation succeeds and
//   tr(N) * tr(N^-1) <= normal_route_limit(lambda)
// (tr(N^-1) = |L^-1|_F^2). This product bounds cond(N) from above and is at
// most 36 cond(N), so it is a cheap test that cannot miss an ill-conditioned N.
// The limit is 1e10 for lambda = 0 (refined twists agree with the robust route
// to ~1e-10 up to cond(N) = 1e10: cond(J) = 1e5) and 1e7 for lambda > 0: a
// rank-deficient J gives N null directions whose rounding noise is amplified
// by 1/lambda^2 and no refinement removes it (relative size ~1e-17 cond(N),
// measured), while the robust route drops them. Rank-deficient J with
// lambda = 0 (fewer than 3 points, the mean Jacobian at the half-turn) fails
// the test (cond(N) ~ 1/eps^2, or the factorisation fails) and takes the
// robust route.
//
// Diagnostics (Status::singular; sigma_min, sigma_max of J), when asked for:
//  * Status::singular (sigma_min <= singular_tolerance(M) sigma_max, 6e-8 for
//    M = 16) comes from the route decision itself: J^T J that passed the
//    full-rank test has cond(J) <= 1e5, so it is not singular (on the damped
//    route J^T J is factored and tested too, ~0.1 us); otherwise the exact
//    singular values decide (the robust route has them; a damped J that fails
//    the test gets them from a QR of J and an SVD of R).
//  * sigma_min, sigma_max are then computed only when read
//    (ServoOutput::sigma_min()), from the J^T J the update kept: its exact
//    eigenvalues (symmetric_eigenvalues below, ~0.5 us; absolute error
//    ~eps sigma_max^2, so sigma_max to rounding and sigma_min to relative
//    ~eps cond(J)^2: <= ~1e-6 where the test passed, ~1e-10 on the paper's
//    frames). Iterative estimates from the Cholesky factor (inverse
//    iteration for sigma_min, power steps for sigma_max, with blocks of two
//    Ritz vectors, warm-started, each certified by an inertia test) were
//    built and measured first: IBVS spectra have clusters of 3-4 small
//    eigenvalues (a symmetric target), on which they cost as much as the
//    exact eigenvalues (~5k instructions) and, without a certificate, can
//    follow the wrong eigenvector through an exact crossing.
//  * exact: QR of J and the singular values of R (JacobiSVD), ~4 us, every
//    frame (sigma_min to eps sigma_max: better than any value from J^T J).
// Status::singular: sigma_min <= singular_tolerance(M) sigma_max.
#pragma once

#include "ibvs/features.hpp"
#include "ibvs/pinv.hpp"
#include "robust.hpp"
#include "ibvs/task.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace ibvs::detail {

/// Which route solved a frame.
enum class Route : std::uint8_t { normal = 0, robust = 1 };

/// What to compute besides the twist: nothing; what Status::singular needs,
/// the singular values being computed later on demand from J^T J (lazy); or
/// the exact singular values now.
enum class Diagnostics : std::uint8_t { off = 0, lazy = 1, exact = 2 };

/// What solve() found out about J's singular values.
struct Spectrum {
  bool known = false;     ///< smin / smax hold the singular values (exact)
  bool singular = false;  ///< smin <= singular_tolerance(M) smax (decided whenever diagnostics are on)
  double smin = std::numeric_limits<double>::quiet_NaN(), smax = std::numeric_limits<double>::quiet_NaN();
};

/// The normal route is accurate while tr(N) tr(N^-1) stays below this (see above).
inline double normal_route_limit(double lambda) noexcept { return lambda > 0.0 ? 1e7 : 1e10; }

using Matrix6 = Eigen::Matrix<double, 6, 6>;

// Fully unrolled loops of fixed trip counts (GCC and Clang): the same operations in the same
// order, so the same results bit for bit, without the loop overhead of the triangular loops
// (measured with callgrind: a third of Normal::factor's instructions).
#if defined(__GNUC__) || defined(__clang__)
#define IBVS_UNROLL _Pragma("GCC unroll 8")
#else
#define IBVS_UNROLL
#endif

/// Cholesky factorisation of a 6x6 symmetric matrix (lower triangle read), the
/// inverse of its factor, and the condition bound tr(N) tr(N^-1). Hand-written
/// (fixed size, fully unrolled by the compiler, no pivoting).
struct Normal {
  Matrix6 L = Matrix6::Zero();   ///< lower Cholesky factor, N = L L^T
  Matrix6 Li = Matrix6::Zero();  ///< L^-1 (lower)
  double bound = std::numeric_limits<double>::infinity();  ///< tr(N) tr(N^-1) >= cond(N); inf if not factored

  /// False when N is not numerically positive definite (a pivot not > 0) or
  /// the bound is not finite; the upper triangles of L and Li stay zero.
  bool factor(const Matrix6& N) noexcept {
    bound = std::numeric_limits<double>::infinity();
    IBVS_UNROLL
    for (int j = 0; j < 6; ++j) {
      double d = N(j, j);
      IBVS_UNROLL
      for (int k = 0; k < j; ++k) d -= L(j, k) * L(j, k);
      if (!(d > 0.0)) return false;
      const double ljj = std::sqrt(d), inv = 1.0 / ljj;
      L(j, j) = ljj;
      Li(j, j) = inv;
      IBVS_UNROLL
      for (int i = j + 1; i < 6; ++i) {
        double s = N(i, j);
        IBVS_UNROLL
        for (int k = 0; k < j; ++k) s -= L(i, k) * L(j, k);
        L(i, j) = s * inv;
      }
    }
    // L^-1 column by column (forward substitution of the unit vectors).
    IBVS_UNROLL
    for (int j = 0; j < 6; ++j)
      IBVS_UNROLL
      for (int i = j + 1; i < 6; ++i) {
        double s = 0.0;
        IBVS_UNROLL
        for (int k = j; k < i; ++k) s -= L(i, k) * Li(k, j);
        Li(i, j) = s * Li(i, i);
      }
    bound = N.trace() * Li.squaredNorm();
    return std::isfinite(bound);
  }
};

/// Eigenvalues (ascending) of a symmetric 6x6 matrix, lower triangle read:
/// Householder reduction to tridiagonal form, then implicit symmetric QR steps
/// with the Wilkinson shift, deflating from the bottom (Golub & Van Loan,
/// Matrix Computations, Algorithms 8.3.1 and 8.3.3), eigenvalues only.
/// Fixed size and hand-written: about half the instructions of Eigen's
/// SelfAdjointEigenSolver; absolute error ~eps * max |eigenvalue|. False if
/// the QR steps have not converged after 30 per eigenvalue (never seen).
inline bool symmetric_eigenvalues(const Matrix6& A, double ev[6]) noexcept {
  constexpr int n = 6;
  double a[n][n];  // full symmetric copy, a[i][j] = A(i, j)
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) a[i][j] = A(std::max(i, j), std::min(i, j));
  double d[n], e[n];  // diagonal and sub-diagonal (e[k] couples k and k+1)
  for (int k = 0; k < n - 2; ++k) {
    // Householder reflection I - beta v v^T mapping column k below the sub-diagonal to alpha e_(k+1).
    double sigma = 0.0;
    for (int i = k + 2; i < n; ++i) sigma += a[i][k] * a[i][k];
    const double x0 = a[k + 1][k];
    d[k] = a[k][k];
    if (sigma == 0.0) {
      e[k] = x0;
      continue;
    }
    const double mu = std::sqrt(x0 * x0 + sigma);
    const double alpha = x0 <= 0.0 ? mu : -mu;  // the sign that avoids cancellation in v
    double v[n], w[n];
    v[k + 1] = x0 - alpha;
    for (int i = k + 2; i < n; ++i) v[i] = a[i][k];
    const double beta = 1.0 / (mu * (mu + std::abs(x0)));  // 2 / |v|^2
    e[k] = alpha;
    // Trailing block S <- H S H = S - v w^T - w v^T with w = p - (beta/2)(v.p) v, p = beta S v.
    double vp = 0.0;
    for (int i = k + 1; i < n; ++i) {
      double t = 0.0;
      for (int j = k + 1; j < n; ++j) t += a[i][j] * v[j];
      w[i] = beta * t;
      vp += v[i] * w[i];
    }
    const double K = 0.5 * beta * vp;
    for (int i = k + 1; i < n; ++i) w[i] -= K * v[i];
    for (int j = k + 1; j < n; ++j)
      for (int i = k + 1; i < n; ++i) a[i][j] -= v[i] * w[j] + w[i] * v[j];
  }
  d[n - 2] = a[n - 2][n - 2];
  d[n - 1] = a[n - 1][n - 1];
  e[n - 2] = a[n - 1][n - 2];
  e[n - 1] = 0.0;
  const double eps = std::numeric_limits<double>::epsilon();
  const auto negligible = [&](int k) { return std::abs(e[k]) <= eps * (std::abs(d[k]) + std::abs(d[k + 1])); };
  int q = n - 1;  // bottom of the unreduced block
  for (int step = 0; q > 0; ++step) {
    if (step > 30 * n) return false;
    if (negligible(q - 1)) {
      --q;
      continue;
    }
    int p = q - 1;
    while (p > 0 && !negligible(p - 1)) --p;
    // Wilkinson shift: the eigenvalue of the trailing 2x2 nearer d[q].
    const double t = 0.5 * (d[q - 1] - d[q]), b2 = e[q - 1] * e[q - 1];
    const double shift = d[q] - b2 / (t + std::copysign(std::sqrt(t * t + b2), t));
    // Chase the bulge down the block with Givens rotations [c s; -s c].
    double x = d[p] - shift, z = e[p];
    for (int k = p; k < q; ++k) {
      const double r = std::sqrt(x * x + z * z);
      const double c = r > 0.0 ? x / r : 1.0, s = r > 0.0 ? z / r : 0.0;
      if (k > p) e[k - 1] = r;
      const double dk = d[k], dk1 = d[k + 1], ek = e[k];
      d[k] = c * c * dk + 2.0 * c * s * ek + s * s * dk1;
      d[k + 1] = s * s * dk - 2.0 * c * s * ek + c * c * dk1;
      e[k] = c * s * (dk1 - dk) + (c * c - s * s) * ek;
      if (k < q - 1) {
        x = e[k];
        z = s * e[k + 1];
        e[k + 1] *= c;
      }
    }
  }
  for (int i = 0; i < n; ++i) ev[i] = d[i];
  std::sort(ev, ev + n);
  return true;
}

/// Solver workspace for one row count: Rows = 8 or 16 (fully unrolled fixed
/// sizes) or Dynamic with at most MaxRows rows (a compile-time bound keeps
/// Eigen's temporaries on the stack). J has max(M, 6) rows with rows past M
/// zero, so the QR of the robust route (robust.hpp, shared by every row
/// count) is always of a tall matrix ([J; 0]+ = [J+, 0]: the solution is
/// unchanged).
template <int Rows, int MaxRows = Rows>
struct Solver {
  using Jac = Eigen::Matrix<double, Rows, 6, Eigen::ColMajor, MaxRows, 6>;
  using Vec = Eigen::Matrix<double, Rows, 1, Eigen::ColMajor, MaxRows, 1>;

  explicit Solver(Eigen::Index rows)
      : res(Vec::Zero(rows)), robust_route(rows) {}

  Matrix6 N0 = Matrix6::Zero();  ///< J^T J
  Matrix6 N = Matrix6::Zero();   ///< J^T J + lambda^2 I
  Normal normal;                 ///< factor of N (the solve)
  Normal normal0;                ///< factor of N0 when lambda > 0 (the diagnostics)
  Vec res;                       ///< e - J x (refinement)
  Robust robust_route;           ///< QR of J + SVD of R (robust route, exact diagnostics)

  /// x = J+ e by the route decided above (m = rows in use), and what the
  /// diagnostics ask about J's singular values (see the header comment).
  /// Returns the route taken.
  ///
  /// dof (a Task's degrees of freedom; nullptr: all six): J's columns of the
  /// components left out are zero, and the law is solved on the others: their
  /// diagonal entries of J^T J are padded with the mean of the kept ones (the
  /// normal equations stay block-diagonal, so x is exactly 0 there), and the
  /// singular values reported are those of the kept columns.
  Route solve(const Jac& J, const Vec& e, Eigen::Index m, double lambda, Diagnostics diagnostics, Twist& x,
              Spectrum& spectrum, const Dof* dof = nullptr) noexcept {
    spectrum = Spectrum{};
    gram(J);
    const int kept = dof ? pad(*dof) : 6;
    N = N0;
    if (lambda > 0.0) N.diagonal().array() += lambda * lambda;
    if (normal.factor(N) && normal.bound <= normal_route_limit(lambda)) {
      solve_normal(J, e, lambda * lambda, x);
      if (dof) clear(*dof, x);
      if (diagnostics == Diagnostics::off) return Route::normal;  // the full-rank test is only for the diagnostics
      // Undamped: N = J^T J passed the full-rank test, cond(J) <= 1e5: not singular. Damped: test J^T J too.
      const bool full_rank = lambda == 0.0 || (normal0.factor(N0) && normal0.bound <= normal_route_limit(0.0));
      if (diagnostics == Diagnostics::exact || (diagnostics == Diagnostics::lazy && !full_rank)) {
        robust_route.singular_values(J, spectrum.smin, spectrum.smax, kept);
        spectrum.known = true;
        spectrum.singular = spectrum.smin <= singular_tolerance(m) * spectrum.smax;
      }
      return Route::normal;
    }
    double smin, smax;
    robust_route.solve(J, e, m, lambda, x, smin, smax, kept);
    if (dof) clear(*dof, x);
    if (diagnostics != Diagnostics::off) {
      spectrum.known = true;
      spectrum.smin = smin;
      spectrum.smax = smax;
      spectrum.singular = spectrum.smin <= singular_tolerance(m) * spectrum.smax;
    }
    return Route::robust;
  }

  /// N0's diagonal entries of the components left out (zero: J's columns are) set to the mean
  /// of the kept ones (1 if those are all 0); returns how many are kept.
  int pad(const Dof& dof) noexcept {
    int kept = 0;
    double sum = 0.0;
    for (int i = 0; i < 6; ++i)
      if (dof[static_cast<std::size_t>(i)]) {
        ++kept;
        sum += N0(i, i);
      }
    const double fill = sum > 0.0 ? sum / kept : 1.0;
    for (int i = 0; i < 6; ++i)
      if (!dof[static_cast<std::size_t>(i)]) N0(i, i) = fill;
    return kept;
  }
  static void clear(const Dof& dof, Twist& x) noexcept {
    for (int i = 0; i < 6; ++i)
      if (!dof[static_cast<std::size_t>(i)]) x(i) = 0.0;
  }

  /// The route solve() would take (for the benchmark's counts), without solving.
  Route route(const Jac& J, double lambda) noexcept {
    gram(J);
    N = N0;
    if (lambda > 0.0) N.diagonal().array() += lambda * lambda;
    return normal.factor(N) && normal.bound <= normal_route_limit(lambda) ? Route::normal : Route::robust;
  }

  /// N0 = J^T J: the 21 distinct dot products, mirrored.
  void gram(const Jac& J) noexcept {
    for (int j = 0; j < 6; ++j)
      for (int i = j; i < 6; ++i) N0(i, j) = N0(j, i) = J.col(i).dot(J.col(j));
  }

  /// Normal route after normal.factor(N): x = N^-1 J^T e, plus one refinement step.
  void solve_normal(const Jac& J, const Vec& e, double l2, Twist& x) noexcept {
    const Matrix6& Li = normal.Li;
    Twist g;
    g.noalias() = J.transpose().lazyProduct(e);
    Twist y;
    y.noalias() = Li * g;
    x.noalias() = Li.transpose() * y;
    res = e;
    res.noalias() -= J.lazyProduct(x);
    g.noalias() = J.transpose().lazyProduct(res);
    g -= l2 * x;
    y.noalias() = Li * g;
    x.noalias() += Li.transpose() * y;
  }

  /// Robust route: QR of J, SVD of its 6x6 R factor, the filter factors of
  /// pinv_factor (singular values at or below rank_tolerance(m, .) dropped).
  void robust(const Jac& J, const Vec& e, Eigen::Index m, double lambda, Twist& x) noexcept {
    double smin, smax;
    robust_route.solve(J, e, m, lambda, x, smin, smax, 6);
  }

  /// The singular values of J exactly (to rounding): QR of J, then those of R.
  void exact_singular_values(const Jac& J, double& smin, double& smax) noexcept {
    robust_route.singular_values(J, smin, smax, 6);
  }

  /// sigma_min, sigma_max of J from the eigenvalues of N0 = J^T J (symmetric_eigenvalues);
  /// false if the QR iteration did not converge (the caller then takes the QR + SVD route).
  static bool from_gram(const Matrix6& N0, double& smin, double& smax) noexcept {
    double ev[6];
    if (!symmetric_eigenvalues(N0, ev)) return false;
    smin = std::sqrt(std::max(ev[0], 0.0));
    smax = std::sqrt(std::max(ev[5], 0.0));
    return std::isfinite(smax);
  }

};

}  // namespace ibvs::detail
