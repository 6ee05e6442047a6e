// Rigid motion helpers: the SE(3) exponential of a camera twist and the
// pinhole projection of eq. (1). Poses are 4x4 homogeneous transforms;
// T_wc maps camera coordinates into the world (world <- camera).
#pragma once

#include "ibvs/features.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>

namespace ibvs {

using Pose = Eigen::Matrix4d;

/// exp of the twist xi = (T, w) held constant for unit time: the exact rigid
/// motion of a body moving with that twist in its own frame. A camera moving
/// with twist v for dt seconds goes from T_wc to T_wc * se3_exp(v * dt).
inline Pose se3_exp(const Twist& xi) noexcept {
  const Eigen::Vector3d t = xi.head<3>(), w = xi.tail<3>();
  const double th = w.norm();
  Eigen::Matrix3d W;
  W << 0, -w(2), w(1), w(2), 0, -w(0), -w(1), w(0), 0;
  const Eigen::Matrix3d W2 = W * W;
  double a, b, c;  // sin(th)/th, (1-cos th)/th^2, (th - sin th)/th^3
  if (th < 1e-4) {  // Taylor series, error below 1e-17
    const double t2 = th * th;
    a = 1.0 - t2 / 6.0;
    b = 0.5 - t2 / 24.0;
    c = 1.0 / 6.0 - t2 / 120.0;
  } else {
    a = std::sin(th) / th;
    b = (1.0 - std::cos(th)) / (th * th);
    c = (th - std::sin(th)) / (th * th * th);
  }
  Pose T = Pose::Identity();
  T.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() + a * W + b * W2;
  T.topRightCorner<3, 1>() = (Eigen::Matrix3d::Identity() + b * W + c * W2) * t;
  return T;
}

/// Inverse of a rigid transform.
inline Pose se3_inverse(const Pose& T) noexcept {
  Pose Ti = Pose::Identity();
  Ti.topLeftCorner<3, 3>() = T.topLeftCorner<3, 3>().transpose();
  Ti.topRightCorner<3, 1>() = -Ti.topLeftCorner<3, 3>() * T.topRightCorner<3, 1>();
  return Ti;
}

}  // namespace ibvs
