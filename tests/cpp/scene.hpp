// Test scenes: random points and a camera flying about a static target, used
// to check Jacobians against finite differences and to close the loop.
#pragma once

#include "ibvs/ibvs.hpp"

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

}  // namespace ibvs_test
