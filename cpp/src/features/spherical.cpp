#include "ibvs/features/spherical.hpp"

#include "ibvs/limits.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace ibvs {

namespace {

// Shared by both kinds: the bearing (unit to 1e-6) and the distance.
const char* check_bearing(const double* m, int& entry) noexcept {
  for (entry = 0; entry < 4; ++entry)
    if (!std::isfinite(m[entry])) return "is not finite";
  entry = -1;
  const double n2 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2];
  if (!(std::abs(n2 - 1.0) <= 2e-6)) return "the bearing (bx, by, bz) must be a unit vector (|b| = 1 to 1e-6)";
  entry = 3;
  if (!(m[3] >= min_depth && m[3] <= max_depth)) return "the distance R must be within [min_depth, max_depth]";
  return nullptr;
}

// The unit bearing of an accepted measurement (renormalised: |b| is 1 to 1e-6 only).
Eigen::Vector3d unit(const double* m) noexcept {
  const Eigen::Vector3d b(m[0], m[1], m[2]);
  return b / b.norm();
}

// Rows of the spherical point block (Hamel & Mahony eq. 9), for s, R.
void point_rows(const Eigen::Vector3d& s, double R, Eigen::Ref<MatrixX6> L) noexcept {
  const double iR = 1.0 / R;
  L.topLeftCorner<3, 3>() = (s * s.transpose() - Eigen::Matrix3d::Identity()) * iR;
  L.block<3, 3>(0, 3) << 0.0, -s.z(), s.y(),  //
      s.z(), 0.0, -s.x(),                      //
      -s.y(), s.x(), 0.0;
}

}  // namespace

std::array<double, 4> SphericalPointFeature::measure(double X, double Y, double Z) {
  const double R = std::sqrt(X * X + Y * Y + Z * Z);
  if (!(R > 0.0) || !std::isfinite(R)) throw std::invalid_argument("ibvs: spherical point: P must be finite and non-zero");
  return {X / R, Y / R, Z / R, R};
}

const char* SphericalPointFeature::check(const double* m, int& entry) const noexcept { return check_bearing(m, entry); }

void SphericalPointFeature::value(const double* m, double* s) const noexcept {
  const Eigen::Vector3d b = unit(m);
  s[0] = b.x();
  s[1] = b.y();
  s[2] = b.z();
}

void SphericalPointFeature::interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept {
  point_rows(unit(m), m[3], L.topRows<3>());
}

SphericalPolarFeature::SphericalPolarFeature(double min_sin) : min_sin_(min_sin) {
  if (!(min_sin > 0.0 && min_sin < 1.0))
    throw std::invalid_argument("ibvs: spherical_polar: min_sin must be in (0, 1), got " + std::to_string(min_sin));
}

std::string SphericalPolarFeature::describe() const {
  if (min_sin_ == default_polar_min_radius) return "spherical_polar";
  char buf[64];
  std::snprintf(buf, sizeof buf, "spherical_polar(min_sin=%g)", min_sin_);
  return buf;
}

const char* SphericalPolarFeature::check(const double* m, int& entry) const noexcept { return check_bearing(m, entry); }

void SphericalPolarFeature::value(const double* m, double* s) const noexcept {
  const Eigen::Vector3d b = unit(m);
  const double sb = std::hypot(b.x(), b.y());
  if (sb < min_sin_) {
    s[0] = b.x();
    s[1] = b.y();
    return;
  }
  s[0] = std::atan2(sb, b.z());
  s[1] = polar_angle(b.x(), b.y());
}

void SphericalPolarFeature::error(const double* m, const double* md, double* e) const noexcept {
  const Eigen::Vector3d b = unit(m), bd = unit(md);
  const double sb = std::hypot(b.x(), b.y()), sbd = std::hypot(bd.x(), bd.y());
  if (sb < min_sin_) {  // the (bx, by) rows
    e[0] = b.x() - bd.x();
    e[1] = b.y() - bd.y();
    return;
  }
  e[0] = std::atan2(sb, b.z()) - std::atan2(sbd, bd.z());
  e[1] = sbd < min_sin_ ? 0.0 : wrap_angle(polar_angle(b.x(), b.y()) - polar_angle(bd.x(), bd.y()));
}

std::uint64_t SphericalPolarFeature::axis_angle_rows(const double* m, const double* md) const noexcept {
  // As error(): the azimuth row is an angle only when neither bearing is within min_sin of the axis.
  const Eigen::Vector3d b = unit(m), bd = unit(md);
  return std::hypot(b.x(), b.y()) < min_sin_ || std::hypot(bd.x(), bd.y()) < min_sin_ ? 0 : std::uint64_t{1} << 1;
}

void SphericalPolarFeature::interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept {
  const Eigen::Vector3d b = unit(m);
  const double R = m[3], iR = 1.0 / R, sb = std::hypot(b.x(), b.y());
  if (sb < min_sin_) {
    Eigen::Matrix<double, 3, 6> P;
    point_rows(b, R, P);
    L.topRows<2>() = P.topRows<2>();
    return;
  }
  const double cb = b.z(), cp = b.x() / sb, sp = b.y() / sb, cot = cb / sb;
  L.row(0) << -cb * cp * iR, -cb * sp * iR, sb * iR, sp, -cp, 0.0;
  L.row(1) << sp * iR / sb, -cp * iR / sb, 0.0, cp * cot, sp * cot, -1.0;
}

int spherical_measurements(const CameraModel& camera, const Eigen::Ref<const Points>& pixels,
                           const Eigen::Ref<const Eigen::VectorXd>& distance,
                           Eigen::Ref<Eigen::VectorXd> measurements) noexcept {
  const Eigen::Index n = pixels.cols();
  if (distance.size() != n || measurements.size() != 4 * n) {
    measurements.setConstant(std::numeric_limits<double>::quiet_NaN());
    return static_cast<int>(n);
  }
  int failed = 0;
  Eigen::Vector3d b;
  for (Eigen::Index i = 0; i < n; ++i) {
    const bool ok = camera.to_bearing(pixels(0, i), pixels(1, i), b) && distance(i) >= min_depth && distance(i) <= max_depth;
    measurements.segment<3>(4 * i) = b;
    measurements(4 * i + 3) = ok ? distance(i) : std::numeric_limits<double>::quiet_NaN();
    if (!ok) measurements.segment<3>(4 * i).setConstant(std::numeric_limits<double>::quiet_NaN());
    failed += !ok;
  }
  return failed;
}

}  // namespace ibvs
