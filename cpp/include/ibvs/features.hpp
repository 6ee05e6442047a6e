// Point features and their 2x6 image Jacobians (Cartesian eq. 3, polar eq. 7,
// and the cylindrical (r, r theta) of Iwatsuki & Okiyama, paper Section II).
//
// Conventions (the same everywhere in ibvs):
//  * camera frame: x right, y down, z forward (optical axis);
//  * twist v = (Tx, Ty, Tz, wx, wy, wz): the camera's own linear (m/s) and
//    angular (rad/s) velocity, expressed in the camera frame;
//  * features are in normalised image coordinates (unit focal length):
//    u = x/z, v = y/z (eq. 1); polar r = sqrt(u^2 + v^2), theta = atan2(v, u)
//    (eqs. 4-5), theta in radians in (-pi, pi];
//  * a Jacobian J maps the camera twist to the feature rate of a static point:
//    d(feature)/dt = J v.
//
// Eq. (3) of the paper is already in this convention. Eq. (7) as printed is
// the negation of it (it describes a moving point seen by a fixed camera);
// polar_jacobian() below is -(eq. 7), and the finite-difference tests prove it.
#pragma once

#include "ibvs/limits.hpp"

#include <Eigen/Core>

#include <cmath>
#include <cstdint>

namespace ibvs {

using Twist = Eigen::Matrix<double, 6, 1>;
using Matrix26 = Eigen::Matrix<double, 2, 6, Eigen::RowMajor>;
using MatrixX6 = Eigen::Matrix<double, Eigen::Dynamic, 6>;

inline constexpr double pi = 3.14159265358979323846;

/// How one image point is turned into two feature rows.
enum class Representation : std::uint8_t {
  cartesian = 0,  ///< (u, v), Jacobian eq. (3)
  polar = 1,      ///< (r, theta), Jacobian -(eq. 7)
  cylindrical = 2,  ///< (r, r theta) of Iwatsuki & Okiyama; error (r - r*, r wrap(theta - theta*))
};

/// Default radius below which a polar block falls back to its Cartesian block
/// (about one pixel for a focal length of 1000 px). See Layout / Servo docs.
inline constexpr double default_polar_min_radius = 1e-3;

/// Wraps an angle into (-pi, pi]. An input of exactly -pi (or any odd multiple
/// of pi) maps to +pi, so a half-turn error always has a positive sign.
inline double wrap_angle(double a) noexcept {
  double w = std::remainder(a, 2.0 * pi);  // in [-pi, pi]
  if (w <= -pi) w += 2.0 * pi;
  return w;
}

/// theta = atan2(v, u) in (-pi, pi]: atan2 gives -pi for v = -0.0, u < 0, mapped to +pi.
inline double polar_angle(double u, double v) noexcept {
  const double t = std::atan2(v, u);
  return t <= -pi ? pi : t;
}

/// Polar features (r, theta) of a point (u, v); theta = polar_angle(u, v), so
/// the principal point itself gives (0, 0) rather than NaN.
inline Eigen::Vector2d polar_features(double u, double v) noexcept {
  return {std::sqrt(u * u + v * v), polar_angle(u, v)};
}

/// Eq. (3): Jacobian of (u, v) for a point at depth z > 0.
inline Matrix26 cartesian_jacobian(double u, double v, double z) noexcept {
  const double iz = 1.0 / z;
  Matrix26 J;
  J << -iz, 0.0, u * iz, u * v, -(1.0 + u * u), v,  //
      0.0, -iz, v * iz, 1.0 + v * v, -u * v, -u;
  return J;
}

/// -(eq. 7): Jacobian of (r, theta) for a point at depth z > 0, radius r > 0
/// and direction (c, s) = (cos theta, sin theta) = (u/r, v/r):
///   dr/dt     = [ -c/z,     -s/z,    r/z, (1+r^2)s, -(1+r^2)c,  0 ] v
///   dtheta/dt = [ s/(rz), -c/(rz),   0,    c/r,       s/r,     -1 ] v
/// The caller guarantees r > 0 (Layout-level code applies the r -> 0 policy).
inline Matrix26 polar_jacobian(double r, double c, double s, double z) noexcept {
  const double iz = 1.0 / z, ir = 1.0 / r;
  const double k = 1.0 + r * r;
  Matrix26 J;
  J << -c * iz, -s * iz, r * iz, k * s, -k * c, 0.0,  //
      s * ir * iz, -c * ir * iz, 0.0, c * ir, s * ir, -1.0;
  return J;
}

/// -(eq. 7) at the point (u, v), r = |(u, v)| > 0.
inline Matrix26 polar_jacobian(double u, double v, double z) noexcept {
  const double r = std::sqrt(u * u + v * v);  // normalised coordinates: no overflow to guard against
  return polar_jacobian(r, u / r, v / r, z);
}

/// Cylindrical features (r, r theta) of Iwatsuki & Okiyama (IROS 2002, cited
/// as [6] in the paper), theta = atan2(v, u) in (-pi, pi]: 0 at the principal point.
inline Eigen::Vector2d cylindrical_features(double u, double v) noexcept {
  const double r = std::sqrt(u * u + v * v);
  return {r, r * polar_angle(u, v)};
}

/// Jacobian of (r, r alpha), alpha = theta - theta0 the point's angle from a
/// fixed origin theta0, at radius r >= 0, direction (c, s), depth z > 0:
///   dr/dt         = [ -c/z, -s/z, r/z, (1+r^2)s, -(1+r^2)c,  0 ] v   (row 1 of -(eq. 7))
///   d(r alpha)/dt = alpha dr/dt + r dtheta/dt
///                 = alpha (row above) + [ s/z, -c/z, 0, c, s, -r ] v
/// No 1/r: r dtheta/dt is bounded. At r = 0 the direction (c, s) is undefined
/// (the map is continuous but not differentiable there) and the caller picks
/// it; with alpha = 0 the block is then the Cartesian block of eq. (3)
/// expressed in the orthonormal basis (c, s), (-s, c), so it keeps rank 2.
/// Servo uses theta0 = theta* (the error's angle origin, see Layout docs);
/// jacobian() of a Layout uses theta0 = 0 (the features above).
inline Matrix26 cylindrical_jacobian(double r, double c, double s, double alpha, double z) noexcept {
  const double iz = 1.0 / z;
  const double k = 1.0 + r * r;
  Matrix26 J;
  J << -c * iz, -s * iz, r * iz, k * s, -k * c, 0.0,  //
      s * iz, -c * iz, 0.0, c, s, -r;
  J.row(1) += alpha * J.row(0);
  return J;
}

/// True when a polar block at squared radius r2 must use its Cartesian rows:
/// below the policy radius, and always below polar_radius_floor (the
/// principal point itself included), where the 1/r rows would overflow.
inline bool polar_falls_back(double r2, double polar_min_radius) noexcept {
  return r2 < polar_min_radius * polar_min_radius || r2 < polar_radius_floor * polar_radius_floor;
}

}  // namespace ibvs
