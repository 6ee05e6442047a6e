#include "ibvs/sim/source.hpp"

#include "ibvs/features.hpp"
#include "ibvs/features/line.hpp"
#include "ibvs/features/spherical.hpp"
#include "ibvs/features/segment.hpp"
#include "ibvs/limits.hpp"

#include "../checks.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs::sim {

FeatureSource::~FeatureSource() = default;

void FeatureSource::validate(const Eigen::Matrix3Xd&, const std::string&) const {}

bool plane_in_camera(const Pose& cMo, const Eigen::Vector3d& n, double d, double plane[3]) noexcept {
  // X_c = R X + t, so n . X = d becomes (R n) . X_c = d + (R n) . t; with X_c = Z (x, y, 1),
  // 1/Z = (R n) . (x, y, 1) / (d + (R n) . t).
  const Eigen::Vector3d nc = cMo.topLeftCorner<3, 3>() * n;
  const double dc = d + nc.dot(cMo.topRightCorner<3, 1>());
  if (!(std::abs(dc) > 0.0) || !std::isfinite(dc) || !nc.allFinite()) return false;
  const Eigen::Vector3d p = nc / dc;
  if (!p.allFinite()) return false;  // a plane nearly through the camera centre: 1/Z overflows
  for (int r = 0; r < 3; ++r) plane[r] = p(r);
  return true;
}

LineSource::LineSource(int i, int j, int k) : i_(i), j_(j), k_(k) {
  if (i < 0 || j < 0) throw std::invalid_argument("ibvs: line: point indices must be >= 0");
  if (i == j) throw std::invalid_argument("ibvs: line: needs two distinct points, got " + std::to_string(i) + " twice");
  if (k < -1 || k == i || k == j)
    throw std::invalid_argument("ibvs: line: the plane's third point must be another point (or -1: the target plane)");
}

std::string LineSource::describe() const {
  return "line(" + std::to_string(i_) + ", " + std::to_string(j_) + (k_ >= 0 ? ", " + std::to_string(k_) : "") + ")";
}

bool LineSource::fits(const Feature& f) const noexcept { return dynamic_cast<const LineFeature*>(&f) != nullptr; }

void LineSource::validate(const Eigen::Matrix3Xd& points, const std::string& name) const {
  const int n = static_cast<int>(points.cols());
  const auto fail = [&](const std::string& why) { throw std::invalid_argument("ibvs: " + name + ": " + why); };
  for (int p : {i_, j_, k_})
    if (p >= n) fail("point " + std::to_string(p) + " is not a target point (the target has " + std::to_string(n) + ")");
  const Eigen::Vector3d a = points.col(i_), b = points.col(j_);
  const double scale = std::max({1.0, a.norm(), b.norm()});
  if ((b - a).norm() <= 1e-12 * scale) fail("its two points coincide");
  if (k_ < 0) {
    if (std::abs(a(2)) > 1e-12 * scale || std::abs(b(2)) > 1e-12 * scale)
      fail("its points are not in the target's z = 0 plane: give a third point for the plane that holds the line");
  } else if ((b - a).cross(points.col(k_) - a).norm() <= 1e-12 * scale * scale) {
    fail("its third point is on the line: no plane");
  }
}

bool LineSource::measure(const SourceFrame& f, double* m) const noexcept {
  // The plane holding the 3-D line, in the target frame: z = 0, or through points i, j and k.
  Eigen::Vector3d n(0.0, 0.0, 1.0);
  double d = 0.0;
  if (k_ >= 0) {
    const auto& P = *f.points;
    n = (P.col(j_) - P.col(i_)).cross(P.col(k_) - P.col(i_)).normalized();
    d = n.dot(P.col(i_));
  }
  double plane[3];
  if (!plane_in_camera(f.depth_pose, n, d, plane)) return false;
  const auto& uv = *f.uv;
  return LineFeature::measure(uv(0, i_), uv(1, i_), uv(0, j_), uv(1, j_), plane[0], plane[1], plane[2], m);
}

}  // namespace ibvs::sim

namespace ibvs::sim {

namespace {

/// The goal's a* and Z* of a planar target (z = 0) seen with pose cMo: the area of its image
/// (a polygon's by the shoelace formula, or the points' mu20 + mu02) and the depth of the plane at
/// the image's centre of gravity. False when a point is not in front of the camera.
bool goal_area_depth(const Eigen::Matrix3Xd& P, const Pose& cMo, MomentsFeature::Source source, double& a,
                     double& z) noexcept {
  const Eigen::Index n = P.cols();
  const auto image = [&](Eigen::Index k, double& x, double& y) {
    const Eigen::Vector3d q = cMo.topLeftCorner<3, 3>() * P.col(k) + cMo.topRightCorner<3, 1>();
    x = q(0) / q(2);
    y = q(1) / q(2);
    return q(2) >= min_depth;
  };
  double s0 = 0.0, sx = 0.0, sy = 0.0, sxx = 0.0, syy = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    double x0, y0, x1, y1;
    if (!image(k, x0, y0) || !image((k + 1) % n, x1, y1)) return false;
    if (source == MomentsFeature::Source::region) {
      const double c = x0 * y1 - x1 * y0;  // Green's theorem: m00 = sum c / 2, m10 = sum (x0 + x1) c / 6
      s0 += c / 2.0;
      sx += (x0 + x1) * c / 6.0;
      sy += (y0 + y1) * c / 6.0;
    } else {
      s0 += 1.0;
      sx += x0;
      sy += y0;
      sxx += x0 * x0;
      syy += y0 * y0;
    }
  }
  if (!(std::abs(s0) > 0.0)) return false;
  a = source == MomentsFeature::Source::region ? std::abs(s0) : sxx - sx * sx / s0 + syy - sy * sy / s0;
  double plane[3];
  if (!plane_in_camera(cMo, Eigen::Vector3d::UnitZ(), 0.0, plane)) return false;
  const double inverse_depth = plane[0] * sx / s0 + plane[1] * sy / s0 + plane[2];
  z = 1.0 / inverse_depth;
  return inverse_depth > 0.0 && std::isfinite(z) && a > 0.0;
}

/// Whether T is finite (a NaN depth pose: no estimate yet).
bool known(const Pose& T) noexcept { return T.allFinite(); }

/// A measurement of n values is answered only when every one is finite (e.g. not the moments of
/// points beyond the overflow range, not a NaN depth).
bool finite(const double* m, int n) noexcept {
  return std::all_of(m, m + n, [](double v) { return std::isfinite(v); });
}

}  // namespace

std::string MomentsSource::describe() const {
  return std::string("moments(") + (source_ == MomentsFeature::Source::region ? "region" : "points") + ")";
}

bool MomentsSource::fits(const Feature& f) const noexcept {
  const auto* m = dynamic_cast<const MomentsFeature*>(&f);
  return m != nullptr && m->source() == source_;
}

void MomentsSource::validate(const Eigen::Matrix3Xd& points, const std::string& name) const {
  if (points.cols() < 3) throw std::invalid_argument("ibvs: " + name + ": moments need at least 3 target points");
  if (!points.allFinite()) throw std::invalid_argument("ibvs: " + name + ": the target's points must be finite");
  const double scale = std::max(1.0, largest_magnitude(points));
  if (!finite_within(points.row(2), 1e-12 * scale))
    throw std::invalid_argument("ibvs: " + name + ": the target's points must be in its z = 0 plane (a planar object)");
}

bool MomentsSource::measure(const SourceFrame& f, double* m) const noexcept {
  double a_desired = 0.0, depth_desired = 0.0, plane[3];
  if (!goal_area_depth(*f.points, f.goal, source_, a_desired, depth_desired)) return false;
  if (!known(f.depth_pose) || !plane_in_camera(f.depth_pose, Eigen::Vector3d::UnitZ(), 0.0, plane)) return false;
  const Moments mo = source_ == MomentsFeature::Source::region ? MomentsFeature::of_polygon(*f.uv)
                                                                 : MomentsFeature::of_points(*f.uv);
  const auto out = MomentsFeature::measure(mo, source_, a_desired, depth_desired, plane[0], plane[1], plane[2]);
  std::copy(out.begin(), out.end(), m);
  return finite(m, MomentsFeature::measurement_size);
}

std::string PbvsSource::describe() const {
  return std::string("pbvs(") + (target_ == PbvsTarget::desired_camera ? "desired_camera" : "object") + ")";
}

bool PbvsSource::fits(const Feature& f) const noexcept {
  const auto* p = dynamic_cast<const PbvsFeature*>(&f);
  return p != nullptr && p->target() == target_;
}

/// camera <- target rotations of the depth pose and the goal: a rigid transform's, to the 1e-6
/// PbvsFeature::measure asks (checked here so that measure() need not throw).
static bool rigid(const Pose& T) noexcept {
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  return T.allFinite() && finite_within(R.transpose() * R - Eigen::Matrix3d::Identity(), 1e-6) &&
         R.determinant() > 0.0 && T(3, 0) == 0.0 && T(3, 1) == 0.0 && T(3, 2) == 0.0 && T(3, 3) == 1.0;
}

bool PbvsSource::measure(const SourceFrame& f, double* m) const noexcept {
  if (!rigid(f.depth_pose) || !rigid(f.goal)) return false;
  const Pose cdMc = f.goal * se3_inverse(f.depth_pose);  // the current camera in the desired camera's frame
  const Eigen::Vector3d tu = theta_u(cdMc.topLeftCorner<3, 3>());
  const Eigen::Vector3d t = target_ == PbvsTarget::desired_camera ? Eigen::Vector3d(cdMc.topRightCorner<3, 1>())
                                                                  : Eigen::Vector3d(f.depth_pose.topRightCorner<3, 1>());
  for (int r = 0; r < 3; ++r) {
    m[r] = t(r);
    m[3 + r] = tu(r);
  }
  return finite(m, 6);
}

Point25DSource::Point25DSource(int i) : i_(i) {
  if (i < 0) throw std::invalid_argument("ibvs: point25d: the reference point's index must be >= 0");
}

bool Point25DSource::fits(const Feature& f) const noexcept {
  return dynamic_cast<const Point25DFeature*>(&f) != nullptr;
}

void Point25DSource::validate(const Eigen::Matrix3Xd& points, const std::string& name) const {
  if (i_ >= points.cols())
    throw std::invalid_argument("ibvs: " + name + ": point " + std::to_string(i_) + " is not a target point (the target has " +
                                std::to_string(points.cols()) + ")");
}

bool Point25DSource::measure(const SourceFrame& f, double* m) const noexcept {
  if (!rigid(f.depth_pose) || !rigid(f.goal)) return false;
  const Eigen::Matrix3d cdRc = f.goal.topLeftCorner<3, 3>() * f.depth_pose.topLeftCorner<3, 3>().transpose();
  const Eigen::Vector3d tu = theta_u(cdRc);
  m[0] = (*f.uv)(0, i_);
  m[1] = (*f.uv)(1, i_);
  m[2] = (*f.depth)(i_);
  for (int r = 0; r < 3; ++r) m[3 + r] = tu(r);
  return finite(m, 6);
}

SphericalSource::SphericalSource(int i) : i_(i) {
  if (i < 0) throw std::invalid_argument("ibvs: spherical: point index must be >= 0, got " + std::to_string(i));
}

bool SphericalSource::fits(const Feature& f) const noexcept {
  return dynamic_cast<const SphericalPointFeature*>(&f) != nullptr ||
         dynamic_cast<const SphericalPolarFeature*>(&f) != nullptr;
}

void SphericalSource::validate(const Eigen::Matrix3Xd& points, const std::string& name) const {
  if (i_ >= points.cols())
    throw std::invalid_argument("ibvs: " + name + ": point " + std::to_string(i_) +
                                " is not a target point (the target has " + std::to_string(points.cols()) + ")");
}

bool SphericalSource::measure(const SourceFrame& f, double* m) const noexcept {
  if (!f.bearings || !f.points) return false;
  const Eigen::Vector3d b = f.bearings->col(i_);
  const Eigen::Vector3d p =
      f.depth_pose.topLeftCorner<3, 3>() * f.points->col(i_) + f.depth_pose.topRightCorner<3, 1>();
  const double R = p.norm();
  if (!b.allFinite() || !std::isfinite(R) || !(R > 0.0)) return false;
  m[0] = b(0);
  m[1] = b(1);
  m[2] = b(2);
  m[3] = R;
  return true;
}

}  // namespace ibvs::sim

// ---------------------------------------------------------------- segments and circles

namespace ibvs::sim {

SegmentSource::SegmentSource(int i, int j) : i_(i), j_(j) {
  if (i < 0 || j < 0) throw std::invalid_argument("ibvs: segment: point indices i, j must be >= 0");
  if (i == j)
    throw std::invalid_argument("ibvs: segment: i and j must be two distinct points, got " + std::to_string(i) +
                                " twice");
}

std::string SegmentSource::describe() const {
  return "segment(" + std::to_string(i_) + ", " + std::to_string(j_) + ")";
}

bool SegmentSource::fits(const Feature& f) const noexcept { return dynamic_cast<const SegmentFeature*>(&f) != nullptr; }

void SegmentSource::validate(const Eigen::Matrix3Xd& points, const std::string& name) const {
  const int n = static_cast<int>(points.cols());
  for (int p : {i_, j_})
    if (p >= n)
      throw std::invalid_argument("ibvs: " + name + ": point " + std::to_string(p) +
                                  " is not a target point (the target has " + std::to_string(n) + ")");
  const Eigen::Vector3d a = points.col(i_), b = points.col(j_);
  if ((b - a).norm() <= 1e-12 * std::max({1.0, a.norm(), b.norm()}))
    throw std::invalid_argument("ibvs: " + name + ": its points i = " + std::to_string(i_) + " and j = " +
                                std::to_string(j_) + " coincide (a segment of zero length)");
}

bool SegmentSource::measure(const SourceFrame& f, double* m) const noexcept {
  // SegmentFeature::measure's arithmetic, without its throws: Feature::check refuses the rest.
  const auto& uv = *f.uv;
  const double x1 = uv(0, i_), y1 = uv(1, i_), x2 = uv(0, j_), y2 = uv(1, j_);
  const double dx = x2 - x1, dy = y2 - y1, l = std::hypot(dx, dy);
  if (!(l >= min_segment_length)) return false;  // seen end-on: no orientation
  m[0] = 0.5 * (x1 + x2);
  m[1] = 0.5 * (y1 + y2);
  m[2] = l;
  m[3] = polar_angle(dx, dy);
  m[4] = (*f.depth)(i_);
  m[5] = (*f.depth)(j_);
  return finite(m, 6);
}

EllipseSource::EllipseSource(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal, double radius)
    : centre_(centre), radius_(radius) {
  if (!centre.allFinite()) throw std::invalid_argument("ibvs: ellipse source: centre must be finite");
  if (!normal.allFinite() || !(normal.norm() > 0.0) || !std::isfinite(normal.squaredNorm()))
    throw std::invalid_argument("ibvs: ellipse source: normal must be finite and of nonzero length");
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("ibvs: ellipse source: radius must be finite and > 0, got " + detail::number(radius));
  normal_ = normal.normalized();
}

std::string EllipseSource::describe() const {
  return "circle(centre " + detail::number(centre_.x()) + " " + detail::number(centre_.y()) + " " +
         detail::number(centre_.z()) + ", radius " + detail::number(radius_) + ")";
}

bool EllipseSource::fits(const Feature& f) const noexcept { return dynamic_cast<const EllipseFeature*>(&f) != nullptr; }

bool EllipseSource::measure(const SourceFrame& f, double* m) const noexcept {
  const Eigen::Matrix3d R = f.cMo.topLeftCorner<3, 3>();
  const Eigen::Vector3d c = R * centre_ + f.cMo.topRightCorner<3, 1>(), n = R * normal_;
  double plane[3];
  if (!EllipseFeature::project_circle(c, n, radius_, m)) return false;
  if (!known(f.depth_pose) || !plane_in_camera(f.depth_pose, normal_, normal_.dot(centre_), plane)) return false;
  for (int r = 0; r < 3; ++r) m[5 + r] = plane[r];
  return finite(m, 8);
}

}  // namespace ibvs::sim
