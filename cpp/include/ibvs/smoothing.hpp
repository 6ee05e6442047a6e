// Smooth starts and switches of the control law: the continuous law of
// Mansard & Chaumette (IEEE T-RA 23(1), 2007, "Task sequencing for high-level
// sensor-based control", eq. 17; ViSP's vpServo::computeControlLaw(t, e_dot_init))
// and acceleration limits on the twist. Pure state and arithmetic: real-time safe.
//
// A law switched on at time t_s (the start of a task, a change of law or of the
// points it uses) commands v_law(t), generally different from the twist v(t_s-)
// the camera had just before. The continuous law adds the difference, decaying:
//
//   v(t) = v_law(t) + (v(t_s-) - v_law(t_s)) exp(-mu (t - t_s))        (eq. 17)
//
// so v(t_s) = v(t_s-) (no jump), and v(t) -> v_law(t) at rate mu (1/s). At a start
// from rest, v(t_s-) = 0 and this is ViSP's -lambda J+ e + lambda J+(0) e(0) exp(-mu t).
// The exponential convergence of e = 0 is delayed by at most 1/mu (for a law
// e' = -lambda e switched on from rest: e(t) = e(0) exp(-lambda (t - (1 - exp(-mu t)) / mu))).
//
// Acceleration limits: the change of twist over one period is scaled by one factor
// s in (0, 1] so that |T - T_prev| <= max_linear_acceleration * period and
// |w - w_prev| <= max_angular_acceleration * period; the change keeps its direction
// (like saturation_scale for the speeds), and since the new twist is the convex
// combination prev + s (v - prev), twists within speed limits stay within them.
#pragma once

#include "ibvs/gain.hpp"

#include <cmath>
#include <limits>

namespace ibvs {

/// Options of the smooth law (ServoOptions::smoothing). Off by default: the law is then
/// exactly the instantaneous one, bit for bit.
struct Smoothing {
  double decay_rate = 0.0;                  ///< mu >= 0, 1/s: the continuous law's decay (0 = off)
  double max_linear_acceleration = no_limit;   ///< > 0, m/s^2 (inf = none)
  double max_angular_acceleration = no_limit;  ///< > 0, rad/s^2 (inf = none)
  /// Time between two updates, s (the control period, 1 / frame rate); > 0 whenever the
  /// decay, an acceleration limit or a stop_time is used. The simulator sets it to 1 / fps.
  double period = 0.0;

  /// The continuous law or an acceleration limit is on.
  bool enabled() const noexcept {
    return decay_rate > 0.0 || max_linear_acceleration < no_limit || max_angular_acceleration < no_limit;
  }
  bool operator==(const Smoothing& o) const noexcept {
    return decay_rate == o.decay_rate && max_linear_acceleration == o.max_linear_acceleration &&
           max_angular_acceleration == o.max_angular_acceleration && period == o.period;
  }
};

/// The state of the smooth law: the last commanded twist and the decaying offset of eq. (17).
class TwistSmoother {
 public:
  /// The law changes before the next apply(): the offset is taken there from `from`
  /// (the twist the camera has; by default the last commanded one).
  void switch_law() noexcept { pending_ = true; }
  void switch_law(const Twist& from) noexcept {
    last_ = from;
    pending_ = true;
  }
  /// The smooth twist for this period's law twist v (updated in place): eq. (17) (the blend
  /// scaled back within the speed limits max_linear / max_angular, saturation_scale), then the
  /// acceleration limits. Returns true when an acceleration limit scaled the change.
  bool apply(const Smoothing& s, double max_linear, double max_angular, Twist& v) noexcept {
    if (s.decay_rate > 0.0) {
      if (pending_) {
        offset_ = last_ - v;  // eq. (17) at t = t_s: exactly the twist the camera has
        elapsed_ = 0.0;
        v = last_;
      } else {
        v += offset_ * std::exp(-s.decay_rate * elapsed_);
      }
      elapsed_ += s.period;
      const double k = saturation_scale(v, max_linear, max_angular);
      if (k < 1.0) v *= k;
    }
    pending_ = false;
    const Twist dv = v - last_;
    const double k = saturation_scale(dv, s.max_linear_acceleration * s.period, s.max_angular_acceleration * s.period);
    const bool limited = k < 1.0;
    if (limited) v = last_ + k * dv;
    last_ = v;
    return limited;
  }
  /// Records a twist commanded without apply() (the instantaneous law, a stop, a refusal).
  void note(const Twist& v) noexcept { last_ = v; }
  const Twist& last() const noexcept { return last_; }
  bool switching() const noexcept { return pending_; }  ///< the next apply() starts a transition

 private:
  Twist last_ = Twist::Zero();
  Twist offset_ = Twist::Zero();
  double elapsed_ = 0.0;
  bool pending_ = true;  // a start: from rest
};

}  // namespace ibvs
