// 3-D, 2.5-D and user-defined feature blocks (features/pose.hpp,
// features/function.hpp): theta u and its interaction matrix at and near 0 and
// pi; each block's L against central differences of its own measurement (the
// camera moved by a small twist, the poses measured anew) and against ViSP's
// published formulas; the known closed-loop properties (PBVS to the desired
// camera: camera centre on a straight line; PBVS to the object: the object
// origin's image on a straight line; 2.5-D: the reference point's image on a
// straight line), from large rotations up to 170 degrees about the optical
// axis; a user's FunctionFeature stacked with the others; validate() and
// update() refusing the same measurements.
#include "check.hpp"
#include "scene.hpp"

#include "ibvs/features/function.hpp"
#include "ibvs/features/pose.hpp"

#include <array>
#include <limits>

using namespace ibvs;

namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d S;
  S << 0, -a(2), a(1), a(2), 0, -a(0), -a(1), a(0), 0;
  return S;
}

Eigen::Vector3d random_axis(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// ViSP's vpFeatureThetaU (cdRc) interaction, transcribed: [theta u / 2]x + I + (1 - sinc / sinc^2(theta/2)) [u]x^2.
Eigen::Matrix3d visp_theta_u(const Eigen::Vector3d& tu) {
  const double th = tu.norm();
  Eigen::Matrix3d L = skew(tu / 2) + Eigen::Matrix3d::Identity();
  if (th >= 1e-6) {
    const auto sinc = [](double a) { return std::sin(a) / a; };
    const Eigen::Matrix3d U = skew(tu / th);
    L += (1 - sinc(th) / (sinc(th / 2) * sinc(th / 2))) * U * U;
  }
  return L;
}

void theta_u_round_trip() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> ang(0.0, pi);
  double worst = 0.0;
  const double edges[] = {0.0, 1e-300, 1e-12, 1e-8, 1e-5, 1e-2, pi - 1e-2, pi - 1e-6, pi - 1e-10, pi};
  for (int c = 0; c < ibvs_test::cases + 10; ++c) {
    const double th = c < 10 ? edges[c] : ang(rng);
    const Eigen::Vector3d tu = th * random_axis(rng);
    const Eigen::Matrix3d R = rotation_of(tu);
    const Eigen::Vector3d back = theta_u(R);
    CHECK(back.norm() <= pi + 1e-15);
    worst = std::max(worst, (rotation_of(back) - R).cwiseAbs().maxCoeff());
    if (th < pi - 1e-6) worst = std::max(worst, (back - tu).norm());  // unique below pi
    // Eigen's own angle-axis as an independent check of the angle.
    CHECK_NEAR(back.norm(), Eigen::AngleAxisd(R).angle(), 1e-9);
  }
  std::printf("theta u: worst round-trip difference %.2g\n", worst);
  CHECK(worst < 1e-12);
  // At pi: the axis' sign chosen with its largest component positive, for either sign given.
  for (double sgn : {1.0, -1.0}) {
    const Eigen::Vector3d tu = theta_u(rotation_of(sgn * pi * Eigen::Vector3d(0.36, -0.48, 0.8)));
    CHECK_NEAR(tu.norm(), pi, 1e-12);
    CHECK(tu(2) > 0.0);
  }
  // The principal form: theta in (pi, 2 pi] -> (2 pi - theta)(-u), the same rotation.
  const Eigen::Vector3d u(0.0, 0.6, 0.8);
  for (double th : {pi + 1e-9, 4.0, 2 * pi - 1e-9, 2 * pi}) {
    const Eigen::Vector3d p = principal_theta_u(th * u);
    CHECK(p.norm() <= pi);
    CHECK((rotation_of(p) - rotation_of(th * u)).cwiseAbs().maxCoeff() < 1e-12);
  }
}

// L_tu against central differences of theta u (the camera turned by +-h about each axis: c*Rc exp([h e_k]x)),
// against ViSP's formula, and smooth where its [u]x^2 coefficient switches to its series.
void theta_u_jacobian() {
  std::mt19937_64 rng(ibvs_test::seed + 1);
  std::uniform_real_distribution<double> ang(0.0, pi - 1e-3);
  double worst_fd = 0.0, worst_visp = 0.0;
  const double edges[] = {0.0, 1e-9, 1e-4, 1e-2 - 1e-12, 1e-2 + 1e-12, 1.0, 3.0, pi - 1e-3};
  for (int c = 0; c < ibvs_test::cases + 8; ++c) {
    const double th = c < 8 ? edges[c] : ang(rng);
    const Eigen::Vector3d tu = th * random_axis(rng);
    const Eigen::Matrix3d R = rotation_of(tu), L = theta_u_interaction(tu);
    Eigen::Matrix3d Ln;
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(k);
      Ln.col(k) = (theta_u(R * rotation_of(d)) - theta_u(R * rotation_of(-d))) / (2 * h);
    }
    worst_fd = std::max(worst_fd, (L - Ln).cwiseAbs().maxCoeff());
    worst_visp = std::max(worst_visp, (L - visp_theta_u(tu)).cwiseAbs().maxCoeff());
  }
  std::printf("L_tu: worst difference %.2g (finite differences), %.2g (ViSP's formula)\n", worst_fd, worst_visp);
  CHECK(worst_fd < 1e-7);
  CHECK(worst_visp < 1e-9);
  // Near 0: I + [theta u]x / 2 + [theta u]x^2 / 12 to rounding; continuous across the series switch.
  const Eigen::Vector3d u = Eigen::Vector3d(1, 2, 2) / 3;
  const Eigen::Matrix3d small = theta_u_interaction(1e-9 * u);
  CHECK((small - (Eigen::Matrix3d::Identity() + 0.5e-9 * skew(u))).cwiseAbs().maxCoeff() < 1e-16);
  const Eigen::Matrix3d jump =  // less the [theta u]x / 2 term's own change over the 2e-13 step
      theta_u_interaction((1e-2 + 1e-13) * u) - theta_u_interaction((1e-2 - 1e-13) * u) - 1e-13 * skew(u);
  CHECK(jump.cwiseAbs().maxCoeff() < 1e-15);
  // At pi: finite and invertible (det = 1 / sinc^2(pi/2) = pi^2/4); the same at -pi u's principal twin.
  const Eigen::Matrix3d Lpi = theta_u_interaction(pi * u);
  CHECK(Lpi.allFinite());
  CHECK_NEAR(Lpi.determinant(), pi * pi / 4, 1e-12);
  CHECK(theta_u_interaction((2 * pi - 1e-3) * u).allFinite());
}

// Random poses of an object in front of the camera.
Pose random_pose(std::mt19937_64& rng, double max_angle) {
  std::uniform_real_distribution<double> t(-0.5, 0.5), z(0.8, 3.0), a(0.0, max_angle);
  Pose T = Pose::Identity();
  T.topLeftCorner<3, 3>() = rotation_of(a(rng) * random_axis(rng));
  T.topRightCorner<3, 1>() << t(rng), t(rng), z(rng);
  return T;
}

// The object seen after the camera moves with twist xi for unit time: c'Mo = (cMc')^-1 cMo.
Pose moved(const Pose& cMo, const Twist& xi) { return se3_inverse(se3_exp(xi)) * cMo; }

// The block's value at the measurement of (cMo, cdMo), as a function of the camera's motion.
template <class Measure>
double fd_worst(const Feature& f, const Pose& cMo, const Measure& measure) {
  const auto m = measure(cMo);
  MatrixX6 L(6, 6);
  f.interaction(m.data(), L);
  Eigen::Matrix<double, 6, 6> Ln;
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    Twist xi = Twist::Zero();
    xi(k) = h;
    const auto a = measure(moved(cMo, xi)), b = measure(moved(cMo, -xi));
    double sa[6], sb[6];
    f.value(a.data(), sa);
    f.value(b.data(), sb);
    for (int i = 0; i < 6; ++i) Ln(i, k) = (sa[i] - sb[i]) / (2 * h);
  }
  return (L - Ln).cwiseAbs().maxCoeff() / std::max(1.0, L.cwiseAbs().maxCoeff());
}

void pose_jacobians() {
  std::mt19937_64 rng(ibvs_test::seed + 2);
  const PbvsFeature to_camera(PbvsTarget::desired_camera), to_object(PbvsTarget::object);
  const Point25DFeature p25;
  double worst[3] = {0, 0, 0}, visp[3] = {0, 0, 0};
  for (int c = 0; c < ibvs_test::cases; ++c) {
    const Pose cMo = random_pose(rng, 2.5), cdMo = random_pose(rng, 0.5);
    const Eigen::Vector3d P(0.1, -0.05, 0.02);
    const Eigen::Matrix3d Rdc = cdMo.topLeftCorner<3, 3>() * cMo.topLeftCorner<3, 3>().transpose();
    if (theta_u(Rdc).norm() > pi - 1e-3) continue;  // theta u's sign flips at pi
    worst[0] = std::max(worst[0], fd_worst(to_camera, cMo, [&](const Pose& T) {
      return PbvsFeature::measure(T, cdMo, PbvsTarget::desired_camera);
    }));
    worst[1] = std::max(worst[1], fd_worst(to_object, cMo, [&](const Pose& T) {
      return PbvsFeature::measure(T, cdMo, PbvsTarget::object);
    }));
    worst[2] = std::max(worst[2],
                        fd_worst(p25, cMo, [&](const Pose& T) { return Point25DFeature::measure(T, cdMo, P); }));
    // ViSP's formulas: vpFeatureTranslation cdMc ([c*Rc 0]) and cMo ([-I [t]x]), vpFeatureThetaU cdRc,
    // vpFeaturePoint and vpFeatureDepth ([0 0 -1/Z -y x 0]).
    MatrixX6 L(6, 6);
    Eigen::Matrix<double, 6, 6> V = Eigen::Matrix<double, 6, 6>::Zero();
    const auto a = PbvsFeature::measure(cMo, cdMo, PbvsTarget::desired_camera);
    const Eigen::Vector3d tu(a[3], a[4], a[5]);
    to_camera.interaction(a.data(), L);
    V.topLeftCorner<3, 3>() = Rdc;
    V.bottomRightCorner<3, 3>() = visp_theta_u(tu);
    visp[0] = std::max(visp[0], (L - V).cwiseAbs().maxCoeff());
    const auto b = PbvsFeature::measure(cMo, cdMo, PbvsTarget::object);
    to_object.interaction(b.data(), L);
    V.topLeftCorner<3, 3>() = -Eigen::Matrix3d::Identity();
    V.topRightCorner<3, 3>() = skew(cMo.topRightCorner<3, 1>());
    visp[1] = std::max(visp[1], (L - V).cwiseAbs().maxCoeff());
    const auto d = Point25DFeature::measure(cMo, cdMo, P);
    p25.interaction(d.data(), L);
    const double x = d[0], y = d[1], Z = d[2];
    V.setZero();
    V.row(0) << -1 / Z, 0, x / Z, x * y, -(1 + x * x), y;
    V.row(1) << 0, -1 / Z, y / Z, 1 + y * y, -x * y, -x;
    V.row(2) << 0, 0, -1 / Z, -y, x, 0;
    V.bottomRightCorner<3, 3>() = visp_theta_u(tu);
    visp[2] = std::max(visp[2], (L - V).cwiseAbs().maxCoeff());
  }
  std::printf("jacobians, worst relative FD difference: pbvs(desired_camera) %.2g, pbvs(object) %.2g, 2.5-D %.2g; "
              "ViSP: %.2g %.2g %.2g\n",
              worst[0], worst[1], worst[2], visp[0], visp[1], visp[2]);
  for (int i = 0; i < 3; ++i) {
    CHECK(worst[i] < 1e-6);
    CHECK(visp[i] < 1e-9);
  }
}

// Distance of p from the line through a and b, relative to |b - a|.
double off_line(const Eigen::VectorXd& p, const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::VectorXd d = (b - a).normalized(), r = p - a;
  return (r - r.dot(d) * d).norm() / (b - a).norm();
}

struct Path {
  bool converged = false;
  double pos = 0, rot = 0, worst_off_line = 0;
};

// Closes the loop on one pose-based block: the camera (pose oMc, object <- camera) moves with the
// twist for dt; `track` gives the quantity that should move on a straight line, `measure` the
// measurement of the current and desired object poses.
template <class Measure, class Track>
Path close_loop(const Feature& f, const Pose& oMc0, const Pose& oMcd, double dt, const Measure& measure,
                const Track& track) {
  Task task;
  task.add(f);
  ServoOptions o;
  o.gain = 1.0;
  Servo servo(task, o);
  ServoInput in(task);
  ServoOutput out(task);
  const Pose cdMo = se3_inverse(oMcd);
  const auto md = measure(cdMo, cdMo);
  in.measurements_desired = Eigen::Map<const Eigen::VectorXd>(md.data(), 6);
  Pose oMc = oMc0;
  const Eigen::VectorXd start = track(se3_inverse(oMc0), oMc0), goal = track(cdMo, oMcd);
  Path path;
  for (int k = 0; k < static_cast<int>(40.0 / dt); ++k) {
    const Pose cMo = se3_inverse(oMc);
    const auto m = measure(cMo, cdMo);
    in.measurements = Eigen::Map<const Eigen::VectorXd>(m.data(), 6);
    if (servo.update(in, out) != Status::ok) break;
    path.worst_off_line = std::max(path.worst_off_line, off_line(track(cMo, oMc), start, goal));
    if (out.error_norm < 1e-9) {
      path.converged = true;
      break;
    }
    oMc = oMc * se3_exp(out.velocity * dt);
  }
  const Pose d = se3_inverse(oMcd) * oMc;
  path.pos = d.topRightCorner<3, 1>().norm();
  path.rot = theta_u(d.topLeftCorner<3, 3>()).norm();
  return path;
}

// The known straight lines, from large rotations (170 and 180 degrees about the optical axis among them). The
// law is continuous-time: one step of the constant twist is a screw, so the path leaves the line by
// O(dt); with dt = 1e-3 s and gain 1 it stays within 0.1 % of its length, and the deviation halves with dt.
void straight_lines() {
  Pose oMcd = Pose::Identity();
  oMcd.topRightCorner<3, 1>() << 0.0, 0.0, -1.0;  // the goal: 1 m in front of the object, facing it
  std::vector<Pose> starts;
  for (double deg : {170.0, 180.0, 90.0, 45.0}) {  // 180: theta u at pi, its axis' sign chosen by theta_u()
    Pose T = oMcd;
    T.topLeftCorner<3, 3>() = rotation_of(deg * pi / 180 * Eigen::Vector3d::UnitZ());
    T.topRightCorner<3, 1>() << 0.3, -0.2, -1.6;
    starts.push_back(T);
  }
  {
    Pose T = oMcd;  // a general motion: 150 degrees about a tilted axis
    T.topLeftCorner<3, 3>() = rotation_of(150 * pi / 180 * Eigen::Vector3d(0.2, -0.3, 0.93).normalized());
    T.topRightCorner<3, 1>() << -0.4, 0.3, -1.2;
    starts.push_back(T);
  }
  const Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  const auto centre = [](const Pose&, const Pose& oMc) -> Eigen::VectorXd { return oMc.topRightCorner<3, 1>(); };
  const auto origin_image = [](const Pose& cMo, const Pose&) -> Eigen::VectorXd {
    return cMo.topRightCorner<2, 1>() / cMo(2, 3);
  };
  const auto point_image = origin_image;
  const auto pbvs_c = [](const Pose& a, const Pose& b) {
    return PbvsFeature::measure(a, b, PbvsTarget::desired_camera);
  };
  const auto pbvs_o = [](const Pose& a, const Pose& b) { return PbvsFeature::measure(a, b, PbvsTarget::object); };
  const auto p25 = [&](const Pose& a, const Pose& b) { return Point25DFeature::measure(a, b, origin); };
  double worst[3] = {0, 0, 0};
  for (const Pose& s : starts) {
    const Path a = close_loop(PbvsFeature(PbvsTarget::desired_camera), s, oMcd, 1e-3, pbvs_c, centre);
    const Path b = close_loop(PbvsFeature(PbvsTarget::object), s, oMcd, 1e-3, pbvs_o, origin_image);
    const Path c = close_loop(Point25DFeature(), s, oMcd, 1e-3, p25, point_image);
    for (const Path* p : {&a, &b, &c}) {
      CHECK(p->converged);
      CHECK(p->pos < 1e-8 && p->rot < 1e-8);
    }
    worst[0] = std::max(worst[0], a.worst_off_line);
    worst[1] = std::max(worst[1], b.worst_off_line);
    worst[2] = std::max(worst[2], c.worst_off_line);
  }
  std::printf("straight lines (dt 1e-3 s, gain 1), worst deviation / length: camera centre (pbvs desired_camera) %.2g, "
              "object origin's image (pbvs object) %.2g, reference point's image (2.5-D) %.2g\n",
              worst[0], worst[1], worst[2]);
  for (double w : worst) CHECK(w < 1e-3);
  // First order in dt: the camera centre's deviation from 170 degrees about z halves with dt.
  const Path coarse = close_loop(PbvsFeature(PbvsTarget::desired_camera), starts[0], oMcd, 2e-3, pbvs_c, centre);
  const Path fine = close_loop(PbvsFeature(PbvsTarget::desired_camera), starts[0], oMcd, 1e-3, pbvs_c, centre);
  std::printf("camera centre deviation: %.3g at dt 2e-3, %.3g at dt 1e-3\n", coarse.worst_off_line,
              fine.worst_off_line);
  CHECK(fine.worst_off_line < 0.6 * coarse.worst_off_line);
}

// A user's feature: the Cartesian point (x, y) of a measurement (x, y, Z) through FunctionFeature; four
// of them stacked in a Task give the twist of the Layout of four Cartesian points; stacked with a
// PBVS block they give the weighted least-squares solution of the stacked rows.
void function_feature() {
  // --8<-- [start:function_feature]
  // A Cartesian image point as a user's block: measurement (x, y, Z), value (x, y), L of eq. (3).
  const auto point = [](const double* m, double* s, Eigen::Ref<MatrixX6> L) noexcept {
    if (!(m[2] > 0.0)) return false;  // refused: behind the camera
    s[0] = m[0];
    s[1] = m[1];
    L = cartesian_jacobian(m[0], m[1], m[2]);
    return true;
  };
  const FunctionFeature f(2, 3, point, "point");  // 2 rows, 3 doubles per measurement
  // --8<-- [end:function_feature]
  CHECK(f.describe() == "point(rows=2)");
  Task task;
  for (int i = 0; i < 4; ++i) task.add(f);
  Servo a(Layout::cartesian(4)), b(task);
  ServoInput ia(Layout::cartesian(4)), ib(task);
  ServoOutput oa(Layout::cartesian(4)), ob(task);
  ia.uv << 0.16, -0.05, -0.16, 0.05, 0.05, 0.16, -0.05, -0.16;
  ia.uv_desired << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  ia.depth << 0.6, 0.7, 0.8, 0.9;
  for (int i = 0; i < 4; ++i) {
    ib.measurements.segment<3>(3 * i) << ia.uv(0, i), ia.uv(1, i), ia.depth(i);
    ib.measurements_desired.segment<3>(3 * i) << ia.uv_desired(0, i), ia.uv_desired(1, i), 1.0;
  }
  CHECK(a.update(ia, oa) == Status::ok);
  CHECK(b.update(ib, ob) == Status::ok);
  CHECK((oa.velocity - ob.velocity).norm() < 1e-12 * oa.velocity.norm());
  // Refusals: the function's false, a non-finite measurement, a non-finite output.
  int entry = 0;
  const double behind[3] = {0.1, 0.1, -1.0}, nan_in[3] = {0.1, std::nan(""), 1.0};
  CHECK(f.check(behind, entry) != nullptr && entry == -1);
  CHECK(f.check(nan_in, entry) != nullptr && entry == 1);
  CHECK_THROWS(f.validate(behind, "m"));
  const FunctionFeature bad(1, 1, [](const double* m, double* s, Eigen::Ref<MatrixX6> L) noexcept {
    s[0] = 1.0 / m[0];  // infinite at 0
    L.setZero();
    return true;
  });
  const double zero[1] = {0.0}, one[1] = {1.0};
  CHECK(bad.check(zero, entry) != nullptr);
  CHECK(bad.check(one, entry) == nullptr);
  CHECK_THROWS(FunctionFeature(0, 1, point));
  CHECK_THROWS(FunctionFeature(max_function_rows + 1, 1, point));
  // A NaN, an infinity or a huge value at ANY entry of s or L is refused (issue 35: a check comparing
  // maxCoeff() with a bound let a NaN past the first entry through, and update() gave a NaN twist).
  for (int rows = 1; rows <= 3; ++rows)
    for (int k = 0; k < 7 * rows; ++k)
      for (const double v : {std::nan(""), -std::numeric_limits<double>::infinity(), 1e200}) {
        const auto poisoned = [rows, k, v](const double*, double* s, Eigen::Ref<MatrixX6> L) noexcept {
          for (int i = 0; i < rows; ++i) s[i] = 0.1;
          L.setConstant(0.5);
          if (k < rows) s[k] = v;
          else L.data()[k - rows] = v;
          return true;
        };
        const FunctionFeature g(rows, 1, poisoned);
        const double m[1] = {0.5};
        CHECK(g.check(m, entry) != nullptr);
        Task one;
        one.add(g);
        Servo servo(one);
        ServoInput in(one);
        ServoOutput out(one);
        in.measurements << 0.5;
        in.measurements_desired << 0.4;
        CHECK_THROWS(servo.validate(in));
        CHECK(servo.update(in, out) == Status::invalid_input && out.velocity.isZero(0.0));
      }
  // Mixed: a point function block and a PBVS block; the twist against the stacked least-squares solve.
  Task mixed;
  mixed.add(f, 2.0).add(PbvsFeature(PbvsTarget::object));
  Servo servo(mixed);
  ServoInput in(mixed);
  ServoOutput out(mixed);
  in.measurements << 0.1, -0.2, 1.5, 0.05, -0.02, 1.4, 0.1, 0.2, -0.3;
  in.measurements_desired << 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0;
  servo.validate(in);
  CHECK(servo.update(in, out) == Status::ok);
  MatrixX6 J(8, 6), Lp(6, 6);
  Eigen::VectorXd e(8);
  J.topRows<2>() = 2.0 * cartesian_jacobian(0.1, -0.2, 1.5);
  e.head<2>() << 2.0 * 0.1, 2.0 * -0.2;
  PbvsFeature(PbvsTarget::object).interaction(in.measurements.data() + 3, Lp);
  J.bottomRows<6>() = Lp;
  e.tail<6>() << 0.05, -0.02, 0.4, 0.1, 0.2, -0.3;
  const Twist ref = -out.gain * J.completeOrthogonalDecomposition().solve(e);
  CHECK((out.velocity - ref).norm() < 1e-10 * ref.norm());
}

// validate() throws exactly for the measurements update() refuses, for each kind.
void refusals_agree() {
  const auto pt = [](const double* m, double* s, Eigen::Ref<MatrixX6> L) noexcept {
    s[0] = m[0];
    L.setZero();
    L(0, 0) = 1.0 / m[0];  // infinite at 0: refused
    return m[0] < 1e3;
  };
  Task task(Layout::cartesian(1));
  task.add(PbvsFeature(PbvsTarget::desired_camera)).add(PbvsFeature(PbvsTarget::object)).add(Point25DFeature());
  task.add(FunctionFeature(1, 1, pt));
  Servo servo(task);
  ServoInput in(task);
  ServoOutput out(task);
  in.uv_desired << 0.1, 0.1;
  in.measurements << 0.1, 0.2, 0.3, 0.1, 0.2, 0.3, 0.1, 0.2, 1.5, 0.1, 0.2, 0.3, 0.1, 0.2, 0.8, 0.1, 0.2, 0.3, 0.5;
  in.measurements_desired = in.measurements;
  servo.validate(in);
  CHECK(servo.update(in, out) == Status::ok);
  std::mt19937_64 rng(ibvs_test::seed + 3);
  std::uniform_int_distribution<int> which(0, static_cast<int>(in.measurements.size()) - 1);
  const double bad[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 1e300, 0.0,
                        -11.0, 7.0, 0.1, 2e6, -1e-7, 5e3};
  int agree = 0, refused = 0;
  for (int c = 0; c < ibvs_test::cases; ++c) {
    ServoInput x = in;
    Eigen::VectorXd& m = c % 2 ? x.measurements : x.measurements_desired;
    m(which(rng)) = bad[static_cast<std::size_t>(c) % (sizeof bad / sizeof bad[0])];
    bool threw = false;
    try {
      servo.validate(x);
    } catch (const std::invalid_argument&) {
      threw = true;
    }
    const Status st = servo.update(x, out);
    agree += threw == (st == Status::invalid_input);
    refused += threw;
    if (st != Status::invalid_input) CHECK(out.velocity.allFinite());
  }
  CHECK(agree == ibvs_test::cases);
  CHECK(refused > 0 && refused < ibvs_test::cases);
  // Named refusals.
  int entry = 0;
  const double far_rot[6] = {0, 0, 1, 7.0, 0, 0}, no_depth[6] = {0.1, 0.1, 0.0, 0, 0, 0};
  CHECK(PbvsFeature().check(far_rot, entry) != nullptr && entry == -1);
  CHECK(Point25DFeature().check(no_depth, entry) != nullptr && entry == 2);
  Pose skewed = Pose::Identity();
  skewed(0, 1) = 0.1;
  CHECK_THROWS(PbvsFeature::measure(skewed, Pose::Identity(), PbvsTarget::object));
  Pose behind = Pose::Identity();
  behind(2, 3) = -1.0;
  CHECK_THROWS(Point25DFeature::measure(behind, Pose::Identity(), Eigen::Vector3d::Zero()));
}

}  // namespace

void run_tests() {
  theta_u_round_trip();
  theta_u_jacobian();
  pose_jacobians();
  straight_lines();
  function_feature();
  refusals_agree();
}
