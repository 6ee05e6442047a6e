// The Eigen floors of the task benchmarks (ibvs-bench --sections tasks): one
// whole damped step of a Task of feature blocks, written directly with
// fixed-size Eigen, as Floor<NP, K> (kernels.hpp) is for the point layouts:
// the block's value and interaction matrix from its measurement, the error,
// then (J^T J + lambda^2 I) x = J^T e by LLT and the twist -gain x. No
// validation, no representation choice, no outputs besides the twist: the
// least a correct step must do. Each floor is checked to give Servo::update's
// twist (ibvs-bench refuses to report a floor that disagrees).
//
// The formulas are the published ones the features cite (written again here,
// independently of cpp/src/features, so that the check means something):
//  * image moments, Tahri & Chaumette 2005 (xn, yn, an, the P invariants
//    r1 = I1 / I3^2, r2 = a I2 / I3^3, alpha oriented by the third-order
//    moments), the rows of the raw moments of a planar region from Chaumette
//    2004 eq. (13), chained by forward-mode derivatives;
//  * PBVS: camera to desired camera, L = [c*Rc 0; 0 L_tu]; camera to object,
//    L = [-I [c t_o]x; 0 L_tu]; L_tu of Malis et al. 1999 (features/pose.hpp eq. 1);
//  * 2.5-D: the point's rows (paper eq. 3), [0 0 -1/Z -y x 0], [0 L_tu].
#pragma once

#include "kernels.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <cmath>
#include <type_traits>

namespace ibvs_bench::tasks {

using Row6 = Eigen::Matrix<double, 1, 6>;
using Matrix3 = Eigen::Matrix3d;
using Vector3 = Eigen::Vector3d;

/// A value and its row of the interaction matrix (its derivative along the camera twist).
struct D {
  double v;
  Row6 d;
};
inline D operator+(const D& a, const D& b) { return {a.v + b.v, a.d + b.d}; }
inline D operator-(const D& a, const D& b) { return {a.v - b.v, a.d - b.d}; }
inline D operator*(const D& a, const D& b) { return {a.v * b.v, a.v * b.d + b.v * a.d}; }
inline D operator*(double k, const D& a) { return {k * a.v, k * a.d}; }
inline D operator/(const D& a, const D& b) {
  const double q = a.v / b.v;
  return {q, (a.d - q * b.d) / b.v};
}
inline D operator/(double k, const D& b) {
  const double q = k / b.v;
  return {q, (-q / b.v) * b.d};
}
inline D sqrt(const D& a) {
  const double r = std::sqrt(a.v);
  return {r, (0.5 / r) * a.d};
}
inline D atan2(const D& y, const D& x) {
  return {std::atan2(y.v, x.v), (x.v * y.d - y.v * x.d) / (x.v * x.v + y.v * y.v)};
}
inline double value(double x) { return x; }
inline double value(const D& x) { return x.v; }
inline double& value_ref(double& x) { return x; }
inline double& value_ref(D& x) { return x.v; }

/// The six moment features (xn, yn, an, r1, r2, alpha) of a region's measurement (20 doubles:
/// m_ij of order 0..4 at (i+j)(i+j+1)/2 + j, a*, Z*, A, B, C). S = D: with their rows; S = double:
/// the values only (the goal's, for the error).
template <class S>
void moment_features(const double* mm, S s[6]) noexcept {
  using std::atan2;
  using std::sqrt;
  const auto raw = [mm](int i, int j) { return i < 0 || j < 0 ? 0.0 : mm[(i + j) * (i + j + 1) / 2 + j]; };
  S m[4][4];
  for (int n = 0; n <= 3; ++n)
    for (int j = 0; j <= n; ++j) {
      const int i = n - j;
      if constexpr (std::is_same_v<S, D>) {
        const double A = mm[17], B = mm[18], C = mm[19], mij = raw(i, j), k = n + 3.0;
        m[i][j].v = mij;  // Chaumette 2004, eq. (13)
        m[i][j].d << -i * (A * mij + B * raw(i - 1, j + 1) + C * raw(i - 1, j)) - A * mij,
            -j * (A * raw(i + 1, j - 1) + B * mij + C * raw(i, j - 1)) - B * mij,
            k * (A * raw(i + 1, j) + B * raw(i, j + 1) + C * mij) - C * mij, k * raw(i, j + 1) + j * raw(i, j - 1),
            -k * raw(i + 1, j) - i * raw(i - 1, j), i * raw(i - 1, j + 1) - j * raw(i + 1, j - 1);
      } else {
        m[i][j] = raw(i, j);
      }
    }
  const S xg = m[1][0] / m[0][0], yg = m[0][1] / m[0][0];
  const S mu20 = m[2][0] - xg * m[1][0], mu11 = m[1][1] - xg * m[0][1], mu02 = m[0][2] - yg * m[0][1];
  const S xg2 = xg * xg, yg2 = yg * yg;
  const S mu30 = m[3][0] - 3.0 * (xg * m[2][0]) + 2.0 * (xg2 * m[1][0]);
  const S mu21 = m[2][1] - 2.0 * (xg * m[1][1]) - yg * m[2][0] + 2.0 * (xg2 * m[0][1]);
  const S mu12 = m[1][2] - 2.0 * (yg * m[1][1]) - xg * m[0][2] + 2.0 * (yg2 * m[1][0]);
  const S mu03 = m[0][3] - 3.0 * (yg * m[0][2]) + 2.0 * (yg2 * m[0][1]);
  const S I3 = mu20 + mu02, a = m[0][0];
  const S an = mm[16] * sqrt(mm[15] / a);
  s[0] = an * xg;
  s[1] = an * yg;
  s[2] = an;
  const S c1 = mu20 - mu02, s1 = 2.0 * mu11, c2 = mu03 - 3.0 * mu21, s2 = mu30 - 3.0 * mu12;
  const S I1 = c1 * c1 + s1 * s1, I2 = c2 * c2 + s2 * s2;
  s[3] = I1 / (I3 * I3);
  s[4] = a * I2 / (I3 * I3 * I3);
  S alpha = 0.5 * atan2(s1, c1);
  const double t = 3.0 * value(alpha);
  if (value(s2) * std::cos(t) - value(c2) * std::sin(t) < 0.0) {  // the axis oriented by Re(z3 e^{-3 i alpha}) > 0
    double& v = value_ref(alpha);
    v += ibvs::pi;
    if (v > ibvs::pi) v -= 2.0 * ibvs::pi;
  }
  s[5] = alpha;
}

inline double wrap(double d) noexcept {
  if (d > ibvs::pi) d -= 2.0 * ibvs::pi;
  else if (d <= -ibvs::pi) d += 2.0 * ibvs::pi;
  return d;
}

/// theta u with angle <= pi (a rotation vector of angle up to 2 pi in its principal form).
inline Vector3 principal(const double* p) noexcept {
  const Vector3 tu(p[0], p[1], p[2]);
  const double th = tu.norm();
  return th > ibvs::pi ? Vector3(tu * ((th - 2.0 * ibvs::pi) / th)) : tu;
}

/// L_tu = I + [theta u]x / 2 + (1 - (theta/2) cot(theta/2)) / theta^2 [theta u]x^2 (Malis et al. 1999).
inline Matrix3 theta_u_rows(const Vector3& tu) noexcept {
  const double th2 = tu.squaredNorm(), th = std::sqrt(th2);
  Matrix3 W;
  W << 0, -tu(2), tu(1), tu(2), 0, -tu(0), -tu(1), tu(0), 0;
  const double b = th < 1e-2 ? 1.0 / 12.0 + th2 / 720.0 + th2 * th2 / 30240.0
                             : (1.0 - 0.5 * th * std::cos(0.5 * th) / std::sin(0.5 * th)) / th2;
  return Matrix3::Identity() + 0.5 * W + b * (W * W);
}

/// exp([theta u]x) (Rodrigues).
inline Matrix3 rotation(const Vector3& tu) noexcept {
  const double th2 = tu.squaredNorm(), th = std::sqrt(th2);
  Matrix3 W;
  W << 0, -tu(2), tu(1), tu(2), 0, -tu(0), -tu(1), tu(0), 0;
  const double a = th < 1e-4 ? 1.0 - th2 / 6.0 : std::sin(th) / th;
  const double b = th < 1e-4 ? 0.5 - th2 / 24.0 : (1.0 - std::cos(th)) / th2;
  return Matrix3::Identity() + a * W + b * (W * W);
}

using J6 = Eigen::Matrix<double, 6, 6>;
using V6 = Eigen::Matrix<double, 6, 1>;

/// -gain (A0 + lambda^2 I)^-1 g by LLT, for A0 = J^T J and g = J^T e.
inline Twist solve_gram(const Matrix6& A0, const V6& g, double lambda, double gain) noexcept {
  Matrix6 A = A0;
  A.diagonal().array() += lambda * lambda;
  Eigen::LLT<Matrix6> llt(A);
  Twist x = g;
  llt.solveInPlace(x);
  return -gain * x;
}

template <class Jac, class Vec>
inline Twist solve(const Jac& J, const Vec& e, double lambda, double gain) noexcept {
  Matrix6 A;
  A.noalias() = J.transpose().lazyProduct(J);
  V6 g;
  g.noalias() = J.transpose().lazyProduct(e);
  return solve_gram(A, g, lambda, gain);
}

/// The moments block (6 rows) at the current measurement m, error against the goal's md.
inline void moments_block(const double* m, const double* md, J6& J, V6& e) noexcept {
  D s[6];
  double sd[6];
  moment_features(m, s);
  moment_features(md, sd);
  for (int r = 0; r < 6; ++r) {
    J.row(r) = s[r].d;
    e(r) = s[r].v - sd[r];
  }
  e(5) = wrap(e(5));
}

/// Moments task: xn, yn, an, r1, r2, alpha of a region (6 x 6).
inline Twist moments_step(const double* m, const double* md, double lambda, double gain) noexcept {
  J6 J;
  V6 e;
  moments_block(m, md, J, e);
  return solve(J, e, lambda, gain);
}

/// PBVS, camera to desired camera: s = (c*t_c, theta u), s* = the goal's measurement.
inline Twist pbvs_step(const double* m, const double* md, double lambda, double gain) noexcept {
  const Vector3 tu = principal(m + 3), tud = principal(md + 3);
  J6 J;
  J.topLeftCorner<3, 3>() = rotation(tu);
  J.topRightCorner<3, 3>().setZero();
  J.bottomLeftCorner<3, 3>().setZero();
  J.bottomRightCorner<3, 3>() = theta_u_rows(tu);
  V6 e;
  e << m[0] - md[0], m[1] - md[1], m[2] - md[2], tu - tud;
  return solve(J, e, lambda, gain);
}

/// PBVS, camera to object: s = (c t_o, theta u), L = [-I [c t_o]x; 0 L_tu].
inline Twist pbvs_object_step(const double* m, const double* md, double lambda, double gain) noexcept {
  const Vector3 tu = principal(m + 3), tud = principal(md + 3);
  J6 J;
  J.topLeftCorner<3, 3>() = -Matrix3::Identity();
  J.topRightCorner<3, 3>() << 0, -m[2], m[1], m[2], 0, -m[0], -m[1], m[0], 0;
  J.bottomLeftCorner<3, 3>().setZero();
  J.bottomRightCorner<3, 3>() = theta_u_rows(tu);
  V6 e;
  e << m[0] - md[0], m[1] - md[1], m[2] - md[2], tu - tud;
  return solve(J, e, lambda, gain);
}

/// 2.5-D: (x, y, log Z, theta u) of a reference point.
inline Twist point25d_step(const double* m, const double* md, double lambda, double gain) noexcept {
  const double x = m[0], y = m[1], iz = 1.0 / m[2];
  const Vector3 tu = principal(m + 3), tud = principal(md + 3);
  J6 J;
  J.row(0) << -iz, 0.0, x * iz, x * y, -(1.0 + x * x), y;
  J.row(1) << 0.0, -iz, y * iz, 1.0 + y * y, -x * y, -x;
  J.row(2) << 0.0, 0.0, -iz, -y, x, 0.0;
  J.bottomLeftCorner<3, 3>().setZero();
  J.bottomRightCorner<3, 3>() = theta_u_rows(tu);
  V6 e;
  e << x - md[0], y - md[1], std::log(m[2]) - std::log(md[2]), tu - tud;
  return solve(J, e, lambda, gain);
}

/// Mixed: the stacked rows of 4 points (Floor<4, stacked>) and the moments block, 22 x 6.
inline Twist mixed_step(const Eigen::Matrix<double, 2, 4>& uv, const Eigen::Matrix<double, 4, 1>& z,
                        const Eigen::Matrix<double, 2, 4>& uvd, const double* m, const double* md, double lambda,
                        double gain) noexcept {
  using P = Floor<4, Kind::stacked>;
  P::Jac Jp;
  Eigen::Matrix<double, P::M, 1> ep;
  P::assemble(uv, z, uvd, Jp, ep);
  J6 Jm;
  V6 em;
  moments_block(m, md, Jm, em);
  Matrix6 A;
  A.noalias() = Jp.transpose().lazyProduct(Jp);
  A.noalias() += Jm.transpose().lazyProduct(Jm);
  V6 g;
  g.noalias() = Jp.transpose().lazyProduct(ep);
  g.noalias() += Jm.transpose().lazyProduct(em);
  return solve_gram(A, g, lambda, gain);
}

}  // namespace ibvs_bench::tasks
