// JointMapping (robot_mapping.hpp): the camera Jacobian of eq. (1) against
// central differences of a serial arm's camera pose, in both Jacobian frames;
// joint velocities that reproduce the twist (full rank), least squares (n < 6),
// the damped closed form, speed limits, the null-space task, bad input.
#include "check.hpp"
#include "random_arm.hpp"

#include "ibvs/pinv.hpp"
#include "ibvs/robot_mapping.hpp"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <cmath>

#include <random>

using namespace ibvs;
using ibvs_test::RandomArm;

namespace {

Twist random_twist(std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Twist v;
  for (int i = 0; i < 6; ++i) v(i) = g(rng);
  return v;
}

// Eq. (1) against differences of the camera pose b <- c = (b <- e)(q) eMc, for
// the end-effector Jacobian given in e and in b.
void camera_jacobian_matches_finite_differences() {
  std::mt19937 rng(ibvs_test::seed);
  double worst = 0.0;
  for (int c = 0; c < ibvs_test::cases / 5; ++c) {
    const int n = 1 + c % 9;
    const RandomArm arm(n, rng);
    const JointVector q = arm.random_q(rng);
    const Pose eMc = RandomArm::random_pose(rng);
    const RobotJacobian Jc_fd = arm.body_jacobian_fd(q, eMc);
    const RobotJacobian Je = arm.body_jacobian_fd(q, Pose::Identity());
    const Eigen::Matrix3d bRe = arm.fk(q).topLeftCorner<3, 3>();
    RobotJacobian Jb(6, n);  // base frame: (velocity of e's origin, angular velocity) in b
    Jb.topRows<3>() = bRe * Je.topRows<3>();
    Jb.bottomRows<3>() = bRe * Je.bottomRows<3>();
    RobotJacobian Jc;
    JointMapping::camera_jacobian(eMc, JacobianFrame::end_effector, Je, Eigen::Matrix3d::Identity(), Jc);
    worst = std::max(worst, (Jc - Jc_fd).cwiseAbs().maxCoeff());
    JointMapping::camera_jacobian(eMc, JacobianFrame::base, Jb, bRe, Jc);
    worst = std::max(worst, (Jc - Jc_fd).cwiseAbs().maxCoeff());
  }
  ibvs_test::report(worst < 1e-7, "camera Jacobian (eq. 1) = central differences of the camera pose", __FILE__,
                    __LINE__, std::to_string(worst));
}

void reproduces_the_twist() {
  std::mt19937 rng(ibvs_test::seed + 1);
  double worst = 0.0, worst_ls = 0.0;
  int skipped = 0;
  for (int c = 0; c < ibvs_test::cases / 5; ++c) {
    const int n = 1 + c % max_joints;
    const RandomArm arm(n, rng);
    JointMappingOptions o;
    o.frame = c % 2 ? JacobianFrame::base : JacobianFrame::end_effector;
    JointMapping map(n, RandomArm::random_pose(rng), o);
    JointMappingInput in(n);
    JointMappingOutput out(n);
    const JointVector q = arm.random_q(rng);
    in.jacobian = arm.body_jacobian_fd(q, Pose::Identity());
    if (o.frame == JacobianFrame::base) {
      in.base_rotation = arm.fk(q).topLeftCorner<3, 3>();
      in.jacobian.topRows<3>() = in.base_rotation * in.jacobian.topRows<3>().eval();
      in.jacobian.bottomRows<3>() = in.base_rotation * in.jacobian.bottomRows<3>().eval();
    }
    in.twist = random_twist(rng);
    const Status s = map.update(in, out);
    const RobotJacobian& Jc = out.camera_jacobian;
    CHECK(out.qdot.allFinite());
    if (out.sigma_min < 1e-3 * out.sigma_max) {  // a random arm near a singularity: compared below
      ++skipped;
      continue;
    }
    if (n >= 6) {  // full row rank: Jc qdot = v exactly
      CHECK(s == Status::ok && out.rank == 6);
      worst = std::max(worst, (Jc * out.qdot - in.twist).norm() / in.twist.norm());
      if (n == 6) worst = std::max(worst, (out.qdot - Jc.leftCols<6>().eval().partialPivLu().solve(in.twist)).norm());
      else  // minimum norm: qdot lies in the row space of Jc
        worst = std::max(worst, (out.qdot - Jc.transpose() * (Jc * Jc.transpose()).ldlt().solve(in.twist)).norm());
    } else {  // least squares: Jc^T (Jc qdot - v) = 0
      CHECK(s == Status::ok && out.rank == n);
      worst_ls = std::max(worst_ls, (Jc.transpose() * (Jc * out.qdot - in.twist)).norm());
      CHECK_NEAR(out.manipulability, std::sqrt((Jc.transpose() * Jc).determinant()), 1e-9);
    }
  }
  ibvs_test::report(worst < 1e-9, "Jc qdot = v (n >= 6), minimum norm, = LU (n = 6)", __FILE__, __LINE__,
                    std::to_string(worst));
  CHECK(skipped <= ibvs_test::cases / 50);  // at most 2 % of the cases (none of a small run)
  ibvs_test::report(worst_ls < 1e-9, "normal equations (n < 6)", __FILE__, __LINE__, std::to_string(worst_ls));
}

void damping_and_variable_damping() {
  std::mt19937 rng(ibvs_test::seed + 2);
  const RandomArm arm(7, rng);
  const JointVector q = arm.random_q(rng);
  JointMappingOptions o;
  o.damping = 0.3;
  JointMapping map(7, RandomArm::random_pose(rng), o);
  JointMappingInput in(7);
  JointMappingOutput out(7);
  in.jacobian = arm.body_jacobian_fd(q, Pose::Identity());
  in.twist = random_twist(rng);
  map.update(in, out);
  const RobotJacobian& Jc = out.camera_jacobian;
  Eigen::Matrix<double, 7, 7> A = Jc.transpose() * Jc;
  A.diagonal().array() += 0.09;
  CHECK((out.qdot - A.ldlt().solve(Jc.transpose() * in.twist)).norm() < 1e-12);
  CHECK_NEAR(out.damping, 0.3, 0);
  // eq. (3): no damping outside the region, lambda^2 = (1 - (w/eps)^2) lambda_max^2 inside it
  CHECK_NEAR(out.manipulability, std::sqrt((Jc * Jc.transpose()).determinant()), 1e-9 * out.manipulability);
  o.singular_region = 0.5 * out.manipulability;
  JointMapping outside(7, map.eMc(), o);
  outside.update(in, out);
  CHECK(out.damping == 0.0 && (out.camera_jacobian * out.qdot - in.twist).norm() < 1e-10);
  o.singular_region = 2.0 * out.manipulability;
  JointMapping inside(7, map.eMc(), o);
  inside.update(in, out);
  CHECK_NEAR(out.damping * out.damping, 0.09 * 0.75, 1e-14);
  // A singular arm (a joint repeated: two equal columns, n = 6 but rank 5):
  // Moore-Penrose drops the lost direction and reports it; damping keeps qdot finite.
  RobotJacobian J6 = arm.body_jacobian_fd(q, Pose::Identity()).leftCols<6>();
  J6.col(5) = J6.col(4);
  for (double damping : {0.0, 0.1}) {
    JointMappingOptions p;
    p.damping = damping;
    JointMapping m6(6, Pose::Identity(), p);
    JointMappingInput i6(6);
    JointMappingOutput o6(6);
    i6.jacobian = J6;
    i6.twist = random_twist(rng);
    CHECK(m6.update(i6, o6) == Status::singular);
    CHECK(o6.rank == 5 && o6.qdot.allFinite() && o6.manipulability < 1e-12);
    CHECK(std::abs(o6.qdot(4) - o6.qdot(5)) < 1e-9);  // minimum norm splits the repeated joint's share
  }
}

void speed_limits_keep_the_direction() {
  std::mt19937 rng(ibvs_test::seed + 3);
  int saturated = 0;
  for (int c = 0; c < ibvs_test::cases / 5; ++c) {
    const int n = 6 + c % 4;
    const RandomArm arm(n, rng);
    JointMappingOptions o;
    std::uniform_real_distribution<double> u(0.05, 1.0);
    o.max_joint_speed.resize(n);
    for (int i = 0; i < n; ++i) o.max_joint_speed(i) = i == 2 ? no_limit : u(rng);
    JointMapping map(n, RandomArm::random_pose(rng), o);
    JointMappingInput in(n);
    JointMappingOutput out(n);
    in.jacobian = arm.body_jacobian_fd(arm.random_q(rng), Pose::Identity());
    in.twist = 3.0 * random_twist(rng);
    map.update(in, out);
    for (int i = 0; i < n; ++i) CHECK(std::abs(out.qdot(i)) <= o.max_joint_speed(i) * (1 + 1e-12));
    CHECK(out.saturation_scale > 0.0 && out.saturation_scale <= 1.0);
    if (out.rank == 6)  // (a random arm can be singular: four parallel prismatic joints)
      CHECK((out.camera_jacobian * out.qdot - out.saturation_scale * in.twist).norm() < 1e-9 * in.twist.norm());
    if (out.saturated) {
      ++saturated;  // one joint sits exactly at its limit
      double at = 0.0;
      for (int i = 0; i < n; ++i) at = std::max(at, std::abs(out.qdot(i)) / o.max_joint_speed(i));
      CHECK_NEAR(at, 1.0, 1e-12);
    }
  }
  CHECK(saturated > ibvs_test::cases / 10);
}

void null_space_task_leaves_the_camera_alone() {
  std::mt19937 rng(ibvs_test::seed + 4);
  double worst = 0.0;
  for (int c = 0; c < ibvs_test::cases / 5; ++c) {
    const int n = 7 + c % 6;
    const RandomArm arm(n, rng);
    JointMappingOptions o;
    o.damping = c % 2 ? 0.05 : 0.0;
    JointMapping map(n, RandomArm::random_pose(rng), o);
    JointMappingInput in(n);
    JointMappingOutput plain(n), with(n);
    in.jacobian = arm.body_jacobian_fd(arm.random_q(rng), Pose::Identity());
    in.twist = random_twist(rng);
    map.update(in, plain);
    std::normal_distribution<double> g(0.0, 1.0);
    for (int i = 0; i < n; ++i) in.secondary(i) = g(rng);
    map.update(in, with);
    const JointVector dq = with.qdot - plain.qdot;
    // the camera twist is unchanged, and dq is the projection of z: z - dq is in the row space
    worst = std::max(worst, (with.camera_jacobian * dq).norm());
    const JointVector rest = in.secondary - dq;
    const RobotJacobian& Jc = with.camera_jacobian;
    const JointVector back = Jc.transpose() * (Jc * Jc.transpose()).ldlt().solve(Jc * rest);
    worst = std::max(worst, (back - rest).norm());
    CHECK(dq.norm() > 1e-3);  // and it does something
  }
  ibvs_test::report(worst < 1e-9, "null-space task: Jc dq = 0 and dq = (I - Jc+ Jc) z", __FILE__, __LINE__,
                    std::to_string(worst));
}

void bad_input() {
  CHECK_THROWS(JointMapping(0, Pose::Identity()));
  CHECK_THROWS(JointMapping(max_joints + 1, Pose::Identity()));
  Pose bad = Pose::Identity();
  bad(0, 0) = 2.0;
  CHECK_THROWS(JointMapping(6, bad));
  JointMappingOptions o;
  o.damping = -1.0;
  CHECK_THROWS(JointMapping(6, Pose::Identity(), o));
  o.damping = 0.1;
  o.singular_region = std::nan("");
  CHECK_THROWS(JointMapping(6, Pose::Identity(), o));
  o.singular_region = 0.0;
  o.max_joint_speed = JointVector::Ones(5);
  CHECK_THROWS(JointMapping(6, Pose::Identity(), o));
  o.max_joint_speed = JointVector::Zero(6);
  CHECK_THROWS(JointMapping(6, Pose::Identity(), o));
  o.max_joint_speed = JointVector::Ones(6);
  o.frame = JacobianFrame::base;
  JointMapping map(6, Pose::Identity(), o);
  JointMappingInput in(6);
  JointMappingOutput out(6);
  in.jacobian.setIdentity();
  in.twist.setOnes();
  map.validate(in);
  CHECK(map.update(in, out) == Status::ok && out.qdot.isApprox(JointVector::Constant(6, 1.0 / 1.01)));
  in.twist(3) = std::nan("");
  CHECK_THROWS(map.validate(in));
  CHECK(map.update(in, out) == Status::invalid_input && out.qdot.isZero(0));
  in.twist.setOnes();
  in.base_rotation(0, 0) = 0.5;  // not a rotation
  CHECK_THROWS(map.validate(in));
  CHECK(map.update(in, out) == Status::invalid_input);
  in.base_rotation.setIdentity();
  in.jacobian.resize(6, 5);
  in.jacobian.setOnes();
  CHECK_THROWS(map.validate(in));
  CHECK(map.update(in, out) == Status::invalid_input);
  in.jacobian.setIdentity(6, 6);
  in.secondary.resize(3);
  CHECK_THROWS(map.validate(in));
  CHECK(map.update(in, out) == Status::invalid_input);
}

}  // namespace

// Both routes (Cholesky of Jc Jc^T for a well-conditioned Jc with n >= 6, SVD
// otherwise) against eqs. (2)-(4) written on an independent JacobiSVD of Jc:
// qdot to 1e-9 relative (plus eps-level absolute), sigma_max to 1e-12,
// sigma_min to 1e-6 relative (it comes from the eigenvalues of Jc Jc^T on the
// normal route), the manipulability to 1e-9, over random arms of 6-16 joints
// with damping, variable damping and a null-space task.
void routes_agree_with_the_svd_formula() {
  std::mt19937 rng(ibvs_test::seed + 7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst_q = 0.0, worst_smin = 0.0, worst_smax = 0.0, worst_w = 0.0;
  for (int c = 0; c < ibvs_test::cases / 2; ++c) {
    const int n = 6 + c % (max_joints - 5);
    const RandomArm arm(n, rng);
    JointMappingOptions o;
    o.damping = c % 3 == 0 ? 0.0 : 0.05 * u(rng);
    JointMappingInput in(n);
    JointMappingOutput out(n);
    in.jacobian = arm.body_jacobian_fd(arm.random_q(rng), Pose::Identity());
    in.twist = random_twist(rng);
    if (c % 2) in.secondary = JointVector::Random(n);
    const Pose eMc = RandomArm::random_pose(rng);
    RobotJacobian Jc;
    JointMapping::camera_jacobian(eMc, JacobianFrame::end_effector, in.jacobian, in.base_rotation, Jc);
    const Eigen::MatrixXd A = Jc;
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::VectorXd sv = svd.singularValues();
    const double w = sv.prod();
    if (c % 4 == 1) o.singular_region = 2.0 * w;  // inside eq. (3)'s region: damped by a fraction of o.damping
    double lambda = o.damping;
    if (o.singular_region > 0.0) lambda = o.damping * std::sqrt(1.0 - (w / o.singular_region) * (w / o.singular_region));
    const double tol = rank_tolerance(n, sv(0));
    Eigen::VectorXd ref = in.secondary;
    for (int i = 0; i < 6; ++i) {
      if (!(sv(i) > tol)) continue;
      const Eigen::VectorXd vi = svd.matrixV().col(i);
      ref += pinv_factor(sv(i), lambda, tol) * svd.matrixU().col(i).dot(in.twist) * vi - vi.dot(in.secondary) * vi;
    }
    JointMapping map(n, eMc, o);
    map.update(in, out);
    CHECK(out.rank == (sv.array() > tol).count());
    worst_q = std::max(worst_q, (out.qdot - ref).norm() / (ref.norm() + 1e-300));
    worst_smax = std::max(worst_smax, std::abs(out.sigma_max - sv(0)) / sv(0));
    worst_smin = std::max(worst_smin, std::abs(out.sigma_min - sv(5)) / sv(5));
    worst_w = std::max(worst_w, std::abs(out.manipulability - w) / w);
  }
  ibvs_test::report(worst_q < 1e-9, "qdot = the SVD formula of eqs. (2)-(4), both routes", __FILE__, __LINE__,
                    std::to_string(worst_q));
  ibvs_test::report(worst_smax < 1e-12 && worst_smin < 1e-6 && worst_w < 1e-9,
                    "sigma_max, sigma_min, manipulability of both routes", __FILE__, __LINE__,
                    std::to_string(worst_smax) + " " + std::to_string(worst_smin) + " " + std::to_string(worst_w));
}

// Eq. (5), eye-to-hand: Jc = -cVe(q) eJe against central differences of the camera's pose in the
// end effector's frame, eMc(q) = bMe(q)^-1 bMc (the target rides on e, the camera is fixed); both
// Jacobian frames; and update() solving it: Jc qdot = v.
void eye_to_hand_matches_finite_differences() {
  std::mt19937 rng(ibvs_test::seed + 7);
  double worst = 0.0, worst_v = 0.0;
  const double h = 1e-6;
  for (int c = 0; c < ibvs_test::cases / 5; ++c) {
    const int n = 6 + c % 4;
    const RandomArm arm(n, rng);
    const JointVector q = arm.random_q(rng);
    const Pose bMc = RandomArm::random_pose(rng);
    const auto rel = [&](const JointVector& x) { return Pose(se3_inverse(arm.fk(x)) * bMc); };
    RobotJacobian fd(6, n);
    const Pose Ti = se3_inverse(rel(q));
    for (int j = 0; j < n; ++j) {
      JointVector dq = JointVector::Zero(n);
      dq(j) = h;
      const Pose D = Ti * (rel(q + dq) - rel(q - dq)) / (2 * h);
      fd.col(j) << D(0, 3), D(1, 3), D(2, 3), D(2, 1), D(0, 2), D(1, 0);
    }
    const Pose bMe = arm.fk(q);
    const RobotJacobian Je = arm.body_jacobian_fd(q, Pose::Identity());
    RobotJacobian Jb(6, n);
    Jb.topRows<3>() = bMe.topLeftCorner<3, 3>() * Je.topRows<3>();
    Jb.bottomRows<3>() = bMe.topLeftCorner<3, 3>() * Je.bottomRows<3>();
    RobotJacobian Jc;
    JointMapping::camera_jacobian(bMc, Mounting::eye_to_hand, JacobianFrame::end_effector, Je, bMe, Jc);
    worst = std::max(worst, (Jc - fd).cwiseAbs().maxCoeff());
    JointMapping::camera_jacobian(bMc, Mounting::eye_to_hand, JacobianFrame::base, Jb, bMe, Jc);
    worst = std::max(worst, (Jc - fd).cwiseAbs().maxCoeff());
    JointMappingOptions o;
    o.mounting = Mounting::eye_to_hand;
    JointMapping map(n, bMc, o);
    JointMappingInput in(n);
    JointMappingOutput out(n);
    in.twist = random_twist(rng);
    in.jacobian = Je;
    in.base_pose = bMe;
    map.validate(in);
    if (map.update(in, out) == Status::ok)
      worst_v = std::max(worst_v, (out.camera_jacobian * out.qdot - in.twist).cwiseAbs().maxCoeff());
  }
  ibvs_test::report(worst < 1e-7, "eye-to-hand camera Jacobian (eq. 5) = central differences of eMc(q)", __FILE__,
                    __LINE__, std::to_string(worst));
  ibvs_test::report(worst_v < 1e-8, "eye-to-hand update: Jc qdot = twist", __FILE__, __LINE__, std::to_string(worst_v));
  // A bMe that is not rigid is refused by both channels.
  JointMappingOptions o;
  o.mounting = Mounting::eye_to_hand;
  JointMapping map(6, Pose::Identity(), o);
  JointMappingInput in(6);
  JointMappingOutput out(6);
  in.base_pose(0, 0) = 2.0;
  CHECK_THROWS(map.validate(in));
  CHECK(map.update(in, out) == Status::invalid_input && out.qdot.isZero(0.0));
  in.base_pose = Pose::Identity();
  in.base_pose(1, 3) = std::numeric_limits<double>::quiet_NaN();
  CHECK(map.update(in, out) == Status::invalid_input);
}

void run_tests() {
  eye_to_hand_matches_finite_differences();
  routes_agree_with_the_svd_formula();
  camera_jacobian_matches_finite_differences();
  reproduces_the_twist();
  damping_and_variable_damping();
  speed_limits_keep_the_direction();
  null_space_task_leaves_the_camera_alone();
  bad_input();
}
