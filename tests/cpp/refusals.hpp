// validate() throws exactly for the measurements update() refuses: the check shared by the feature-block tests.
#pragma once

#include "check.hpp"

#include <ibvs/servo.hpp>

#include <initializer_list>
#include <random>
#include <stdexcept>
#include <vector>

namespace ibvs_test {

/// ibvs_test::cases copies of `in`, each with one measurement entry (current or desired, alternately; the entry
/// drawn from rng) set to the next value of `bad`: validate() must throw for exactly the inputs update() refuses,
/// a refused input leaves no non-finite output, and some but not all inputs are refused (the check can fail).
inline void check_refusals_agree(ibvs::Servo& servo, const ibvs::ServoInput& in, ibvs::ServoOutput& out,
                                 std::mt19937_64& rng, std::initializer_list<double> bad) {
  const std::vector<double> values(bad);
  std::uniform_int_distribution<int> which(0, static_cast<int>(in.measurements.size()) - 1);
  int agree = 0, refused = 0;
  for (int c = 0; c < cases; ++c) {
    ibvs::ServoInput x = in;
    Eigen::VectorXd& m = c % 2 ? x.measurements : x.measurements_desired;
    m(which(rng)) = values[static_cast<std::size_t>(c) % values.size()];
    bool threw = false;
    try {
      servo.validate(x);
    } catch (const std::invalid_argument&) {
      threw = true;
    }
    const bool refuses = servo.update(x, out) == ibvs::Status::invalid_input;
    agree += threw == refuses;
    refused += refuses;
    if (!refuses) CHECK(out.velocity.allFinite() && out.jacobian.allFinite());
  }
  CHECK(agree == cases);
  CHECK(refused > 0 && refused < cases);
}

}  // namespace ibvs_test
