// Angle wrap of a layout's polar / cylindrical angle errors (paper eq. 13):
// point by point, or as one rotation (the consistent wrap, the default).
// In a Servo, the angle rows of its feature blocks about the optical axis
// (Feature::axis_angle_rows: a SphericalPolarFeature's azimuth) take part too:
// their differences, as Feature::error wraps them into (-pi, pi], join the
// same circular mean and are re-wrapped about the same centre, by the rules
// below (a block whose row is no angle this frame, near the axis, stays out).
//
// Eq. (13) read point by point wraps every difference theta_i - theta*_i into
// (-pi, pi] on its own. Near a half-turn that depends on the last bit of a
// sine or on one pixel of noise: a rotation of pi - 1e-16 about the optical
// axis can give (+pi, -pi, +pi, +pi), and the law then asks for a large
// translation to reconcile four points that disagree about the direction of
// one rotation. The consistent wrap takes the circular mean phi of the
// per-point differences (the direction of the sum of their unit vectors) and
// wraps every difference into (phi - pi, phi + pi], so a rotation near pi
// gives differences that are all near +pi or all near -pi.
//
// Exact rules (deterministic):
//  * each difference is first wrapped into (-pi, pi] (wrap_angle, eq. 13);
//  * the mean is atan2 of the summed unit vectors, taken in (-pi, pi] (an
//    exact -pi becomes +pi, as for wrap_angle), so an exact half-turn keeps
//    its +pi;
//  * the mean is undefined, and every difference keeps its per-point wrap,
//    when the resultant length |sum of unit vectors| / count is below
//    wrap_min_resultant (the differences spread evenly around the circle: no
//    rotation describes them), or when no block has an angle;
//  * a difference exactly opposite the mean (at phi - pi) is taken as
//    phi + pi: the interval is half-open like (-pi, pi] in eq. (13);
//  * continuity (Servo only, frame to frame): the mean is unwrapped against
//    the previous frame's (its representative nearest to it) as long as it
//    stays within pi + wrap_hysteresis of 0, so a servo near the half-turn
//    keeps turning the way it started instead of alternating with the noise;
//    Servo::reset() forgets the previous frame.
#pragma once

#include "ibvs/features.hpp"

#include <cmath>
#include <cstdint>

namespace ibvs {

/// How the angle rows of a layout (polar theta, cylindrical r theta) and a task's feature blocks
/// (Feature::axis_angle_rows) are wrapped.
enum class AngleWrap : std::uint8_t {
  consistent = 0,  ///< as one rotation: every difference into (phi - pi, phi + pi], phi their circular mean
  per_point = 1,   ///< eq. (13) point by point: every difference into (-pi, pi] on its own
};

/// Below this resultant length (|sum of the unit vectors| / count, in [0, 1])
/// the circular mean is undefined and the per-point wrap is kept.
inline constexpr double wrap_min_resultant = 1e-6;

/// How far past the half-turn (radians) the Servo keeps the previous frame's
/// branch: the unwrapped mean is kept while |phi| <= pi + wrap_hysteresis.
inline constexpr double wrap_hysteresis = pi / 4;

/// Running sum of the unit vectors (cos d, sin d) of a layout's angle differences.
struct AngleResultant {
  double c = 0.0, s = 0.0;
  int count = 0;

  void add(double cos_d, double sin_d) noexcept {
    c += cos_d;
    s += sin_d;
    ++count;
  }
  /// |sum| / count in [0, 1]; 0 without any angle (|c|, |s| <= count: no overflow to guard against).
  double length() const noexcept { return count > 0 ? std::sqrt(c * c + s * s) / count : 0.0; }
  /// True when the circular mean is defined (length() >= wrap_min_resultant).
  bool defined() const noexcept { return count > 0 && length() >= wrap_min_resultant; }
  /// Circular mean in (-pi, pi] (meaningful only when defined()): atan2 is in [-pi, pi], and its
  /// -pi (a sum along -x with a sine of -0) is taken as +pi.
  double mean() const noexcept {
    const double m = std::atan2(s, c);
    return m <= -pi ? pi : m;
  }
};

/// A difference d in (-pi, pi] wrapped into (centre - pi, centre + pi]: d itself
/// or d -/+ 2 pi (so d is returned bit for bit when it already lies there).
/// |centre| < 2 pi.
inline double wrap_about(double d, double centre) noexcept {
  const double x = d - centre;
  if (x > pi) return d - 2.0 * pi;
  if (x <= -pi) return d + 2.0 * pi;
  return d;
}

/// The centre of this frame from its circular mean (in (-pi, pi]) and the
/// previous frame's centre (NaN: none): the representative of `mean` nearest
/// the previous centre while it stays within pi + wrap_hysteresis of 0,
/// otherwise `mean` itself.
inline double continued_centre(double mean, double previous) noexcept {
  if (std::isnan(previous)) return mean;
  const double c = wrap_about(mean, previous);  // mean or mean -/+ 2 pi
  return std::abs(c) <= pi + wrap_hysteresis ? c : mean;
}

}  // namespace ibvs
