#include "robust.hpp"

#include "ibvs/pinv.hpp"
#include "ibvs/limits.hpp"

#include <Eigen/QR>
#include <Eigen/SVD>

#include <variant>

namespace ibvs::detail {
namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;

// QR workspace for J of one storage kind: bounded (no heap) or dynamic.
template <int MaxRows>
struct Qr {
  using Jac = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::ColMajor, MaxRows, 6>;
  using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, MaxRows, 1>;
  explicit Qr(Eigen::Index rows) : J(Jac::Zero(rows, 6)), qte(Vec::Zero(rows)), qr(rows, 6) {}
  Jac J;    ///< copy of J (the QR works in place)
  Vec qte;  ///< Q^T e
  Eigen::HouseholderQR<Jac> qr;

  Matrix6 r_factor(const Eigen::Ref<const MatrixX6>& Jin) noexcept {
    J = Jin;
    qr.compute(J);
    return qr.matrixQR().template topRows<6>().template triangularView<Eigen::Upper>();
  }
  void qt_e(const Eigen::Ref<const Eigen::VectorXd>& e) noexcept {
    qte = e;
    qte.applyOnTheLeft(qr.householderQ().transpose());
  }
};

}  // namespace

struct Robust::Work {
  explicit Work(Eigen::Index rows)
      : svd(6, 6, Eigen::ComputeFullU | Eigen::ComputeFullV), svd_values(6, 6) {
    if (rows <= max_realtime_rows) qr.emplace<Qr<max_realtime_rows>>(rows);
    else qr.emplace<Qr<Eigen::Dynamic>>(rows);
  }
  std::variant<Qr<max_realtime_rows>, Qr<Eigen::Dynamic>> qr{std::in_place_index<0>, 6};
  Eigen::JacobiSVD<Matrix6> svd;         ///< robust route: U, S, V of R
  Eigen::JacobiSVD<Matrix6> svd_values;  ///< exact diagnostics: singular values of R only
};

Robust::Robust(Eigen::Index rows) : work_(std::make_unique<Work>(rows)) {}
Robust::~Robust() = default;
Robust::Robust(Robust&&) noexcept = default;
Robust& Robust::operator=(Robust&&) noexcept = default;

void Robust::solve(const Eigen::Ref<const MatrixX6>& J, const Eigen::Ref<const Eigen::VectorXd>& e, Eigen::Index m,
                   double lambda, Twist& x, double& smin, double& smax, int columns) noexcept {
  Work& w = *work_;
  std::visit(
      [&](auto& q) noexcept {
        w.svd.compute(q.r_factor(J));
        q.qt_e(e);
        const auto& s = w.svd.singularValues();
        const double tol = rank_tolerance(m, s(0));
        Twist y = w.svd.matrixU().transpose() * q.qte.template head<6>();
        for (int i = 0; i < 6; ++i) y(i) *= pinv_factor(s(i), lambda, tol);
        x.noalias() = w.svd.matrixV() * y;
      },
      w.qr);
  smin = w.svd.singularValues()(columns - 1);
  smax = w.svd.singularValues()(0);
}

void Robust::singular_values(const Eigen::Ref<const MatrixX6>& J, double& smin, double& smax, int columns) noexcept {
  Work& w = *work_;
  std::visit([&](auto& q) noexcept { w.svd_values.compute(q.r_factor(J)); }, w.qr);
  smin = w.svd_values.singularValues()(columns - 1);
  smax = w.svd_values.singularValues()(0);
}

}  // namespace ibvs::detail
