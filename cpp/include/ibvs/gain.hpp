// Gain scheduling and twist limits for the control law: the adaptive gain of
// ViSP's vpAdaptiveGain and a uniform velocity saturation that keeps the
// twist's direction. Both are pure functions of their arguments (real-time safe).
#pragma once

#include "ibvs/features.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ibvs {

/// Gain as a function of the error norm x >= 0 (ViSP's vpAdaptiveGain):
///   gain(x) = (g0 - ginf) * exp(-(g0' / (g0 - ginf)) * x) + ginf
/// g0 = at_zero is the gain at x = 0 (used near convergence), ginf =
/// at_infinity the gain for large errors, g0' = slope_at_zero = -d gain/dx at 0
/// (how fast the gain falls from g0 to ginf). With g0 > ginf a large error is
/// met with a small gain (no huge first twist) and the final approach with a
/// large one (fast exponential convergence). Off (the constant ServoOptions::gain
/// is used) while at_zero == 0, the default.
struct AdaptiveGain {
  double at_zero = 0.0;        ///< g0 > 0, 1/s
  double at_infinity = 0.0;    ///< ginf, 0 < ginf <= g0, 1/s
  double slope_at_zero = 0.0;  ///< g0' >= 0, 1/s per unit of error norm

  bool enabled() const noexcept { return at_zero != 0.0; }
  bool operator==(const AdaptiveGain& o) const noexcept {
    return at_zero == o.at_zero && at_infinity == o.at_infinity && slope_at_zero == o.slope_at_zero;
  }

  /// gain(x). For g0 == ginf (a constant gain) or g0' == 0 the exponential is
  /// skipped: it would be 0/0 resp. 1.
  double operator()(double x) const noexcept {
    const double a = at_zero - at_infinity;
    if (a == 0.0 || slope_at_zero == 0.0) return at_zero;
    // -(g0' x) / a rather than -(g0' / a) x: no inf * 0 at x = 0 when a is tiny.
    return a * std::exp(-(slope_at_zero * x) / a) + at_infinity;
  }
};

/// Largest s in (0, 1] such that s * |T| <= max_linear and s * |w| <= max_angular
/// for the twist (T, w); infinite limits never bind. Scaling the whole twist by
/// s keeps its direction (the instantaneous screw axis), so the commanded
/// feature motion keeps its direction too and only slows down; clipping each
/// component separately would not.
inline double saturation_scale(const Twist& v, double max_linear, double max_angular) noexcept {
  double s = 1.0;
  double t = v.head<3>().norm(), w = v.tail<3>().norm();
  if (std::isinf(t)) t = v.head<3>().stableNorm();  // squares overflowed (huge gain): rescaled norm
  if (std::isinf(w)) w = v.tail<3>().stableNorm();
  if (t > max_linear) s = max_linear / t;
  if (w > max_angular) s = std::min(s, max_angular / w);
  return s;
}

inline constexpr double no_limit = std::numeric_limits<double>::infinity();

}  // namespace ibvs
