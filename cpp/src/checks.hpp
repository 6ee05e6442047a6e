// Argument checks of the throwing (validate) path, shared by the library's
// allocating functions and Servo::validate, and the same tests as predicates
// for the noexcept update() paths (so that both channels agree on every
// input). Messages name the argument. Limits: ibvs/limits.hpp.
#pragma once

#include "ibvs/finite.hpp"
#include "ibvs/layout.hpp"
#include "ibvs/limits.hpp"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace ibvs {
struct ServoOutput;
enum class Status : std::int8_t;
}  // namespace ibvs

namespace ibvs::detail {

/// update()'s refusal (servo.cpp): a zero twist, NaN error, Jacobian and
/// diagnostics (nothing of an earlier frame), Status::invalid_input.
Status refuse(ServoOutput& out) noexcept;

/// The validate() path's refusal: std::invalid_argument("ibvs: " + what).
[[noreturn]] inline void fail(const std::string& what) { throw std::invalid_argument("ibvs: " + what); }

/// A double for a message: shortest of %g at 6 digits (0.000001 prints as 1e-06).
inline std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

/// A finite normalised coordinate within max_normalized_coordinate.
inline bool valid_coordinate(double x) noexcept { return std::abs(x) <= max_normalized_coordinate; }

/// A depth within [min_depth, max_depth] (false for NaN).
inline bool valid_depth(double z) noexcept { return z >= min_depth && z <= max_depth; }

/// Every point finite and within the normalised-coordinate bound.
inline bool valid_points(const Eigen::Ref<const Points>& p) noexcept {
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    if (!valid_coordinate(p(0, i)) || !valid_coordinate(p(1, i))) return false;
  return true;
}

inline bool valid_depths(const Eigen::Ref<const Eigen::VectorXd>& z) noexcept {
  for (Eigen::Index i = 0; i < z.size(); ++i)
    if (!valid_depth(z(i))) return false;
  return true;
}

inline void check_points(const Eigen::Ref<const Points>& p, const char* name, int n) {
  if (p.cols() != n)
    throw std::invalid_argument(std::string("ibvs: ") + name + " must hold " + std::to_string(n) +
                                " points for this layout, got " + std::to_string(p.cols()));
  for (Eigen::Index i = 0; i < p.cols(); ++i) {
    if (!p.col(i).allFinite())
      throw std::invalid_argument(std::string("ibvs: ") + name + "[" + std::to_string(i) + "] is not finite");
    if (!valid_coordinate(p(0, i)) || !valid_coordinate(p(1, i)))
      throw std::invalid_argument(std::string("ibvs: ") + name + "[" + std::to_string(i) + "] = (" + number(p(0, i)) +
                                  ", " + number(p(1, i)) + ") is outside |u|, |v| <= " +
                                  number(max_normalized_coordinate) +
                                  " (normalised coordinates, 84 degrees off the optical axis): these look like "
                                  "pixels; ibvs.CameraModel.normalize (C++ CameraModel::normalize) converts pixels "
                                  "to normalised coordinates");
  }
}

inline void check_depth(const Eigen::Ref<const Eigen::VectorXd>& z, const char* name, int n) {
  if (z.size() != n)
    throw std::invalid_argument(std::string("ibvs: ") + name + " must hold " + std::to_string(n) +
                                " depths for this layout, got " + std::to_string(z.size()));
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (!(z(i) > 0.0) || !std::isfinite(z(i)))
      throw std::invalid_argument(std::string("ibvs: ") + name + "[" + std::to_string(i) + "] = " + number(z(i)) +
                                  " must be finite and > 0 (point behind the camera?)");
    if (!valid_depth(z(i)))
      throw std::invalid_argument(std::string("ibvs: ") + name + "[" + std::to_string(i) + "] = " + number(z(i)) +
                                  " m is outside [" + number(min_depth) + ", " + number(max_depth) + "] m");
  }
}

inline void check_features(const Eigen::Ref<const Eigen::VectorXd>& f, const char* name, Eigen::Index rows) {
  if (f.size() != rows)
    throw std::invalid_argument(std::string("ibvs: ") + name + " must have " + std::to_string(rows) +
                                " rows for this layout, got " + std::to_string(f.size()));
  for (Eigen::Index i = 0; i < f.size(); ++i)
    if (!std::isfinite(f(i)))
      throw std::invalid_argument(std::string("ibvs: ") + name + "[" + std::to_string(i) + "] is not finite");
}

inline void check_angle_wrap(AngleWrap w) {
  if (w != AngleWrap::consistent && w != AngleWrap::per_point)
    throw std::invalid_argument("ibvs: angle_wrap must be consistent or per_point");
}

inline void check_nonnegative(double x, const char* name) {
  if (!(x >= 0.0) || !std::isfinite(x))
    throw std::invalid_argument(std::string("ibvs: ") + name + " must be finite and >= 0, got " + number(x));
}

/// A gain in (0, max_gain].
inline void check_gain(double g, const char* name) {
  if (!(g > 0.0) || !(g <= max_gain))
    throw std::invalid_argument(std::string("ibvs: ") + name + " must be > 0 and <= " + number(max_gain) + ", got " +
                                number(g));
}

}  // namespace ibvs::detail
