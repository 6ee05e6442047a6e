#include "ibvs/secondary_task.hpp"

#include "ibvs/pinv.hpp"

#include "checks.hpp"
#include "svd_instances.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ibvs {

const char* to_string(Projector p) noexcept {
  switch (p) {
    case Projector::classical: return "classical";
    case Projector::large: return "large";
  }
  return "unknown";
}

namespace {

using detail::fail;

std::string entries(const char* name, int n, Eigen::Index got) {
  return std::string(name) + " must have " + std::to_string(n) + " entries, got " + std::to_string(got);
}

// The sigmoid of eq. (3) and of the avoidance's activation: 0 at x = 0, 1 at x = 1 (to 0.25 %).
double sigmoid(double x) noexcept { return 1.0 / (1.0 + std::exp(-12.0 * x + 6.0)); }

// Relative rank threshold on the eigenvalues of G = L^T L: sigma_j > 1e-6 sigma_max.
constexpr double gram_rank_ratio = 1e-12;

// |(P g_i)_i| below this: joint i has no room in the null space (b = 1, the term is ~0).
constexpr double pivot_floor = 1e-9;

}  // namespace

SecondaryTaskInput::SecondaryTaskInput(int n)
    : camera_jacobian(RobotJacobian::Zero(6, n)),
      qdot(JointVector::Zero(n)),
      q(JointVector::Zero(n)),
      qdot_previous(JointVector::Zero(n)),
      joints(JointVector::Zero(n)) {}

SecondaryTaskOutput::SecondaryTaskOutput(int n)
    : qdot(JointVector::Zero(n)), secondary(JointVector::Zero(n)), avoidance(JointVector::Zero(n)) {}

SecondaryTask::SecondaryTask(const SecondaryTask&) = default;
SecondaryTask& SecondaryTask::operator=(const SecondaryTask&) = default;
SecondaryTask::~SecondaryTask() = default;

SecondaryTask::SecondaryTask(int n, SecondaryTaskOptions options)
    : n_(n), options_(std::move(options)), work_(6, std::max(1, std::min(n, max_joints))),
      svd_(6, std::max(1, std::min(n, max_joints)), Eigen::ComputeThinU | Eigen::ComputeThinV),
      V_(Eigen::Matrix<double, max_joints, 6>::Zero()), h_(JointVector::Zero(std::max(1, std::min(n, max_joints)))) {
  if (n < 1 || n > max_joints)
    fail("n_joints must be in [1, " + std::to_string(max_joints) + "], got " + std::to_string(n));
  const SecondaryTaskOptions& o = options_;
  if (o.projector != Projector::classical && o.projector != Projector::large)
    fail("projector must be classical or large");
  if (!(o.switch_low >= 0.0) || !std::isfinite(o.switch_low) || !(o.switch_high > o.switch_low) ||
      !std::isfinite(o.switch_high))
    fail("switch_low and switch_high must be finite with 0 <= switch_low < switch_high");
  if (o.q_min.size() != o.q_max.size()) fail("q_min and q_max must both be empty or both have n entries");
  if (o.q_min.size() != 0) {
    if (o.q_min.size() != n) fail(entries("q_min", n, o.q_min.size()));
    for (int i = 0; i < n; ++i)
      if (!std::isfinite(o.q_min(i)) || !std::isfinite(o.q_max(i)) || !(o.q_min(i) < o.q_max(i)))
        fail("q_min[" + std::to_string(i) + "] < q_max[" + std::to_string(i) + "] must hold, both finite");
  }
  if (!(o.rho > 0.0 && o.rho < 0.5)) fail("rho must be in (0, 0.5)");
  if (!(o.rho1 > 0.0 && o.rho1 <= 1.0)) fail("rho1 must be in (0, 1]");
  if (!(o.lambda_tune >= 0.0) || !std::isfinite(o.lambda_tune)) fail("lambda_tune must be finite and >= 0");
  if (o.max_joint_speed.size() != 0) {
    if (o.max_joint_speed.size() != n) fail(entries("max_joint_speed", n, o.max_joint_speed.size()));
    for (int i = 0; i < n; ++i)
      if (!(o.max_joint_speed(i) > 0.0)) fail("max_joint_speed[" + std::to_string(i) + "] must be > 0 (inf = none)");
  }
  if (o.max_joint_acceleration.size() != 0) {
    if (o.max_joint_acceleration.size() != n)
      fail(entries("max_joint_acceleration", n, o.max_joint_acceleration.size()));
    for (int i = 0; i < n; ++i)
      if (!(o.max_joint_acceleration(i) > 0.0))
        fail("max_joint_acceleration[" + std::to_string(i) + "] must be > 0 (inf = none)");
    if (!(o.period > 0.0) || !std::isfinite(o.period)) fail("period must be finite and > 0 with max_joint_acceleration");
  }
}

bool SecondaryTask::input_ok(const SecondaryTaskInput& in) const noexcept {
  const int n = n_;
  return in.task_gram.allFinite() && in.task_gram.isApprox(in.task_gram.transpose(), 1e-9) &&
         in.task_gradient.allFinite() && std::isfinite(in.error_norm) && in.error_norm >= 0.0 &&
         in.camera_jacobian.cols() == n && in.camera_jacobian.allFinite() && in.qdot.size() == n &&
         in.qdot.allFinite() && in.q.size() == n && in.q.allFinite() && in.qdot_previous.size() == n &&
         in.qdot_previous.allFinite() && in.twist.allFinite() && in.joints.size() == n && in.joints.allFinite();
}

void SecondaryTask::validate(const SecondaryTaskInput& in) const {
  const int n = n_;
  if (!in.task_gram.allFinite()) fail("task_gram must be finite");
  if (!in.task_gram.isApprox(in.task_gram.transpose(), 1e-9)) fail("task_gram must be symmetric (L^T L)");
  if (!in.task_gradient.allFinite()) fail("task_gradient must be finite");
  if (!std::isfinite(in.error_norm) || in.error_norm < 0.0) fail("error_norm must be finite and >= 0");
  if (in.camera_jacobian.cols() != n)
    fail("camera_jacobian must have shape (6, " + std::to_string(n) + "), got (6, " +
         std::to_string(in.camera_jacobian.cols()) + ")");
  if (!in.camera_jacobian.allFinite()) fail("camera_jacobian must be finite");
  const std::pair<const char*, const JointVector*> vectors[] = {
      {"qdot", &in.qdot}, {"q", &in.q}, {"qdot_previous", &in.qdot_previous}, {"joints", &in.joints}};
  for (const auto& [name, v] : vectors) {
    if (v->size() != n) fail(entries(name, n, v->size()));
    for (int i = 0; i < n; ++i)
      if (!std::isfinite((*v)(i))) fail(std::string(name) + "[" + std::to_string(i) + "] must be finite");
  }
  if (!in.twist.allFinite()) fail("twist must be finite");
}

void SecondaryTask::project(const JointVector& z, JointVector& pz) const noexcept {
  pz = z;
  const double c = 1.0 - weight_;  // eq. (3): (1 - s) P_e + s P_|e|
  if (c > 0.0)
    for (int i = 0; i < rank_; ++i) pz.noalias() -= (c * V_.col(i).head(n_).dot(z)) * V_.col(i).head(n_);
  if (weight_ > 0.0) pz.noalias() -= (weight_ * h_.dot(z) / h2_) * h_;
}

Status SecondaryTask::update(const SecondaryTaskInput& in, SecondaryTaskOutput& out) noexcept {
  const int n = n_;
  const SecondaryTaskOptions& o = options_;
  out.qdot.setZero(n);
  out.secondary.setZero(n);
  out.avoidance.setZero(n);
  out.weight = 0.0;
  out.rank = 0;
  out.active = 0;
  out.saturation_scale = out.acceleration_scale = 1.0;
  rank_ = 0;
  weight_ = 0.0;
  if (!input_ok(in)) return out.status = Status::invalid_input;
  const auto& Jc = in.camera_jacobian;

  // The task-space motion as joints: Jc^+ v2 on the SVD of Jc.
  JointVector zt = JointVector::Zero(n);
  if (!in.twist.isZero(0.0)) {
    work_ = Jc;
    svd_.compute(work_, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const auto& s = svd_.singularValues();
    const double tol = rank_tolerance(n, s(0));
    for (Eigen::Index i = 0; i < s.size(); ++i)
      if (s(i) > tol) zt.noalias() += (svd_.matrixU().col(i).dot(in.twist) / s(i)) * svd_.matrixV().col(i);
  }

  // Eq. (1): the row space of L from G's eigenvectors, B = Q Jc (Q = I for a rank-6 L: B = Jc exactly).
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(in.task_gram);
  const auto& ev = eig.eigenvalues();  // increasing
  int rank_L = 0;
  Eigen::Matrix<double, 6, 6> Q = Eigen::Matrix<double, 6, 6>::Zero();
  if (eig.info() == Eigen::Success && ev(5) > 0.0)
    for (int j = 0; j < 6; ++j)
      if (ev(j) > gram_rank_ratio * ev(5)) {
        ++rank_L;
        Q.noalias() += eig.eigenvectors().col(j) * eig.eigenvectors().col(j).transpose();
      }
  if (rank_L == 6)
    work_ = Jc;
  else
    work_.noalias() = Q * Jc;
  if (!Q.allFinite() || !work_.allFinite() || !zt.allFinite()) {  // finite input that overflows
    out.qdot.setZero(n);
    return out.status = Status::invalid_input;
  }
  if (rank_L > 0) {
    svd_.compute(work_, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const auto& s = svd_.singularValues();
    const double tol = rank_tolerance(n, s(0));
    for (Eigen::Index i = 0; i < s.size(); ++i)
      if (s(i) > tol && s(0) > 0.0) V_.col(rank_++).head(n) = svd_.matrixV().col(i);
  }
  out.rank = rank_;

  // Eqs. (2)-(3): the large projector and its weight.
  if (o.projector == Projector::large) {
    h_.noalias() = Jc.transpose() * in.task_gradient;
    h2_ = h_.squaredNorm();
    if (h2_ > 0.0 && std::isfinite(h2_)) {
      const double e = in.error_norm;
      weight_ = e >= o.switch_high ? 1.0
                : e <= o.switch_low ? 0.0
                                    : sigmoid((e - o.switch_low) / (o.switch_high - o.switch_low));
    }
  }
  out.weight = weight_;

  // The secondary motions, projected.
  JointVector z = in.joints + zt;
  project(z, out.secondary);

  // Joint-limit avoidance (Marey & Chaumette, IROS 2010; ViSP's secondaryTaskJointLimitAvoidance).
  if (avoids_joint_limits()) {
    JointVector gi = JointVector::Zero(n), pg(n);
    for (int i = 0; i < n; ++i) {
      const double range = o.q_max(i) - o.q_min(i), qi = in.q(i);
      const double l0_min = o.q_min(i) + o.rho * range, l0_max = o.q_max(i) - o.rho * range;
      if (qi >= l0_min && qi <= l0_max) continue;
      const double l1_min = l0_min - o.rho * o.rho1 * range, l1_max = l0_max + o.rho * o.rho1 * range;
      ++out.active;
      gi.setZero(n);
      gi(i) = qi < l0_min ? -1.0 : 1.0;
      project(gi, pg);
      const double p = std::abs(pg(i));
      // ViSP takes b = 1 below 10 eps; a projector's entries are O(1), so rounding of a projector with
      // no room (P = 0 to ~1e-16) would pass that test and give an arbitrary correction: 1e-9 here.
      double b = p >= pivot_floor ? std::abs(in.qdot(i)) / p : 1.0;
      double c = 1.0;  // zone beyond q_l1: full correction, b unbounded
      if (qi >= l1_min && qi <= l1_max) {  // between the thresholds: sigmoid, b <= 1
        b = std::min(b, 1.0);
        c = qi > l0_max ? sigmoid((qi - l0_max) / (l1_max - l0_max)) : sigmoid((qi - l0_min) / (l1_min - l0_min));
      }
      out.avoidance.noalias() -= (c * (1.0 + o.lambda_tune) * b) * pg;
    }
  }
  out.qdot = in.qdot + out.secondary + out.avoidance;

  // Caps: speed (one factor), then the change from the previous command (one factor).
  if (o.max_joint_speed.size() == n) {
    double scale = 1.0;
    for (int i = 0; i < n; ++i) {
      const double a = std::abs(out.qdot(i));
      if (a * scale > o.max_joint_speed(i)) scale = o.max_joint_speed(i) / a;
    }
    out.qdot *= scale;
    out.saturation_scale = scale;
  }
  if (o.max_joint_acceleration.size() == n) {
    double scale = 1.0;
    for (int i = 0; i < n; ++i) {
      const double d = std::abs(out.qdot(i) - in.qdot_previous(i)), cap = o.max_joint_acceleration(i) * o.period;
      if (d * scale > cap) scale = cap / d;
    }
    if (scale < 1.0) out.qdot = in.qdot_previous + scale * (out.qdot - in.qdot_previous);
    out.acceleration_scale = scale;
  }
  if (!out.qdot.allFinite()) {  // finite input whose result overflows
    out.qdot.setZero(n);
    return out.status = Status::invalid_input;
  }
  return out.status = Status::ok;
}

}  // namespace ibvs
