// Rigid motion helpers: the SE(3) exponential of a camera twist and the
// pinhole projection of eq. (1). Poses are 4x4 homogeneous transforms;
// T_wc maps camera coordinates into the world (world <- camera).
#pragma once

#include "ibvs/features.hpp"
#include "ibvs/limits.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>

namespace ibvs {

using Pose = Eigen::Matrix4d;

/// exp of the twist xi = (T, w) held constant for unit time: the exact rigid
/// motion of a body moving with that twist in its own frame. A camera moving
/// with twist v for dt seconds goes from T_wc to T_wc * se3_exp(v * dt).
/// Finite for entries up to max_twist_entry: with th = |w| and the unit axis
/// k = w / th (K its cross-product matrix), R = I + sin th K + (1 - cos th) K^2
/// and the translation (I + (1 - cos th)/th K + (1 - sin th / th) K^2) T,
/// whose coefficients are bounded for every th.
inline Pose se3_exp(const Twist& xi) noexcept {
  const Eigen::Vector3d t = xi.head<3>(), w = xi.tail<3>();
  double th = w.norm();
  if (std::isinf(th)) th = w.stableNorm();  // components beyond 1e154
  Pose T = Pose::Identity();
  if (th < 1e-4) {  // Taylor series in W = th K, error below 1e-17
    Eigen::Matrix3d W;
    W << 0, -w(2), w(1), w(2), 0, -w(0), -w(1), w(0), 0;
    const Eigen::Matrix3d W2 = W * W;
    const double t2 = th * th;
    const double a = 1.0 - t2 / 6.0, b = 0.5 - t2 / 24.0, c = 1.0 / 6.0 - t2 / 120.0;
    T.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() + a * W + b * W2;
    T.topRightCorner<3, 1>() = (Eigen::Matrix3d::Identity() + b * W + c * W2) * t;
    return T;
  }
  const Eigen::Vector3d k = w / th;
  Eigen::Matrix3d K;
  K << 0, -k(2), k(1), k(2), 0, -k(0), -k(1), k(0), 0;
  const Eigen::Matrix3d K2 = K * K;
  const double s = std::sin(th), c = std::cos(th);
  T.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() + s * K + (1.0 - c) * K2;
  T.topRightCorner<3, 1>() = (Eigen::Matrix3d::Identity() + ((1.0 - c) / th) * K + (1.0 - s / th) * K2) * t;
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
