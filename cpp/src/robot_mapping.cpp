#include "ibvs/robot_mapping.hpp"

#include "ibvs/pinv.hpp"

#include "checks.hpp"
#include "svd_instances.hpp"
#include "solve.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs {

const char* to_string(JacobianFrame f) noexcept {
  switch (f) {
    case JacobianFrame::end_effector: return "end_effector";
    case JacobianFrame::base: return "base";
  }
  return "unknown";
}

const char* to_string(Mounting m) noexcept {
  switch (m) {
    case Mounting::eye_in_hand: return "eye_in_hand";
    case Mounting::eye_to_hand: return "eye_to_hand";
  }
  return "unknown";
}

namespace {

bool is_rotation(const Eigen::Matrix3d& R) noexcept {
  return R.allFinite() && (R.transpose() * R).isIdentity(1e-9) && std::abs(R.determinant() - 1.0) <= 1e-9;
}

bool is_rigid(const Pose& T) noexcept {
  return T.allFinite() && is_rotation(T.topLeftCorner<3, 3>()) && T(3, 0) == 0.0 && T(3, 1) == 0.0 &&
         T(3, 2) == 0.0 && T(3, 3) == 1.0;
}

using detail::fail;

int checked_joints(int n) {
  if (n < 1 || n > max_joints)
    fail("n_joints must be in [1, " + std::to_string(max_joints) + "], got " + std::to_string(n));
  return n;
}

// A refused update: zero joint velocities, zero diagnostics, Status::invalid_input.
Status refuse_joint_update(JointMappingOutput& out, int n) noexcept {
  out.qdot.setZero(n);
  out.saturated = false;
  out.saturation_scale = 1.0;
  out.sigma_min = out.sigma_max = out.manipulability = out.damping = 0.0;
  out.rank = 0;
  return out.status = Status::invalid_input;
}

}  // namespace

JointMappingInput::JointMappingInput(int n)
    : jacobian(RobotJacobian::Zero(6, n)), secondary(JointVector::Zero(n)) {}

JointMappingOutput::JointMappingOutput(int n)
    : qdot(JointVector::Zero(n)), camera_jacobian(RobotJacobian::Zero(6, n)) {}

JointMapping::JointMapping(const JointMapping&) = default;
JointMapping& JointMapping::operator=(const JointMapping&) = default;
JointMapping::~JointMapping() = default;

JointMapping::JointMapping(int n, const Pose& eMc, JointMappingOptions options)
    : n_(checked_joints(n)),
      eMc_(eMc),
      options_(std::move(options)),
      work_(6, n_),
      svd_(6, n_, Eigen::ComputeThinU | Eigen::ComputeThinV) {
  if (!is_rigid(eMc))
    fail(std::string(options_.mounting == Mounting::eye_to_hand ? "bMc" : "eMc") +
         " must be a rigid transform (orthonormal R, last row 0 0 0 1)");
  const JointMappingOptions& o = options_;
  if (o.frame != JacobianFrame::end_effector && o.frame != JacobianFrame::base)
    fail("frame must be end_effector or base");
  if (o.mounting != Mounting::eye_in_hand && o.mounting != Mounting::eye_to_hand)
    fail("mounting must be eye_in_hand or eye_to_hand");
  if (!(o.damping >= 0.0) || !std::isfinite(o.damping)) fail("damping must be finite and >= 0");
  if (!(o.singular_region >= 0.0) || !std::isfinite(o.singular_region))
    fail("singular_region must be finite and >= 0");
  if (o.max_joint_speed.size() != 0) {
    if (o.max_joint_speed.size() != n)
      fail("max_joint_speed must have " + std::to_string(n) + " entries, got " +
           std::to_string(o.max_joint_speed.size()));
    for (int i = 0; i < n; ++i)
      if (!(o.max_joint_speed(i) > 0.0))  // +inf allowed (no limit on that joint)
        fail("max_joint_speed must be > 0 (inf = no limit), joint " + std::to_string(i));
  }
}

void JointMapping::validate(const JointMappingInput& in) const {
  if (!in.twist.allFinite()) fail("twist must be finite");
  if (in.jacobian.cols() != n_)
    fail("jacobian must have shape (6, " + std::to_string(n_) + "), got (6, " + std::to_string(in.jacobian.cols()) +
         ")");
  if (!in.jacobian.allFinite()) fail("jacobian must be finite");
  if (options_.mounting == Mounting::eye_to_hand) {
    if (!is_rigid(in.base_pose)) fail("bMe must be a rigid transform (orthonormal R, last row 0 0 0 1)");
  } else if (options_.frame == JacobianFrame::base && !is_rotation(in.base_rotation)) {
    fail("bRe must be a rotation matrix (orthonormal, det +1)");
  }
  if (in.secondary.size() != n_)
    fail("secondary must have " + std::to_string(n_) + " entries, got " + std::to_string(in.secondary.size()));
  if (!in.secondary.allFinite()) fail("secondary must be finite");
}

void JointMapping::camera_jacobian(const Pose& eMc, JacobianFrame frame, const RobotJacobian& J,
                                   const Eigen::Matrix3d& bRe, RobotJacobian& Jc) noexcept {
  const Eigen::Matrix3d RT = eMc.topLeftCorner<3, 3>().transpose();
  const Eigen::Vector3d t = eMc.topRightCorner<3, 1>();
  Jc.resize(6, J.cols());
  for (Eigen::Index j = 0; j < J.cols(); ++j) {
    Eigen::Vector3d v = J.col(j).head<3>(), w = J.col(j).tail<3>();
    if (frame == JacobianFrame::base) {  // eJe = diag(bRe^T, bRe^T) bJe
      v = bRe.transpose() * v;
      w = bRe.transpose() * w;
    }
    Jc.col(j).head<3>() = RT * (v + w.cross(t));  // the camera origin's velocity, camera frame
    Jc.col(j).tail<3>() = RT * w;
  }
}

void JointMapping::camera_jacobian(const Pose& mount, Mounting mounting, JacobianFrame frame, const RobotJacobian& J,
                                   const Pose& bMe, RobotJacobian& Jc) noexcept {
  const Eigen::Matrix3d bRe = bMe.topLeftCorner<3, 3>();
  if (mounting == Mounting::eye_in_hand) return camera_jacobian(mount, frame, J, bRe, Jc);
  camera_jacobian(se3_inverse(bMe) * mount, frame, J, bRe, Jc);  // eq. (5): eMc(q) = bMe^-1 bMc
  Jc = -Jc;
}

Status JointMapping::update(const JointMappingInput& in, JointMappingOutput& out) noexcept {
  const int n = n_;
  out.qdot.setZero(n);
  out.saturated = false;
  out.saturation_scale = 1.0;
  const bool eye_to_hand = options_.mounting == Mounting::eye_to_hand;
  const bool ok = in.twist.allFinite() && in.jacobian.cols() == n && in.jacobian.allFinite() &&
                  in.secondary.size() == n && in.secondary.allFinite() &&
                  (eye_to_hand ? is_rigid(in.base_pose)
                               : (options_.frame != JacobianFrame::base || is_rotation(in.base_rotation)));
  if (!ok) {
    out.camera_jacobian.setZero(6, n);
    return refuse_joint_update(out, n);
  }
  if (eye_to_hand)
    camera_jacobian(eMc_, Mounting::eye_to_hand, options_.frame, in.jacobian, in.base_pose, out.camera_jacobian);
  else
    camera_jacobian(eMc_, options_.frame, in.jacobian, in.base_rotation, out.camera_jacobian);
  if (!out.camera_jacobian.allFinite()) return refuse_joint_update(out, n);  // finite input whose eq. (1) overflows
  if (n >= 6 && normal_route(in, out)) return finish(out, Status::ok);
  work_ = out.camera_jacobian;
  svd_.compute(work_, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto& s = svd_.singularValues();  // min(6, n), decreasing
  const Eigen::Index d = s.size();
  out.sigma_max = s(0);
  out.sigma_min = s(d - 1);
  out.manipulability = s.prod();
  const double tol = rank_tolerance(n, out.sigma_max);
  // Damping, eq. (3).
  double lambda = options_.damping;
  if (options_.singular_region > 0.0) {
    const double ratio = out.manipulability / options_.singular_region;
    lambda = ratio < 1.0 ? options_.damping * std::sqrt(1.0 - ratio * ratio) : 0.0;
  }
  out.damping = lambda;
  // Eq. (2), then eq. (4) with the right singular vectors of the numerical range.
  const auto& U = svd_.matrixU();
  const auto& V = svd_.matrixV();
  int rank = 0;
  for (Eigen::Index i = 0; i < d; ++i) {
    if (!(s(i) > tol)) continue;
    ++rank;
    out.qdot.noalias() += (pinv_factor(s(i), lambda, tol) * U.col(i).dot(in.twist)) * V.col(i);
  }
  out.rank = rank;
  JointVector z = in.secondary;
  for (Eigen::Index i = 0; i < d; ++i)
    if (s(i) > tol) z.noalias() -= V.col(i).dot(in.secondary) * V.col(i);
  out.qdot += z;
  return finish(out, rank < std::min<int>(6, n) ? Status::singular : Status::ok);
}

// The normal route for n >= 6 (see the header, "Two routes"): A = Jc Jc^T (6x6),
// its Cholesky factor, the full-rank test tr(A) tr(A^-1) <= 1e10 of solve.hpp
// (cond(Jc) <= 1e5: every singular value far above the rank tolerance, rank 6),
// then eqs. (2)-(4) as qdot = Jc^T (A + lambda^2 I)^-1 v and
// z - Jc^T A^-1 Jc z, each solve with one refinement step whose residual is
// taken from Jc itself. sigma_min, sigma_max from the eigenvalues of A,
// manipulability = sqrt(det A) = prod diag(L). False (nothing written but
// scratch) when the test fails: the caller takes the SVD route.
bool JointMapping::normal_route(const JointMappingInput& in, JointMappingOutput& out) noexcept {
  const auto& Jc = out.camera_jacobian;
  detail::Matrix6 A;
  for (int j = 0; j < 6; ++j)
    for (int i = j; i < 6; ++i) A(i, j) = A(j, i) = Jc.row(i).dot(Jc.row(j));
  detail::Normal gram;
  if (!gram.factor(A) || gram.bound > detail::normal_route_limit(0.0)) return false;
  double ev[6];
  if (!detail::symmetric_eigenvalues(A, ev)) return false;
  out.sigma_min = std::sqrt(std::max(ev[0], 0.0));
  out.sigma_max = std::sqrt(std::max(ev[5], 0.0));
  out.manipulability = gram.L.diagonal().prod();
  double lambda = options_.damping;  // eq. (3)
  if (options_.singular_region > 0.0) {
    const double ratio = out.manipulability / options_.singular_region;
    lambda = ratio < 1.0 ? options_.damping * std::sqrt(1.0 - ratio * ratio) : 0.0;
  }
  out.damping = lambda;
  out.rank = 6;
  const double l2 = lambda * lambda;
  detail::Normal damped;
  if (l2 > 0.0) {
    detail::Matrix6 N = A;
    N.diagonal().array() += l2;
    if (!damped.factor(N)) return false;
  }
  // y = (Jc Jc^T + l2 I)^-1 b, refined once: y += N^-1 (b - Jc (Jc^T y) - l2 y).
  const auto solve = [&](const detail::Normal& f, double l2f, const Twist& b) noexcept {
    Twist y = f.Li.transpose() * (f.Li * b);
    JointVector Jty = Jc.transpose() * y;
    const Twist r = b - Jc * Jty - l2f * y;
    y.noalias() += f.Li.transpose() * (f.Li * r);
    return y;
  };
  out.qdot.noalias() = Jc.transpose() * solve(l2 > 0.0 ? damped : gram, l2, in.twist);
  if (!in.secondary.isZero(0.0)) {  // eq. (4): the null space of Jc (full row rank)
    const Twist Jz = Jc * in.secondary;
    out.qdot += in.secondary;
    out.qdot.noalias() -= Jc.transpose() * solve(gram, 0.0, Jz);
  }
  return true;
}

// Uniform joint-speed saturation, the finiteness check and the status.
Status JointMapping::finish(JointMappingOutput& out, Status status) noexcept {
  const int n = n_;
  if (options_.max_joint_speed.size() == n) {
    double scale = 1.0;
    for (int i = 0; i < n; ++i) {
      const double a = std::abs(out.qdot(i));
      if (a * scale > options_.max_joint_speed(i)) scale = options_.max_joint_speed(i) / a;
    }
    if (scale < 1.0) {
      out.qdot *= scale;
      out.saturated = true;
      out.saturation_scale = scale;
    }
  }
  if (!out.qdot.allFinite()) return refuse_joint_update(out, n);  // e.g. a huge twist over a tiny singular value
  return out.status = status;
}

}  // namespace ibvs
