#include "ibvs/features/segment.hpp"

#include "../checks.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs {

namespace {

void require_point(double x, double y, const char* name) {
  if (!std::isfinite(x) || !std::isfinite(y))
    throw std::invalid_argument(std::string("ibvs: segment: ") + name + " is not finite");
  if (!detail::valid_coordinate(x) || !detail::valid_coordinate(y))
    throw std::invalid_argument(std::string("ibvs: segment: ") + name + " = (" + detail::number(x) + ", " +
                                detail::number(y) + ") is outside |x|, |y| <= " +
                                detail::number(max_normalized_coordinate) + " (normalised coordinates)");
}

void require_depth(double z, const char* name) {
  if (!detail::valid_depth(z))
    throw std::invalid_argument(std::string("ibvs: segment: ") + name + " = " + detail::number(z) +
                                " must be within [" + detail::number(min_depth) + ", " + detail::number(max_depth) +
                                "] m (a point in front of the camera)");
}

}  // namespace

std::array<double, 6> SegmentFeature::measure(double x1, double y1, double Z1, double x2, double y2, double Z2) {
  require_point(x1, y1, "p1");
  require_point(x2, y2, "p2");
  require_depth(Z1, "Z1");
  require_depth(Z2, "Z2");
  const double dx = x2 - x1, dy = y2 - y1, l = std::hypot(dx, dy);
  if (!(l >= min_segment_length))
    throw std::invalid_argument("ibvs: segment: p1 and p2 must be distinct (length " + detail::number(l) + " < " +
                                detail::number(min_segment_length) + ")");
  return {0.5 * (x1 + x2), 0.5 * (y1 + y2), l, polar_angle(dx, dy), Z1, Z2};
}

std::array<double, 6> SegmentFeature::project(const Eigen::Vector3d& P1, const Eigen::Vector3d& P2) {
  if (!P1.allFinite() || !P2.allFinite()) throw std::invalid_argument("ibvs: segment: P1 and P2 must be finite");
  require_depth(P1.z(), "P1.z");
  require_depth(P2.z(), "P2.z");
  return measure(P1.x() / P1.z(), P1.y() / P1.z(), P1.z(), P2.x() / P2.z(), P2.y() / P2.z(), P2.z());
}

const char* SegmentFeature::check(const double* m, int& entry) const noexcept {
  for (entry = 0; entry < 6; ++entry)
    if (!std::isfinite(m[entry])) return "is not finite";
  for (entry = 0; entry < 2; ++entry)
    if (!detail::valid_coordinate(m[entry])) return "the centre is beyond the normalised-coordinate limit";
  entry = 2;
  if (!(m[2] >= min_segment_length)) return "the segment's length is zero (or below min_segment_length)";
  if (m[2] > 4.0 * max_normalized_coordinate)
    return "the segment's length is beyond 4 x the normalised-coordinate limit";
  entry = 3;
  if (std::abs(m[3]) > 2.0 * pi) return "alpha must be within [-2 pi, 2 pi]";
  for (entry = 4; entry < 6; ++entry)
    if (!detail::valid_depth(m[entry])) return "the end point's depth must be within [min_depth, max_depth]";
  entry = -1;
  return nullptr;
}

void SegmentFeature::align(double* m, const double* md) const noexcept {
  if (std::abs(wrap_angle(m[3] - md[3])) > 0.5 * pi) {  // the reverse segment is nearer the goal's
    m[3] = wrap_angle(m[3] + pi);
    std::swap(m[4], m[5]);
  }
}

void SegmentFeature::value(const double* m, double* s) const noexcept {
  const double l = m[2];
  if (normalized_) {
    s[0] = m[0] / l;
    s[1] = m[1] / l;
    s[2] = 1.0 / l;
  } else {
    s[0] = m[0];
    s[1] = m[1];
    s[2] = l;
  }
  s[3] = m[3];
}

void SegmentFeature::error(const double* m, const double* md, double* e) const noexcept {
  double s[4], sd[4];
  value(m, s);
  value(md, sd);
  for (int i = 0; i < 3; ++i) e[i] = s[i] - sd[i];
  e[3] = wrap_angle(s[3] - sd[3]);
}

void SegmentFeature::interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept {
  const double xc = m[0], yc = m[1], l = m[2], c = std::cos(m[3]), s = std::sin(m[3]);
  const double hx = 0.5 * l * c, hy = 0.5 * l * s;  // half the segment, p2 - c
  const Matrix26 L1 = cartesian_jacobian(xc - hx, yc - hy, m[4]);
  const Matrix26 L2 = cartesian_jacobian(xc + hx, yc + hy, m[5]);
  const Matrix26 D = L2 - L1;                        // rate of p2 - p1
  const Eigen::Matrix<double, 1, 6> Lc_x = 0.5 * (L1.row(0) + L2.row(0)), Lc_y = 0.5 * (L1.row(1) + L2.row(1));
  const Eigen::Matrix<double, 1, 6> Ll = c * D.row(0) + s * D.row(1);
  L.row(3) = (-s * D.row(0) + c * D.row(1)) / l;
  if (normalized_) {
    const double il = 1.0 / l;
    L.row(0) = il * (Lc_x - (xc * il) * Ll);
    L.row(1) = il * (Lc_y - (yc * il) * Ll);
    L.row(2) = -(il * il) * Ll;
  } else {
    L.row(0) = Lc_x;
    L.row(1) = Lc_y;
    L.row(2) = Ll;
  }
}

}  // namespace ibvs
