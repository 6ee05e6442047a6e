// Argument checks of the throwing (validate) path, shared by the library's
// allocating functions and Servo::validate. Messages name the argument.
#pragma once

#include "ibvs/layout.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs::detail {

inline void check_points(const Eigen::Ref<const Points>& p, const char* name, int n) {
  if (p.cols() != n)
    throw std::invalid_argument(std::string("ibvs: ") + name + " must hold " + std::to_string(n) +
                                " points for this layout, got " + std::to_string(p.cols()));
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    if (!p.col(i).allFinite())
      throw std::invalid_argument(std::string("ibvs: ") + name + "[" + std::to_string(i) + "] is not finite");
}

inline void check_depth(const Eigen::Ref<const Eigen::VectorXd>& z, const char* name, int n) {
  if (z.size() != n)
    throw std::invalid_argument(std::string("ibvs: ") + name + " must hold " + std::to_string(n) +
                                " depths for this layout, got " + std::to_string(z.size()));
  for (Eigen::Index i = 0; i < z.size(); ++i)
    if (!(z(i) > 0.0) || !std::isfinite(z(i)))
      throw std::invalid_argument(std::string("ibvs: ") + name + "[" + std::to_string(i) + "] = " +
                                  std::to_string(z(i)) + " must be finite and > 0 (point behind the camera?)");
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
    throw std::invalid_argument(std::string("ibvs: ") + name + " must be finite and >= 0, got " + std::to_string(x));
}

}  // namespace ibvs::detail
