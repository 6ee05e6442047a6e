// Secondary tasks of a redundant visual servo: joint motions added to the
// primary joint velocities qdot1 (JointMapping's, for the servo's twist) in a
// null space of the primary task, joint-limit avoidance, and the joints' speed
// and acceleration caps.
//
// The primary task is the servo's: error e (M), interaction matrix L (M x 6),
// camera Jacobian Jc (6 x n, robot_mapping.hpp eq. 1 or 5), so the task
// Jacobian in joint space is J1 = L Jc (ViSP's J1 = L cVe eJe). It enters
// through two fixed-size quantities, G = L^T L (6 x 6) and g = L^T e (6),
// and |e|.
//
// Projectors (n x n), applied to every secondary motion z:
//   classical  P_e = I - J1^+ J1 (Siciliano & Slotine 1991; ViSP's I_WpW).
//              J1^+ J1 is the projector onto the row space of J1, which is
//              that of B = Q Jc with Q = L^+ L = sum over G's eigenvectors u_j
//              of non-zero eigenvalue of u_j u_j^T (the row space of L), so
//                P_e z = z - sum_i v_i (v_i . z),  v_i right singular vectors of B  (1)
//              with singular value above rank_tolerance (pinv.hpp). J1 P_e = 0:
//              the feature velocity L Jc qdot is that of qdot1, exactly. For a
//              rank-6 L and a full-rank Jc this is eq. (4) of robot_mapping.hpp.
//   large      P_|e| = I - h h^T / (h^T h),  h = J1^T e = Jc^T g               (2)
//              (Marey & Chaumette, ICRA 2010, "A new large projection operator
//              for the redundancy framework", eq. 24): the null space of the
//              error's norm only (n - 1 dimensions), so that d|e|^2/dt =
//              2 e^T J1 qdot is that of qdot1, exactly. Near convergence
//              (h -> 0) it switches smoothly to P_e as ViSP's
//              vpServo::computeProjectionOperators does:
//                P = s P_|e| + (1 - s) P_e,
//                s = 1 above e1, 0 below e0, 1 / (1 + exp(-12 (|e| - e0) / (e1 - e0) + 6)) between  (3)
//              (e0 = 0.1, e1 = 0.7 by default, ViSP's); s = 0 when h = 0.
//              Both terms annihilate h^T (g lies in the row space of L), so (3)
//              keeps d|e|^2/dt at every s.
//
// Secondary motions (all projected with the chosen P):
//   joint space  z (n joint velocities);
//   task space   a camera twist v2 (camera frame), as the joint motion
//                Jc^+ v2 (minimum-norm pseudo-inverse on the SVD of Jc), so
//                that it is executed as far as the primary task leaves room
//                (ViSP's vpServo::secondaryTask(de2dt) in the space of the
//                controlled velocities);
//   joint-limit avoidance (Marey & Chaumette, IROS 2010, "New strategies for
//                avoiding robot joint limits: application to visual servoing
//                using a large projection operator"; ViSP's
//                vpServo::secondaryTaskJointLimitAvoidance): with
//                Dq_i = q_max_i - q_min_i, activation thresholds
//                  q_l0_min = q_min + rho Dq,  q_l0_max = q_max - rho Dq,
//                  q_l1_min = q_l0_min - rho rho1 Dq,  q_l1_max = q_l0_max + rho rho1 Dq;
//                joint i beyond its q_l0 threshold adds
//                  -c_i (1 + lambda_tune) b_i P g_i,  g_i = -e_i below, +e_i above,
//                  b_i = |qdot1_i| / |(P g_i)_i|  (1 if |(P g_i)_i| < 1e-9: no room;
//                  ViSP's floor is 10 eps, below the rounding of a projector),
//                c_i = 1 beyond q_l1 (b_i unbounded), else the sigmoid
//                1 / (1 + exp(-12 (q_i - q_l0) / (q_l1 - q_l0) + 6)) with b_i
//                clamped to 1: at full activation the term moves joint i by
//                -(1 + lambda_tune) |qdot1_i| (P_ii > 0), so a joint the task
//                drives towards its limit moves back at lambda_tune |qdot1_i|.
// qdot = qdot1 + P (z + Jc^+ v2) + avoidance.
//
// Caps (the URDF's <limit velocity>, and an acceleration limit): qdot scaled
// by one factor so that every |qdot_i| <= max_joint_speed_i (direction kept),
// then the change from the previous command limited by one factor in (0, 1]
// so that every |qdot_i - qdot_prev_i| <= max_joint_acceleration_i period (a
// convex combination of two commands within the speed caps stays within
// them). Without caps, the secondary motion leaves the primary's feature
// velocity (classical) or error-norm rate (large) unchanged to rounding.
//
// SecondaryTask is sized once (n <= max_joints); update() is noexcept and
// allocation-free; validate() throws std::invalid_argument naming the field.
#pragma once

#include "ibvs/robot_mapping.hpp"

#include <Eigen/Core>
#include <Eigen/SVD>

#include <cstdint>

namespace ibvs {

enum class Projector : std::uint8_t {
  classical = 0,  ///< P_e, eq. (1)
  large = 1,      ///< P_|e| switched to P_e near convergence, eqs. (2)-(3)
};
const char* to_string(Projector p) noexcept;

struct SecondaryTaskOptions {
  Projector projector = Projector::classical;
  double switch_low = 0.1;   ///< e0 of eq. (3), >= 0 (error-norm units of the servo)
  double switch_high = 0.7;  ///< e1 of eq. (3), > switch_low
  /// Joint-limit avoidance: on when q_min and q_max have n entries (q_min < q_max, finite).
  JointVector q_min, q_max;
  double rho = 0.1;          ///< in (0, 0.5): width of the safe zone's margin (ViSP's default)
  double rho1 = 0.3;         ///< in (0, 1]: the sigmoid's span as a fraction of that margin
  double lambda_tune = 0.7;  ///< >= 0: at full activation the joint moves back at lambda_tune |qdot1_i|
  /// n caps > 0 (inf = none), or empty = none.
  JointVector max_joint_speed;
  JointVector max_joint_acceleration;  ///< n caps > 0 (inf = none) with period > 0, or empty = none
  double period = 0.0;                 ///< s, > 0 with max_joint_acceleration: the control period
};

/// Per-frame input, sized once for n joints.
struct SecondaryTaskInput {
  explicit SecondaryTaskInput(int n);
  Eigen::Matrix<double, 6, 6> task_gram = Eigen::Matrix<double, 6, 6>::Identity();  ///< G = L^T L (symmetric)
  Twist task_gradient = Twist::Zero();  ///< g = L^T e
  double error_norm = 0.0;              ///< |e| >= 0 (eq. 3)
  RobotJacobian camera_jacobian;        ///< Jc, 6 x n (JointMappingOutput::camera_jacobian)
  JointVector qdot;                     ///< qdot1, n (JointMappingOutput::qdot, without speed caps)
  JointVector q;                        ///< joint positions, n (joint-limit avoidance)
  JointVector qdot_previous;            ///< the last command, n (acceleration caps)
  Twist twist = Twist::Zero();          ///< task-space secondary motion v2 (camera frame)
  JointVector joints;                   ///< joint-space secondary motion z, n
};

struct SecondaryTaskOutput {
  explicit SecondaryTaskOutput(int n);
  Status status = Status::ok;  ///< invalid_input: qdot = 0
  JointVector qdot;            ///< the command, n
  JointVector secondary;       ///< P (z + Jc^+ v2), n
  JointVector avoidance;       ///< the joint-limit avoidance term, n
  double weight = 0.0;         ///< s of eq. (3) (large; 0 classical)
  int rank = 0;                ///< rank of J1 (the rows P_e removes)
  int active = 0;              ///< joints beyond their q_l0 threshold
  double saturation_scale = 1.0;    ///< speed-cap factor in (0, 1]
  double acceleration_scale = 1.0;  ///< acceleration-cap factor in (0, 1]
};

class SecondaryTask {
 public:
  /// n joints in [1, max_joints]. Throws std::invalid_argument naming the bad option.
  SecondaryTask(int n, SecondaryTaskOptions options = {});
  // Copy and destruction defined in the library (which allocates the SVD's workspace), for consumers built with
  // other flags. No move members: a move copies, so a moved-from SecondaryTask stays sized and usable.
  SecondaryTask(const SecondaryTask&);
  SecondaryTask& operator=(const SecondaryTask&);
  ~SecondaryTask();
  int joints() const noexcept { return n_; }
  const SecondaryTaskOptions& options() const noexcept { return options_; }
  bool avoids_joint_limits() const noexcept { return options_.q_min.size() == n_; }

  /// Throws std::invalid_argument naming the first bad field of `in`.
  void validate(const SecondaryTaskInput& in) const;
  /// Eqs. (1)-(3), the avoidance and the caps. noexcept, allocation-free; input
  /// validate() refuses (or whose result overflows) gives Status::invalid_input, qdot = 0.
  Status update(const SecondaryTaskInput& in, SecondaryTaskOutput& out) noexcept;

  /// P z (after an update(): the projector of its input) into pz.
  void project(const JointVector& z, JointVector& pz) const noexcept;

 private:
  bool input_ok(const SecondaryTaskInput& in) const noexcept;
  int n_;
  SecondaryTaskOptions options_;
  // Dynamic storage sized once by the constructor (6 x n): compute() on a matrix of the same size allocates
  // nothing, and JacobiSVD<MatrixXd> is the one instantiation the library shares with damped_pinv().
  Eigen::MatrixXd work_;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd_;
  // The projector of the last update: P z = z - sum_{i<rank_} V_i (V_i . z) - weight_ h (h . z) / (h . h) ...
  Eigen::Matrix<double, max_joints, 6> V_;  // the rank_ right singular vectors of B (eq. 1)
  int rank_ = 0;
  JointVector h_;  // h of eq. (2), and its weight s (0: classical)
  double h2_ = 0.0, weight_ = 0.0;
};

}  // namespace ibvs
