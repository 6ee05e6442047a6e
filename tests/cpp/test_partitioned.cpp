// Partitioned IBVS (Corke & Hutchinson 2001): its two feature Jacobians
// against central differences, the law's structure, convergence on the
// z-rotation pi (a pure rotation, no retreat), x-translation and general
// motion, and both error channels.
#include "check.hpp"
#include "scene.hpp"

#include "ibvs/partitioned.hpp"

using namespace ibvs;
using ibvs_test::moved_uv;

namespace {

void feature_jacobians_fd() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::uniform_real_distribution<double> c(-0.4, 0.4), d(0.3, 5.0);
  for (int t = 0; t < ibvs_test::cases; ++t) {
    const int n = 3 + t % 4;
    Points uv(2, n);
    Eigen::VectorXd z(n);
    Eigen::Matrix3Xd P(3, n);
    for (int k = 0; k < n; ++k) {
      uv.col(k) << c(rng), c(rng);
      z(k) = d(rng);
      P.col(k) = ibvs_test::point(uv(0, k), uv(1, k), z(k));
    }
    // Keep the central-difference truncation error (~h^2 / size^3) small.
    if (area_scale(uv) < 0.05 || (uv.col(1) - uv.col(0)).norm() < 0.05) continue;
    const double h = 1e-6;
    Eigen::Matrix<double, 1, 6> Ja, Js;
    for (int k = 0; k < 6; ++k) {
      Twist xi = Twist::Zero();
      xi(k) = h;
      Points a(2, n), b(2, n);
      for (int q = 0; q < n; ++q) {
        a.col(q) = moved_uv(P.col(q), xi);
        b.col(q) = moved_uv(P.col(q), -xi);
      }
      Ja(k) = wrap_angle(segment_angle(a, 0, 1) - segment_angle(b, 0, 1)) / (2 * h);
      Js(k) = (area_scale(a) - area_scale(b)) / (2 * h);
    }
    const auto Jta = segment_angle_jacobian(uv, z, 0, 1);
    const auto Jsa = area_scale_jacobian(uv, z);
    ibvs_test::report((Jta - Ja).cwiseAbs().maxCoeff() <= 1e-6 * std::max(1.0, Jta.cwiseAbs().maxCoeff()),
                      "segment angle FD", __FILE__, __LINE__);
    ibvs_test::report((Jsa - Js).cwiseAbs().maxCoeff() <= 1e-6 * std::max(1.0, Jsa.cwiseAbs().maxCoeff()),
                      "area scale FD", __FILE__, __LINE__);
  }
}

struct Run : ibvs_test::Run {
  double max_lateral = 0.0;  // largest |(Tx, Ty)| + |(wx, wy)|
};

Run converge(const Twist& start, double lambda) {
  PartitionedOptions o;
  o.gain = 1.0;
  o.damping = lambda;
  PartitionedServo servo(4, o);
  Run run;
  static_cast<ibvs_test::Run&>(run) =
      ibvs_test::converge(servo, ibvs_test::square(0.25, 3.0), start, [&](const ServoOutput& out) {
        run.max_lateral = std::max(run.max_lateral, out.velocity.head<2>().norm() + out.velocity.segment<2>(3).norm());
      });
  return run;
}

void closed_loop() {
  Twist rot, xshift, general, easy;
  rot << 0, 0, 0, 0, 0, pi - 1e-6;
  xshift << 0.2, 0, 0, 0, 0, 0;
  general << 0.1, -0.08, -0.3, 0.1, -0.08, 1.2;
  easy << 0.03, -0.02, -0.2, 0.02, -0.02, 0.3;
  for (double lambda : {0.0, 0.001}) {
    const Run r = converge(rot, lambda);
    ibvs_test::report(r.frames > 0 && r.retreat < 1e-9 && r.max_lateral < 1e-9, "pi rotation: pure wz", __FILE__,
                      __LINE__, std::to_string(r.frames) + " " + std::to_string(r.retreat));
    for (const Twist& s : {xshift, general, easy}) {
      const Run q = converge(s, lambda);
      ibvs_test::report(q.frames > 0, "partitioned converges", __FILE__, __LINE__, std::to_string(q.frames));
    }
  }
}

void first_step_structure() {
  // wz and Tz are exactly the decoupled laws; the four others solve the moved columns.
  PartitionedServo servo(4, {0.8});
  ServoOutput out(servo.layout());
  Points uv(2, 4), uvd(2, 4);
  uv << 0.1, -0.12, -0.1, 0.11, 0.09, 0.1, -0.1, -0.13;
  uvd << 0.2, -0.2, -0.2, 0.2, 0.2, 0.2, -0.2, -0.2;
  const Eigen::Vector4d z(1.0, 1.1, 1.2, 0.9);
  CHECK(servo.update(uv, z, uvd, z, out) == Status::ok);
  CHECK_NEAR(out.velocity(5), 0.8 * wrap_angle(segment_angle(uv, 0, 1) - segment_angle(uvd, 0, 1)), 1e-15);
  CHECK_NEAR(out.velocity(2), 0.8 * std::log(area_scale(uvd) / area_scale(uv)), 1e-15);
  const MatrixX6 J = jacobian(Layout::cartesian(4), uv, z);
  Eigen::Matrix<double, 8, 4> Jxy;
  Jxy << J.col(0), J.col(1), J.col(3), J.col(4);
  const Eigen::VectorXd b = -(0.8 * (features(Layout::cartesian(4), uv) - features(Layout::cartesian(4), uvd)) +
                              J.col(2) * out.velocity(2) + J.col(5) * out.velocity(5));
  const Eigen::Vector4d x = Jxy.completeOrthogonalDecomposition().solve(b);
  CHECK((Eigen::Vector4d(out.velocity(0), out.velocity(1), out.velocity(3), out.velocity(4)) - x).norm() < 1e-10);
}

void bad_input() {
  CHECK_THROWS(PartitionedServo(2));
  CHECK_THROWS(PartitionedServo(4, {-1.0}));
  CHECK_THROWS(PartitionedServo(4, {1.0, -0.1}));
  CHECK_THROWS(PartitionedServo(4, {1.0, 0.0, 1, 1}));
  CHECK_THROWS(PartitionedServo(4, {1.0, 0.0, 0, 4}));
  PartitionedServo servo(4, {});
  ServoOutput out(servo.layout());
  Points uv(2, 4), uvd(2, 4);
  uv << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  uvd = 1.2 * uv;
  Eigen::Vector4d z = Eigen::Vector4d::Ones();
  CHECK(servo.update(uv, z, uvd, z, out) == Status::ok);
  auto expect = [&](const Points& a, const Eigen::Vector4d& depth, const Points& b, const char* what) {
    out.velocity.setOnes();
    CHECK(servo.update(a, depth, b, depth, out) == Status::invalid_input && out.velocity.isZero(0.0));
    bool named = false;
    try {
      servo.validate(a, depth, b);
    } catch (const std::invalid_argument& e) {
      named = std::string(e.what()).find(what) != std::string::npos;
    }
    ibvs_test::report(named, "validate names the argument", __FILE__, __LINE__, what);
  };
  Points bad = uv;
  bad(0, 2) = std::nan("");
  expect(bad, z, uvd, "uv[2]");
  Eigen::Vector4d zb = z;
  zb(1) = -1.0;
  expect(uv, zb, uvd, "depth[1]");
  bad = uvd;
  bad.col(1) = bad.col(0);
  expect(uv, z, bad, "uv_desired");
  bad = uv;
  bad.row(1).setZero();  // collinear: no area
  expect(bad, z, uvd, "uv");
}

// Coincident points i and j have no segment: segment_angle and its Jacobian both give NaN (the
// bindings refuse both with the same ValueError); any other pair, however close, a finite angle.
void coincident_segment() {
  Points uv(2, 3);
  uv << 0.1, 0.1, -0.2, -0.05, -0.05, 0.3;
  const Eigen::Vector3d z(1.0, 1.5, 2.0);
  CHECK(std::isnan(segment_angle(uv, 0, 1)) && std::isnan(segment_angle(uv, 1, 0)));
  CHECK(segment_angle_jacobian(uv, z, 0, 1).array().isNaN().all());
  CHECK(std::isfinite(segment_angle(uv, 0, 2)) && segment_angle_jacobian(uv, z, 0, 2).allFinite());
  uv(0, 1) = std::nextafter(0.1, 1.0);  // one ulp apart: a segment along +u
  CHECK(segment_angle(uv, 0, 1) == 0.0 && segment_angle_jacobian(uv, z, 0, 1).allFinite());
  CHECK_NEAR(segment_angle(uv, 1, 0), std::acos(-1.0), 1e-15);
}

}  // namespace

void run_tests() {
  feature_jacobians_fd();
  coincident_segment();
  first_step_structure();
  closed_loop();
  bad_input();
}
