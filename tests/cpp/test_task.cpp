// Tasks of feature blocks (task.hpp, feature.hpp): the image line against
// central differences of its own projection and against ViSP's published
// formula; a Task of points only is the Servo of its Layout, bit for bit;
// weights and degrees of freedom against an independent weighted least-squares
// solve; a task of four lines closes the loop; validate() and update() refuse
// the same measurements.
#include "check.hpp"
#include "refusals.hpp"
#include "scene.hpp"

#include <array>

using namespace ibvs;

namespace {

// A 3-D line through camera-frame points P1, P2 and the plane through them and P3:
// the line's measurement (rho, theta, A, B, C), 1/Z = A x + B y + C on the plane.
std::array<double, 5> line_of(const Eigen::Vector3d& P1, const Eigen::Vector3d& P2, const Eigen::Vector3d& P3) {
  const Eigen::Vector3d n = (P2 - P1).cross(P3 - P1);
  const double d = n.dot(P1);  // plane n . X = d
  return LineFeature::measure(P1.x() / P1.z(), P1.y() / P1.z(), P2.x() / P2.z(), P2.y() / P2.z(), n.x() / d,
                              n.y() / d, n.z() / d);
}

Eigen::Vector3d moved(const Eigen::Vector3d& P, const Twist& xi) {
  const Pose T = se3_inverse(se3_exp(xi));
  return T.topLeftCorner<3, 3>() * P + T.topRightCorner<3, 1>();
}

// ViSP's vpFeatureLine::interaction, transcribed with its plane A' X + B' Y + C' Z + D' = 0.
Eigen::Matrix<double, 2, 6> visp_line(double rho, double theta, double A, double B, double C, double D) {
  const double co = std::cos(theta), si = std::sin(theta);
  const double lt = (A * si - B * co) / D, lr = (C + rho * A * co + rho * B * si) / D;
  Eigen::Matrix<double, 2, 6> L;
  L << co * lr, si * lr, -rho * lr, si * (1 + rho * rho), -co * (1 + rho * rho), 0,  //
      co * lt, si * lt, -rho * lt, -rho * co, -rho * si, -1;
  return L;
}

void line_jacobian() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> u(-0.4, 0.4), z(0.5, 5.0);
  const LineFeature line;
  int checked = 0;
  double worst_fd = 0.0, worst_visp = 0.0;
  for (int c = 0; c < ibvs_test::cases; ++c) {
    const Eigen::Vector3d P1 = ibvs_test::point(u(rng), u(rng), z(rng)), P2 = ibvs_test::point(u(rng), u(rng), z(rng)),
                          P3 = ibvs_test::point(u(rng), u(rng), z(rng));
    const std::array<double, 5> m = line_of(P1, P2, P3);
    int entry = 0;
    if (line.check(m.data(), entry) || std::abs(m[0]) < 0.02) continue;  // an edge-on plane; rho near 0 flips
    MatrixX6 L(2, 6);
    line.interaction(m.data(), L);
    // Central differences of the line's own projection (the measurement taken anew after the motion).
    const double h = 1e-6;
    Eigen::Matrix<double, 2, 6> Ln;
    for (int k = 0; k < 6; ++k) {
      Twist xi = Twist::Zero();
      xi(k) = h;
      const auto a = line_of(moved(P1, xi), moved(P2, xi), moved(P3, xi));
      const auto b = line_of(moved(P1, -xi), moved(P2, -xi), moved(P3, -xi));
      Ln(0, k) = (a[0] - b[0]) / (2 * h);
      Ln(1, k) = wrap_angle(a[1] - b[1]) / (2 * h);
    }
    const double scale = std::max(1.0, L.cwiseAbs().maxCoeff());
    worst_fd = std::max(worst_fd, (L - Ln).cwiseAbs().maxCoeff() / scale);
    // ViSP's plane: A' X + B' Y + C' Z + D' = 0 with (A', B', C') = n, D' = -d, scaled anyhow.
    const Eigen::Vector3d n = (P2 - P1).cross(P3 - P1);
    const double d = n.dot(P1), k = 3.7;
    worst_visp = std::max(worst_visp,
                          (L - visp_line(m[0], m[1], k * n.x(), k * n.y(), k * n.z(), -k * d)).cwiseAbs().maxCoeff() /
                              scale);
    ++checked;
  }
  std::printf("line: %d lines, worst relative difference %.2g (finite differences), %.2g (ViSP's formula)\n", checked,
              worst_fd, worst_visp);
  CHECK(checked > ibvs_test::cases / 2);
  CHECK(worst_fd < 1e-6);
  CHECK(worst_visp < 1e-12);
}

void line_measure_and_align() {
  // The line y = 0.1 (theta = pi/2, rho = 0.1) through two points, in either order.
  for (bool swap : {false, true}) {
    const auto m = swap ? LineFeature::measure(0.3, 0.1, -0.2, 0.1, 0, 0, 1) : LineFeature::measure(-0.2, 0.1, 0.3, 0.1, 0, 0, 1);
    CHECK_NEAR(m[0], 0.1, 1e-15);
    CHECK_NEAR(m[1], pi / 2, 1e-15);
  }
  CHECK_THROWS(LineFeature::measure(0.1, 0.1, 0.1, 0.1, 0, 0, 1));
  // The same line as (-rho, theta + pi): aligned to a goal near theta = -pi/2 it takes that form.
  const LineFeature line;
  double m[5] = {0.1, pi / 2, 0, 0, 1}, md[5] = {-0.05, -pi / 2 + 0.1, 0, 0, 1}, e[2];
  line.align(m, md);
  CHECK_NEAR(m[0], -0.1, 1e-15);
  CHECK_NEAR(m[1], -pi / 2, 1e-15);
  line.error(m, md, e);
  CHECK_NEAR(e[0], -0.05, 1e-15);
  CHECK_NEAR(e[1], -0.1, 1e-15);
}

void line_refusals() {
  const LineFeature line;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double good[5] = {0.1, 0.3, 0.0, 0.0, 0.5};
  int entry = 0;
  CHECK(line.check(good, entry) == nullptr);
  for (int i = 0; i < 5; ++i) {
    double m[5];
    std::copy(good, good + 5, m);
    m[i] = nan;
    CHECK(line.check(m, entry) != nullptr && entry == i);
  }
  const double far[5] = {11.0, 0.3, 0, 0, 0.5}, edge_on[5] = {0.1, 0.0, -10.0, 0.0, 1.0};
  CHECK(line.check(far, entry) != nullptr && entry == 0);
  CHECK(line.check(edge_on, entry) != nullptr && entry == -1);  // 1/Z = -10 x + 1 vanishes at x = 0.1
  CHECK_THROWS(line.validate(edge_on, "line"));
}

// Four points of the paper's square and a task of those points only: the same twist, bit for bit.
void points_only_task_is_the_layout() {
  const Layout L = Layout::stacked(4);
  Servo a(L), b{Task(L)};
  ServoInput in(L);
  ServoOutput oa(L), ob(L);
  in.uv << 0.16, -0.05, -0.16, 0.05, 0.05, 0.16, -0.05, -0.16;
  in.uv_desired << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  in.depth.setConstant(0.6);
  a.update(in.uv, in.depth, in.uv_desired, in.depth_desired, oa);
  b.update(in, ob);
  CHECK((oa.velocity.array() == ob.velocity.array()).all());
  CHECK(oa.sigma_min() == ob.sigma_min());
}

// Weights and degrees of freedom: the twist equals the weighted least-squares solution on the kept
// columns, computed independently (damped_pinv of the weighted, reduced J).
void weights_and_dof() {
  std::mt19937_64 rng(ibvs_test::seed + 1);
  std::uniform_real_distribution<double> u(-0.3, 0.3), z(0.5, 3.0), w(0.2, 3.0);
  const Eigen::Vector3d Q1(0.2, -0.1, 2.0), Q2(-0.3, 0.25, 2.5), Q3(0.1, 0.3, 1.5);
  for (int c = 0; c < 50; ++c) {
    Task task(Layout::cartesian(3));
    const double w0 = w(rng), w1 = w(rng), w2 = w(rng), wl = w(rng);
    task.set_point_weights({w0, w1, w2});
    task.add(LineFeature(), wl);
    Dof dof = all_dof;
    dof[static_cast<std::size_t>(c % 6)] = false;  // one component left out
    if (c % 2) dof[static_cast<std::size_t>((c + 3) % 6)] = false;
    task.set_dof(dof);
    for (double damping : {0.0, 0.01}) {
      ServoOptions o;
      o.damping = damping;
      Servo servo(task, o);
      ServoInput in(task);
      ServoOutput out(task);
      for (int i = 0; i < 3; ++i) {
        in.uv.col(i) << u(rng), u(rng);
        in.uv_desired.col(i) << u(rng), u(rng);
        in.depth(i) = z(rng);
      }
      const auto mc = line_of(Q1, Q2, Q3), md = line_of(Q1 + Eigen::Vector3d(0.05, 0, 0), Q2, Q3);
      in.measurements = Eigen::Map<const Eigen::VectorXd>(mc.data(), 5);
      in.measurements_desired = Eigen::Map<const Eigen::VectorXd>(md.data(), 5);
      servo.validate(in);
      const Status st = servo.update(in, out);
      CHECK(st != Status::invalid_input);
      // Independent: the weighted stack, its kept columns, damped_pinv.
      MatrixX6 J = jacobian(Layout::cartesian(3), in.uv, in.depth);
      Eigen::VectorXd e = feature_error(Layout::cartesian(3), features(Layout::cartesian(3), in.uv),
                                        features(Layout::cartesian(3), in.uv_desired));
      const double pw[3] = {w0, w1, w2};
      for (int i = 0; i < 3; ++i) {
        J.middleRows(2 * i, 2) *= pw[i];
        e.segment(2 * i, 2) *= pw[i];
      }
      MatrixX6 Ll(2, 6);
      LineFeature().interaction(mc.data(), Ll);
      double el[2];
      double mca[5] = {mc[0], mc[1], mc[2], mc[3], mc[4]};
      LineFeature().align(mca, md.data());
      LineFeature().error(mca, md.data(), el);
      MatrixX6 Jall(8, 6);
      Jall << J, wl * Ll;
      Eigen::VectorXd eall(8);
      eall << e, wl * el[0], wl * el[1];
      int kept = 0;
      for (bool b : dof) kept += b;
      Eigen::MatrixXd Jk(8, kept);
      for (int i = 0, j = 0; i < 6; ++i)
        if (dof[static_cast<std::size_t>(i)]) Jk.col(j++) = Jall.col(i);
      const Eigen::VectorXd xk = Jk.completeOrthogonalDecomposition().solve(eall);  // undamped reference
      MatrixX6 Jz = Jall;
      for (int i = 0; i < 6; ++i)
        if (!dof[static_cast<std::size_t>(i)]) Jz.col(i).setZero();
      const Twist xd = damped_pinv(Jz, damping) * eall;
      Twist ref = Twist::Zero();
      for (int i = 0, j = 0; i < 6; ++i)
        if (dof[static_cast<std::size_t>(i)]) ref(i) = damping > 0 ? xd(i) : xk(j++);
      const Twist v = -out.velocity / o.gain;
      ibvs_test::report((v - ref).norm() <= 1e-9 * std::max(1.0, ref.norm()), "weighted, reduced solve", __FILE__,
                        __LINE__, task.describe() + " damping " + std::to_string(damping));
      for (int i = 0; i < 6; ++i)
        if (!dof[static_cast<std::size_t>(i)]) CHECK(out.velocity(i) == 0.0);
      CHECK(std::isfinite(out.sigma_min()) && out.sigma_min() > 0.0);  // of the kept columns
    }
  }
}

// The square target's four edges as lines (their plane: the target's), from a general start: the
// camera reaches the goal pose.
void four_lines_converge() {
  const Eigen::Matrix<double, 3, 4> Pw = ibvs_test::square(0.25, 3.0);
  Task task;
  for (int i = 0; i < 4; ++i) task.add(LineFeature());
  ServoOptions o;
  o.gain = 1.0;
  Servo servo(task, o);
  ServoInput in(task);
  ServoOutput out(task);
  const auto lines_at = [&](const Pose& T_wc, Eigen::VectorXd& m) {
    const Pose T_cw = se3_inverse(T_wc);
    Eigen::Matrix<double, 3, 4> P;
    for (int i = 0; i < 4; ++i) P.col(i) = T_cw.topLeftCorner<3, 3>() * Pw.col(i) + T_cw.topRightCorner<3, 1>();
    for (int i = 0; i < 4; ++i) {
      const auto l = line_of(P.col(i), P.col((i + 1) % 4), P.col((i + 2) % 4));
      for (int j = 0; j < 5; ++j) m(5 * i + j) = l[static_cast<std::size_t>(j)];
    }
  };
  lines_at(Pose::Identity(), in.measurements_desired);
  Twist start;
  start << 0.1, -0.08, -0.4, 0.1, -0.12, 0.5;
  Pose T = se3_exp(start);
  const double dt = 1.0 / 60;
  int k = 0;
  for (; k < 3000; ++k) {
    lines_at(T, in.measurements);
    if (servo.update(in, out) == Status::invalid_input) break;
    if (out.error_norm < 1e-8) break;
    T = T * se3_exp(out.velocity * dt);
  }
  const double dp = T.topRightCorner<3, 1>().norm();
  const double dr = Eigen::AngleAxisd(Eigen::Matrix3d(T.topLeftCorner<3, 3>())).angle();
  std::printf("four lines: converged at frame %d, %.2g m and %.2g rad from the goal\n", k, dp, dr);
  CHECK(k < 3000);
  CHECK(dp < 1e-6 && dr < 1e-6);
}

// validate() throws exactly for the measurements update() refuses.
void refusals_agree() {
  Task task(Layout::cartesian(1));
  task.add(LineFeature());
  Servo servo(task);
  ServoInput in(task);
  ServoOutput out(task);
  in.uv_desired << 0.1, 0.1;
  const double good[5] = {0.1, 0.3, 0.0, 0.0, 0.5};
  in.measurements = Eigen::Map<const Eigen::VectorXd>(good, 5);
  in.measurements_desired = in.measurements;
  std::mt19937_64 rng(ibvs_test::seed + 2);
  const std::initializer_list<double> bad = {
      std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 1e300, -11.0, 7.0, 0.1, 2e6};
  ibvs_test::check_refusals_agree(servo, in, out, rng, bad);
  // A task with feature blocks given no measurements is refused; so is a task with nothing in it.
  CHECK(servo.update(in.uv, in.depth, in.uv_desired, in.depth_desired, out) == Status::invalid_input);
  CHECK_THROWS(Servo{Task()});
  CHECK_THROWS(Task().set_dof({false, false, false, false, false, false}));
  CHECK_THROWS(Task(Layout::cartesian(2)).set_point_weights({1.0}));
  CHECK_THROWS(Task().add(LineFeature(), 0.0));
  // Weights within [1/max_task_weight, max_task_weight] (beyond, J^T J could overflow: the fuzz driver).
  CHECK_THROWS(Task().add(LineFeature(), 2 * max_task_weight));
  CHECK_THROWS(Task().add(LineFeature(), 0.5 / max_task_weight));
  CHECK_THROWS(Task(Layout::cartesian(1)).set_point_weights({2 * max_task_weight}));
  CHECK(Task().add(LineFeature(), max_task_weight).add(LineFeature(), 1.0 / max_task_weight).n_features() == 2);
}

}  // namespace

void run_tests() {
  line_jacobian();
  line_measure_and_align();
  line_refusals();
  points_only_task_is_the_layout();
  weights_and_dof();
  four_lines_converge();
  refusals_agree();
}
