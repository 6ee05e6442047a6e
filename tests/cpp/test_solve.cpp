// The pseudoinverse routes of cpp/src/solve.hpp (white-box: the test includes
// the library's internal header) and the servo's twist against damped_pinv:
//  * the normal route (Cholesky of J^T J + lambda^2 I, one refinement step)
//    gives the twist of the QR + SVD route to 1e-9 relative on every frame of
//    the paper's cases (simulated here, every scheme and interaction matrix),
//    and Servo::update gives -gain * damped_pinv(J, lambda) e for every lambda,
//    rank-deficient J and tiny lambda included;
//  * the full-rank test tr(N) tr(N^-1) bounds cond(N) from above, within 36x;
//  * rank-deficient J (fewer than 3 points, the mean Jacobian at the
//    half-turn, tiny damping on them) take the robust route;
//  * the default diagnostics match the exact singular values to the documented accuracy, and
//    Status::singular agrees with the exact test sigma_min <= tau sigma_max.
#include "check.hpp"
#include "scene.hpp"
#include "sim_cases.hpp"

#include "solve.hpp"  // cpp/src

#include <Eigen/Eigenvalues>

#include <cstdio>
#include <vector>

using namespace ibvs;

namespace {

const Layout hybrid({{0, Representation::cartesian}, {1, Representation::cartesian}, {2, Representation::polar},
                     {3, Representation::polar}});

// |a - b| within 1e-9 |b|, or within 1e-13 |J+| |e| where b itself is at the
// rounding level of the problem (e almost in J's null space).
bool twist_agrees(const Twist& a, const Twist& b, const MatrixX6& J, const Eigen::VectorXd& e, double gain,
                  double* worst = nullptr) {
  const Eigen::VectorXd s = singular_values(J);
  const double tol = rank_tolerance(J.rows(), s(0));
  double kept = s(0);
  for (Eigen::Index i = 0; i < s.size(); ++i)
    if (s(i) > tol) kept = s(i);
  const double d = (a - b).norm(), scale = b.norm() + 1e-4 * gain * e.norm() / kept;
  if (worst) *worst = std::max(*worst, d / scale);
  return d <= 1e-9 * b.norm() + 1e-13 * gain * e.norm() / kept;
}

// The two routes of the solver on one J, e: normal vs robust (the QR + SVD of before).
struct RouteCheck {
  int frames = 0, robust = 0;
  double worst = 0.0;

  void operator()(const MatrixX6& J0, const Eigen::VectorXd& e0, double lambda, const std::string& what) {
    using Jac = detail::Solver<Eigen::Dynamic, Eigen::Dynamic>::Jac;
    const Eigen::Index m = J0.rows(), rows = std::max<Eigen::Index>(m, 6);
    Jac J = Jac::Zero(rows, 6);
    J.topRows(m) = J0;
    Eigen::VectorXd e = Eigen::VectorXd::Zero(rows);
    e.head(m) = e0;
    detail::Solver<Eigen::Dynamic, Eigen::Dynamic> solver(rows);
    ++frames;
    Twist robust_x;
    solver.robust(J, e, m, lambda, robust_x);
    if (solver.route(J, lambda) == detail::Route::robust) {
      ++robust;
      return;
    }
    Twist x;
    solver.solve_normal(J, e, lambda * lambda, x);
    ibvs_test::report(twist_agrees(x, robust_x, J0, e0, 1.0, &worst), "normal route = QR + SVD route", __FILE__,
                      __LINE__, what + " lambda=" + std::to_string(lambda));
  }
};

// Every frame of the paper's cases (free flight: x-translation, half-turn, general
// motion; gantry: general motion, joint-limit start), for the four schemes, the
// three interaction matrices, undamped and damped (the servo of the run), checked
// with both routes.
void paper_frames() {
  using namespace sim_cases;
  RouteCheck check;
  const Layout layouts[] = {Layout::cartesian(4), Layout::polar(4), hybrid, Layout::stacked(4)};
  for (const Layout& L : layouts)
    for (auto mode : {InteractionMatrix::current, InteractionMatrix::desired, InteractionMatrix::mean})
      for (double lambda : {0.0, 0.01})
        for (int c = 0; c < 5; ++c) {
          const bool gantry = c >= 3;
          ServoOptions so;
          so.gain = gantry ? 2.0 : 1.0;
          so.damping = lambda;
          so.jacobian = mode;
          EpisodeOptions eo;
          eo.duration = gantry ? 15.0 : 10.0;
          eo.depth = gantry ? DepthMode::pose : DepthMode::exact;
          const Gantry g = Gantry::afma6();
          std::optional<Episode> ep;
          if (gantry)
            ep.emplace(Servo(L, so), Camera::afma6(), gantry_target(g), g, eo);
          else
            ep.emplace(Servo(L, so), Camera::normalized(0.3), Target::paper(), eo);
          const EpisodeResult& r = c == 0   ? ep->run(x_translation(), Pose::Identity())
                                   : c == 1 ? ep->run(half_turn_z(), Pose::Identity())
                                   : c == 2 ? ep->run(general_motion(), Pose::Identity())
                                   : c == 3 ? ep->run(gantry_start(), gantry_goal())
                                            : ep->run(gantry_joint_limit_start(), gantry_goal());
          const History& h = r.history;
          for (int k = 0; k < h.frames; ++k) {
            Points uv(2, 4);
            Eigen::VectorXd z(4);
            for (int i = 0; i < 4; ++i) {
              uv.col(i) << h.uv(k, 2 * i), h.uv(k, 2 * i + 1);
              z(i) = h.depth(k, i);
            }
            if (!uv.allFinite() || !z.allFinite()) continue;
            MatrixX6 J = jacobian(L, uv, z);
            const MatrixX6 Jd = jacobian(L, r.uv_desired, r.depth_desired);
            if (mode == InteractionMatrix::desired) J = Jd;
            if (mode == InteractionMatrix::mean) J = 0.5 * (J + Jd);
            // The servo's own error (its polar rows may fall back near the centre: take it from a step).
            Servo servo(L, so);
            ServoOutput out(L);
            servo.update(uv, z, r.uv_desired, r.depth_desired, out);
            check(out.jacobian, out.error, lambda, L.describe() + " case " + std::to_string(c) + " frame " +
                                                       std::to_string(k));
          }
        }
  std::printf("paper frames: %d, robust route %d, worst normal-vs-robust difference %.2g (relative)\n", check.frames,
              check.robust, check.worst);
  CHECK(check.frames > 20000);
  CHECK(check.robust < check.frames / 100);  // the fast route is the rule
}

// Servo::update = -gain * damped_pinv(J, lambda) e for random frames, every layout kind,
// point count and interaction matrix, lambda from 0 to 1 (tiny ones included).
void servo_matches_damped_pinv() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> c(-0.4, 0.4), d(0.3, 5.0);
  double worst = 0.0;
  int cases = 0;
  for (int n : {1, 2, 3, 4, 6}) {
    const Layout kinds[] = {Layout::cartesian(n), Layout::polar(n), Layout::stacked(n), Layout::cylindrical(n)};
    for (const Layout& L : kinds)
      for (auto mode : {InteractionMatrix::current, InteractionMatrix::desired, InteractionMatrix::mean})
        for (double lambda : {0.0, 1e-300, 1e-12, 1e-8, 1e-6, 1e-4, 1e-2, 1.0})
          for (int rep = 0; rep < 3; ++rep) {
            ServoOptions o;
            o.gain = 0.7;
            o.damping = lambda;
            o.jacobian = mode;
            Servo servo(L, o);
            ServoInput in(L);
            ServoOutput out(L);
            for (int i = 0; i < n; ++i) {
              in.uv.col(i) << c(rng), c(rng);
              in.uv_desired.col(i) << c(rng), c(rng);
              in.depth(i) = d(rng);
              in.depth_desired(i) = d(rng);
            }
            if (rep == 2) {  // the half-turn: the mean Jacobian loses a rank
              in.uv = -in.uv_desired;
              in.depth = in.depth_desired;
            }
            if (servo.update(in, out) == Status::invalid_input) {
              CHECK(false);
              continue;
            }
            const Twist ref = -0.7 * damped_pinv(out.jacobian, lambda) * out.error;
            ++cases;
            ibvs_test::report(twist_agrees(out.velocity, ref, out.jacobian, out.error, 0.7, &worst),
                              "Servo = -gain damped_pinv(J, lambda) e", __FILE__, __LINE__,
                              L.describe() + " lambda=" + std::to_string(lambda) + " mode " +
                                  std::to_string(int(mode)));
          }
  }
  std::printf("servo vs damped_pinv: %d cases, worst relative difference %.2g\n", cases, worst);
}

// tr(N) tr(N^-1) from the Cholesky factor: >= cond(N), <= 36 cond(N).
void condition_bound() {
  std::mt19937_64 rng(ibvs_test::seed + 1);
  std::normal_distribution<double> g;
  for (int k = 0; k < 200; ++k) {
    MatrixX6 J(16, 6);
    for (Eigen::Index i = 0; i < J.size(); ++i) J.data()[i] = g(rng);
    J.col(k % 6) *= std::pow(10.0, -(k % 5));  // conditioning from 1 to 1e4
    const Eigen::Matrix<double, 6, 6> N = J.transpose() * J;
    detail::Normal f;
    CHECK(f.factor(N));
    const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(N).eigenvalues();
    const double cond = ev(5) / ev(0);
    ibvs_test::report(f.bound >= cond * (1 - 1e-9) && f.bound <= 36 * cond * (1 + 1e-9), "cond <= bound <= 36 cond",
                      __FILE__, __LINE__, std::to_string(f.bound / cond));
    CHECK((f.L * f.L.transpose() - N).norm() <= 1e-13 * N.norm());
    CHECK((f.L * f.Li - Eigen::Matrix<double, 6, 6>::Identity()).norm() <= 1e-10);
  }
  detail::Normal f;
  CHECK(!f.factor(Eigen::Matrix<double, 6, 6>::Zero()));  // not positive definite: refused
}

// Fewer than 3 points and the mean Jacobian at the half-turn are rank-deficient:
// the robust route, for lambda = 0 and for a tiny lambda.
void rank_deficient_take_robust_route() {
  using Solve = detail::Solver<Eigen::Dynamic, Eigen::Dynamic>;
  auto route = [](const MatrixX6& J0, double lambda) {
    Solve s(std::max<Eigen::Index>(J0.rows(), 6));
    Solve::Jac J = Solve::Jac::Zero(std::max<Eigen::Index>(J0.rows(), 6), 6);
    J.topRows(J0.rows()) = J0;
    return s.route(J, lambda);
  };
  Points uv(2, 4);
  uv << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  const Eigen::Vector4d z = Eigen::Vector4d::Constant(2.0);
  for (double lambda : {0.0, 1e-12, 1e-8}) {
    CHECK(route(jacobian(Layout::cartesian(1), uv.leftCols(1), z.head(1)), lambda) == detail::Route::robust);
    CHECK(route(jacobian(Layout::cartesian(2), uv.leftCols(2), z.head(2)), lambda) == detail::Route::robust);
    CHECK(route(jacobian(Layout::polar(2), uv.leftCols(2), z.head(2)), lambda) == detail::Route::robust);
    const MatrixX6 mean = 0.5 * (jacobian(Layout::cartesian(4), uv, z) + jacobian(Layout::cartesian(4), -uv, z));
    CHECK(route(mean, lambda) == detail::Route::robust);
  }
  // Full rank, and the usual damping: the normal route.
  CHECK(route(jacobian(Layout::cartesian(4), uv, z), 0.0) == detail::Route::normal);
  CHECK(route(jacobian(Layout::stacked(4), uv, z), 0.01) == detail::Route::normal);
  const MatrixX6 mean = 0.5 * (jacobian(Layout::cartesian(4), uv, z) + jacobian(Layout::cartesian(4), -uv, z));
  CHECK(route(mean, 0.01) == detail::Route::normal);
}

// Diagnostics: the default values (computed when read) against the exact singular values (random frames of every
// layout, and every step of closed loops), Status::singular against the exact test.
void diagnostics_accuracy() {
  std::mt19937_64 rng(ibvs_test::seed + 2);
  std::uniform_real_distribution<double> c(-0.5, 0.5), d(0.3, 5.0);
  double worst_max = 0.0, worst_min = 0.0;
  int singular = 0, total = 0;
  for (int n : {1, 2, 3, 4, 5, 8}) {
    const Layout kinds[] = {Layout::cartesian(n), Layout::polar(n), Layout::stacked(n), Layout::cylindrical(n)};
    for (const Layout& L : kinds)
      for (auto mode : {InteractionMatrix::current, InteractionMatrix::mean})
        for (double lambda : {0.0, 0.01})
          for (int rep = 0; rep < 10; ++rep) {
            ServoOptions o;
            o.damping = lambda;
            o.jacobian = mode;
            Servo servo(L, o);
            ServoInput in(L);
            ServoOutput out(L);
            for (int i = 0; i < n; ++i) {
              in.uv.col(i) << c(rng), c(rng);
              in.uv_desired.col(i) << c(rng), c(rng);
              in.depth(i) = d(rng);
              in.depth_desired(i) = in.depth(i);
            }
            if (rep % 3 == 0) in.uv = -in.uv_desired;  // half-turn: rank-deficient mean
            const Status st = servo.update(in, out);
            const Eigen::VectorXd s = singular_values(out.jacobian);
            const double smin = L.rows() >= 6 ? s(5) : 0.0, smax = s(0);
            const bool exact_singular = smin <= singular_tolerance(L.rows()) * smax;
            ++total;
            singular += exact_singular;
            ibvs_test::report((st == Status::singular) == exact_singular, "Status::singular = exact test", __FILE__,
                              __LINE__, L.describe() + " " + std::to_string(smin / smax));
            // The documented accuracy: sigma_max to rounding; sigma_min^2 (an eigenvalue of J^T J) within a
            // few eps sigma_max^2 (the rounding of J^T J), i.e. relative ~eps cond(J)^2 for sigma_min.
            const double eps = std::numeric_limits<double>::epsilon();
            worst_max = std::max(worst_max, std::abs(out.sigma_max() - smax) / smax);
            if (!exact_singular)
              worst_min = std::max(worst_min, std::abs(out.sigma_min() - smin) * smin / (eps * smax * smax));
            else CHECK(out.sigma_min() <= singular_tolerance(L.rows()) * out.sigma_max());
          }
  }
  std::printf("diagnostics: %d frames (%d singular), worst relative error sigma_max %.2g, "
              "sigma_min error %.2g eps sigma_max^2 / sigma_min\n", total, singular, worst_max, worst_min);
  CHECK(singular > 50 && singular < total);
  CHECK(worst_max <= 1e-14);
  CHECK(worst_min <= 16.0);

  // Closed loops (every frame of them): the default values and the exact option agree.
  Twist start;
  start << 0.1, -0.05, -0.3, 0.1, -0.05, 1.0;
  double worst_loop = 0.0;
  for (const Layout& L : {Layout::cartesian(4), Layout::polar(4), hybrid, Layout::stacked(4)}) {
    ServoOptions exact;
    exact.exact_diagnostics = true;
    Servo est_servo(L, {}), exact_servo(L, exact);
    ServoInput in(L);
    ServoOutput a(L), b(L);
    ibvs_test::look(Pose::Identity(), ibvs_test::square(0.25, 3.0), in.uv_desired, in.depth_desired);
    Pose T = ibvs_test::pose(start);
    for (int k = 0; k < 600; ++k) {
      ibvs_test::look(T, ibvs_test::square(0.25, 3.0), in.uv, in.depth);
      est_servo.update(in, a);
      exact_servo.update(in, b);
      CHECK(a.velocity == b.velocity);  // the twist never depends on the diagnostics
      worst_loop = std::max({worst_loop, std::abs(a.sigma_min() - b.sigma_min()) / b.sigma_min(),
                             std::abs(a.sigma_max() - b.sigma_max()) / b.sigma_max()});
      CHECK(a.status == b.status);
      T = T * se3_exp(a.velocity / 60.0);
    }
  }
  std::printf("diagnostics along closed loops: worst relative error %.2g\n", worst_loop);
  CHECK(worst_loop <= 1e-8);
}

}  // namespace

void run_tests() {
  condition_bound();
  rank_deficient_take_robust_route();
  servo_matches_damped_pinv();
  diagnostics_accuracy();
  paper_frames();
}
