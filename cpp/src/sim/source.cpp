#include "ibvs/sim/source.hpp"

#include "ibvs/features/line.hpp"

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
