// SecondaryTask (secondary_task.hpp): the projected secondary motions leave the
// primary task alone (feature velocity for the classical projector, error-norm
// rate for the large one, to 1e-9), the projector against an explicit
// J1 = L Jc and its pseudo-inverse (eqs. 1-3 written out as ViSP does), the
// joint-limit avoidance against ViSP's loop written out with that projector,
// the caps, and bad input.
#include "check.hpp"
#include "random_arm.hpp"

#include "ibvs/robot_mapping.hpp"
#include "ibvs/secondary_task.hpp"

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

using namespace ibvs;
using ibvs_test::RandomArm;
using Matrix6 = Eigen::Matrix<double, 6, 6>;

namespace {

struct Frame {  // one random primary task on a random arm
  int n;
  Eigen::MatrixXd L;  // M x 6
  Eigen::VectorXd e;
  RobotJacobian Jc;
  JointVector qdot1, q;
};

Frame random_frame(std::mt19937& rng, int n, int M, int rank_L, double error_scale) {
  std::normal_distribution<double> g(0.0, 1.0);
  const RandomArm arm(n, rng);
  Frame f{n, Eigen::MatrixXd(M, 6), Eigen::VectorXd(M), RobotJacobian(), JointVector(), arm.random_q(rng)};
  Eigen::MatrixXd A(M, rank_L), B(rank_L, 6);
  for (int i = 0; i < M; ++i)
    for (int j = 0; j < rank_L; ++j) A(i, j) = g(rng);
  for (int i = 0; i < rank_L; ++i)
    for (int j = 0; j < 6; ++j) B(i, j) = g(rng);
  f.L = A * B;
  for (int i = 0; i < M; ++i) f.e(i) = error_scale * g(rng);
  JointMapping map(n, RandomArm::random_pose(rng));
  JointMappingInput in(n);
  JointMappingOutput out(n);
  in.jacobian = arm.body_jacobian_fd(f.q, Pose::Identity());
  in.twist = -(f.L.completeOrthogonalDecomposition().pseudoInverse() * f.e);  // the servo's v = -L^+ e
  map.update(in, out);
  f.Jc = out.camera_jacobian;
  f.qdot1 = out.qdot;
  return f;
}

SecondaryTaskInput input_of(const Frame& f, std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  SecondaryTaskInput in(f.n);
  in.task_gram = f.L.transpose() * f.L;
  in.task_gradient = f.L.transpose() * f.e;
  in.error_norm = f.e.norm();
  in.camera_jacobian = f.Jc;
  in.qdot = f.qdot1;
  in.q = f.q;
  for (int i = 0; i < f.n; ++i) in.joints(i) = g(rng);
  for (int i = 0; i < 6; ++i) in.twist(i) = g(rng);
  return in;
}

// Eqs. (1)-(3) written out with dynamic matrices, as ViSP's computeProjectionOperators does.
Eigen::MatrixXd explicit_projector(const Frame& f, Projector p, double e0, double e1) {
  const Eigen::MatrixXd J1 = f.L * Eigen::MatrixXd(f.Jc);
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(f.n, f.n);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(J1, Eigen::ComputeThinU | Eigen::ComputeThinV);
  svd.setThreshold(1e-9);
  const Eigen::MatrixXd Pe = I - svd.solve(J1);  // I - J1^+ J1
  if (p == Projector::classical) return Pe;
  const Eigen::VectorXd h = J1.transpose() * f.e;
  const double ne = f.e.norm();
  const double s = ne > e1 ? 1.0 : ne < e0 ? 0.0 : 1.0 / (1.0 + std::exp(-12.0 * (ne - e0) / (e1 - e0) + 6.0));
  return s * (I - h * h.transpose() / h.squaredNorm()) + (1.0 - s) * Pe;
}

void primary_task_unchanged() {
  std::mt19937 rng(ibvs_test::seed);
  double worst_c = 0.0, worst_l = 0.0, worst_p = 0.0;
  int moved = 0, total = 0;
  for (int c = 0; c < ibvs_test::cases / 5; ++c) {
    const int n = 6 + c % 4, M = 2 + 2 * (c % 5), rank_L = std::min(M, 6) - (c % 3 == 0 ? 2 : 0);
    const double scale = (c % 4 == 0) ? 0.02 : (c % 4 == 1 ? 0.3 : 1.0);  // s = 0, in between, 1
    const Frame f = random_frame(rng, n, M, std::max(rank_L, 1), scale);
    SecondaryTaskInput in = input_of(f, rng);
    const Eigen::MatrixXd LJ = f.L * Eigen::MatrixXd(f.Jc);
    for (Projector p : {Projector::classical, Projector::large}) {
      SecondaryTaskOptions o;
      o.projector = p;
      SecondaryTask task(n, o);
      SecondaryTaskOutput out(n);
      task.validate(in);
      if (task.update(in, out) != Status::ok) continue;
      const Eigen::VectorXd d = Eigen::VectorXd(out.qdot - f.qdot1);
      const double ref = std::max(1.0, d.norm()) * std::max(1.0, LJ.norm());
      if (p == Projector::classical)
        worst_c = std::max(worst_c, (LJ * d).cwiseAbs().maxCoeff() / ref);  // the feature velocity
      else
        worst_l = std::max(worst_l, std::abs(f.e.dot(LJ * d)) / (ref * std::max(1.0, f.e.norm())));  // d|e|^2/dt
      const Eigen::MatrixXd P = explicit_projector(f, p, o.switch_low, o.switch_high);
      const Eigen::VectorXd z = Eigen::VectorXd(in.joints) +
                                Eigen::MatrixXd(f.Jc).completeOrthogonalDecomposition().pseudoInverse() * in.twist;
      worst_p = std::max(worst_p, (P * z - Eigen::VectorXd(out.secondary)).cwiseAbs().maxCoeff() / std::max(1.0, z.norm()));
      ++total;
      if (out.secondary.norm() > 1e-6) ++moved;
    }
  }
  ibvs_test::report(worst_c < 1e-9, "classical: L Jc qdot unchanged by the secondary motion", __FILE__, __LINE__,
                    std::to_string(worst_c));
  ibvs_test::report(worst_l < 1e-9, "large: e^T L Jc qdot unchanged by the secondary motion", __FILE__, __LINE__,
                    std::to_string(worst_l));
  ibvs_test::report(worst_p < 1e-7, "P (z + Jc^+ v2) = the explicit projector of J1 = L Jc (ViSP's)", __FILE__,
                    __LINE__, std::to_string(worst_p));
  ibvs_test::report(moved > total / 2, "the secondary motion moves the joints in most cases", __FILE__, __LINE__,
                    std::to_string(moved) + "/" + std::to_string(total));
}

// The classical projector is idempotent; the blended one of eq. (3) is not in general, so only s in {0, 1}.
void classical_projector_is_idempotent() {
  std::mt19937 rng(ibvs_test::seed + 1);
  double worst = 0.0;
  for (int c = 0; c < ibvs_test::cases / 5; ++c) {
    const Frame f = random_frame(rng, 7, 4, 4, 1.0);
    SecondaryTaskInput in = input_of(f, rng);
    for (Projector p : {Projector::classical, Projector::large}) {
      SecondaryTaskOptions o;
      o.projector = p;
      SecondaryTask task(7, o);
      SecondaryTaskOutput out(7);
      in.error_norm = 5.0;  // s = 1 for the large projector
      task.update(in, out);
      JointVector pz, ppz;
      task.project(in.joints, pz);
      task.project(pz, ppz);
      worst = std::max(worst, (ppz - pz).cwiseAbs().maxCoeff() / std::max(1.0, pz.norm()));
    }
  }
  ibvs_test::report(worst < 1e-12, "P P z = P z (classical, and large at s = 1)", __FILE__, __LINE__,
                    std::to_string(worst));
}

// Joint-limit avoidance: ViSP's vpServo::secondaryTaskJointLimitAvoidance written out with the
// explicit projector, and the joint in its zone pushed away from the limit.
void joint_limit_avoidance_matches_visp() {
  std::mt19937 rng(ibvs_test::seed + 2);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0.0;
  int active = 0, away = 0, room = 0;
  for (int c = 0; c < ibvs_test::cases / 5; ++c) {
    const int n = 6 + c % 3;
    const Frame f = random_frame(rng, n, 8, 6, c % 2 ? 1.0 : 0.05);
    SecondaryTaskInput in = input_of(f, rng);
    in.joints.setZero();
    in.twist.setZero();
    SecondaryTaskOptions o;
    o.projector = c % 2 ? Projector::large : Projector::classical;
    o.q_min = JointVector::Constant(n, -2.0);
    o.q_max = JointVector::Constant(n, 2.0);
    // place some joints in the zones: beyond q_l1, between the thresholds, safe
    for (int i = 0; i < n; ++i) in.q(i) = -2.0 + 4.0 * u(rng);
    in.q(0) = 2.0 - 0.01;   // beyond q_l1_max (q_l0_max = 1.6, q_l1_max = 1.72)
    in.q(1) = -1.65;        // between q_l0_min = -1.6 and q_l1_min = -1.72
    SecondaryTask task(n, o);
    SecondaryTaskOutput out(n);
    task.update(in, out);
    // ViSP's loop with the explicit projector.
    const Eigen::MatrixXd P = explicit_projector(f, o.projector, o.switch_low, o.switch_high);
    Eigen::VectorXd q2 = Eigen::VectorXd::Zero(n);
    for (int i = 0; i < n; ++i) {
      const double range = o.q_max(i) - o.q_min(i);
      const double l0min = o.q_min(i) + o.rho * range, l0max = o.q_max(i) - o.rho * range;
      const double l1min = l0min - o.rho * o.rho1 * range, l1max = l0max + o.rho * o.rho1 * range;
      if (in.q(i) > l0min && in.q(i) < l0max) continue;
      Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
      g(i) = in.q(i) < l0min ? -1.0 : 1.0;
      const Eigen::VectorXd Pg = P * g;
      double b = std::abs(Pg(i)) >= 1e-9 ? std::abs(in.qdot(i)) / std::abs(Pg(i)) : 1.0;  // (ViSP: 10 eps)
      if (in.q(i) < l1min || in.q(i) > l1max) {
        q2 -= (1 + o.lambda_tune) * b * Pg;
      } else {
        double lam = 0.0;
        if (in.q(i) >= l0max && in.q(i) <= l1max) lam = 1 / (1 + std::exp(-12 * ((in.q(i) - l0max) / (l1max - l0max)) + 6));
        else if (in.q(i) >= l1min && in.q(i) <= l0min) lam = 1 / (1 + std::exp(-12 * ((in.q(i) - l0min) / (l1min - l0min)) + 6));
        q2 -= lam * (1 + o.lambda_tune) * std::min(b, 1.0) * Pg;
      }
    }
    worst = std::max(worst, (q2 - Eigen::VectorXd(out.avoidance)).cwiseAbs().maxCoeff() / std::max(1.0, q2.norm()));
    active += out.active;
    // Joint 0 alone beyond q_l1, with room in the null space (P_00 > 0): it moves away from its upper limit.
    if (P(0, 0) > 1e-6 && std::abs(in.qdot(0)) > 1e-9) {
      ++room;
      in.q.setZero();  // mid-range
      in.q(0) = 2.0 - 0.01;
      task.update(in, out);
      if (out.active == 1 && out.qdot(0) < 0.0) ++away;
    }
  }
  ibvs_test::report(worst < 1e-7, "joint-limit avoidance = ViSP's loop with the explicit projector", __FILE__,
                    __LINE__, std::to_string(worst));
  ibvs_test::report(active >= 2 * (ibvs_test::cases / 5), "at least two joints active per case", __FILE__, __LINE__);
  ibvs_test::report(room > ibvs_test::cases / 10 && away == room, "a joint beyond q_l1 moves away from its limit",
                    __FILE__, __LINE__, std::to_string(away) + "/" + std::to_string(room));
}

void caps() {
  std::mt19937 rng(ibvs_test::seed + 3);
  bool speed_ok = true, acc_ok = true, direction_ok = true;
  for (int c = 0; c < ibvs_test::cases / 5; ++c) {
    const int n = 7;
    const Frame f = random_frame(rng, n, 8, 6, 1.0);
    SecondaryTaskInput in = input_of(f, rng);
    std::normal_distribution<double> g(0.0, 0.3);
    for (int i = 0; i < n; ++i) in.qdot_previous(i) = g(rng);
    SecondaryTaskOptions o;
    o.max_joint_speed = JointVector::Constant(n, 0.5);
    o.max_joint_speed(3) = std::numeric_limits<double>::infinity();
    o.max_joint_acceleration = JointVector::Constant(n, 2.0);
    o.period = 0.01;
    SecondaryTask task(n, o);
    SecondaryTaskOutput out(n);
    task.update(in, out);
    SecondaryTaskOptions free = o;
    free.max_joint_speed.resize(0);
    free.max_joint_acceleration.resize(0);
    SecondaryTask uncapped(n, free);
    SecondaryTaskOutput raw(n);
    uncapped.update(in, raw);
    // the command is prev + a (s raw - prev), a, s in (0, 1]
    const JointVector target = out.saturation_scale * raw.qdot;
    const JointVector d1 = out.qdot - in.qdot_previous, d2 = target - in.qdot_previous;
    direction_ok = direction_ok && std::abs(d1.dot(d2) - d1.norm() * d2.norm()) <= 1e-9 * (1 + d1.norm() * d2.norm());
    for (int i = 0; i < n; ++i) {
      // speed caps hold when the previous command held them (a convex combination)
      if (in.qdot_previous.cwiseAbs().maxCoeff() <= 0.5) speed_ok = speed_ok && std::abs(out.qdot(i)) <= o.max_joint_speed(i) + 1e-12;
      acc_ok = acc_ok && std::abs(out.qdot(i) - in.qdot_previous(i)) <= 2.0 * 0.01 + 1e-12;
    }
  }
  CHECK(speed_ok);
  CHECK(acc_ok);
  CHECK(direction_ok);
}

void bad_input() {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  SecondaryTaskOptions o;
  CHECK_THROWS(SecondaryTask(0, o));
  CHECK_THROWS(SecondaryTask(max_joints + 1, o));
  o.rho = 0.6;
  CHECK_THROWS(SecondaryTask(6, o));
  o = {};
  o.q_min = JointVector::Zero(6);
  CHECK_THROWS(SecondaryTask(6, o));  // q_max missing
  o.q_max = JointVector::Zero(6);
  CHECK_THROWS(SecondaryTask(6, o));  // q_min < q_max fails
  o = {};
  o.max_joint_acceleration = JointVector::Ones(6);
  CHECK_THROWS(SecondaryTask(6, o));  // no period
  o.period = 0.01;
  o.switch_low = 1.0;
  CHECK_THROWS(SecondaryTask(6, o));
  o.switch_low = 0.1;
  SecondaryTask task(6, o);
  SecondaryTaskInput in(6);
  SecondaryTaskOutput out(6);
  task.validate(in);
  CHECK(task.update(in, out) == Status::ok);
  const auto refused = [&](SecondaryTaskInput bad) {
    bool threw = false;
    try {
      task.validate(bad);
    } catch (const std::invalid_argument&) {
      threw = true;
    }
    return threw && task.update(bad, out) == Status::invalid_input && out.qdot.isZero(0.0);
  };
  SecondaryTaskInput b = in;
  b.q(2) = nan;
  CHECK(refused(b));
  b = in;
  b.task_gram(0, 1) = 1.0;  // not symmetric
  CHECK(refused(b));
  b = in;
  b.error_norm = -1.0;
  CHECK(refused(b));
  b = in;
  b.camera_jacobian.resize(6, 5);
  CHECK(refused(b));
  b = in;
  b.twist(4) = std::numeric_limits<double>::infinity();
  CHECK(refused(b));
  b = in;
  b.joints.resize(3);
  CHECK(refused(b));
  b = in;  // finite but overflowing
  b.qdot.setConstant(1e308);
  b.joints.setConstant(1e308);
  CHECK(task.update(b, out) == Status::invalid_input && out.qdot.isZero(0.0));
}

}  // namespace

void run_tests() {
  primary_task_unchanged();
  classical_projector_is_idempotent();
  joint_limit_avoidance_matches_visp();
  caps();
  bad_input();
}
