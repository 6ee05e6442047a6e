// Every analytic Jacobian against central differences of the projection of a
// static point under a small camera twist: the test, not the paper's print,
// decides the sign convention.
#include "check.hpp"
#include "scene.hpp"

using namespace ibvs;
using ibvs_test::numeric_jacobian;
using ibvs_test::point;

namespace {

// Relative agreement, entry by entry: |Ja - Jn| <= tol * max(1, |Ja|).
bool agrees(const Matrix26& Ja, const Matrix26& Jn, double tol) {
  return ((Ja - Jn).array().abs() <= tol * Ja.array().abs().max(1.0)).all();
}

void check_point(double u, double v, double z) {
  const Eigen::Vector3d P = point(u, v, z);
  const double r = std::hypot(u, v);
  const double h = 1e-6 * std::min({1.0, z, r > 0 ? r * 10 : 1.0});
  const Matrix26 Jc = cartesian_jacobian(u, v, z);
  const bool ok_c = agrees(Jc, numeric_jacobian(P, false, h), 1e-6);
  ibvs_test::report(ok_c, "cartesian FD", __FILE__, __LINE__,
                    "u=" + std::to_string(u) + " v=" + std::to_string(v) + " z=" + std::to_string(z));
  if (r > 0) {
    const Matrix26 Jp = polar_jacobian(u, v, z);
    const bool ok_p = agrees(Jp, numeric_jacobian(P, true, h), 1e-6);
    ibvs_test::report(ok_p, "polar FD", __FILE__, __LINE__,
                      "u=" + std::to_string(u) + " v=" + std::to_string(v) + " z=" + std::to_string(z));
  }
}

void random_points() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> log_z(std::log(0.1), std::log(10.0)), theta(-pi, pi), log_r(std::log(1e-4), std::log(1.0));
  for (int i = 0; i < ibvs_test::cases; ++i) {
    const double r = std::exp(log_r(rng)), t = theta(rng), z = std::exp(log_z(rng));
    check_point(r * std::cos(t), r * std::sin(t), z);
  }
}

void edge_points() {
  // theta exactly pi and just either side of the cut; tiny radius; depth extremes.
  for (double z : {0.1, 1.0, 10.0}) {
    check_point(-0.2, 0.0, z);
    check_point(-0.2, 1e-12, z);
    check_point(-0.2, -1e-12, z);
    check_point(-0.2, 1e-3, z);
    check_point(1e-4, 0.0, z);
    check_point(0.0, -1e-4, z);
    check_point(0.3, 0.3, z);
    check_point(0.0, 0.0, z);  // Cartesian only: the principal point itself
  }
}

void eq7_is_negated() {
  // The printed eq. (7) is exactly -J: record the convention difference.
  const double u = 0.15, v = -0.1, z = 2.0, r = std::hypot(u, v), c = u / r, s = v / r;
  Matrix26 printed;
  printed << c / z, s / z, -r / z, -(1 + r * r) * s, (1 + r * r) * c, 0,  //
      -s / (r * z), c / (r * z), 0, -c / r, -s / r, 1;
  CHECK((polar_jacobian(u, v, z) + printed).cwiseAbs().maxCoeff() < 1e-15);
}

void stacked_row_order() {
  // Rows follow the layout's block order, for every kind of layout.
  Points uv(2, 3);
  uv << 0.1, -0.2, 0.05, 0.2, 0.1, -0.3;
  const Eigen::Vector3d z(1.0, 2.0, 3.0);
  const Layout hybrid({{2, Representation::polar}, {0, Representation::cartesian}, {2, Representation::cartesian},
                       {1, Representation::polar}});
  for (const Layout& L : {Layout::cartesian(3), Layout::polar(3), Layout::stacked(3), hybrid}) {
    const MatrixX6 J = jacobian(L, uv, z);
    const Eigen::VectorXd f = features(L, uv);
    CHECK(J.rows() == L.rows() && f.size() == L.rows());
    for (std::size_t k = 0; k < L.blocks().size(); ++k) {
      const Block b = L.blocks()[k];
      const double u = uv(0, b.point), v = uv(1, b.point);
      const bool polar = b.representation == Representation::polar;
      const Matrix26 Jb = polar ? polar_jacobian(u, v, z(b.point)) : cartesian_jacobian(u, v, z(b.point));
      const Eigen::Vector2d fb = polar ? polar_features(u, v) : Eigen::Vector2d(u, v);
      CHECK(J.middleRows<2>(2 * k) == Jb);
      CHECK(f.segment<2>(2 * k) == fb);
    }
  }
  CHECK(Layout::stacked(4).rows() == 16 && Layout::cartesian(4).rows() == 8 && Layout::polar(64).rows() == 128);
  CHECK(hybrid.n_points() == 3);
}

void principal_point_policy() {
  // A polar block at r = 0 exactly falls back to its Cartesian rows: finite.
  Points uv(2, 2);
  uv << 0.0, 0.1, 0.0, 0.1;
  const Eigen::Vector2d z(1.5, 2.0);
  const MatrixX6 J = jacobian(Layout::polar(2), uv, z);
  CHECK(J.allFinite());
  CHECK(J.topRows<2>() == MatrixX6(cartesian_jacobian(0.0, 0.0, 1.5)));
  CHECK(J.bottomRows<2>() == MatrixX6(polar_jacobian(0.1, 0.1, 2.0)));
  const Eigen::VectorXd f = features(Layout::polar(2), uv);
  CHECK(f.allFinite() && f(0) == 0.0 && f(1) == 0.0);
}

void layout_errors() {
  CHECK_THROWS(Layout::cartesian(0));
  CHECK_THROWS(Layout::stacked(-1));
  CHECK_THROWS(Layout(std::vector<Block>{}));
  CHECK_THROWS(Layout({{-1, Representation::polar}}));
  CHECK_THROWS(Layout({{0, Representation::polar}, {0, Representation::polar}}));
  CHECK_THROWS(Layout({{3, Representation::polar}}, 2));
  CHECK_THROWS(Layout({{0, static_cast<Representation>(7)}}));
  Points uv(2, 3);
  uv.setConstant(0.1);
  CHECK_THROWS(features(Layout::cartesian(4), uv));
  CHECK_THROWS(jacobian(Layout::cartesian(3), uv, Eigen::Vector3d(1, 0, 1)));
  CHECK_THROWS(jacobian(Layout::cartesian(3), uv, Eigen::Vector3d(1, -1, 1)));
  uv(1, 2) = std::nan("");
  CHECK_THROWS(jacobian(Layout::cartesian(3), uv, Eigen::Vector3d(1, 1, 1)));
}

}  // namespace

void run_tests() {
  random_points();
  edge_points();
  eq7_is_negated();
  stacked_row_order();
  principal_point_policy();
  layout_errors();
}
