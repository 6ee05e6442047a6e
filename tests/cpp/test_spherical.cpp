// Spherical point and spherical-polar feature blocks (features/spherical.hpp):
// interaction matrices against central differences of their own projection
// (the camera moved by a small twist, the point re-measured) at any angle off
// the axis, behind the camera too, and against the published forms (Hamel &
// Mahony 2002 eq. 9 as cross products; Corke 2010 / MVTB's
// SphericalCamera.visjac_p transcribed with its (phi, theta) row order); the
// wrapped azimuth error and the near-axis rows; stacking with other kinds;
// refusals; closed loops, among them a target 100 degrees off the axis seen
// through a fisheye lens model, servoed from its pixels.
#include "check.hpp"
#include "scene.hpp"

#include <array>
#include <cmath>

using namespace ibvs;

namespace {

constexpr double deg = pi / 180.0;

Eigen::Vector3d moved(const Eigen::Vector3d& P, const Twist& xi) {
  const Pose T = se3_inverse(se3_exp(xi));
  return T.topLeftCorner<3, 3>() * P + T.topRightCorner<3, 1>();
}

std::array<double, 4> measure(const Eigen::Vector3d& P) { return SphericalPointFeature::measure(P.x(), P.y(), P.z()); }

// A random point at colatitude in [lo, hi] degrees, distance in [0.3, 5] m.
Eigen::Vector3d random_point(std::mt19937_64& rng, double lo, double hi) {
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const double b = (lo + (hi - lo) * U(rng)) * deg, p = (2.0 * U(rng) - 1.0) * pi, R = 0.3 + 4.7 * U(rng);
  return R * Eigen::Vector3d(std::sin(b) * std::cos(p), std::sin(b) * std::sin(p), std::cos(b));
}

// Corke, ICRA 2010 (MVTB SphericalCamera.visjac_p): rows (phi = longitude, theta = colatitude).
Eigen::Matrix<double, 2, 6> corke(double phi, double theta, double R) {
  const double cp = std::cos(phi), sp = std::sin(phi), ct = std::cos(theta), st = std::sin(theta);
  Eigen::Matrix<double, 2, 6> L;
  L << sp / R / st, -cp / R / st, 0, cp * ct / st, sp * ct / st, -1,  //
      -cp * ct / R, -sp * ct / R, st / R, sp, -cp, 0;
  return L;
}

// Hamel & Mahony 2002 eq. 9, p_dot = -Omega x p - (I - p p^T) V / r, column by column.
Eigen::Matrix<double, 3, 6> hamel_mahony(const Eigen::Vector3d& p, double r) {
  Eigen::Matrix<double, 3, 6> L;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(i);
    L.col(i) = -(e - p * p.dot(e)) / r;
    L.col(3 + i) = -e.cross(p);
  }
  return L;
}

void jacobians() {
  std::mt19937_64 rng(ibvs_test::seed);
  const SphericalPointFeature point;
  const SphericalPolarFeature polar;
  double worst_fd_point = 0, worst_fd_polar = 0, worst_pub_point = 0, worst_pub_polar = 0;
  for (int c = 0; c < ibvs_test::cases; ++c) {
    const Eigen::Vector3d P = random_point(rng, 2.0, 178.0);  // in front, sideways and behind
    const auto m = measure(P);
    int entry = 0;
    CHECK(point.check(m.data(), entry) == nullptr && polar.check(m.data(), entry) == nullptr);
    MatrixX6 Ls(3, 6), Lp(2, 6);
    point.interaction(m.data(), Ls);
    polar.interaction(m.data(), Lp);
    const double h = 1e-6;
    for (int j = 0; j < 6; ++j) {
      Twist xi = Twist::Zero();
      xi(j) = h;
      const auto a = measure(moved(P, xi)), b = measure(moved(P, -xi));
      double sa[3], sb[3], e[2];
      point.value(a.data(), sa);
      point.value(b.data(), sb);
      for (int i = 0; i < 3; ++i) worst_fd_point = std::max(worst_fd_point, std::abs((sa[i] - sb[i]) / (2 * h) - Ls(i, j)));
      polar.error(a.data(), b.data(), e);  // the wrapped difference: continuous across phi = +-pi
      const double scale = 1.0 + Lp.col(j).cwiseAbs().maxCoeff();
      for (int i = 0; i < 2; ++i) worst_fd_polar = std::max(worst_fd_polar, std::abs(e[i] / (2 * h) - Lp(i, j)) / scale);
    }
    worst_pub_point = std::max(worst_pub_point, (Ls - hamel_mahony(P.normalized(), P.norm())).cwiseAbs().maxCoeff());
    double s[2];
    polar.value(m.data(), s);
    Eigen::Matrix<double, 2, 6> swapped;
    swapped << Lp.row(1), Lp.row(0);
    worst_pub_polar = std::max(worst_pub_polar, (swapped - corke(s[1], s[0], P.norm())).cwiseAbs().maxCoeff());
  }
  std::printf("spherical point: FD %.2g, Hamel & Mahony %.2g; spherical polar: FD %.2g (relative), Corke %.2g\n",
              worst_fd_point, worst_pub_point, worst_fd_polar, worst_pub_polar);
  CHECK(worst_fd_point < 1e-7 && worst_fd_polar < 1e-6);
  CHECK(worst_pub_point < 1e-14 && worst_pub_polar < 1e-12);
  // Small colatitude: the spherical-polar rows tend to the paper's -(eq. 7) rows of (r, theta) (Z ~ R).
  const Eigen::Vector3d Q(2e-3, -4e-3, 1.0);  // 0.26 degrees: above min_sin
  MatrixX6 Lq(2, 6);
  polar.interaction(measure(Q).data(), Lq);
  const Matrix26 Jp = polar_jacobian(Q.x() / Q.z(), Q.y() / Q.z(), Q.z());
  CHECK((Lq - MatrixX6(Jp)).cwiseAbs().maxCoeff() < 1e-4 * Jp.cwiseAbs().maxCoeff());  // O(beta^2) apart
}

void azimuth_and_axis() {
  const SphericalPolarFeature polar;
  // Across phi = +-pi the azimuth error is the short way round.
  const auto a = measure(Eigen::Vector3d(-1.0, 0.01, 1.0)), b = measure(Eigen::Vector3d(-1.0, -0.01, 1.0));
  double e[2];
  polar.error(a.data(), b.data(), e);
  CHECK(std::abs(e[1]) < 0.03 && std::abs(e[0]) < 1e-12);
  // A half-turn about the axis: error pi, positive (wrap_angle's convention).
  const auto c = measure(Eigen::Vector3d(0.5, 0.0, 1.0)), d = measure(Eigen::Vector3d(-0.5, 0.0, 1.0));
  polar.error(c.data(), d.data(), e);
  CHECK(e[1] == pi);
  // Near the axis: the (bx, by) rows of the spherical point, in value, error and interaction.
  const auto n = measure(Eigen::Vector3d(1e-5, 2e-5, 1.0)), g = measure(Eigen::Vector3d(0.3, 0.1, 1.0));
  double s[2];
  polar.value(n.data(), s);
  CHECK(s[0] == n[0] && s[1] == n[1]);
  polar.error(n.data(), g.data(), e);
  CHECK_NEAR(e[0], n[0] - g[0], 1e-15);
  MatrixX6 L(2, 6), Ls(3, 6);
  polar.interaction(n.data(), L);
  SphericalPointFeature().interaction(n.data(), Ls);
  CHECK(L == Ls.topRows<2>());
  // A goal on the axis has no azimuth: its error is 0.
  const auto axis = measure(Eigen::Vector3d(0.0, 0.0, 2.0));
  polar.error(g.data(), axis.data(), e);
  CHECK(e[1] == 0.0 && e[0] > 0.0);
  CHECK(polar.describe() == "spherical_polar" && SphericalPolarFeature(0.01).describe() == "spherical_polar(min_sin=0.01)");
  CHECK_THROWS(SphericalPolarFeature(0.0));
  CHECK_THROWS(SphericalPolarFeature(1.0));
}

void refusals() {
  const SphericalPointFeature point;
  const SphericalPolarFeature polar;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double bad[][4] = {{nan, 0, 1, 1}, {0, 0, 0, 1}, {0, 0, 1.01, 1}, {0, 0, 1, 0}, {0, 0, 1, 2e6}, {0, 0, 1, -1}};
  const int entries[] = {0, -1, -1, 3, 3, 3};
  for (int i = 0; i < 6; ++i) {
    int entry = 99;
    CHECK(point.check(bad[i], entry) != nullptr && entry == entries[i]);
    CHECK(polar.check(bad[i], entry) != nullptr);
    CHECK_THROWS(point.validate(bad[i], "m"));
  }
  CHECK_THROWS(SphericalPointFeature::measure(0, 0, 0));
  // Pixels through the lens: refused points NaN and counted; sizes.
  const CameraModel cam = CameraModel::from_opencv(Eigen::Matrix3d(Eigen::Vector3d(300, 300, 1).asDiagonal()) +
                                                       (Eigen::Matrix3d() << 0, 0, 640, 0, 0, 512, 0, 0, 0).finished(),
                                                   Eigen::Vector4d::Zero(), 1280, 1024, true);
  Points px(2, 3);
  px << 640, 640 + 1e6, 700, 512, 512, 500;
  Eigen::VectorXd R(3), m(12);
  R << 1.0, 1.0, 0.0;
  CHECK(spherical_measurements(cam, px, R, m) == 2);
  CHECK(std::isfinite(m(0)) && std::isnan(m(4)) && std::isnan(m(8)) && std::isnan(m(11)));
  Eigen::VectorXd wrong(8);
  CHECK(spherical_measurements(cam, px, R, wrong) == 3 && std::isnan(wrong(0)));
}

// Stacked with a Cartesian point and a line in one task: rows and measurement offsets.
void stacking() {
  Task task(Layout::cartesian(1));
  task.add(SphericalPointFeature()).add(SphericalPolarFeature(), 2.0).add(LineFeature());
  CHECK(task.rows() == 2 + 3 + 2 + 2 && task.measurement_size() == 4 + 4 + 5);
  CHECK(task.describe().find("spherical_point") != std::string::npos);
  Servo servo(task);
  ServoInput in(task);
  ServoOutput out(task);
  in.uv << 0.1, -0.05;
  in.uv_desired << 0.0, 0.0;
  in.depth << 1.0;
  const auto p = measure(Eigen::Vector3d(0.4, 0.1, 1.0)), pd = measure(Eigen::Vector3d(0.3, 0.0, 1.0));
  const auto q = measure(Eigen::Vector3d(-1.0, 0.2, -0.3)), qd = measure(Eigen::Vector3d(-1.0, 0.0, -0.2));
  const std::array<double, 5> l{0.2, 0.3, 0.0, 0.0, 0.5}, ld{0.25, 0.35, 0.0, 0.0, 0.5};
  in.measurements << p[0], p[1], p[2], p[3], q[0], q[1], q[2], q[3], l[0], l[1], l[2], l[3], l[4];
  in.measurements_desired << pd[0], pd[1], pd[2], pd[3], qd[0], qd[1], qd[2], qd[3], ld[0], ld[1], ld[2], ld[3], ld[4];
  servo.validate(in);
  CHECK(servo.update(in, out) != Status::invalid_input && out.velocity.allFinite());
  in.measurements(6) = 0.0;  // the polar block's bearing no longer unit
  CHECK(servo.update(in, out) == Status::invalid_input);
  CHECK_THROWS(servo.validate(in));
}

// Four points of a square, the goal view in front; the camera starts turned so that the target lies
// `angle` off its axis. Kind 0: spherical points, 1: spherical polar. through_lens: the measurements
// come from the fisheye's pixels (from_bearing, then spherical_measurements). Returns the frames taken
// (or -1) and the final pose error.
int servo_to(int kind, double angle, bool through_lens, double& dp, double& dr) {
  const Eigen::Matrix<double, 3, 4> Pw = ibvs_test::square(0.25, 1.0);
  Task task;
  for (int i = 0; i < 4; ++i) {
    if (kind == 0) task.add(SphericalPointFeature());
    else task.add(SphericalPolarFeature());
  }
  ServoOptions o;
  o.gain = 1.0;
  Servo servo(task, o);
  ServoInput in(task);
  ServoOutput out(task);
  Eigen::Matrix3d K;
  K << 300, 0, 640, 0, 300, 512, 0, 0, 1;
  const CameraModel fish = CameraModel::from_opencv(K, Eigen::Vector4d(-0.013, 0.02, -0.012, 0.002), 1280, 1024, true);
  Points px(2, 4);
  Eigen::VectorXd R(4);
  const auto measure_at = [&](const Pose& T_wc, Eigen::VectorXd& m) {
    const Pose T_cw = se3_inverse(T_wc);
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d P = T_cw.topLeftCorner<3, 3>() * Pw.col(i) + T_cw.topRightCorner<3, 1>();
      if (through_lens) {
        Eigen::Vector2d q;
        fish.from_bearing(P.x(), P.y(), P.z(), q);
        px.col(i) = q;
        R(i) = P.norm();
      } else {
        const auto mi = measure(P);
        for (int j = 0; j < 4; ++j) m(4 * i + j) = mi[static_cast<std::size_t>(j)];
      }
    }
    if (through_lens) spherical_measurements(fish, px, R, m);
  };
  measure_at(Pose::Identity(), in.measurements_desired);
  // Start: turned by `angle` about y and moved a little: the target centre lies `angle` off the axis.
  Twist start;
  start << 0.05, -0.04, -0.2, 0.0, angle, 0.3;
  Pose T = se3_exp(start);
  const double dt = 1.0 / 60;
  int k = 0;
  for (; k < 4000; ++k) {
    measure_at(T, in.measurements);
    if (servo.update(in, out) == Status::invalid_input) return -1;
    if (out.error_norm < 1e-9) break;
    T = T * se3_exp(out.velocity * dt);
  }
  dp = T.topRightCorner<3, 1>().norm();
  dr = Eigen::AngleAxisd(Eigen::Matrix3d(T.topLeftCorner<3, 3>())).angle();
  return k < 4000 ? k : -1;
}

void closed_loops() {
  // The target's centre starts 100 degrees off the optical axis: beyond any perspective camera.
  const Eigen::Matrix<double, 3, 4> Pw = ibvs_test::square(0.25, 1.0);
  Twist start;
  start << 0.05, -0.04, -0.2, 0.0, 107 * deg, 0.3;
  const Pose T_cw = se3_inverse(se3_exp(start));
  const Eigen::Vector3d c = T_cw.topLeftCorner<3, 3>() * Pw.rowwise().mean() + T_cw.topRightCorner<3, 1>();
  const double off = std::acos(c.normalized().z()) / deg;
  std::printf("target centre %.1f degrees off the axis at the start\n", off);
  CHECK(off > 100.0);
  for (int kind : {0, 1})
    for (bool lens : {false, true}) {
      double dp = 0, dr = 0;
      const int k = servo_to(kind, 107 * deg, lens, dp, dr);
      std::printf("%s%s, target 100 degrees off the axis: converged at frame %d, %.2g m and %.2g rad from the goal\n",
                  kind == 0 ? "spherical points" : "spherical polar", lens ? " from fisheye pixels" : "", k, dp, dr);
      CHECK(k > 0);
      CHECK(dp < 1e-6 && dr < 1e-6);
    }
}

// ---- The consistent wrap of the azimuths (Feature::axis_angle_rows, angle_wrap.hpp) ----

// Rotation about z by a, built from cos/sin as a user would (rotz(pi) is not diag(-1, -1, 1)).
Pose rotz(double a) {
  Pose T = Pose::Identity();
  T(0, 0) = std::cos(a);
  T(0, 1) = -std::sin(a);
  T(1, 0) = std::sin(a);
  T(1, 1) = std::cos(a);
  return T;
}

// The camera-frame points of `Pw` seen from camera pose T_wc, as image points (uv, z) and as
// spherical measurements (4 per point).
void view(const Eigen::Matrix<double, 3, 4>& Pw, const Pose& T_wc, Points& uv, Eigen::VectorXd& z,
          Eigen::VectorXd& m) {
  const Pose T_cw = se3_inverse(T_wc);
  uv.resize(2, 4);
  z.resize(4);
  m.resize(16);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d P = T_cw.topLeftCorner<3, 3>() * Pw.col(i) + T_cw.topRightCorner<3, 1>();
    uv.col(i) << P.x() / P.z(), P.y() / P.z();
    z(i) = P.z();
    const auto mi = measure(P);
    for (int j = 0; j < 4; ++j) m(4 * i + j) = mi[static_cast<std::size_t>(j)];
  }
}

Task spherical_polar_task(int n) {
  Task task;
  for (int i = 0; i < n; ++i) task.add(SphericalPolarFeature());
  return task;
}

// The exact half-turn about the axis (rotz(pi) from cos/sin): per point the four azimuth errors
// split (+pi, -pi, ...) and the law throws the camera sideways; the consistent wrap puts them on
// one branch and commands a pure rotation about z, as IBVS-P does. The same Servo from pi -/+ 0.01,
// alternating: the first frame's branch is kept (continuity), reset() forgets it.
void azimuths_half_turn() {
  const Eigen::Matrix<double, 3, 4> Pw = ibvs_test::square(0.25, 1.0);
  Points uv, uvd;
  Eigen::VectorXd z, zd;
  const Task task = spherical_polar_task(4);
  ServoInput in(task);
  view(Pw, Pose::Identity(), uvd, zd, in.measurements_desired);
  view(Pw, rotz(pi), uv, z, in.measurements);
  ServoOutput out(task), pp(task);
  ServoOptions o;
  o.gain = 1.0;
  Servo consistent(task, o);
  o.angle_wrap = AngleWrap::per_point;
  Servo per_point(task, o);
  CHECK(consistent.update(in, out) == Status::ok && per_point.update(in, pp) == Status::ok);
  double lo = pi, hi = -pi, plo = pi, phi = -pi;
  for (int i = 0; i < 4; ++i) {
    const double e = out.error(2 * i + 1), ep = pp.error(2 * i + 1);
    CHECK_NEAR(std::abs(e), pi, 1e-12);
    lo = std::min(lo, e), hi = std::max(hi, e), plo = std::min(plo, ep), phi = std::max(phi, ep);
    CHECK(e == ep || std::abs(std::abs(e - ep) - 2 * pi) < 1e-12);  // the same difference, taken the same way round
    CHECK(out.error(2 * i) == pp.error(2 * i));    // colatitude rows untouched
  }
  CHECK(plo < 0.0 && phi > 0.0);  // eq. (13) point by point splits the signs
  CHECK(hi - lo < 1e-12);         // one branch
  const double T = out.velocity.head<3>().norm(), wxy = out.velocity.segment<2>(3).norm();
  ibvs_test::report(T < 1e-9 && wxy < 1e-9 && std::abs(out.velocity(5)) > 0.5, "spherical polar half-turn: pure wz",
                    __FILE__, __LINE__, "|T| " + std::to_string(T) + " |wxy| " + std::to_string(wxy));
  CHECK(pp.velocity.head<3>().norm() > 0.5);  // the sideways throw of the per-point wrap
  for (InteractionMatrix which : {InteractionMatrix::desired, InteractionMatrix::mean}) {  // the unfused path too
    ServoOptions wo;
    wo.jacobian = which;
    Servo other(task, wo);
    ServoOutput oo(task);
    CHECK(other.update(in, oo) != Status::invalid_input);
    CHECK(oo.error == out.error);
  }
  // As IBVS-P on the same view: the same twist.
  ServoOptions po;
  po.gain = 1.0;
  Servo polar(Layout::polar(4), po);
  ServoOutput pout(Layout::polar(4));
  polar.update(uv, z, uvd, zd, pout);
  CHECK(std::abs(pout.velocity(5) - out.velocity(5)) < 1e-9 && pout.velocity.head<5>().norm() < 1e-9);
  // Continuity across pi -/+ 0.01 (the camera turned by pi -/+ 0.01 sees the points turned by -(pi -/+ 0.01)).
  ServoInput a(task), b(task);
  view(Pw, Pose::Identity(), uvd, zd, a.measurements_desired);
  b.measurements_desired = a.measurements_desired;
  view(Pw, rotz(pi - 0.01), uv, z, a.measurements);
  view(Pw, rotz(pi + 0.01), uv, z, b.measurements);
  consistent.reset();  // forget the exact half-turn's branch
  for (int k = 0; k < 6; ++k) {
    consistent.update(k % 2 ? b : a, out);
    for (int i = 0; i < 4; ++i) CHECK_NEAR(out.error(2 * i + 1), k % 2 ? -pi - 0.01 : -pi + 0.01, 1e-9);
  }
  consistent.reset();
  consistent.update(b, out);
  for (int i = 0; i < 4; ++i) CHECK_NEAR(out.error(2 * i + 1), pi - 0.01, 1e-9);
  for (int k = 0; k < 4; ++k) {  // per point: each frame's principal value
    per_point.update(k % 2 ? b : a, pp);
    CHECK_NEAR(pp.error(1), k % 2 ? pi - 0.01 : -pi + 0.01, 1e-9);
  }
}

// Random views (a turn about the axis, near the half-turn too, with tilt and scatter): in one task of
// polar points and the spherical-polar blocks of the same points, every azimuth error equals its
// point's theta error (one circular mean over both); the spherical-polar task alone wraps its azimuths
// into one half-open turn, each the per-point error or it -/+ 2 pi; under per_point every azimuth
// error is Feature::error's.
void azimuths_join_the_mean() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const Eigen::Matrix<double, 3, 4> Pw = ibvs_test::square(0.25, 1.0);
  Task mixed(Layout::polar(4));
  for (int i = 0; i < 4; ++i) mixed.add(SphericalPolarFeature());
  const Task alone = spherical_polar_task(4);
  const SphericalPolarFeature f;
  for (int k = 0; k < ibvs_test::cases; ++k) {
    const double turn = k % 3 == 0 ? pi + 1e-3 * U(rng) : pi * U(rng);
    Twist tilt;
    tilt << 0.05 * U(rng), 0.05 * U(rng), 0.1 * U(rng), 0.1 * U(rng), 0.1 * U(rng), 0.0;
    Points uv, uvd;
    Eigen::VectorXd z, zd, m, md;
    view(Pw, Pose::Identity(), uvd, zd, md);
    view(Pw, rotz(turn) * se3_exp(tilt), uv, z, m);
    ServoOptions o;
    o.polar_min_radius = 0.0;
    Servo sm(mixed, o), sa(alone, o);
    ServoOutput om(mixed), oa(alone);
    CHECK(sm.update(uv, z, uvd, zd, m, md, om) != Status::invalid_input);
    CHECK(sa.update(Points(2, 0), Eigen::VectorXd(0), Points(2, 0), Eigen::VectorXd(0), m, md, oa) !=
          Status::invalid_input);
    double lo = 10, hi = -10;
    for (int i = 0; i < 4; ++i) {
      ibvs_test::report(std::abs(om.error(8 + 2 * i + 1) - om.error(2 * i + 1)) < 1e-12,
                        "azimuth error == its polar point's theta error", __FILE__, __LINE__, std::to_string(turn));
      double e[2];
      f.error(m.data() + 4 * i, md.data() + 4 * i, e);
      const double d = oa.error(2 * i + 1);
      CHECK(d == e[1] || std::abs(std::abs(d - e[1]) - 2 * pi) < 1e-12);
      lo = std::min(lo, d), hi = std::max(hi, d);
    }
    CHECK(hi - lo < 2 * pi);
    o.angle_wrap = AngleWrap::per_point;
    Servo sp(alone, o);
    sp.update(Points(2, 0), Eigen::VectorXd(0), Points(2, 0), Eigen::VectorXd(0), m, md, oa);
    for (int i = 0; i < 4; ++i) {
      double e[2];
      f.error(m.data() + 4 * i, md.data() + 4 * i, e);
      CHECK(oa.error(2 * i + 1) == e[1]);
    }
  }
}

// Which rows join: the azimuth only, and only off the axis (current and goal); spread evenly around
// the circle (resultant below wrap_min_resultant) the per-point wrap is kept.
void azimuths_which_rows() {
  const SphericalPolarFeature f;
  const auto g = measure(Eigen::Vector3d(0.3, 0.1, 1.0)), c = measure(Eigen::Vector3d(-0.2, 0.3, 1.0));
  const auto near = measure(Eigen::Vector3d(1e-5, 2e-5, 1.0));
  CHECK(f.axis_angle_rows(c.data(), g.data()) == 2u);
  CHECK(f.axis_angle_rows(near.data(), g.data()) == 0u && f.axis_angle_rows(g.data(), near.data()) == 0u);
  CHECK(SphericalPointFeature().axis_angle_rows(c.data(), g.data()) == 0u);
  CHECK(LineFeature().axis_angle_rows(c.data(), g.data()) == 0u);  // the default: none
  // Two blocks turned by +pi/2 and -pi/2 (resultant 0): per point; with a block near the axis beside
  // two at +(pi - 0.1) and one at -(pi - 0.1): the near one keeps its (bx, by) error untouched.
  const Task two = spherical_polar_task(2);
  ServoInput in(two);
  const Eigen::Vector3d P(0.3, 0.0, 1.0);
  const auto put = [](Eigen::VectorXd& m, int i, const Eigen::Vector3d& Q) {
    const auto q = measure(Q);
    for (int j = 0; j < 4; ++j) m(4 * i + j) = q[static_cast<std::size_t>(j)];
  };
  const Eigen::Matrix3d up = Eigen::AngleAxisd(pi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  put(in.measurements_desired, 0, P);
  put(in.measurements_desired, 1, P);
  put(in.measurements, 0, up * P);
  put(in.measurements, 1, up.transpose() * P);
  Servo s2(two);
  ServoOutput o2(two);
  s2.update(in, o2);
  CHECK_NEAR(o2.error(1), pi / 2, 1e-15);
  CHECK_NEAR(o2.error(3), -pi / 2, 1e-15);
  const Task four = spherical_polar_task(4);
  ServoInput in4(four);
  const Eigen::Matrix3d a = Eigen::AngleAxisd(pi - 0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (int i = 0; i < 4; ++i) put(in4.measurements_desired, i, P);
  put(in4.measurements, 0, a * P);
  put(in4.measurements, 1, a * P);
  put(in4.measurements, 2, a.transpose() * P);
  put(in4.measurements, 3, Eigen::Vector3d(1e-5, 2e-5, 1.0));
  Servo s4(four);
  ServoOutput o4(four);
  s4.update(in4, o4);
  CHECK_NEAR(o4.error(1), pi - 0.1, 1e-12);
  CHECK_NEAR(o4.error(5), pi + 0.1, 1e-12);  // taken the same way round as the other two
  double e[2];
  f.error(in4.measurements.data() + 12, in4.measurements_desired.data() + 12, e);
  CHECK(o4.error(6) == e[0] && o4.error(7) == e[1]);
}

// Closed loop from the exact half-turn: spherical-polar blocks converge turning about the axis only
// (the camera centre still), as IBVS-P; per point the camera travels.
void azimuths_closed_loop() {
  const Eigen::Matrix<double, 3, 4> Pw = ibvs_test::square(0.25, 1.0);
  for (AngleWrap w : {AngleWrap::consistent, AngleWrap::per_point}) {
    const Task task = spherical_polar_task(4);
    ServoOptions o;
    o.gain = 1.0;
    o.angle_wrap = w;
    Servo servo(task, o);
    ServoInput in(task);
    ServoOutput out(task);
    Points uv, uvd;
    Eigen::VectorXd z, zd;
    view(Pw, Pose::Identity(), uvd, zd, in.measurements_desired);
    Pose T = rotz(pi);
    double path = 0.0, peak = 0.0;
    int k = 0;
    for (; k < 2000; ++k) {
      view(Pw, T, uv, z, in.measurements);
      if (servo.update(in, out) == Status::invalid_input) break;
      if (out.error_norm < 1e-9) break;
      const Pose next = T * se3_exp(out.velocity / 60.0);
      path += (next.topRightCorner<3, 1>() - T.topRightCorner<3, 1>()).norm();
      peak = std::max(peak, out.velocity.head<3>().norm());
      T = next;
    }
    const std::string detail = "frames " + std::to_string(k) + " path " + std::to_string(path) + " m, peak |T| " +
                               std::to_string(peak) + " m/s";
    if (w == AngleWrap::consistent)
      ibvs_test::report(k < 2000 && out.error_norm < 1e-9 && path < 1e-9 && peak < 1e-9,
                        "spherical polar from rotz(pi): converges turning about z only", __FILE__, __LINE__, detail);
    else
      ibvs_test::report(path > 0.1 && peak > 0.5, "per point: the camera is thrown sideways", __FILE__, __LINE__,
                        detail);
  }
}

}  // namespace

void run_tests() {
  jacobians();
  azimuth_and_axis();
  refusals();
  stacking();
  closed_loops();
  azimuths_half_turn();
  azimuths_join_the_mean();
  azimuths_which_rows();
  azimuths_closed_loop();
}
