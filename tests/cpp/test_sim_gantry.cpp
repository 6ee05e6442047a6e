// Afma6-like gantry: FK as published, camera Jacobian vs central differences
// of the FK, det J = cos q5, inverse, damping at the singularity, saturation.
#include "check.hpp"
#include "sim_cases.hpp"

#include <Eigen/LU>

#include <random>

using namespace ibvs;
using namespace ibvs::sim;

namespace {

// Body twist (camera frame) from the derivative of T: T^-1 dT = xi^.
Twist vee(const Pose& M) { return (Twist() << M(0, 3), M(1, 3), M(2, 3), M(2, 1), M(0, 2), M(1, 0)).finished(); }

Joints random_q(const Gantry& g, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Joints q;
  for (int i = 0; i < 6; ++i) q(i) = g.q_min(i) + u(rng) * (g.q_max(i) - g.q_min(i));
  return q;
}

void fk_matches_published_model() {
  const Gantry g = Gantry::afma6();
  std::mt19937 rng(ibvs_test::seed);
  for (int n = 0; n < 50; ++n) {
    const Joints q = random_q(g, rng);
    const Pose T = g.end_effector(q);
    const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
    CHECK(R.transpose().lazyProduct(R).isIdentity(1e-12));
    CHECK_NEAR(R.determinant(), 1.0, 1e-12);
    // Published entries, written out independently.
    const double c1 = std::cos(q(3)), s1 = std::sin(q(3)), c2 = std::cos(q(4)), s2 = std::sin(q(4));
    const double q6 = q(5) - 0.009091 * q(4), c3 = std::cos(q6), s3 = std::sin(q6);
    CHECK_NEAR(R(0, 0), s1 * s2 * c3 + c1 * s3, 1e-14);
    CHECK_NEAR(R(1, 1), c1 * s2 * s3 + s1 * c3, 1e-14);
    CHECK_NEAR(R(2, 1), -c2 * s3, 1e-14);
    CHECK_NEAR(R(0, 2), -s1 * c2, 1e-14);
    CHECK_NEAR(T(0, 3), q(0) - 0.06924 * c1, 1e-14);
    CHECK_NEAR(T(1, 3), q(1) - 0.06924 * s1, 1e-14);
    CHECK_NEAR(T(2, 3), q(2), 1e-14);
  }
  // Camera mount: rxyz (33.54, 89.34, 57.83) deg = Rx Ry Rz, t = (0.0373, 0.0024, 0.2286).
  const double d = pi / 180;
  const Eigen::Matrix3d Rm = Eigen::AngleAxisd(33.54 * d, Eigen::Vector3d::UnitX()).toRotationMatrix() *
                             Eigen::AngleAxisd(89.34 * d, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                             Eigen::AngleAxisd(57.83 * d, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  CHECK((g.mount.topLeftCorner<3, 3>().isApprox(Rm, 1e-14)));
  CHECK_NEAR(g.mount(2, 3), 0.2286, 0);
  CHECK_NEAR(g.q_min(4), -0.3001, 0);
  CHECK_NEAR(g.q_max(3), 2.7301, 0);
}

void jacobian_matches_finite_differences() {
  const Gantry g = Gantry::afma6();
  std::mt19937 rng(ibvs_test::seed + 1);
  const double h = 1e-6;
  double worst = 0;
  for (int n = 0; n < ibvs_test::cases; ++n) {
    Joints q = random_q(g, rng);
    if (n == 0) q.setZero();
    const Pose Ti = se3_inverse(g.camera(q));
    const Matrix6 J = g.jacobian(q);
    for (int j = 0; j < 6; ++j) {
      Joints dq = Joints::Zero();
      dq(j) = h;
      const Twist fd = vee(Ti * (g.camera(q + dq) - g.camera(q - dq)) / (2 * h));
      worst = std::max(worst, (fd - J.col(j)).norm());
    }
    CHECK_NEAR(std::abs(J.determinant()), g.manipulability(q), 1e-12);
  }
  ibvs_test::report(worst < 1e-8, "camera Jacobian = central differences of FK", __FILE__, __LINE__,
                    std::to_string(worst));
}

void inverse_damping_and_saturation() {
  const Gantry g = Gantry::afma6();
  const Joints q = sim_cases::gantry_start();
  const Twist v = (Twist() << 0.05, -0.02, 0.1, 0.2, -0.1, 0.3).finished();
  CHECK((g.jacobian(q) * g.joint_velocity(q, v) - v).norm() < 1e-12);
  // At the wrist singularity the damped solution stays finite and bounded.
  Joints qs = q;
  qs(4) = pi / 2;
  CHECK(g.manipulability(qs) < 1e-15);
  const Joints qd = g.joint_velocity(qs, v);
  CHECK(qd.allFinite());
  CHECK(qd.norm() < 100.0);
  // Nakamura-Hanafusa damping on w = |det J| = |cos q5| (robot_mapping.hpp eq. 3):
  // none at the start pose, lambda^2 = (1 - (w / 0.1)^2) 0.01 just inside the region.
  JointMapping map(6, g.mount, g.mapping_options());
  JointMappingInput in(6);
  JointMappingOutput mo(6);
  Pose T;
  in.twist = v;
  CHECK(g.kinematics(q, T, in.jacobian));
  in.base_rotation = T.topLeftCorner<3, 3>();
  map.update(in, mo);
  CHECK(mo.damping == 0.0 && (mo.camera_jacobian * mo.qdot - v).norm() < 1e-12);
  CHECK_NEAR(mo.manipulability, g.manipulability(q), 1e-12);
  Joints near = q;
  near(4) = std::acos(0.05);
  CHECK(g.kinematics(near, T, in.jacobian));
  in.base_rotation = T.topLeftCorner<3, 3>();
  map.update(in, mo);
  CHECK_NEAR(mo.damping * mo.damping, (1 - 0.25) * 0.01, 1e-12);
  // Speed limits: one common factor, every joint within its limit.
  in.twist = 20.0 * v;
  map.update(in, mo);
  CHECK(mo.saturated);
  for (int i = 0; i < 6; ++i) CHECK(std::abs(mo.qdot(i)) <= g.qdot_max(i) * (1 + 1e-15));
  CHECK(g.outside_limits(q) == -1);
  Joints out = q;
  out(2) = 0.47;
  CHECK(g.outside_limits(out) == 2);
  Gantry bad = g;
  bad.q_min(1) = 1.0;
  CHECK_THROWS(bad.validate());
}

}  // namespace

void run_tests() {
  fk_matches_published_model();
  jacobian_matches_finite_differences();
  inverse_damping_and_saturation();
}
