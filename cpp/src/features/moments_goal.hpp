// The goal's side of MomentsFeature::evaluate, split off so that Servo::update can keep it while
// the goal's measurement is unchanged (servo_caches.hpp): the goal's check (its entries, its
// evaluation: the interaction entries too) and its feature values s*. Internal (not installed).
#pragma once

#include "ibvs/features/moments.hpp"

namespace ibvs::detail {

struct MomentsGoal {
  double s[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};  ///< the goal's xn, yn, an, r1, r2, alpha (all six)
  const char* refused = nullptr;                 ///< check(m_desired): nullptr when accepted
};

/// The goal's side of f.evaluate(m, m_desired, ...) from m_desired alone.
void moments_goal(const MomentsFeature& f, const double* m_desired, MomentsGoal& goal) noexcept;

/// f.evaluate(m, m_desired, e, L) with the goal's side given (from moments_goal of the same
/// m_desired): the same refusals (nullptr or not) and the same e and L, bit for bit.
const char* moments_evaluate(const MomentsFeature& f, double* m, const MomentsGoal& goal, double* e,
                             Eigen::Ref<MatrixX6> L) noexcept;

}  // namespace ibvs::detail
