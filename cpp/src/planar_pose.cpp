#include "ibvs/planar_pose.hpp"

#include "checks.hpp"
#include "svd_instances.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

// The one instantiation of JacobiSVD<Matrix3d> (svd_instances.hpp), shared with the simulator.
template class Eigen::JacobiSVD<Eigen::Matrix3d>;

namespace ibvs {

PlanarPose::PlanarPose(const PlanarPose&) = default;
PlanarPose::PlanarPose(PlanarPose&&) noexcept = default;
PlanarPose& PlanarPose::operator=(const PlanarPose&) = default;
PlanarPose& PlanarPose::operator=(PlanarPose&&) noexcept = default;
PlanarPose::~PlanarPose() = default;

PlanarPose::PlanarPose(const Eigen::Matrix3Xd& points, int iterations) : points_(points), iterations_(iterations) {
  if (points_.cols() < 4)
    throw std::invalid_argument("ibvs: points: a planar pose needs at least 4 target points, got " +
                                std::to_string(points_.cols()));
  if (!finite_within(points_, max_depth))
    throw std::invalid_argument("ibvs: points must be finite and within +-" + detail::number(max_depth) + " m");
  for (Eigen::Index i = 0; i < points_.cols(); ++i)
    if (std::abs(points_(2, i)) > 1e-12)
      throw std::invalid_argument("ibvs: points: a planar pose needs a planar target (all points with z = 0), point " +
                                  std::to_string(i) + " has z = " + std::to_string(points_(2, i)));
  // Not all on one line: the 2x2 scatter of the points must have rank 2.
  const Eigen::Vector2d c = points_.topRows<2>().rowwise().mean();
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();
  for (Eigen::Index i = 0; i < points_.cols(); ++i) S += (points_.block<2, 1>(0, i) - c) * (points_.block<2, 1>(0, i) - c).transpose();
  // Its eigenvalues in closed form, m -+ sqrt(d^2 + b^2) (m, d: half the trace and half the
  // difference of the diagonal; b: the off-diagonal entry). Eigen's iterative solver for this
  // 2x2 cost ~15 s of compile time.
  const double m = 0.5 * (S(0, 0) + S(1, 1)), d = 0.5 * (S(0, 0) - S(1, 1)), h = std::hypot(d, S(1, 0));
  const Eigen::Vector2d ev(m - h, m + h);
  if (!(ev(0) > 1e-12 * ev(1)))
    throw std::invalid_argument("ibvs: points: the target points lie on one line (no pose from them)");
  if (iterations_ < 0) throw std::invalid_argument("ibvs: iterations must be >= 0, got " + std::to_string(iterations_));
}

void PlanarPose::validate(const Eigen::Ref<const Points>& uv) const {
  if (uv.cols() != points_.cols())
    throw std::invalid_argument("ibvs: uv must hold " + std::to_string(points_.cols()) + " points (the target's), got " +
                                std::to_string(uv.cols()));
  detail::check_points(uv, "uv", static_cast<int>(uv.cols()));
}

bool PlanarPose::estimate(const Eigen::Ref<const Points>& uv, Pose& T, Eigen::Ref<Eigen::VectorXd> depth) const noexcept {
  Pose E;
  if (depth.size() != points_.cols() || !estimate(uv, E)) return false;
  for (Eigen::Index i = 0; i < points_.cols(); ++i) depth(i) = E.row(2).head<3>().dot(points_.col(i)) + E(2, 3);
  T = E;
  return true;
}

namespace {
using Matrix9d = Eigen::Matrix<double, 9, 9>;

// Similarity moving the centroid of 2-D points to 0 and their RMS radius to sqrt(2) (Hartley). The
// points' coordinates are p[i * stride], p[i * stride + 1]. (Plain loops here and below where Eigen's
// expressions would only add template instantiations: compile time, docs/installation.md.)
Eigen::Matrix3d normaliser(const double* p, Eigen::Index n, Eigen::Index stride) noexcept {
  double cx = 0.0, cy = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) cx += p[i * stride], cy += p[i * stride + 1];
  cx /= static_cast<double>(n);
  cy /= static_cast<double>(n);
  double r2 = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double dx = p[i * stride] - cx, dy = p[i * stride + 1] - cy;
    r2 += dx * dx + dy * dy;
  }
  const double s = r2 > 0.0 ? std::sqrt(2.0 * static_cast<double>(n) / r2) : 1.0;
  Eigen::Matrix3d N;
  N << s, 0, -s * cx, 0, s, -s * cy, 0, 0, 1;
  return N;
}

// The homography Hn (rows of the smallest eigenvector of A^T A, the DLT's least-squares null
// vector); false unless that null space is one-dimensional: a second (nearly) zero eigenvalue
// means the image does not determine it (e.g. three of four points on a line).
bool null_homography(const Matrix9d& AtA, Eigen::Matrix3d& Hn) noexcept {
  const Eigen::SelfAdjointEigenSolver<Matrix9d> eig(AtA);
  if (eig.info() != Eigen::Success) return false;
  if (!(eig.eigenvalues()(1) > 1e-10 * eig.eigenvalues()(8))) return false;
  const Eigen::Matrix<double, 9, 1> h = eig.eigenvectors().col(0);
  Hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  return true;
}

// H ~ [r1 r2 t]: lambda = sign 2 / (|h1| + |h2|) scales the rotation columns to unit length; the
// rotation r1, r2, r1 x r2 is re-orthonormalised (the nearest rotation, by the SVD), t = lambda h3.
bool decompose(const Eigen::Matrix3d& H, double sign, Pose& E) noexcept {
  const double n1 = H.col(0).norm(), n2 = H.col(1).norm();
  if (!(n1 > 0.0) || !(n2 > 0.0)) return false;
  const double lambda = sign * 2.0 / (n1 + n2);
  Eigen::Matrix3d M;
  M.col(0) = lambda * H.col(0);
  M.col(1) = lambda * H.col(1);
  M.col(2) = M.col(0).cross(M.col(1));
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  E.setIdentity();
  E.topLeftCorner<3, 3>() = svd.matrixU() * D * svd.matrixV().transpose();
  E.topRightCorner<3, 1>() = lambda * H.col(2);
  return E.allFinite();
}

// Gauss-Newton on 2-row residuals r_i with r_i(exp(-d) T) ~ r_i + L_i d (L_i the residual's
// Jacobian for the camera twist d), so the step is d = -(L^T L)^-1 L^T r and T <- exp(-d) T.
// residual(data, i, E, L, r) fills point i's L and r, false to refuse the pose E. (A function
// pointer, not a template: one copy of the loop for both estimates, for the compile time.)
using Residual = bool (*)(const void* data, Eigen::Index i, const Pose& E, Matrix26& L, Eigen::Vector2d& r);
bool refine(Eigen::Index n, int iterations, Pose& E, Residual residual, const void* data) noexcept {
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix<double, 6, 6> LtL = Eigen::Matrix<double, 6, 6>::Zero();
    Twist Ltr = Twist::Zero();
    for (Eigen::Index i = 0; i < n; ++i) {
      Matrix26 L;
      Eigen::Vector2d r;
      if (!residual(data, i, E, L, r)) return false;
      LtL.noalias() += L.transpose() * L;
      Ltr.noalias() += L.transpose() * r;
    }
    const Twist d = LtL.ldlt().solve(Ltr);
    if (!d.allFinite()) return false;
    E = se3_exp(d) * E;  // exp(-(-d)): the step is -d, and T <- exp(-step) T
    if (d.norm() < 1e-14) break;
  }
  return E.allFinite();
}

// What the residuals read: the target's points and the image points or bearings.
struct ImagePoints {
  const Eigen::Matrix3Xd& points;
  const Eigen::Ref<const Points>& uv;
};
struct BearingPoints {
  const Eigen::Matrix3Xd& points;
  const Eigen::Ref<const Eigen::Matrix3Xd>& bearings;
};

// The unit vector of a finite, non-zero column (scaled by its largest entry first: its norm cannot
// overflow or underflow); false otherwise.
bool unit(const Eigen::Ref<const Eigen::Matrix3Xd>& b, Eigen::Index i, Eigen::Vector3d& u) noexcept {
  const double x = b(0, i), y = b(1, i), z = b(2, i);
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return false;
  const double m = std::max(std::abs(x), std::max(std::abs(y), std::abs(z)));
  if (!(m > 0.0)) return false;
  const double sx = x / m, sy = y / m, sz = z / m, l = std::sqrt(sx * sx + sy * sy + sz * sz);
  u(0) = sx / l;
  u(1) = sy / l;
  u(2) = sz / l;
  return true;
}

// a x b.
Eigen::Vector3d cross(const Eigen::Vector3d& a, const Eigen::Vector3d& b) noexcept {
  Eigen::Vector3d c;
  c(0) = a(1) * b(2) - a(2) * b(1);
  c(1) = a(2) * b(0) - a(0) * b(2);
  c(2) = a(0) * b(1) - a(1) * b(0);
  return c;
}

// An orthonormal basis (e1, e2) of the plane orthogonal to the unit vector b, with e1 x e2 = b:
// e1 along b x a, a the axis of b's smallest entry.
void tangent_basis(const Eigen::Vector3d& b, Eigen::Vector3d& e1, Eigen::Vector3d& e2) noexcept {
  const double ax = std::abs(b(0)), ay = std::abs(b(1)), az = std::abs(b(2));
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  a(ax <= ay && ax <= az ? 0 : (ay <= az ? 1 : 2)) = 1.0;
  e1 = cross(b, a);
  e1 /= std::sqrt(e1(0) * e1(0) + e1(1) * e1(1) + e1(2) * e1(2));
  e2 = cross(b, e1);
}
}  // namespace

bool PlanarPose::estimate(const Eigen::Ref<const Points>& uv, Pose& T) const noexcept {
  const Eigen::Index n = points_.cols();
  if (uv.cols() != n || !detail::valid_points(uv)) return false;
  // 1. Homography image ~ H (X, Y, 1) by the normalised DLT.
  const Eigen::Matrix3d Nm = normaliser(points_.data(), n, 3), Ni = normaliser(uv.data(), n, uv.outerStride());
  Matrix9d AtA = Matrix9d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d X = Nm * Eigen::Vector3d(points_(0, i), points_(1, i), 1.0);
    const Eigen::Vector3d x = Ni * Eigen::Vector3d(uv(0, i), uv(1, i), 1.0);
    Eigen::Matrix<double, 9, 1> a, b;
    a << X, Eigen::Vector3d::Zero(), -x(0) / x(2) * X;
    b << Eigen::Vector3d::Zero(), X, -x(1) / x(2) * X;
    AtA.noalias() += a * a.transpose() + b * b.transpose();
  }
  Eigen::Matrix3d Hn;
  if (!null_homography(AtA, Hn)) return false;
  const Eigen::Matrix3d H = Ni.inverse() * Hn * Nm;
  // 2. H ~ [r1 r2 t], its sign from t_z > 0.
  Pose E;
  if (!decompose(H, H(2, 2) < 0.0 ? -1.0 : 1.0, E)) return false;
  // 3. Gauss-Newton on the reprojection error in normalised coordinates (eq. 3 Jacobian of each point).
  const ImagePoints data{points_, uv};
  const bool ok = refine(n, iterations_, E, [](const void* d, Eigen::Index i, const Pose& P, Matrix26& L, Eigen::Vector2d& r) {
    const auto& [X, x] = *static_cast<const ImagePoints*>(d);
    const Eigen::Vector3d p = P.topLeftCorner<3, 3>() * X.col(i) + P.topRightCorner<3, 1>();
    if (!(p(2) > 0.0)) return false;
    const double u = p(0) / p(2), v = p(1) / p(2);
    L = cartesian_jacobian(u, v, p(2));
    r << u - x(0, i), v - x(1, i);
    return true;
  }, &data);
  if (!ok) return false;
  T = E;
  return true;
}

void PlanarPose::validate_bearings(const Eigen::Ref<const Eigen::Matrix3Xd>& bearings) const {
  if (bearings.cols() != points_.cols())
    throw std::invalid_argument("ibvs: bearings must hold " + std::to_string(points_.cols()) +
                                " bearings (the target's points), got " + std::to_string(bearings.cols()));
  Eigen::Vector3d u;
  for (Eigen::Index i = 0; i < bearings.cols(); ++i) {
    if (unit(bearings, i, u)) continue;
    const std::string which = "ibvs: bearings[" + std::to_string(i) + "]";
    if (!std::isfinite(bearings(0, i)) || !std::isfinite(bearings(1, i)) || !std::isfinite(bearings(2, i))) throw std::invalid_argument(which + " is not finite");
    throw std::invalid_argument(which + " has zero length (a bearing is a direction)");
  }
}

bool PlanarPose::estimate_bearings(const Eigen::Ref<const Eigen::Matrix3Xd>& bearings, Pose& T,
                                   Eigen::Ref<Eigen::VectorXd> range) const noexcept {
  Pose E;
  if (range.size() != points_.cols() || !estimate_bearings(bearings, E)) return false;
  for (Eigen::Index i = 0; i < points_.cols(); ++i)
    range(i) = (E.topLeftCorner<3, 3>() * points_.col(i) + E.topRightCorner<3, 1>()).norm();
  T = E;
  return true;
}

bool PlanarPose::estimate_bearings(const Eigen::Ref<const Eigen::Matrix3Xd>& bearings, Pose& T) const noexcept {
  const Eigen::Index n = points_.cols();
  if (bearings.cols() != n) return false;
  // 1. Normalising the bearings, the idea of Hartley's for image points: rotate their mean direction
  // m onto z (Q, rows e1, e2, m) and scale the spread about it, c = diag(s, s, 1) Q b with
  // s^2 = 2 sum (Q b)_z^2 / sum |(Q b)_xy|^2 (for a narrow view, the image points' RMS radius
  // sqrt(2) about their centroid). Points of a plane not through the camera centre lie in an
  // open hemisphere, so their mean direction is not zero.
  Eigen::Vector3d b, mean = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!unit(bearings, i, b)) return false;
    mean += b;
  }
  const double ml = std::sqrt(mean(0) * mean(0) + mean(1) * mean(1) + mean(2) * mean(2));
  if (!(ml > 1e-12 * static_cast<double>(n))) return false;
  mean /= ml;
  Eigen::Vector3d e1, e2;
  tangent_basis(mean, e1, e2);
  Eigen::Matrix3d Q;
  for (int j = 0; j < 3; ++j) Q(0, j) = e1(j), Q(1, j) = e2(j), Q(2, j) = mean(j);
  double axial = 0.0, spread = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    unit(bearings, i, b);
    const Eigen::Vector3d c = Q * b;
    axial += c(2) * c(2);
    spread += c(0) * c(0) + c(1) * c(1);
  }
  double s = std::sqrt(2.0 * axial / spread);
  if (!std::isfinite(s) || !(s > 0.0)) s = 1.0;  // all bearings alike: the DLT refuses them below
  // 2. Homography b ~ H (X, Y, 1) by the DLT on the normalised bearings c (unit length, so each
  // point weighs the same): the three rows of c x (Hn X) = 0 (rank 2), for any direction of c.
  const Eigen::Matrix3d Nm = normaliser(points_.data(), n, 3);
  Matrix9d AtA = Matrix9d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    unit(bearings, i, b);
    const Eigen::Vector3d X = Nm * Eigen::Vector3d(points_(0, i), points_(1, i), 1.0);
    Eigen::Vector3d c = Q * b;
    c(0) *= s;
    c(1) *= s;
    c /= std::sqrt(c(0) * c(0) + c(1) * c(1) + c(2) * c(2));
    // The rows [c]_x (I3 kron X^T) of the point give A^T A = ([c]_x^T [c]_x) kron (X X^T), with
    // [c]_x^T [c]_x = I - c c^T for a unit c.
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) {
        const double cjk = (j == k ? 1.0 : 0.0) - c(j) * c(k);
        for (int a = 0; a < 3; ++a)
          for (int d = 0; d < 3; ++d) AtA(3 * j + a, 3 * k + d) += cjk * X(a) * X(d);
      }
  }
  Eigen::Matrix3d Hn;
  if (!null_homography(AtA, Hn)) return false;
  Eigen::Matrix3d Ni_inv = Q.transpose();  // (diag(s, s, 1) Q)^-1 = Q^T diag(1/s, 1/s, 1)
  for (int j = 0; j < 3; ++j) Ni_inv(j, 0) /= s, Ni_inv(j, 1) /= s;
  const Eigen::Matrix3d H = Ni_inv * Hn * Nm;
  // 3. H ~ [r1 r2 t], its sign putting the points in front along their bearings: b . (H X) > 0 (the
  // sum here; every point is checked below). Not t_z > 0: beyond 90 degrees off the axis z < 0.
  double front = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    unit(bearings, i, b);
    front += b.dot(H * Eigen::Vector3d(points_(0, i), points_(1, i), 1.0));
  }
  Pose E;
  if (!decompose(H, front < 0.0 ? -1.0 : 1.0, E)) return false;
  // 4. Gauss-Newton on each bearing's tangent-plane residual r = B^T P/|P| (B = (e1, e2) orthogonal to
  // the measured b: r = 0 when P lies along b, |r| the sine of the angle between them), its Jacobian
  // B^T [-(I - s s^T)/|P|, [s]_x] with s = P/|P| (Hamel & Mahony eq. 9).
  const auto in_front = [&](const Pose& P) {  // b . (R X + t) > 0 for every point
    for (Eigen::Index i = 0; i < n; ++i) {
      unit(bearings, i, b);
      if (!(b.dot(P.topLeftCorner<3, 3>() * points_.col(i) + P.topRightCorner<3, 1>()) > 0.0)) return false;
    }
    return true;
  };
  if (!in_front(E)) return false;  // the linear start already puts a point behind its bearing
  const BearingPoints data{points_, bearings};
  const bool ok = refine(n, iterations_, E, [](const void* d, Eigen::Index i, const Pose& P, Matrix26& L, Eigen::Vector2d& r) {
    const auto& [X, bs] = *static_cast<const BearingPoints*>(d);
    Eigen::Vector3d u, t1, t2;
    unit(bs, i, u);
    const Eigen::Vector3d p = P.topLeftCorner<3, 3>() * X.col(i) + P.topRightCorner<3, 1>();
    if (!(u.dot(p) > 0.0)) return false;  // not in front along its bearing
    const double R = std::sqrt(p(0) * p(0) + p(1) * p(1) + p(2) * p(2));
    const Eigen::Vector3d q = p / R;
    tangent_basis(u, t1, t2);
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector3d& e = k == 0 ? t1 : t2;
      const double eq = e(0) * q(0) + e(1) * q(1) + e(2) * q(2);
      const Eigen::Vector3d w = cross(e, q);  // e^T [q]_x w = e . (q x w) = (e x q) . w
      r(k) = eq;
      for (int j = 0; j < 3; ++j) {
        L(k, j) = -(e(j) - eq * q(j)) / R;  // e^T (I - q q^T) / R
        L(k, 3 + j) = w(j);
      }
    }
    return true;
  }, &data);
  if (!ok || !in_front(E)) return false;
  T = E;
  return true;
}

}  // namespace ibvs
