#include "ibvs/pinv.hpp"

#include "checks.hpp"
#include "svd_instances.hpp"

#include <Eigen/SVD>

#include <stdexcept>
#include <string>

// The one instantiation of JacobiSVD<MatrixXd> (svd_instances.hpp), shared with JointMapping, SecondaryTask
// and the C++ tests.
template class Eigen::JacobiSVD<Eigen::MatrixXd>;

namespace ibvs {
namespace {

// Returns max |J_ij| after checking the scale limits (limits.hpp).
double check_matrix(const Eigen::Ref<const MatrixX6>& J) {
  if (J.rows() == 0) throw std::invalid_argument("ibvs: J must have at least one row");
  if (!J.allFinite()) throw std::invalid_argument("ibvs: J must contain only finite values");
  const double m = largest_magnitude(J);  // J is finite (checked above)
  if (m > max_matrix_entry)
    throw std::invalid_argument("ibvs: J has an entry of magnitude " + detail::number(m) + ", above the limit " +
                                detail::number(max_matrix_entry));
  return m;
}

}  // namespace

Eigen::Matrix<double, 6, Eigen::Dynamic> damped_pinv(const Eigen::Ref<const MatrixX6>& J, double damping) {
  const double m = check_matrix(J);
  if (m > 0.0 && m < 1.0 / max_matrix_entry)
    throw std::invalid_argument("ibvs: J's largest entry " + detail::number(m) + " is below " +
                                detail::number(1.0 / max_matrix_entry) + ": its pseudoinverse would overflow");
  detail::check_nonnegative(damping, "damping");
  if (damping > max_matrix_entry)
    throw std::invalid_argument("ibvs: damping = " + detail::number(damping) + " is above the limit " +
                                detail::number(max_matrix_entry));
  // A dynamic column count lets JacobiSVD return the thin factors.
  const Eigen::MatrixXd A = J;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  const double tol = rank_tolerance(J.rows(), s.size() ? s(0) : 0.0);
  Eigen::VectorXd phi(s.size());
  for (Eigen::Index i = 0; i < s.size(); ++i) phi(i) = pinv_factor(s(i), damping, tol);
  return svd.matrixV() * phi.asDiagonal() * svd.matrixU().transpose();
}

Eigen::VectorXd singular_values(const Eigen::Ref<const MatrixX6>& J) {
  check_matrix(J);
  const Eigen::MatrixXd A = J;
  return Eigen::JacobiSVD<Eigen::MatrixXd>(A).singularValues();
}

}  // namespace ibvs
