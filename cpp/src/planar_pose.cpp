#include "ibvs/planar_pose.hpp"

#include "checks.hpp"
#include "svd_instances.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>

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
  if (!points_.allFinite() || points_.cwiseAbs().maxCoeff() > max_depth)  // maxCoeff alone may skip a NaN
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
// Similarity moving the centroid of 2-D points to 0 and their RMS radius to sqrt(2) (Hartley).
template <class Get>
Eigen::Matrix3d normaliser(Eigen::Index n, Get get) {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) c += get(i);
  c /= static_cast<double>(n);
  double r2 = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) r2 += (get(i) - c).squaredNorm();
  const double s = r2 > 0.0 ? std::sqrt(2.0 * static_cast<double>(n) / r2) : 1.0;
  Eigen::Matrix3d N;
  N << s, 0, -s * c(0), 0, s, -s * c(1), 0, 0, 1;
  return N;
}
}  // namespace

bool PlanarPose::estimate(const Eigen::Ref<const Points>& uv, Pose& T) const noexcept {
  const Eigen::Index n = points_.cols();
  if (uv.cols() != n || !detail::valid_points(uv)) return false;
  // 1. Homography image ~ H (X, Y, 1) by the normalised DLT.
  const Eigen::Matrix3d Nm = normaliser(n, [&](Eigen::Index i) { return Eigen::Vector2d(points_.block<2, 1>(0, i)); });
  const Eigen::Matrix3d Ni = normaliser(n, [&](Eigen::Index i) { return Eigen::Vector2d(uv.col(i)); });
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d X = Nm * Eigen::Vector3d(points_(0, i), points_(1, i), 1.0);
    const Eigen::Vector3d x = Ni * Eigen::Vector3d(uv(0, i), uv(1, i), 1.0);
    Eigen::Matrix<double, 9, 1> a, b;
    a << X, Eigen::Vector3d::Zero(), -x(0) / x(2) * X;
    b << Eigen::Vector3d::Zero(), X, -x(1) / x(2) * X;
    AtA.noalias() += a * a.transpose() + b * b.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(AtA);
  if (eig.info() != Eigen::Success) return false;
  // A unique homography needs a one-dimensional null space: a second (nearly) zero
  // eigenvalue means the image does not determine it (e.g. three of four points on a line).
  if (!(eig.eigenvalues()(1) > 1e-10 * eig.eigenvalues()(8))) return false;
  const Eigen::Matrix<double, 9, 1> h = eig.eigenvectors().col(0);
  Eigen::Matrix3d Hn;
  Hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  const Eigen::Matrix3d H = Ni.inverse() * Hn * Nm;
  // 2. H ~ [r1 r2 t]: scale from the rotation columns, sign from t_z > 0.
  const double n1 = H.col(0).norm(), n2 = H.col(1).norm();
  if (!(n1 > 0.0) || !(n2 > 0.0)) return false;
  double lambda = 2.0 / (n1 + n2);
  if (H(2, 2) < 0.0) lambda = -lambda;
  Eigen::Matrix3d M;
  M.col(0) = lambda * H.col(0);
  M.col(1) = lambda * H.col(1);
  M.col(2) = M.col(0).cross(M.col(1));
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  Pose E = Pose::Identity();
  E.topLeftCorner<3, 3>() = svd.matrixU() * D * svd.matrixV().transpose();
  E.topRightCorner<3, 1>() = lambda * H.col(2);
  // 3. Gauss-Newton on the reprojection error. With T <- exp(-d) T the
  // projected points move by L d (eq. 3 Jacobian of each point), so the
  // step is d = -(L^T L)^-1 L^T r.
  for (int it = 0; it < iterations_; ++it) {
    Eigen::Matrix<double, 6, 6> LtL = Eigen::Matrix<double, 6, 6>::Zero();
    Twist Ltr = Twist::Zero();
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector3d p = E.topLeftCorner<3, 3>() * points_.col(i) + E.topRightCorner<3, 1>();
      if (!(p(2) > 0.0)) return false;
      const double u = p(0) / p(2), v = p(1) / p(2);
      const Matrix26 L = cartesian_jacobian(u, v, p(2));
      const Eigen::Vector2d r(u - uv(0, i), v - uv(1, i));
      LtL.noalias() += L.transpose() * L;
      Ltr.noalias() += L.transpose() * r;
    }
    const Twist d = LtL.ldlt().solve(Ltr);
    if (!d.allFinite()) return false;
    E = se3_exp(d) * E;  // exp(-(-d)): the step is -d, and T <- exp(-step) T
    if (d.norm() < 1e-14) break;
  }
  if (!E.allFinite()) return false;
  T = E;
  return true;
}

}  // namespace ibvs
