// The goal caches of Servo::update (cpp/src/servo.cpp): what the step derives from the goal
// alone (uv_desired, and the feature blocks' measurements_desired) is kept between frames while
// the goal's bits are unchanged. Internal (not installed): the white-box tests empty them before
// every step to compare the cached step with the uncached one, bit for bit.
#pragma once

namespace ibvs {
class Servo;
namespace detail {

struct ServoCaches {
  /// Empties every goal cache of the servo: its next update computes the goal's values afresh.
  static void forget(Servo& servo) noexcept;
};

}  // namespace detail
}  // namespace ibvs
