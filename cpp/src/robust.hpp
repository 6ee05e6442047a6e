// The robust route of the servo's solve (solve.hpp) and the exact singular
// values of J, compiled once in robust.cpp: a QR of J (M x 6), an SVD of its
// 6x6 R factor, and the filter factors of pinv.hpp. Every Solver<Rows> of
// solve.hpp (fixed 8 or 16 rows, or dynamic) hands its J here through an
// Eigen::Ref, so the Householder QR and the JacobiSVD are instantiated once in
// the library instead of once per row count (each fixed-size instance cost
// ~15 s of compile time). The QR runs on a copy of J in storage bounded at
// max_realtime_rows rows (no heap inside Eigen), or on the heap for larger J;
// its results are bit for bit those of a fixed-size QR of the same J.
#pragma once

#include "ibvs/features.hpp"

#include <Eigen/Core>

#include <memory>

namespace ibvs::detail {

class Robust {
 public:
  /// Workspace for J with `rows` rows (allocated here, once).
  explicit Robust(Eigen::Index rows);
  ~Robust();
  Robust(Robust&&) noexcept;
  Robust& operator=(Robust&&) noexcept;

  /// x = J+ e with the filter factors pinv_factor(s, lambda, rank_tolerance(m, s_max)),
  /// and J's extreme singular values. J has at least 6 rows (rows past m zero).
  /// columns: how many of J's columns are in use (the others are zero: a Task's
  /// degrees of freedom left out); smin is the smallest of that many singular values.
  void solve(const Eigen::Ref<const MatrixX6>& J, const Eigen::Ref<const Eigen::VectorXd>& e, Eigen::Index m,
             double lambda, Twist& x, double& smin, double& smax, int columns) noexcept;

  /// J's extreme singular values (QR of J, then the singular values of R only), of `columns` in use.
  void singular_values(const Eigen::Ref<const MatrixX6>& J, double& smin, double& smax, int columns) noexcept;

 private:
  struct Work;
  std::unique_ptr<Work> work_;
};

}  // namespace ibvs::detail
