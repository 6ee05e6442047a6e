// Benchmark kernels that are not public library API: the solve routes of
// Servo::update isolated on a given J and e (the library's own internal
// cpp/src/solve.hpp, so that "pseudoinverse alone" can be timed), and the
// Eigen "floor": one whole fixed-size damped step written directly, the
// bound Servo::update is compared against.
#pragma once

#include "ibvs/features.hpp"
#include "ibvs/pinv.hpp"
#include "solve.hpp"  // cpp/src: internal, on this target's include path

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <algorithm>
#include <cmath>

namespace ibvs_bench {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using ibvs::Twist;

/// The solve routes of Servo::update (cpp/src/solve.hpp, the same code) on a
/// J and e already assembled. Rows = 8, 16 (fixed, stack storage) or Eigen::Dynamic.
template <int Rows>
struct SolveKernel {
  using Solve = ibvs::detail::Solver<Rows>;

  explicit SolveKernel(Eigen::Index m)
      : J(Solve::Jac::Zero(std::max<Eigen::Index>(m, 6), 6)), e(Solve::Vec::Zero(J.rows())), solver(J.rows()), m_(m) {}

  typename Solve::Jac J;
  typename Solve::Vec e;
  Solve solver;
  Eigen::Index m_;

  /// The whole solve of Servo::update (route decided as there), with the diagnostics asked for.
  Twist solve(double lambda, ibvs::detail::Diagnostics d) noexcept {
    Twist x;
    ibvs::detail::Spectrum spectrum;
    solver.solve(J, e, m_, lambda, d, x, spectrum);
    return x;
  }

  /// The normal route alone (J^T J + lambda^2 I, Cholesky, refinement); assumes it applies.
  Twist normal(double lambda) noexcept {
    Twist x;
    solver.gram(J);
    solver.N = solver.N0;
    solver.N.diagonal().array() += lambda * lambda;
    solver.normal.factor(solver.N);
    solver.solve_normal(J, e, lambda * lambda, x);
    return x;
  }

  /// sigma_min, sigma_max as ServoOutput computes them when read: the eigenvalues of J^T J.
  Eigen::Vector2d eigenvalues() noexcept {
    Eigen::Vector2d s;
    solver.gram(J);
    Solve::from_gram(solver.N0, s(0), s(1));
    return s;
  }

  /// The exact singular values (QR of J, SVD of R).
  Eigen::Vector2d exact() noexcept {
    Eigen::Vector2d s;
    solver.exact_singular_values(J, s(0), s(1));
    return s;
  }

  /// The robust route alone: QR of J, SVD of the 6x6 R, filter factors.
  Twist robust(double lambda) noexcept {
    Twist x;
    solver.robust(J, e, m_, lambda, x);
    return x;
  }

  /// The route Servo::update takes for this J and lambda.
  ibvs::detail::Route route(double lambda) noexcept { return solver.route(J, lambda); }
};

/// Which representation point i gets in the floor kernels (one entry per
/// block, row order as ibvs::Layout::cartesian/polar/stacked and "hybrid").
enum class Kind { cartesian, polar, stacked, hybrid };

constexpr int rows_per_point(Kind k) { return k == Kind::stacked ? 4 : 2; }

/// The Eigen floor: one whole damped step (Jacobian + error + damped normal
/// equations by LLT + twist) for NP points, all fixed-size, written directly,
/// each point's r and theta computed once. No validation, no r -> 0 policy,
/// no outputs besides the twist: the least a correct step must do.
template <int NP, Kind K>
struct Floor {
  static constexpr int M = NP * rows_per_point(K);
  using Pts = Eigen::Matrix<double, 2, NP>;
  using Jac = Eigen::Matrix<double, M, 6>;

  static void polar_block(double u, double v, double z, double ud, double vd, Jac& J, Eigen::Matrix<double, M, 1>& e,
                          int row) noexcept {
    const double r2 = u * u + v * v, r = std::sqrt(r2), ir = 1.0 / r, iz = 1.0 / z;
    const double c = u * ir, s = v * ir, k = 1.0 + r2;
    J.row(row) << -c * iz, -s * iz, r * iz, k * s, -k * c, 0.0;
    J.row(row + 1) << s * ir * iz, -c * ir * iz, 0.0, c * ir, s * ir, -1.0;
    e(row) = r - std::sqrt(ud * ud + vd * vd);
    double d = std::atan2(v, u) - std::atan2(vd, ud);  // in (-2 pi, 2 pi)
    if (d > ibvs::pi) d -= 2.0 * ibvs::pi;
    else if (d <= -ibvs::pi) d += 2.0 * ibvs::pi;
    e(row + 1) = d;
  }
  static void cartesian_block(double u, double v, double z, double ud, double vd, Jac& J,
                              Eigen::Matrix<double, M, 1>& e, int row) noexcept {
    const double iz = 1.0 / z;
    J.row(row) << -iz, 0.0, u * iz, u * v, -(1.0 + u * u), v;
    J.row(row + 1) << 0.0, -iz, v * iz, 1.0 + v * v, -u * v, -u;
    e(row) = u - ud;
    e(row + 1) = v - vd;
  }

  /// Fills J and e (shared by the LLT and the JacobiSVD floors).
  static void assemble(const Pts& uv, const Eigen::Matrix<double, NP, 1>& z, const Pts& uvd, Jac& J,
                       Eigen::Matrix<double, M, 1>& e) noexcept {
    int row = 0;
    for (int i = 0; i < NP; ++i) {
      const double u = uv(0, i), v = uv(1, i), ud = uvd(0, i), vd = uvd(1, i);
      const bool cart = K == Kind::cartesian || K == Kind::stacked || (K == Kind::hybrid && i % 2 == 0);
      const bool pol = K == Kind::polar || K == Kind::stacked || (K == Kind::hybrid && i % 2 == 1);
      if (cart) {
        cartesian_block(u, v, z(i), ud, vd, J, e, row);
        row += 2;
      }
      if (pol) {
        polar_block(u, v, z(i), ud, vd, J, e, row);
        row += 2;
      }
    }
  }

  static Twist step_llt(const Pts& uv, const Eigen::Matrix<double, NP, 1>& z, const Pts& uvd, double lambda,
                        double gain) noexcept {
    Jac J;
    Eigen::Matrix<double, M, 1> e;
    assemble(uv, z, uvd, J, e);
    Matrix6 A;
    A.noalias() = J.transpose().lazyProduct(J);
    A.diagonal().array() += lambda * lambda;
    Twist b;
    b.noalias() = J.transpose().lazyProduct(e);
    Eigen::LLT<Matrix6> llt(A);
    llt.solveInPlace(b);
    return -gain * b;
  }

  /// The ViSP stand-in: the same J and e, then the damped pseudoinverse by an
  /// SVD of J on heap matrices every frame, as vpServo's control law does
  /// (vpMatrix::pseudoInverse): ibvs::damped_pinv (JacobiSVD<MatrixXd>).
  static Twist step_svd(const Pts& uv, const Eigen::Matrix<double, NP, 1>& z, const Pts& uvd, double lambda,
                        double gain) {
    Jac J;
    Eigen::Matrix<double, M, 1> e;
    assemble(uv, z, uvd, J, e);
    return -gain * (ibvs::damped_pinv(J, lambda) * e);
  }
};

}  // namespace ibvs_bench
