#include "ibvs/features/line.hpp"

#include "ibvs/limits.hpp"

#include <array>
#include <cmath>
#include <stdexcept>

namespace ibvs {

std::array<double, 5> LineFeature::measure(double x1, double y1, double x2, double y2, double A, double B, double C) {
  std::array<double, 5> m{};
  if (!measure(x1, y1, x2, y2, A, B, C, m.data()))
    throw std::invalid_argument("ibvs: line: the two points must be distinct and finite (and the plane finite)");
  return m;
}

bool LineFeature::measure(double x1, double y1, double x2, double y2, double A, double B, double C,
                          double* m) noexcept {
  const double dx = x2 - x1, dy = y2 - y1, l = std::hypot(dx, dy);
  if (!(l > 0.0) || !std::isfinite(l)) return false;
  // The unit normal (c, s) = (-dy, dx) / l; rho = (c, s) . p1, made >= 0.
  double c = -dy / l, s = dx / l, rho = c * x1 + s * y1;
  if (rho < 0.0) {
    rho = -rho;
    c = -c;
    s = -s;
  }
  if (!std::isfinite(rho) || !std::isfinite(A) || !std::isfinite(B) || !std::isfinite(C)) return false;
  m[0] = rho;
  m[1] = polar_angle(c, s);
  m[2] = A;
  m[3] = B;
  m[4] = C;
  return true;
}

const char* LineFeature::check(const double* m, int& entry) const noexcept {
  for (entry = 0; entry < 5; ++entry)
    if (!std::isfinite(m[entry])) return "is not finite";
  entry = 0;
  if (std::abs(m[0]) > max_normalized_coordinate) return "rho is beyond the normalised-coordinate limit";
  entry = 1;
  if (std::abs(m[1]) > 2.0 * pi) return "theta must be within [-2 pi, 2 pi]";
  for (entry = 2; entry < 5; ++entry)
    if (std::abs(m[entry]) > 1.0 / min_depth) return "the plane's A, B, C must be within 1 / min_depth";
  entry = -1;
  const double c = std::cos(m[1]), s = std::sin(m[1]);
  const double foot = m[2] * m[0] * c + m[3] * m[0] * s + m[4];  // 1/Z at the line's foot (rho c, rho s)
  if (!(std::abs(foot) >= 1.0 / max_depth))
    return "the plane is seen edge-on at the line (1/Z = A x + B y + C is 0 there: no depth)";
  return nullptr;
}

void LineFeature::align(double* m, const double* md) const noexcept {
  if (std::abs(wrap_angle(m[1] - md[1])) > 0.5 * pi) {  // (-rho, theta + pi) is nearer the goal's
    m[0] = -m[0];
    m[1] = wrap_angle(m[1] + pi);
  }
}

void LineFeature::value(const double* m, double* s) const noexcept {
  s[0] = m[0];
  s[1] = m[1];
}

void LineFeature::error(const double* m, const double* md, double* e) const noexcept {
  e[0] = m[0] - md[0];
  e[1] = wrap_angle(m[1] - md[1]);
}

void LineFeature::interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept {
  const double rho = m[0], c = std::cos(m[1]), s = std::sin(m[1]), A = m[2], B = m[3], C = m[4];
  const double lr = -(A * rho * c + B * rho * s + C), lt = B * c - A * s, k = 1.0 + rho * rho;
  L.row(0) << lr * c, lr * s, -lr * rho, k * s, -k * c, 0.0;
  L.row(1) << lt * c, lt * s, -lt * rho, -rho * c, -rho * s, -1.0;
}

}  // namespace ibvs
