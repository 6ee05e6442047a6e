// Image moments (features/moments.hpp): polygon moments against exact integrals; every row of the
// feature, for a region and for points, each pair of invariants and each orientation, against
// central differences of its own projection (the camera moved, the 3-D object re-projected and
// its moments recomputed) and against the published closed forms of xn, yn, an and alpha (as
// ViSP writes them); a camera facing a non-symmetric object turned by 160 degrees about its axis
// turns back without moving its centre (third-order alpha) or settles on the half-turn
// (second-order alpha, defined modulo pi); a general start converges; degenerate objects are
// refused by validate() and update() alike.
#include "check.hpp"
#include "refusals.hpp"
#include "scene.hpp"

#include <array>
#include <cstdio>
#include <cstring>

using namespace ibvs;
using Src = MomentsFeature::Source;
using Inv = MomentsFeature::Invariants;
using Alp = MomentsFeature::Alpha;

namespace {

double mom(const Moments& m, int i, int j) { return m[static_cast<std::size_t>(moment_index(i, j))]; }

// A non-symmetric star-shaped polygon (simple) of `n` vertices about the origin, radius ~ size.
Eigen::Matrix3Xd star(std::mt19937_64& rng, int n, double size) {
  std::uniform_real_distribution<double> rad(0.5, 1.0), jitter(-0.3, 0.3);
  Eigen::Matrix3Xd P(3, n);
  for (int k = 0; k < n; ++k) {
    const double t = 2 * pi * (k + 0.5 + jitter(rng)) / n, r = size * rad(rng);
    P.col(k) << r * std::cos(t), r * std::sin(t), 0.0;
  }
  return P;
}

// The object's vertices Pw (world, plane z = 0) seen from camera pose T_wc (camera frame).
Eigen::Matrix3Xd in_camera(const Pose& T_wc, const Eigen::Matrix3Xd& Pw) {
  const Pose T = se3_inverse(T_wc);
  return (T.topLeftCorner<3, 3>() * Pw).colwise() + T.topRightCorner<3, 1>();
}

void polygon_moments() {
  // A rectangle [x0, x1] x [y0, y1]: m_pq = (x1^(p+1) - x0^(p+1)) (y1^(q+1) - y0^(q+1)) / ((p+1)(q+1)).
  const double x0 = -0.3, x1 = 0.5, y0 = 0.1, y1 = 0.35;
  Points R(2, 4);
  R << x0, x1, x1, x0, y0, y0, y1, y1;
  const Moments a = MomentsFeature::of_polygon(R), b = MomentsFeature::of_polygon(R.rowwise().reverse());
  double worst = 0.0;
  for (int p = 0; p <= 4; ++p)
    for (int q = 0; p + q <= 4; ++q) {
      const double exact = (std::pow(x1, p + 1) - std::pow(x0, p + 1)) * (std::pow(y1, q + 1) - std::pow(y0, q + 1)) /
                           ((p + 1) * (q + 1));
      worst = std::max({worst, std::abs(mom(a, p, q) - exact), std::abs(mom(b, p, q) - exact)});
    }
  CHECK(worst < 1e-15);
  // Additivity: an L-shaped (concave) hexagon is the sum of two rectangles.
  Points L(2, 6), R1(2, 4), R2(2, 4);
  L << 0, 2, 2, 1, 1, 0, 0, 0, 1, 1, 3, 3;
  R1 << 0, 2, 2, 0, 0, 0, 1, 1;
  R2 << 0, 1, 1, 0, 1, 1, 3, 3;
  const Moments l = MomentsFeature::of_polygon(L * 0.1), r1 = MomentsFeature::of_polygon(R1 * 0.1),
                r2 = MomentsFeature::of_polygon(R2 * 0.1);
  worst = 0.0;
  for (std::size_t k = 0; k < 15; ++k) worst = std::max(worst, std::abs(l[k] - r1[k] - r2[k]));
  CHECK(worst < 1e-15);
  // Points: plain sums.
  const Moments s = MomentsFeature::of_points(R);
  CHECK_NEAR(mom(s, 2, 1), x0 * x0 * y0 + x1 * x1 * y0 + x1 * x1 * y1 + x0 * x0 * y1, 1e-15);
  CHECK(mom(s, 0, 0) == 4.0);
}

// Central differences of the features of the object P (camera frame) under the six twist directions.
Eigen::Matrix<double, 6, 6> numeric_rows(const MomentsFeature& f, const Eigen::Matrix3Xd& P, double a_desired,
                                         double z_desired, double h) {
  Eigen::Matrix<double, 6, 6> N = Eigen::Matrix<double, 6, 6>::Zero();
  for (int k = 0; k < 6; ++k) {
    Twist xi = Twist::Zero();
    xi(k) = h;
    const Pose Ta = se3_inverse(se3_exp(xi)), Tb = se3_inverse(se3_exp(-xi));
    const Eigen::Matrix3Xd Pa = (Ta.topLeftCorner<3, 3>() * P).colwise() + Ta.topRightCorner<3, 1>();
    const Eigen::Matrix3Xd Pb = (Tb.topLeftCorner<3, 3>() * P).colwise() + Tb.topRightCorner<3, 1>();
    const auto ma = MomentsFeature::project(Pa, f.source(), a_desired, z_desired);
    const auto mb = MomentsFeature::project(Pb, f.source(), a_desired, z_desired);
    double e[6];
    f.error(ma.data(), mb.data(), e);  // the difference, alpha's wrapped
    for (int r = 0; r < f.rows(); ++r) N(r, k) = e[r] / (2 * h);
  }
  return N;
}

// ViSP's closed forms (Tahri & Chaumette 2005) of xn, yn, an and alpha, transcribed from
// vpFeatureMomentGravityCenterNormalized, vpFeatureMomentAreaNormalized and vpFeatureMomentAlpha.
Eigen::Matrix<double, 4, 6> visp_rows(const std::array<double, 20>& m, bool region) {
  const double m00 = m[0], xg = m[1] / m00, yg = m[2] / m00;
  const auto mu = [&](int p, int q) {
    double s = 0.0;
    for (int k = 0; k <= p; ++k)
      for (int l = 0; l <= q; ++l) {
        const double cb = std::tgamma(p + 1.0) / (std::tgamma(k + 1.0) * std::tgamma(p - k + 1.0)) *
                          std::tgamma(q + 1.0) / (std::tgamma(l + 1.0) * std::tgamma(q - l + 1.0));
        s += cb * std::pow(-xg, p - k) * std::pow(-yg, q - l) * m[static_cast<std::size_t>(moment_index(k, l))];
      }
    return s;
  };
  const double mu20 = mu(2, 0), mu11 = mu(1, 1), mu02 = mu(0, 2), mu30 = mu(3, 0), mu21 = mu(2, 1), mu12 = mu(1, 2),
               mu03 = mu(0, 3);
  const double A = m[17], B = m[18], C = m[19];
  const double a = region ? m00 : mu20 + mu02, An = m[16] * std::sqrt(m[15] / a), Xn = An * xg, Yn = An * yg;
  const double n20 = mu20 / m00, n11 = mu11 / m00, n02 = mu02 / m00, n03 = mu03 / m00, n10 = 0.0, n01 = 0.0;
  Eigen::Matrix<double, 4, 6> V;
  double Xnvx, Xnvy, Xnwx, Xnwy, Ynvx, Ynvy, Ynwx, Ynwy, Anvx, Anvy, Anvz, Anwx, Anwy;
  if (!region) {
    const double e11 = mu11 / a, e12 = mu12 / a, e21 = mu21 / a, e30 = mu30 / a, e02 = mu02 / a, e20 = mu20 / a,
                 e03 = mu03 / a, e01 = 0.0, e10 = 0.0, NA = n20 + n02;
    Xnvx = B * Xn * e11 - Yn * B - An * C - n02 * A * Xn / NA;
    Xnvy = A * Xn * e11 + n02 * B * Xn / NA;
    Xnwx = An * e11 * NA + Yn * n10 - Xn * xg * e11 + Xn * n01 + Xn * n10 * e11 - Xn * e21 +
           (-Xn * n03 + (Xn * n01 - Yn * xg) * n02) / NA;
    Xnwy = -An * NA + Xn * e12 + Xn * xg - An + e11 * xg * Yn - Xn * n01 * e11 - 2 * Xn * n10 + Xn * e30 + n02 * An +
           (-Xn * xg + Xn * n10) * n02 / NA;
    Ynvx = (Yn - n02 * Yn / NA) * A + Yn * e11 * B;
    Ynvy = (-Xn + e11 * Yn) * A + (-Yn + n02 * Yn / NA) * B - An * C;
    Ynwx = n02 * An + Yn * n10 * e11 - e11 * xg * Yn + An - Yn * e21 + Yn * n01 +
           (-Yn * n03 + (Yn * n01 - Yn * yg) * n02) / NA;
    Ynwy = -An * e11 * NA + Yn * e11 * yg - Yn * n01 * e11 + Yn * xg + Yn * e12 + Yn * e30 - Xn * n01 - 2 * Yn * n10 +
           (Yn * n10 - Yn * xg) * n02 / NA;
    Anvx = An * A * e20 + An * B * e11;
    Anvy = An * A * e11 + An * B * e02;
    Anwx = (n02 * e01 + n11 * e10 - e03 - e21) * An - Xn * e11 + (-1 - e02) * Yn;
    Anwy = (e12 + e30 - n11 * e01 - n20 * e10) * An + (2 - e02) * Xn + Yn * e11;
    Anvz = -An * C + B * Anwx - A * Anwy;
  } else {
    // ViSP writes -A Xn here; the derivation (and its own yn row, -B Yn / 2, by symmetry) give -A Xn / 2,
    // which the finite differences confirm: the corrected term is the one tested.
    Xnvx = -An * C - 0.5 * A * Xn - Yn * B;
    Xnvy = 0.5 * B * Xn;
    Xnwx = 0.5 * (8. * n10 - xg) * Yn + 4. * An * n11 + 4. * n01 * Xn;
    Xnwy = 0.5 * (-2. - 8. * n20) * An + 0.5 * Xn * (-8. * n10 + xg);
    Ynvx = 0.5 * A * Yn;
    Ynvy = -0.5 * B * Yn - C * An - A * Xn;
    Ynwx = 0.5 * Yn * (8. * n01 - yg) + 0.5 * (2. + 8. * n02) * An;
    Ynwy = 0.5 * (-8. * n10 + xg) * Yn - 4. * An * n11 - 4. * n01 * Xn;
    Anvx = A * An / 2.;
    Anvy = B * An / 2.;
    Anvz = -An * C - 1.5 * A * Xn - 1.5 * B * Yn;
    Anwx = -1.5 * Yn;
    Anwy = 1.5 * Xn;
  }
  const double Ynvz = -A * Ynwy + (-An + Ynwx) * B, Xnvz = -A * An - A * Xnwy + B * Xnwx;
  V.row(0) << Xnvx, Xnvy, Xnvz, Xnwx, Xnwy, Yn;
  V.row(1) << Ynvx, Ynvy, Ynvz, Ynwx, Ynwy, -Xn;
  V.row(2) << Anvx, Anvy, Anvz, Anwx, Anwy, 0.0;
  const double beta = region ? 5 : 2, d = (mu20 - mu02) * (mu20 - mu02) + 4 * mu11 * mu11, DA = mu20 + mu02;
  const double Avx = mu11 * DA * A / d + (DA * mu02 + 0.5 * d - 0.5 * DA * DA) * B / d;
  const double Avy = (DA * mu02 - 0.5 * d - 0.5 * DA * DA) * A / d - B * mu11 * DA / d;
  const double Awx = (beta * (mu12 * (mu20 - mu02) + mu11 * (mu03 - mu21)) +
                      xg * (mu02 * (mu20 - mu02) - 2 * mu11 * mu11) + yg * mu11 * (mu20 + mu02)) / d;
  const double Awy = (beta * (mu21 * (mu02 - mu20) + mu11 * (mu30 - mu12)) + xg * mu11 * (mu20 + mu02) +
                      yg * (mu20 * (mu02 - mu20) - 2 * mu11 * mu11)) / d;
  V.row(3) << Avx, Avy, B * Awx - A * Awy, Awx, Awy, -1.0;
  return V;
}

// The invariants' rows by another route: the interaction matrices of the centred moments mu_ij as
// ViSP's vpFeatureMomentCentered writes them (Chaumette 2004 for a region, delta = 1, epsilon = 4;
// Tahri & Chaumette 2005 for points, delta = 0, epsilon = 1), chained through the invariants'
// definitions by central differences in the centred moments.
Eigen::Matrix<double, 2, 6> visp_invariant_rows(const std::array<double, 20>& m, bool region, bool p_pair) {
  const double m00 = m[0], xg = m[1] / m00, yg = m[2] / m00, A = m[17], B = m[18], C = m[19];
  double mu[6][6] = {};
  for (int p = 0; p <= 4; ++p)
    for (int q = 0; p + q <= 4; ++q)
      for (int k = 0; k <= p; ++k)
        for (int l = 0; l <= q; ++l)
          mu[p][q] += std::tgamma(p + 1.0) / (std::tgamma(k + 1.0) * std::tgamma(p - k + 1.0)) * std::tgamma(q + 1.0) /
                      (std::tgamma(l + 1.0) * std::tgamma(q - l + 1.0)) * std::pow(-xg, p - k) * std::pow(-yg, q - l) *
                      m[static_cast<std::size_t>(moment_index(k, l))];
  const auto MU = [&](int i, int j) { return i < 0 || j < 0 ? 0.0 : mu[i][j]; };
  const double delta = region ? 1 : 0, eps = region ? 4 : 1;
  const double n20 = mu[2][0] / m00, n11 = mu[1][1] / m00, n02 = mu[0][2] / m00;
  const auto Lmu = [&](int i, int j) {
    Eigen::Matrix<double, 1, 6> L;
    const double wx = (i + j + 3 * delta) * MU(i, j + 1) + (i + 2 * j + 3 * delta) * yg * MU(i, j) +
                      i * xg * MU(i - 1, j + 1) - i * eps * n11 * MU(i - 1, j) - j * eps * n02 * MU(i, j - 1);
    const double wy = -(i + j + 3 * delta) * MU(i + 1, j) - (2 * i + j + 3 * delta) * xg * MU(i, j) -
                      j * yg * MU(i + 1, j - 1) + i * eps * n20 * MU(i - 1, j) + j * eps * n11 * MU(i, j - 1);
    L << -(i + delta) * A * MU(i, j) - i * B * MU(i - 1, j + 1), -j * A * MU(i + 1, j - 1) - (j + delta) * B * MU(i, j),
        -A * wy + B * wx + (i + j + 2 * delta) * C * MU(i, j), wx, wy, i * MU(i - 1, j + 1) - j * MU(i + 1, j - 1);
    return L;
  };
  // The invariants of (mu20, mu11, mu02, mu30, mu21, mu12, mu03, a) (Tahri & Chaumette 2005).
  const auto invariants = [&](const double* x) {
    const double c1 = x[0] - x[2], s1 = 2 * x[1], c2 = x[6] - 3 * x[4], s2 = x[3] - 3 * x[5], I3 = x[0] + x[2];
    const double I1 = c1 * c1 + s1 * s1, I2 = c2 * c2 + s2 * s2, c3 = c1 * c1 - s1 * s1, s3 = 2 * s1 * c1;
    if (p_pair) return Eigen::Vector2d(I1 / (I3 * I3), x[7] * I2 / (I3 * I3 * I3));
    const double K = I1 * I3 * std::sqrt(I3) / std::sqrt(x[7]);
    return Eigen::Vector2d((c2 * c3 + s2 * s3) / K, (s2 * c3 - c2 * s3) / K);
  };
  const int ij[7][2] = {{2, 0}, {1, 1}, {0, 2}, {3, 0}, {2, 1}, {1, 2}, {0, 3}};
  double x[8];
  Eigen::Matrix<double, 8, 6> Lx;
  for (int k = 0; k < 7; ++k) {
    x[k] = mu[ij[k][0]][ij[k][1]];
    Lx.row(k) = Lmu(ij[k][0], ij[k][1]);
  }
  x[7] = region ? m00 : mu[2][0] + mu[0][2];
  Lx.row(7) = region ? Lmu(0, 0) : Eigen::Matrix<double, 1, 6>(Lmu(2, 0) + Lmu(0, 2));
  const double I3 = x[0] + x[2];
  Eigen::Matrix<double, 2, 6> R = Eigen::Matrix<double, 2, 6>::Zero();
  for (int k = 0; k < 8; ++k) {
    const double h = 1e-6 * (k < 3 ? I3 : k < 7 ? I3 * std::sqrt(I3 / x[7]) : x[7]);
    double xp[8], xm[8];
    std::copy(x, x + 8, xp);
    std::copy(x, x + 8, xm);
    xp[k] += h;
    xm[k] -= h;
    R += (invariants(xp) - invariants(xm)) / (2 * h) * Lx.row(k);
  }
  return R;
}

void jacobians() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), z(0.6, 3.0);
  for (Src src : {Src::region, Src::points})
    for (Inv inv : {Inv::p, Inv::s})
      for (Alp al : {Alp::second_order, Alp::third_order}) {
        const MomentsFeature f(src, inv, al);
        int checked = 0;
        double worst_fd = 0.0, worst_visp = 0.0, worst_inv = 0.0;
        for (int c = 0; c < std::max(20, ibvs_test::cases / 10); ++c) {
          const Eigen::Matrix3Xd Pw = star(rng, 5 + c % 4, 0.2);
          Twist pose;  // a camera in front of the object's plane, tilted, at depth z
          pose << 0.15 * u(rng), 0.15 * u(rng), 0.0, 0.4 * u(rng), 0.4 * u(rng), pi * u(rng);
          Pose T = se3_exp(pose);
          T(2, 3) = -z(rng);
          const Eigen::Matrix3Xd P = in_camera(T, Pw);
          const double Zd = z(rng), ad = 0.01 + 0.02 * (1 + u(rng));
          const auto m = MomentsFeature::project(P, src, ad, Zd);
          int entry = 0;
          if (f.check(m.data(), entry)) continue;
          MatrixX6 L(6, 6);
          f.interaction(m.data(), L);
          const auto N = numeric_rows(f, P, ad, Zd, 1e-6);
          const double scale = std::max(1.0, L.cwiseAbs().maxCoeff());
          worst_fd = std::max(worst_fd, (L - N).cwiseAbs().maxCoeff() / scale);
          const Eigen::Matrix<double, 4, 6> V = visp_rows(m, src == Src::region);
          Eigen::Matrix<double, 4, 6> Lm;
          Lm << L.topRows(3), L.row(5);
          worst_visp = std::max(worst_visp, (Lm - V).cwiseAbs().maxCoeff() / scale);
          const Eigen::Matrix<double, 2, 6> Ri = visp_invariant_rows(m, src == Src::region, inv == Inv::p);
          worst_inv = std::max(worst_inv, (L.middleRows(3, 2) - Ri).cwiseAbs().maxCoeff() /
                                              std::max(1e-3, L.middleRows(3, 2).cwiseAbs().maxCoeff()));
          ++checked;
        }
        std::printf("%s: %d objects, worst relative difference %.2g (finite differences), %.2g (ViSP's xn, yn, an, "
                    "alpha), %.2g (r1, r2 through ViSP's centred-moment rows)\n",
                    f.describe().c_str(), checked, worst_fd, worst_visp, worst_inv);
        CHECK(checked >= 15);
        CHECK(worst_fd < 1e-5);
        CHECK(worst_visp < 1e-9);
        CHECK(worst_inv < 1e-5);  // limited by the differences in the centred moments
      }
}

// Servo a camera on a moments task from start pose T (world object Pw in the plane z = 0, goal:
// the camera at (0, 0, -Zd) facing it): frames used, distance and angle to the goal at the end,
// the range of the camera's z and its largest distance from the optical axis of the goal.
struct Run {
  int frames = 0;
  double dp = 0.0, dr = 0.0, zmin = 1e9, zmax = -1e9, xymax = 0.0;
};
Run servo_run(const MomentsFeature& f, const Eigen::Matrix3Xd& Pw, Pose T, double Zd,
              InteractionMatrix jacobian = InteractionMatrix::current, int max_frames = 4000) {
  Task task;
  task.add(f);
  ServoOptions o;
  o.gain = 1.0;
  o.jacobian = jacobian;
  Servo servo(task, o);
  ServoInput in(task);
  ServoOutput out(task);
  Pose goal = Pose::Identity();
  goal(2, 3) = -Zd;
  const auto md = MomentsFeature::project(in_camera(goal, Pw), f.source(), 0.0, Zd);
  in.measurements_desired = Eigen::Map<const Eigen::VectorXd>(md.data(), 20);
  Run r;
  const double dt = 1.0 / 60;
  for (; r.frames < max_frames; ++r.frames) {
    std::array<double, 20> m;
    try {
      m = MomentsFeature::project(in_camera(T, Pw), f.source(), md[15], Zd);
    } catch (const std::invalid_argument& ex) {  // the object left the camera's front: a failure
      std::printf("frame %d: %s\n", r.frames, ex.what());
      r.frames = max_frames;
      break;
    }
    in.measurements = Eigen::Map<const Eigen::VectorXd>(m.data(), 20);
    if (servo.update(in, out) == Status::invalid_input) {
      int entry = 0;
      std::printf("refused at frame %d: %s\n", r.frames, f.check(m.data(), entry));
      r.frames = max_frames;
      break;
    }
    r.zmin = std::min(r.zmin, T(2, 3));
    r.zmax = std::max(r.zmax, T(2, 3));
    r.xymax = std::max(r.xymax, T.block<2, 1>(0, 3).norm());
    if (out.error_norm < 1e-9) break;
    T = T * se3_exp(out.velocity * dt);
  }
  const Pose D = se3_inverse(goal) * T;
  r.dp = D.topRightCorner<3, 1>().norm();
  r.dr = Eigen::AngleAxisd(Eigen::Matrix3d(D.topLeftCorner<3, 3>())).angle();
  return r;
}

void half_turn_about_the_axis() {
  std::mt19937_64 rng(ibvs_test::seed + 7);
  Eigen::Matrix3Xd Pw = star(rng, 6, 0.15);
  const double Zd = 0.8;
  for (Src src : {Src::region, Src::points}) {
    // Centre the object (its centre of gravity on the optical axis at the goal).
    Points xy = Pw.topRows(2) / Zd;
    const Moments m0 = src == Src::region ? MomentsFeature::of_polygon(xy) : MomentsFeature::of_points(xy);
    Eigen::Matrix3Xd P = Pw;
    P.row(0).array() -= Zd * mom(m0, 1, 0) / mom(m0, 0, 0);
    P.row(1).array() -= Zd * mom(m0, 0, 1) / mom(m0, 0, 0);
    Twist rot = Twist::Zero();
    rot(5) = 160.0 * pi / 180.0;
    Pose T = se3_exp(rot);
    T(2, 3) = -Zd;
    const Run a = servo_run(MomentsFeature(src, Inv::p, Alp::third_order), P, T, Zd);
    std::printf("%s, 160 deg about the axis, third-order alpha: frame %d, %.2g m and %.2g rad from the goal, "
                "z in [%.6f, %.6f], |xy| <= %.2g\n",
                src == Src::region ? "region" : "points", a.frames, a.dp, a.dr, a.zmin, a.zmax, a.xymax);
    CHECK(a.frames < 4000 && a.dp < 1e-6 && a.dr < 1e-6);
    CHECK(a.zmax - a.zmin < 1e-9 && a.xymax < 1e-9);  // a pure rotation: no retreat, no sideways motion
    // Second-order alpha (modulo pi): the error is 160 - 180 = -20 degrees, and the camera settles on the
    // half-turn, where every feature equals the goal's.
    const Run b = servo_run(MomentsFeature(src, Inv::p, Alp::second_order), P, T, Zd);
    std::printf("  second-order alpha: frame %d, %.3g rad from the goal\n", b.frames, b.dr);
    CHECK(std::abs(b.dr - pi) < 1e-6 && b.dp < 1e-6);
  }
}

// From a general start (a few cm off, tilted by about 10 degrees, turned by 29 degrees about the
// axis), seven-vertex random objects of radius up to 0.3 m at 0.8 m: the law with the mean interaction matrix
// converges for at least three objects in four, with every source and pair of invariants (not for
// all: docs/features.md gives the shares with each interaction matrix and a smaller object).
void general_start_converges() {
  std::mt19937_64 rng(ibvs_test::seed + 8);
  const int shapes = 12;
  int converged[2][2] = {};
  for (int k = 0; k < shapes; ++k) {
    const Eigen::Matrix3Xd Pw = star(rng, 7, 0.3);
    for (Src src : {Src::region, Src::points})
      for (Inv inv : {Inv::p, Inv::s}) {
        Twist start;
        start << 0.05, -0.04, 0.0, 0.15, -0.1, 0.5;
        Pose T = se3_exp(start);
        T(2, 3) = -1.1;
        const Run r = servo_run(MomentsFeature(src, inv, Alp::third_order), Pw, T, 0.8, InteractionMatrix::mean);
        converged[src == Src::points][inv == Inv::s] += r.frames < 4000 && r.dp < 1e-6 && r.dr < 1e-6;
      }
  }
  std::printf("general start, mean interaction matrix, %d objects: converged region p %d, region s %d, points p %d, "
              "points s %d\n", shapes, converged[0][0], converged[0][1], converged[1][0], converged[1][1]);
  for (auto& c : converged)
    for (int n : c) CHECK(4 * n >= 3 * shapes);  // measured: 9 to 12 of 12 over seeds 1 to 5 and 42
}

void refusals() {
  std::mt19937_64 rng(ibvs_test::seed + 9);
  const Eigen::Matrix3Xd Pw = star(rng, 6, 0.15);
  Pose T = Pose::Identity();
  T(2, 3) = -1.0;
  const auto good = MomentsFeature::project(in_camera(T, Pw), Src::region, 0.0, 1.0);
  const MomentsFeature f;
  int entry = 0;
  CHECK(f.check(good.data(), entry) == nullptr);
  // Zero area: a polygon whose vertices are collinear; collinear points.
  Points line(2, 4);
  line << 0.0, 0.1, 0.2, 0.3, 0.0, 0.05, 0.1, 0.15;
  const auto flat_region = MomentsFeature::measure(MomentsFeature::of_polygon(line), Src::region, 0.01, 1.0, 0, 0, 1);
  CHECK(f.check(flat_region.data(), entry) != nullptr && entry == 0);
  const MomentsFeature fp(Src::points);
  const auto flat_points = MomentsFeature::measure(MomentsFeature::of_points(line), Src::points, 0.01, 1.0, 0, 0, 1);
  CHECK(fp.check(flat_points.data(), entry) != nullptr && entry == -1);
  // The plane seen edge-on at the object: 1/Z = A x + C vanishes at its centre of gravity.
  auto edge = good;
  edge[17] = -edge[19] * edge[0] / edge[1];
  CHECK(f.check(edge.data(), entry) != nullptr && entry == -1);
  CHECK_THROWS(f.validate(edge.data(), "moments"));
  // The square: alpha undefined; without the alpha row (P invariants) accepted. A rectangle
  // (centrally symmetric): second-order alpha accepted, third-order refused.
  Points sq(2, 4), rect(2, 4);
  sq << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  rect << 0.2, -0.2, -0.2, 0.2, 0.1, 0.1, -0.1, -0.1;
  const auto msq = MomentsFeature::measure(MomentsFeature::of_polygon(sq), Src::region, 0.0, 1.0, 0, 0, 1);
  const auto mre = MomentsFeature::measure(MomentsFeature::of_polygon(rect), Src::region, 0.0, 1.0, 0, 0, 1);
  using R = MomentsFeature::Row;
  CHECK(MomentsFeature(Src::region, Inv::p, Alp::second_order).check(msq.data(), entry) != nullptr);
  CHECK(MomentsFeature(Src::region, Inv::p, Alp::second_order, R::xn | R::yn | R::an | R::r1 | R::r2)
            .check(msq.data(), entry) == nullptr);
  CHECK(MomentsFeature(Src::region, Inv::s, Alp::second_order, R::r1).check(msq.data(), entry) != nullptr);
  CHECK(MomentsFeature(Src::region, Inv::p, Alp::second_order).check(mre.data(), entry) == nullptr);
  CHECK(MomentsFeature(Src::region, Inv::p, Alp::third_order).check(mre.data(), entry) != nullptr);
  CHECK_THROWS(MomentsFeature(Src::region, Inv::p, Alp::third_order, 0u));
  CHECK_THROWS(MomentsFeature(Src::region, Inv::p, Alp::third_order, 64u));
  CHECK_THROWS(MomentsFeature::project(Eigen::Matrix3Xd::Zero(3, 2), Src::region, 0.0, 1.0));
  // At the goal an = Z*, and the error is zero.
  double s[6], e[6];
  f.value(good.data(), s);
  f.error(good.data(), good.data(), e);
  CHECK_NEAR(s[2], 1.0, 1e-15);
  const Eigen::Map<const Eigen::VectorXd> ev(e, 6);
  CHECK(ev.cwiseAbs().maxCoeff() == 0.0);
  // validate() throws exactly for the measurements update() refuses.
  Task task;
  task.add(f);
  Servo servo(task);
  ServoInput in(task);
  ServoOutput out(task);
  in.measurements = Eigen::Map<const Eigen::VectorXd>(good.data(), 20);
  in.measurements_desired = in.measurements;
  const std::initializer_list<double> bad = {
      std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 1e300, -1.0, 0.0, 1e-300,
      3.0, -11.0, 2e6};
  ibvs_test::check_refusals_agree(servo, in, out, rng, bad);
}

// MomentsFeature::evaluate (the Servo's one pass: each measurement evaluated once) gives exactly
// what the calls it replaces give (Feature::evaluate: check of both, error, interaction): the same
// refusals and the same e and L, bit for bit, for every source, pair of invariants and
// orientation, on random objects and poses and on measurements with one entry spoiled.
void one_pass_evaluation() {
  std::mt19937_64 rng(ibvs_test::seed + 13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> which(0, 19);
  int compared = 0, refused = 0;
  for (int c = 0; c < ibvs_test::cases; ++c) {
    const MomentsFeature f(c % 2 ? Src::points : Src::region, (c / 2) % 2 ? Inv::s : Inv::p,
                           (c / 4) % 2 ? Alp::second_order : Alp::third_order);
    const Eigen::Matrix3Xd Pw = star(rng, 5 + c % 3, 0.15);
    Twist xi, xd;
    xi << 0.1 * u(rng), 0.1 * u(rng), -1.0 + 0.2 * u(rng), 0.3 * u(rng), 0.3 * u(rng), 2.0 * u(rng);
    xd << 0.0, 0.0, -1.0, 0.0, 0.0, 0.0;
    const auto goal = MomentsFeature::project(in_camera(se3_exp(xd), Pw), f.source(), 0.0, 1.0);
    auto m = MomentsFeature::project(in_camera(se3_exp(xi), Pw), f.source(),
                                     MomentsFeature::area(goal.data(), f.source()), 1.0);
    auto md = goal;
    if (c % 5 == 4) (c % 10 == 4 ? m : md)[static_cast<std::size_t>(which(rng))] *= 1e3 * u(rng);
    MatrixX6 L1 = MatrixX6::Zero(6, 6), L2 = MatrixX6::Zero(6, 6);
    double e1[6] = {}, e2[6] = {};
    auto m1 = m, m2 = m;
    const char* a = f.evaluate(m1.data(), md.data(), e1, L1);
    const char* b = f.Feature::evaluate(m2.data(), md.data(), e2, L2);
    CHECK((a == nullptr) == (b == nullptr));
    if (a || b) {
      ++refused;
      continue;
    }
    ++compared;
    for (int r = 0; r < f.rows(); ++r) {
      CHECK(std::memcmp(&e1[r], &e2[r], sizeof(double)) == 0);
      for (int j = 0; j < 6; ++j) CHECK(std::memcmp(&L1(r, j), &L2(r, j), sizeof(double)) == 0);
    }
  }
  CHECK(compared > ibvs_test::cases / 2 && refused > 0);
}

}  // namespace

void run_tests() {
  one_pass_evaluation();
  polygon_moments();
  jacobians();
  half_turn_about_the_axis();
  general_start_converges();
  refusals();
}
