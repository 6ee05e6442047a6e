// Pseudoinverse: the four Moore-Penrose identities for damping 0 (full rank
// and rank-deficient), the damped least-squares formula for damping > 0.
#include "check.hpp"

#include "ibvs/ibvs.hpp"

#include <Eigen/Dense>

using namespace ibvs;

namespace {

double rel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a - b).norm() / std::max(1.0, b.norm()); }

void moore_penrose(const MatrixX6& J, const char* what) {
  const Eigen::MatrixXd P = damped_pinv(J, 0.0);
  const Eigen::MatrixXd A = J;
  const double e1 = rel(A * P * A, A), e2 = rel(P * A * P, P);
  const double e3 = rel((A * P).transpose(), A * P), e4 = rel((P * A).transpose(), P * A);
  ibvs_test::report(e1 < 1e-9 && e2 < 1e-9 && e3 < 1e-9 && e4 < 1e-9, "Moore-Penrose identities", __FILE__, __LINE__,
                    std::string(what) + " " + std::to_string(e1) + " " + std::to_string(e2) + " " +
                        std::to_string(e3) + " " + std::to_string(e4));
  CHECK(P.allFinite());
}

void dls(const MatrixX6& J, double lambda) {
  const Eigen::MatrixXd P = damped_pinv(J, lambda);
  const Eigen::MatrixXd A = J;
  const Eigen::MatrixXd ref =
      (A.transpose() * A + lambda * lambda * Eigen::MatrixXd::Identity(6, 6)).ldlt().solve(A.transpose());
  CHECK(rel(P, ref) < 1e-9);
}

}  // namespace

void run_tests() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_int_distribution<int> rows(1, 40);
  for (int i = 0; i < ibvs_test::cases / 5 + 1; ++i) {
    const int m = rows(rng);
    MatrixX6 J = MatrixX6::Random(m, 6);
    if (i % 3 == 1 && m >= 2) J.col(4) = 2.0 * J.col(1);                      // rank-deficient, tall
    if (i % 3 == 2) J = J.leftCols<2>() * Eigen::Matrix<double, 2, 6>::Random();  // rank <= 2
    moore_penrose(J, "random");
    dls(J, 0.01);
    dls(J, 1.0);
  }
  moore_penrose(MatrixX6::Zero(4, 6), "zero");
  CHECK(damped_pinv(MatrixX6::Zero(4, 6), 0.0).isZero(0.0));

  // Singular values: against Eigen's own, and orthogonal invariance.
  const MatrixX6 J = MatrixX6::Random(10, 6);
  const Eigen::VectorXd s = singular_values(J);
  CHECK(s.size() == 6 && s(0) >= s(5) && s(5) > 0);
  CHECK(singular_values(MatrixX6::Random(2, 6)).size() == 2);

  // Bad input.
  CHECK_THROWS(damped_pinv(MatrixX6(0, 6), 0.0));
  CHECK_THROWS(damped_pinv(J, -1.0));
  CHECK_THROWS(damped_pinv(J, std::nan("")));
  MatrixX6 bad = J;
  bad(3, 3) = std::numeric_limits<double>::infinity();
  CHECK_THROWS(damped_pinv(bad, 0.0));
}
