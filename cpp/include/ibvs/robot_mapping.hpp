// Robot mapping: the camera twist a servo computes -> joint velocities of an
// arm that carries the camera (eye-in-hand).
//
// Frames: b = the robot's base, e = its end effector (flange or tool frame),
// c = the camera (ibvs convention: x right, y down, z forward).
//   eMc  end-effector <- camera (4x4, the hand-eye calibration; metres);
//   bRe  base <- end-effector rotation (3x3; needed for a base-frame Jacobian);
//   J    the robot's end-effector Jacobian (6 x n): J qdot = (v, w), the
//        linear velocity of e's origin (m/s) and the angular velocity (rad/s),
//          JacobianFrame::end_effector: both expressed in e (ViSP's eJe,
//                                       Pinocchio's LOCAL frame);
//          JacobianFrame::base:         both expressed in b (Pinocchio's
//                                       LOCAL_WORLD_ALIGNED); then
//                                       eJe = diag(bRe^T, bRe^T) J.
//
// Camera Jacobian (the camera twist produced by qdot, camera frame):
//   Jc = cVe eJe,  cVe = [[cRe, [cte]x cRe], [0, cRe]]  with cMe = eMc^-1,        (1)
// i.e. Jc = [[R^T (Jv - [t]x Jw)], [R^T Jw]] for eMc = (R, t): the camera
// origin moves with v + w x t. cVe is ViSP's vpVelocityTwistMatrix(cMe), the
// matrix ViSP's vpServo::set_cVe() takes, and eJe is what set_eJe() takes;
// ViSP then computes qdot = -gain (L cVe eJe)+ e in one solve, ibvs in two:
// v = -gain L+ e (Servo), then qdot = Jc+ v (here). The two agree whenever L
// has rank 6 and Jc has rank 6 ((A B)+ = B+ A+ for A of full column rank and
// B of full row rank), e.g. any non-singular 6-joint arm and any redundant
// arm away from its singularities.
//
// Joint velocities: the damped least-squares solution of Jc qdot = v,
//   qdot = sum_i phi(s_i) V_i U_i^T v                                           (2)
// on the SVD Jc = U S V^T, phi as in pinv.hpp (1/s above the rank tolerance
// for lambda = 0: Moore-Penrose; s / (s^2 + lambda^2) for lambda > 0). lambda
// is options.damping, or with options.singular_region = eps > 0 the variable
// damping of Nakamura & Hanafusa (1986) driven by the manipulability
// w = s_1 ... s_d, d = min(6, n) (Yoshikawa's sqrt(det(Jc Jc^T)) for n >= 6,
// |det Jc| for n = 6, sqrt(det(Jc^T Jc)) for n <= 6):
//   lambda^2 = (1 - (w / eps)^2) damping^2 while w < eps, else 0,             (3)
// so the solve is exact away from singularities and damped, continuously,
// near them.
// For a redundant arm (n > rank) an optional secondary task z (joint
// velocities, e.g. the gradient of a joint-limit cost) is added in the null
// space of Jc, where it does not move the camera:
//   qdot += (I - V_r V_r^T) z,   V_r = right singular vectors with s_i > tol.   (4)
// Joint-speed limits: the whole qdot is scaled by one factor <= 1 so that
// every |qdot_i| <= max_joint_speed_i (its direction, hence the camera's path,
// is kept; gain.hpp scales the twist the same way).
//
// Two routes, one result (to ~1e-10 relative): for n >= 6 and a well
// conditioned Jc, the normal equations of the 6x6 A = Jc Jc^T by Cholesky
// (qdot = Jc^T (A + lambda^2 I)^-1 v, the null-space projector
// I - Jc^T A^-1 Jc; one refinement step each; sigma_min / sigma_max from the
// eigenvalues of A; about a fifth of the SVD's cost), taken when the bound
// tr(A) tr(A^-1) >= cond(A) of cpp/src/solve.hpp is at most 1e10, i.e.
// cond(Jc) <= 1e5, so that rank = 6 for certain; otherwise (n < 6, near or at
// a singularity) the SVD of Jc as written above.
//
// Eye-to-hand (Mounting::eye_to_hand): the camera is fixed in the base frame
// (bMc, constant, given in place of eMc) and the target is carried by the end
// effector. The servo's twist v is still the camera's motion relative to the
// target, in the camera frame; the target moving with the end-effector twist
// (v_e, w_e) (frame e) gives the camera the relative twist -cVe (v_e, w_e),
// with cMe = bMc^-1 bMe(q) now changing with q (ViSP's vpServo
// EYETOHAND_L_cVf_fVe_eJe: J1 = -L cVf fVe eJe, cVf = V(bMc^-1), fVe = V(bMe);
// modules/vs/src/vpServo.cpp, computeControlLaw, "J1 *= signInteractionMatrix"
// with the sign -1 of the eye-to-hand types). So
//   Jc = -cVe(q) eJe,  cMe = bMc^-1 bMe,                                        (5)
// i.e. eq. (1) with the q-dependent eMc(q) = bMe^-1 bMc and a minus sign; the
// input's base_pose carries bMe every frame. Everything after eq. (1) (the
// solve, damping, null space, limits) is unchanged.
//
// JointMapping is sized once (n <= max_joints, the compile-time bound of its
// vectors and Jacobians; the SVD's workspace is allocated by the constructor);
// update() is noexcept and never allocates.
#pragma once

#include "ibvs/features.hpp"
#include "ibvs/se3.hpp"
#include "ibvs/servo.hpp"

#include <Eigen/Core>
#include <Eigen/SVD>

#include <cstdint>

namespace ibvs {

/// Largest number of joints a JointMapping handles (the bound of its fixed-capacity vectors and Jacobians).
inline constexpr int max_joints = 16;

using JointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, max_joints, 1>;
/// 6 x n robot or camera Jacobian, n <= max_joints.
using RobotJacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, max_joints>;

/// The frame a robot's end-effector Jacobian is expressed in (see above).
enum class JacobianFrame : std::uint8_t {
  end_effector = 0,  ///< eJe: ViSP, Pinocchio LOCAL
  base = 1,          ///< bJe: Pinocchio LOCAL_WORLD_ALIGNED (needs bRe)
};
const char* to_string(JacobianFrame f) noexcept;

/// Where the camera is (see above, eq. 5).
enum class Mounting : std::uint8_t {
  eye_in_hand = 0,  ///< on the end effector: the constant transform is eMc (eq. 1)
  eye_to_hand = 1,  ///< fixed in the base frame, the target on the end effector: the constant transform is bMc (eq. 5)
};
const char* to_string(Mounting m) noexcept;

struct JointMappingOptions {
  JacobianFrame frame = JacobianFrame::end_effector;
  Mounting mounting = Mounting::eye_in_hand;  ///< eye_to_hand: eq. (5), the input's base_pose needed
  double damping = 0.0;          ///< lambda >= 0 (eq. 2), or its maximum with singular_region > 0
  double singular_region = 0.0;  ///< eps >= 0 of eq. (3); 0 = constant damping
  /// Joint-speed limits (m/s or rad/s per joint), n entries > 0 (inf = none);
  /// empty (the default) = no limits.
  JointVector max_joint_speed;
};

/// Per-frame input, sized once for n joints.
struct JointMappingInput {
  explicit JointMappingInput(int n);
  Twist twist = Twist::Zero();      ///< camera twist (camera frame), m/s and rad/s
  RobotJacobian jacobian;           ///< 6 x n end-effector Jacobian in options.frame
  Eigen::Matrix3d base_rotation = Eigen::Matrix3d::Identity();  ///< bRe (JacobianFrame::base only)
  JointVector secondary;            ///< n joint velocities for the null space (eq. 4); zero = none
  /// bMe, base <- end effector (eye_to_hand only: eq. 5; its rotation then also serves
  /// JacobianFrame::base and base_rotation is not read).
  Pose base_pose = Pose::Identity();
};

/// Per-frame output, sized once for n joints.
struct JointMappingOutput {
  explicit JointMappingOutput(int n);
  Status status = Status::ok;  ///< singular when rank(Jc) < min(6, n); invalid_input: qdot = 0 (see update())
  JointVector qdot;            ///< joint velocities, n
  RobotJacobian camera_jacobian;  ///< Jc of eq. (1), 6 x n: camera twist = Jc qdot
  double sigma_min = 0.0;      ///< smallest of the min(6, n) singular values of Jc
  double sigma_max = 0.0;      ///< largest singular value of Jc
  /// w of eq. (3): the product of the min(6, n) singular values of Jc
  /// (sqrt(det(Jc Jc^T)) for n >= 6, |det Jc| for n = 6).
  double manipulability = 0.0;
  double damping = 0.0;        ///< lambda applied this step
  int rank = 0;                ///< singular values above the rank tolerance
  bool saturated = false;      ///< qdot was scaled down to max_joint_speed
  double saturation_scale = 1.0;  ///< that factor, in (0, 1]
};

class JointMapping {
 public:
  /// n joints in [1, max_joints]; eMc end-effector <- camera (eye_in_hand) or
  /// bMc base <- camera (options.mounting = eye_to_hand). Throws
  /// std::invalid_argument naming the bad argument.
  JointMapping(int n, const Pose& eMc, JointMappingOptions options = {});
  // Copy and destruction defined in the library (which allocates the SVD's workspace), for consumers built with
  // other flags. No move members: a move copies, so a moved-from JointMapping stays sized and usable.
  JointMapping(const JointMapping&);
  JointMapping& operator=(const JointMapping&);
  ~JointMapping();

  int joints() const noexcept { return n_; }
  const Pose& eMc() const noexcept { return eMc_; }
  const JointMappingOptions& options() const noexcept { return options_; }

  /// Throws std::invalid_argument naming the first bad field of `in`.
  void validate(const JointMappingInput& in) const;

  /// Eqs. (1)-(4) and the speed limits. noexcept, allocation-free; non-finite
  /// input, a wrong size, a base_rotation that is not a rotation, or finite
  /// input whose Jc or qdot overflows gives Status::invalid_input and qdot = 0.
  Status update(const JointMappingInput& in, JointMappingOutput& out) noexcept;

  /// Eq. (1): the camera Jacobian of an end-effector Jacobian J (6 x n) in
  /// `frame` (bRe used for JacobianFrame::base).
  static void camera_jacobian(const Pose& eMc, JacobianFrame frame, const RobotJacobian& J,
                              const Eigen::Matrix3d& bRe, RobotJacobian& Jc) noexcept;
  /// Eq. (1) or (5): `mount` is eMc (eye_in_hand) or bMc (eye_to_hand); bMe the
  /// end effector's pose (its rotation for JacobianFrame::base; all of it for eye_to_hand).
  static void camera_jacobian(const Pose& mount, Mounting mounting, JacobianFrame frame, const RobotJacobian& J,
                              const Pose& bMe, RobotJacobian& Jc) noexcept;

 private:
  int n_;
  Pose eMc_;
  JointMappingOptions options_;
  bool normal_route(const JointMappingInput& in, JointMappingOutput& out) noexcept;
  Status finish(JointMappingOutput& out, Status status) noexcept;
  // Dynamic storage sized once by the constructor (6 x n): compute() on a matrix of the same size allocates
  // nothing, and JacobiSVD<MatrixXd> is the one instantiation the library shares with damped_pinv().
  Eigen::MatrixXd work_;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd_;
};

}  // namespace ibvs
