// Test scenes: random points and a camera flying about a static target, used
// to check Jacobians against finite differences and to close the loop.
#pragma once

#include "ibvs/ibvs.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <random>

namespace ibvs_test {

/// Point in the camera frame with image coordinates (u, v) at depth z.
inline Eigen::Vector3d point(double u, double v, double z) { return {u * z, v * z, z}; }

/// Features of camera-frame point P after the camera moves with twist xi for unit time.
inline Eigen::Vector2d moved_uv(const Eigen::Vector3d& P, const ibvs::Twist& xi) {
  const ibvs::Pose T = ibvs::se3_inverse(ibvs::se3_exp(xi));
  const Eigen::Vector3d Q = T.topLeftCorner<3, 3>() * P + T.topRightCorner<3, 1>();
  return {Q.x() / Q.z(), Q.y() / Q.z()};
}

/// Central difference of (u, v) or (r, theta) of P under each unit twist direction.
inline ibvs::Matrix26 numeric_jacobian(const Eigen::Vector3d& P, bool polar, double h) {
  ibvs::Matrix26 J;
  for (int k = 0; k < 6; ++k) {
    ibvs::Twist xi = ibvs::Twist::Zero();
    xi(k) = h;
    Eigen::Vector2d a = moved_uv(P, xi), b = moved_uv(P, -xi);
    if (polar) {
      a = ibvs::polar_features(a.x(), a.y());
      b = ibvs::polar_features(b.x(), b.y());
      J(0, k) = (a(0) - b(0)) / (2 * h);
      J(1, k) = ibvs::wrap_angle(a(1) - b(1)) / (2 * h);
    } else {
      J.col(k) = (a - b) / (2 * h);
    }
  }
  return J;
}

/// The paper's target (Table I): corners of a square of half-side `half` at depth `z` in the world.
inline Eigen::Matrix<double, 3, 4> square(double half, double z) {
  Eigen::Matrix<double, 3, 4> P;
  P << half, -half, -half, half,  //
      half, half, -half, -half,   //
      z, z, z, z;
  return P;
}

/// Image points and depths of world points seen from camera pose T_wc.
template <class Pts>
inline void look(const ibvs::Pose& T_wc, const Pts& Pw, ibvs::Points& uv, Eigen::VectorXd& z) {
  const ibvs::Pose T_cw = ibvs::se3_inverse(T_wc);
  for (int i = 0; i < Pw.cols(); ++i) {
    const Eigen::Vector3d Q = T_cw.topLeftCorner<3, 3>() * Pw.col(i) + T_cw.topRightCorner<3, 1>();
    uv.col(i) << Q.x() / Q.z(), Q.y() / Q.z();
    z(i) = Q.z();
  }
}

inline ibvs::Pose pose(const ibvs::Twist& xi) { return ibvs::se3_exp(xi); }

/// One closed-loop run: static world points Pw, goal camera pose at the identity,
/// the camera starting at pose(start), its twist integrated exactly on SE(3) at
/// 60 Hz. `frames` is the frame at which the error fell below 1e-9 with the pose
/// within 1e-5 (m, rad) of the goal, -1 if never (invalid input, wrong pose or
/// max_frames); `retreat` the largest move away from the target along z.
struct Run {
  int frames = -1;
  double retreat = 0.0;
};

/// on_step(out) sees every output (peaks, switches...). Works for any servo
/// with update(uv, depth, uv_desired, depth_desired, out) (Servo, PartitionedServo).
template <class AnyServo, class Pts, class OnStep>
Run converge(AnyServo& servo, const Pts& Pw, const ibvs::Twist& start, OnStep&& on_step, int max_frames = 4000) {
  const ibvs::Layout& L = servo.layout();
  ibvs::ServoInput in(L);
  ibvs::ServoOutput out(L);
  look(ibvs::Pose::Identity(), Pw, in.uv_desired, in.depth_desired);
  ibvs::Pose T = pose(start);
  const double z0 = T(2, 3);
  Run run;
  for (int k = 0; k < max_frames; ++k) {
    look(T, Pw, in.uv, in.depth);
    run.retreat = std::max(run.retreat, z0 - T(2, 3));
    if (servo.update(in.uv, in.depth, in.uv_desired, in.depth_desired, out) == ibvs::Status::invalid_input) return run;
    on_step(out);
    if (out.error_norm < 1e-9) {
      const double dr = Eigen::AngleAxisd(Eigen::Matrix3d(T.topLeftCorner<3, 3>())).angle();
      if (T.topRightCorner<3, 1>().norm() < 1e-5 && dr < 1e-5) run.frames = k;
      return run;
    }
    T = T * ibvs::se3_exp(out.velocity / 60.0);
  }
  return run;
}

template <class AnyServo, class Pts>
Run converge(AnyServo& servo, const Pts& Pw, const ibvs::Twist& start) {
  return converge(servo, Pw, start, [](const ibvs::ServoOutput&) {});
}

/// The same with a Servo built for layout L (gain 1) on the paper's square at 3 m.
inline Run converge(const ibvs::Layout& L, ibvs::InteractionMatrix mode, double lambda, const ibvs::Twist& start) {
  ibvs::ServoOptions o;
  o.gain = 1.0;
  o.damping = lambda;
  o.jacobian = mode;
  ibvs::Servo servo(L, o);
  return converge(servo, square(0.25, 3.0), start);
}

}  // namespace ibvs_test
