// The image ellipse of second-order moments (features/ellipse.hpp): its
// interaction matrix against central differences of its own projection (the
// camera moved by small twists, the 3-D circle re-projected) and against
// ViSP's transcription of Chaumette 2004 eqs. (14), (26); project_circle()
// against the moments of the circle's image traced as a fine polygon (Green's
// theorem), and measure_moments() of that polygon in normalised coordinates
// and in pixels; a circle alone (five DOF) and a circle with a diameter (six)
// close the loop; check(), validate() and update() refuse the same measurements.
#include "check.hpp"
#include "refusals.hpp"
#include "scene.hpp"

#include <array>
#include <limits>

using namespace ibvs;

namespace {

struct Circle {
  Eigen::Vector3d centre, normal;
  double radius;
};

// The circle seen by a camera moved by twist xi (the centre and normal in the new camera frame).
Circle moved(const Circle& c, const Twist& xi) {
  const Pose T = se3_inverse(se3_exp(xi));
  return {T.topLeftCorner<3, 3>() * c.centre + T.topRightCorner<3, 1>(), T.topLeftCorner<3, 3>() * c.normal,
          c.radius};
}

std::array<double, 8> project(const Circle& c) { return EllipseFeature::project_circle(c.centre, c.normal, c.radius); }

// ViSP's vpFeatureEllipse::interaction, transcribed in its variables (its plane is ours: 1/Z = A x + B y + C).
Eigen::Matrix<double, 5, 6> visp_ellipse(const std::array<double, 8>& m) {
  const double xc = m[0], yc = m[1], n20 = m[2], n11 = m[3], n02 = m[4], A = m[5], B = m[6], C = m[7];
  const double Zinv = A * xc + B * yc + C;
  Eigen::Matrix<double, 5, 6> L;
  L << -Zinv, 0, xc * Zinv + 4.0 * (A * n20 + B * n11), xc * yc + 4.0 * n11, -1 - xc * xc - 4.0 * n20, yc,  //
      0, -Zinv, yc * Zinv + 4.0 * (A * n11 + B * n02), 1 + yc * yc + 4.0 * n02, -xc * yc - 4.0 * n11, -xc,  //
      -2.0 * (A * n20 + B * n11), 0, 2 * ((Zinv + A * xc) * n20 + B * xc * n11), 2 * (yc * n20 + xc * n11),
      -4 * n20 * xc, 2 * n11,  //
      -A * n11 - B * n02, -A * n20 - B * n11, A * yc * n20 + (3 * Zinv - C) * n11 + B * xc * n02,
      3 * yc * n11 + xc * n02, -yc * n20 - 3 * xc * n11, n02 - n20,  //
      0, -2 * (A * n11 + B * n02), 2 * ((Zinv + B * yc) * n02 + A * yc * n11), 4 * yc * n02,
      -2 * (yc * n11 + xc * n02), -2 * n11;
  return L;
}

Circle random_circle(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-0.4, 0.4), z(0.5, 5.0), s(-1.0, 1.0), r(0.02, 0.25);
  const double depth = z(rng);
  Eigen::Vector3d n(s(rng), s(rng), -1.0 - std::abs(s(rng)));  // facing the camera, tilted up to ~55 degrees
  return {ibvs_test::point(u(rng), u(rng), depth), n.normalized(), r(rng) * depth};
}

void ellipse_jacobian() {
  std::mt19937_64 rng(ibvs_test::seed);
  const EllipseFeature ellipse;
  int checked = 0;
  double worst_fd = 0.0, worst_visp = 0.0;
  for (int c = 0; c < ibvs_test::cases; ++c) {
    const Circle circle = random_circle(rng);
    std::array<double, 8> m;
    try {
      m = project(circle);
    } catch (const std::invalid_argument&) {
      continue;
    }
    MatrixX6 L(5, 6);
    ellipse.interaction(m.data(), L);
    const double h = 1e-6;
    Eigen::Matrix<double, 5, 6> Ln;
    for (int k = 0; k < 6; ++k) {
      Twist xi = Twist::Zero();
      xi(k) = h;
      const auto a = project(moved(circle, xi)), b = project(moved(circle, -xi));
      for (std::size_t i = 0; i < 5; ++i) Ln(static_cast<Eigen::Index>(i), k) = (a[i] - b[i]) / (2 * h);
    }
    const double scale = std::max(1.0, L.cwiseAbs().maxCoeff());
    worst_fd = std::max(worst_fd, (L - Ln).cwiseAbs().maxCoeff() / scale);
    worst_visp = std::max(worst_visp, (L - visp_ellipse(m)).cwiseAbs().maxCoeff() / scale);
    ++checked;
  }
  std::printf("ellipse: %d circles, worst relative difference %.2g (finite differences), %.2g (ViSP's formula)\n",
              checked, worst_fd, worst_visp);
  CHECK(checked > ibvs_test::cases * 9 / 10);
  CHECK(worst_fd < 1e-7);
  CHECK(worst_visp < 1e-14);
}

// Area, first-order and centred second-order moments (m00, m10, m01, mu20, mu11, mu02) of a
// closed polygon (Green's theorem), whatever its orientation.
std::array<double, 6> polygon_moments(const Eigen::Matrix2Xd& p) {
  double a = 0, mx = 0, my = 0, mxx = 0, mxy = 0, myy = 0;
  const Eigen::Index n = p.cols();
  const Eigen::Vector2d o = p.col(0);  // about the first vertex: no cancellation against the offset
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x0 = p(0, i) - o.x(), y0 = p(1, i) - o.y(), x1 = p(0, (i + 1) % n) - o.x(),
                 y1 = p(1, (i + 1) % n) - o.y(), c = x0 * y1 - x1 * y0;
    a += c / 2;
    mx += (x0 + x1) * c / 6;
    my += (y0 + y1) * c / 6;
    mxx += (x0 * x0 + x0 * x1 + x1 * x1) * c / 12;
    myy += (y0 * y0 + y0 * y1 + y1 * y1) * c / 12;
    mxy += (x0 * y1 + 2 * x0 * y0 + 2 * x1 * y1 + x1 * y0) * c / 24;
  }
  const double sign = a < 0 ? -1.0 : 1.0, xg = mx / a, yg = my / a;
  return {sign * a, sign * a * (xg + o.x()), sign * a * (yg + o.y()), sign * (mxx - a * xg * xg),
          sign * (mxy - a * xg * yg), sign * (myy - a * yg * yg)};
}

// The circle's image traced point by point (N points of the 3-D circle projected), in normalised
// coordinates, or in pixels through `camera`.
Eigen::Matrix2Xd traced(const Circle& c, int N, const CameraModel* camera = nullptr) {
  Eigen::Vector3d e1 = c.normal.unitOrthogonal(), e2 = c.normal.normalized().cross(e1);
  Eigen::Matrix2Xd p(2, N);
  for (int i = 0; i < N; ++i) {
    const double t = 2 * pi * i / N;
    const Eigen::Vector3d X = c.centre + c.radius * (std::cos(t) * e1 + std::sin(t) * e2);
    p.col(i) << X.x() / X.z(), X.y() / X.z();
    if (camera) {
      Eigen::Vector2d px;
      camera->project(p(0, i), p(1, i), px);
      p.col(i) = px;
    }
  }
  return p;
}

void projection_is_the_traced_image() {
  std::mt19937_64 rng(ibvs_test::seed + 1);
  const CameraModel camera = CameraModel::pinhole(800.0, 780.0, 320.0, 240.0, 640.0, 480.0);
  int checked = 0;
  double worst = 0.0, worst_px = 0.0;
  for (int c = 0; c < 50; ++c) {
    const Circle circle = random_circle(rng);
    std::array<double, 8> m;
    try {
      m = project(circle);
    } catch (const std::invalid_argument&) {
      continue;
    }
    const int N = 20000;
    const auto mo = polygon_moments(traced(circle, N));
    const auto b = EllipseFeature::measure_moments(mo, m[5], m[6], m[7]);
    const auto bp =
        EllipseFeature::measure_moments(polygon_moments(traced(circle, N, &camera)), m[5], m[6], m[7], camera);
    // The polygon is inscribed: its moments are short by O((2 pi / N)^2) ~ 1e-7 of the ellipse's size.
    const double size = std::sqrt(m[2] + m[4]);
    for (int i = 0; i < 5; ++i) {
      const double unit = i < 2 ? size : size * size;
      worst = std::max(worst, std::abs(b[static_cast<std::size_t>(i)] - m[static_cast<std::size_t>(i)]) / unit);
      worst_px = std::max(worst_px, std::abs(bp[static_cast<std::size_t>(i)] - m[static_cast<std::size_t>(i)]) / unit);
    }
    for (int i = 5; i < 8; ++i) CHECK(b[static_cast<std::size_t>(i)] == m[static_cast<std::size_t>(i)]);
    ++checked;
  }
  std::printf("ellipse: %d circles, project_circle vs the traced image's moments: %.2g (normalised), %.2g (pixels)\n",
              checked, worst, worst_px);
  CHECK(checked > 40);
  CHECK(worst < 1e-6 && worst_px < 1e-6);
  // A fronto-parallel disc of radius 0.2 m at 2 m, centred: a disc of radius 0.1, n20 = n02 = 0.1^2 / 4.
  const auto m = EllipseFeature::project_circle({0, 0, 2}, {0, 0, -3}, 0.2);
  CHECK_NEAR(m[0], 0.0, 1e-17);
  CHECK_NEAR(m[2], 0.0025, 1e-17);
  CHECK_NEAR(m[3], 0.0, 1e-17);
  CHECK_NEAR(m[4], 0.0025, 1e-17);
  CHECK_NEAR(m[7], 0.5, 1e-16);
}

void ellipse_refusals() {
  const EllipseFeature ellipse;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double good[8] = {0.1, -0.1, 0.01, 0.002, 0.005, 0.0, 0.0, 0.5};
  int entry = 0;
  CHECK(ellipse.check(good, entry) == nullptr);
  for (int i = 0; i < 8; ++i) {
    double m[8];
    std::copy(good, good + 8, m);
    m[i] = nan;
    CHECK(ellipse.check(m, entry) != nullptr && entry == i);
  }
  const double flat[8] = {0.1, -0.1, 0.01, 0.005, 0.0025, 0, 0, 0.5},  // n20 n02 = n11^2: a segment
      negative[8] = {0.1, -0.1, 0.01, 0.008, 0.0025, 0, 0, 0.5},        // n20 n02 < n11^2
      zero[8] = {0.1, -0.1, 0.0, 0.0, 0.005, 0, 0, 0.5},                // n20 = 0
      edge_on[8] = {0.1, -0.1, 0.01, 0.0, 0.01, -5.0, 0, 0.5},          // 1/Z = 0 at x = 0.1, the centroid
      behind[8] = {0.1, -0.1, 0.01, 0.0, 0.01, 0, 0, -0.5},             // 1/Z < 0
      grazing[8] = {0.1, -0.1, 0.01, 0.0, 0.01, -3.0, 0, 0.5},          // 1/Z = 0.2 at the centroid, < 0 at its rim
      far[8] = {0.1, 11.0, 0.01, 0.0, 0.01, 0, 0, 0.5};
  CHECK(ellipse.check(flat, entry) != nullptr && entry == -1);
  CHECK(ellipse.check(negative, entry) != nullptr && entry == -1);
  CHECK(ellipse.check(zero, entry) != nullptr && entry == 2);
  CHECK(ellipse.check(edge_on, entry) != nullptr && entry == -1);
  CHECK(ellipse.check(behind, entry) != nullptr && entry == -1);
  CHECK(ellipse.check(grazing, entry) != nullptr && entry == -1);
  CHECK(ellipse.check(far, entry) != nullptr && entry == 1);
  CHECK_THROWS(ellipse.validate(flat, "ellipse"));
  // project_circle and measure_moments refuse what has no ellipse.
  CHECK_THROWS(EllipseFeature::project_circle({0, 0, 2}, {0, 0, 1}, 0.0));            // no radius
  CHECK_THROWS(EllipseFeature::project_circle({0, 0, 2}, {0, 0, 0}, 0.1));            // no normal
  CHECK_THROWS(EllipseFeature::project_circle({0, 0, 2}, {1, 0, 0}, 0.1));            // plane through the camera
  CHECK_THROWS(EllipseFeature::project_circle({0, 0, 0.05}, {1, 0, 1}, 0.1));         // partly behind the camera
  CHECK_THROWS(EllipseFeature::project_circle({0, 0, -2}, {0, 0, 1}, 0.1));           // behind the camera
  CHECK_THROWS(EllipseFeature::project_circle({nan, 0, 2}, {0, 0, 1}, 0.1));
  CHECK_THROWS(EllipseFeature::measure_moments({0, 0, 0, 1, 0, 1}, 0, 0, 1));          // no area
  CHECK_THROWS(EllipseFeature::measure_moments({1, 0, 0, 1, 1, 1}, 0, 0, 1));          // a segment
  CHECK_THROWS(EllipseFeature::measure_moments({1, 0, 0, 0.01, 0, 0.01}, 1, 0, 0));    // edge-on at x = 0
  CHECK_THROWS(EllipseFeature::measure_moments({100, 32000, 24000, 400, 0, 400}, 0, 0, 1,
                                               CameraModel::afma6()));                  // distorted pixels
  CHECK(std::abs(EllipseFeature::measure_moments({100, 32000, 24000, 400, 0, 400}, 0, 0, 1,
                                                 CameraModel::pinhole(800, 800, 320, 240, 640, 480))[0]) < 1e-15);
}

// A disc seen obliquely at the goal: from a general start, the ellipse alone (wz left out)
// brings the camera to a pose that sees the circle exactly as the goal does (the goal pose
// turned about the circle's axis: the image of a circle cannot tell them apart, so the circle's
// centre and normal in the camera frame are the goal's); with a diameter as a segment beside
// it, to the goal pose itself. Seen fronto-parallel and centred, the ellipse rows have rank 3
// (tilting the camera changes the image's eccentricity at second order only): checked too.
void circle_converges() {
  const Circle world{{0.0, 0.0, 1.0}, {0.0, 0.0, -1.0}, 0.2};
  const Eigen::Vector3d D1(-0.2, 0.0, 1.0), D2(0.2, 0.0, 1.0);  // a diameter
  Pose goal = Pose::Identity();
  goal.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(0.15, Eigen::Vector3d::UnitX())).toRotationMatrix();
  goal.topRightCorner<3, 1>() << 0.3, -0.15, 0.05;
  const auto in_camera = [&](const Pose& T_wc) {  // the circle in the camera frame
    const Pose T = se3_inverse(T_wc);
    return Circle{T.topLeftCorner<3, 3>() * world.centre + T.topRightCorner<3, 1>(),
                  T.topLeftCorner<3, 3>() * world.normal, world.radius};
  };
  for (bool with_diameter : {false, true}) {
    Task task;
    // Beside the normalised segment (rows of size ~1/l), the ellipse's n_ij rows (size ~n_ij,
    // here 1e-2) weigh little: with unit weights this start ends in a local minimum of the 9-row
    // least squares (residual 1e-3, 0.5 m from the goal); weight 10 balances them.
    task.add(EllipseFeature(), with_diameter ? 10.0 : 1.0);
    if (with_diameter) task.add(SegmentFeature());
    else task.set_dof({true, true, true, true, true, false});
    ServoOptions o;
    o.gain = 1.0;
    Servo servo(task, o);
    ServoInput in(task);
    ServoOutput out(task);
    const auto measure = [&](const Pose& T_wc, Eigen::VectorXd& m) {
      const auto e = project(in_camera(T_wc));
      for (int j = 0; j < 8; ++j) m(j) = e[static_cast<std::size_t>(j)];
      if (with_diameter) {
        const Pose T = se3_inverse(T_wc);
        const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
        const auto s = SegmentFeature::project(R * D1 + T.topRightCorner<3, 1>(), R * D2 + T.topRightCorner<3, 1>());
        for (int j = 0; j < 6; ++j) m(8 + j) = s[static_cast<std::size_t>(j)];
      }
    };
    measure(goal, in.measurements_desired);
    Twist start;
    start << 0.08, -0.05, -0.3, 0.1, -0.12, 0.4;
    Pose T = goal * se3_exp(start);
    const double dt = 1.0 / 60;
    int k = 0;
    for (; k < 3000; ++k) {
      measure(T, in.measurements);
      if (servo.update(in, out) == Status::invalid_input) break;
      if (out.error_norm < 1e-10) break;
      T = T * se3_exp(out.velocity * dt);
    }
    const Circle seen = in_camera(T), wanted = in_camera(goal);
    const double dc = (seen.centre - wanted.centre).norm(), dn = (seen.normal - wanted.normal).norm();
    const Pose D = se3_inverse(goal) * T;
    const double dp = D.topRightCorner<3, 1>().norm();
    const double dr = Eigen::AngleAxisd(Eigen::Matrix3d(D.topLeftCorner<3, 3>())).angle();
    std::printf("ellipse%s: converged at frame %d; circle in the camera frame %.2g m, %.2g off the goal's; "
                "%.2g m, %.2g rad from the goal pose (sigma_min %.2g)\n",
                with_diameter ? " + diameter" : " (wz left out)", k, dc, dn, dp, dr, out.sigma_min());
    CHECK(k < 3000);
    CHECK(dc < 1e-8 && dn < 1e-8);
    if (with_diameter) CHECK(dp < 1e-8 && dr < 1e-8);
    else CHECK(out.velocity(5) == 0.0 && dr > 0.01);  // another pose of the family: turned about the circle's axis
  }
  // The centred, fronto-parallel disc: rank 3.
  MatrixX6 L(5, 6);
  EllipseFeature().interaction(project(world).data(), L);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd{Eigen::MatrixXd(L)};
  const Eigen::VectorXd sv = svd.singularValues();
  CHECK(sv(2) > 1e-2 && sv(3) < 1e-15 * sv(0));
}

// validate() throws exactly for the measurements update() refuses.
void refusals_agree() {
  Task task(Layout::cartesian(1));
  task.add(EllipseFeature());
  Servo servo(task);
  ServoInput in(task);
  ServoOutput out(task);
  in.uv_desired << 0.1, 0.1;
  const double good[8] = {0.1, -0.1, 0.01, 0.002, 0.005, 0.0, 0.0, 0.5};
  in.measurements = Eigen::Map<const Eigen::VectorXd>(good, 8);
  in.measurements_desired = in.measurements;
  std::mt19937_64 rng(ibvs_test::seed + 2);
  const std::initializer_list<double> bad = {
      std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 1e300, -11.0, 0.0, -0.01,
      0.3, 7.0, 0.02, 2e6, -1e-300};
  ibvs_test::check_refusals_agree(servo, in, out, rng, bad);
}

}  // namespace

void run_tests() {
  ellipse_jacobian();
  projection_is_the_traced_image();
  ellipse_refusals();
  circle_converges();
  refusals_agree();
}
