#include "ibvs/features/ellipse.hpp"

#include "../checks.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs {

namespace {

[[noreturn]] void refuse_ellipse(const std::string& what) { throw std::invalid_argument("ibvs: ellipse: " + what); }

// The measurement `m` as check() sees it: thrown as the reason when refused.
std::array<double, 8> checked(const std::array<double, 8>& m, const char* from) {
  int entry = -1;
  if (const char* why = EllipseFeature().check(m.data(), entry))
    refuse_ellipse(std::string(from) + " gives a refused measurement" +
           (entry >= 0 ? " (entry " + std::to_string(entry) + ")" : std::string()) + ": " + why);
  return m;
}

}  // namespace

std::array<double, 8> EllipseFeature::project_circle(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal,
                                                     double radius) {
  if (!centre.allFinite()) refuse_ellipse("centre is not finite");
  if (!normal.allFinite() || !(normal.norm() > 0.0)) refuse_ellipse("normal must be finite and nonzero");
  if (!(radius > 0.0) || !std::isfinite(radius))
    refuse_ellipse("radius must be finite and > 0, got " + detail::number(radius));
  const Eigen::Vector3d n = normal.normalized();
  const double d = n.dot(centre);  // the plane n . X = d; |d| its distance from the camera centre
  if (!(std::abs(d) >= min_depth))
    refuse_ellipse("the circle's plane passes within min_depth of the camera centre (seen edge-on: no ellipse)");
  // Depths of the circle's points: Z0 +- radius |n x e_z|.
  const double spread = radius * std::hypot(n.x(), n.y());
  if (!(centre.z() - spread >= min_depth) || !(centre.z() + spread <= max_depth))
    refuse_ellipse("the circle must lie wholly at depths within [" + detail::number(min_depth) + ", " +
           detail::number(max_depth) + "] m (in front of the camera)");
  std::array<double, 8> m;
  if (!project_circle(centre, normal, radius, m.data())) refuse_ellipse("the circle's image is not an ellipse");
  return checked(m, "the circle");
}

bool EllipseFeature::project_circle(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal, double radius,
                                    double* m) noexcept {
  if (!centre.allFinite() || !normal.allFinite() || !(normal.norm() > 0.0) || !(radius > 0.0) ||
      !std::isfinite(radius))
    return false;
  const Eigen::Vector3d n = normal.normalized();
  const double d = n.dot(centre);
  if (!(std::abs(d) >= min_depth)) return false;  // the plane through the camera centre: seen edge-on
  const double spread = radius * std::hypot(n.x(), n.y());
  if (!(centre.z() - spread >= min_depth) || !(centre.z() + spread <= max_depth)) return false;
  // An image point x~ = (x, y, 1) sees the plane at X = (d / n.x~) x~, on the circle when
  // |d x~ - (n.x~) X0|^2 = r^2 (n.x~)^2: a conic. Written about the centre's image x0 = X0 / Z0
  // (x~ = x0~ + (u, 0)), where the terms of size |X0|^2 cancel exactly, and divided by d^2:
  //   |G u|^2 = r^2 (1/Z0 + a2 . u)^2,  G = (I - X0 a^T) restricted to (u1, u2), a = n / d,
  // i.e. u^T M u + 2 b^T u + c = 0 with M = G^T G - r^2 a2 a2^T, b = -r^2 a2 / Z0, c = -r^2 / Z0^2.
  const Eigen::Vector3d a = n / d;
  const Eigen::Vector2d a2 = a.head<2>();
  const Eigen::Matrix<double, 3, 2> G =
      Eigen::Matrix<double, 3, 2>::Identity() - centre * a2.transpose();  // (I - X0 a^T) e1, e2
  const double r2 = radius * radius, iz = 1.0 / centre.z();
  const Eigen::Matrix2d M = G.transpose() * G - r2 * a2 * a2.transpose();
  if (!(M.determinant() > 0.0) || !(M.trace() > 0.0)) return false;  // a parabola or hyperbola: not an ellipse
  const Eigen::Matrix2d Mi = M.inverse();
  // Centre u_g = -M^-1 b; the ellipse (u - u_g)^T M (u - u_g) = k, k = b^T M^-1 b - c; N = k M^-1 / 4.
  const Eigen::Vector2d ug = (r2 * iz) * (Mi * a2);
  const double k = r2 * iz * iz * (1.0 + r2 * a2.dot(Mi * a2));
  const Eigen::Matrix2d N = 0.25 * k * Mi;
  const double out[8] = {centre.x() * iz + ug.x(), centre.y() * iz + ug.y(), N(0, 0), N(0, 1), N(1, 1),
                         a.x(), a.y(), a.z()};
  for (int r = 0; r < 8; ++r) {
    if (!std::isfinite(out[r])) return false;
    m[r] = out[r];
  }
  return true;
}

std::array<double, 8> EllipseFeature::measure_moments(const std::array<double, 6>& mo, double A, double B, double C,
                                                      const CameraModel& camera) {
  static const char* names[6] = {"m00", "m10", "m01", "mu20", "mu11", "mu02"};
  for (int i = 0; i < 6; ++i)
    if (!std::isfinite(mo[static_cast<std::size_t>(i)]))
      refuse_ellipse(std::string("moments: ") + names[i] + " is not finite");
  if (!(mo[0] > 0.0)) refuse_ellipse("moments: m00 (the area) must be > 0, got " + detail::number(mo[0]));
  if (camera.distortion() != Distortion::none)
    refuse_ellipse("moments of a distorted image are not those of the undistorted blob: undistort the image first "
           "(cv2.undistort) and pass a camera without distortion");
  // Pixels u = u0 + px x, v = v0 + py y: the centroid maps as a point, mu_ij / m00 scales by px^i py^j.
  const double px = camera.px(), py = camera.py(), ia = 1.0 / mo[0];
  return checked({(mo[1] * ia - camera.u0()) / px, (mo[2] * ia - camera.v0()) / py, mo[3] * ia / (px * px),
                  mo[4] * ia / (px * py), mo[5] * ia / (py * py), A, B, C},
                 "the moments");
}

const char* EllipseFeature::check(const double* m, int& entry) const noexcept {
  for (entry = 0; entry < 8; ++entry)
    if (!std::isfinite(m[entry])) return "is not finite";
  for (entry = 0; entry < 2; ++entry)
    if (!detail::valid_coordinate(m[entry])) return "the centroid is beyond the normalised-coordinate limit";
  const double big = max_normalized_coordinate * max_normalized_coordinate;
  for (entry = 2; entry < 5; entry += 2)
    if (!(m[entry] > 0.0 && m[entry] <= big)) return "n20 and n02 must be within (0, max_normalized_coordinate^2]";
  entry = -1;
  const double n20 = m[2], n11 = m[3], n02 = m[4];
  if (!(n20 * n02 - n11 * n11 > 0.0)) return "zero or negative area (n20 n02 - n11^2 <= 0)";
  for (entry = 5; entry < 8; ++entry)
    if (std::abs(m[entry]) > 1.0 / min_depth) return "the plane's A, B, C must be within 1 / min_depth";
  entry = -1;
  const double A = m[5], B = m[6], zg = A * m[0] + B * m[1] + m[7];
  const double least = zg - 2.0 * std::sqrt(A * A * n20 + 2.0 * A * B * n11 + B * B * n02);
  if (!(least >= 1.0 / max_depth))
    return "the plane is seen edge-on or behind the camera (1/Z = A x + B y + C must be > 0 over the ellipse)";
  return nullptr;
}

void EllipseFeature::value(const double* m, double* s) const noexcept {
  for (int i = 0; i < 5; ++i) s[i] = m[i];
}

void EllipseFeature::interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept {
  const double xg = m[0], yg = m[1], n20 = m[2], n11 = m[3], n02 = m[4], A = m[5], B = m[6], C = m[7];
  const double zg = A * xg + B * yg + C;
  const double px = A * n20 + B * n11, py = A * n11 + B * n02;  // N (A, B)
  // Eq. (14): the centroid.
  L.row(0) << -zg, 0.0, xg * zg + 4.0 * px, xg * yg + 4.0 * n11, -(1.0 + xg * xg + 4.0 * n20), yg;
  L.row(1) << 0.0, -zg, yg * zg + 4.0 * py, 1.0 + yg * yg + 4.0 * n02, -(xg * yg + 4.0 * n11), -xg;
  // Eq. (26): the normalised centred moments.
  L.row(2) << -2.0 * px, 0.0, 2.0 * ((zg + A * xg) * n20 + B * xg * n11), 2.0 * (yg * n20 + xg * n11),
      -4.0 * xg * n20, 2.0 * n11;
  L.row(3) << -py, -px, A * yg * n20 + (3.0 * zg - C) * n11 + B * xg * n02, 3.0 * yg * n11 + xg * n02,
      -(yg * n20 + 3.0 * xg * n11), n02 - n20;
  L.row(4) << 0.0, -2.0 * py, 2.0 * ((zg + B * yg) * n02 + A * yg * n11), 4.0 * yg * n02,
      -2.0 * (yg * n11 + xg * n02), -2.0 * n11;
}

}  // namespace ibvs
