#include "ibvs/sim/target.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace ibvs::sim {

namespace {
// Corners of a square of half-side h in the z = 0 plane: (-,-), (+,-), (+,+), (-,+).
Eigen::Matrix3Xd square_points(double h) {
  Eigen::Matrix3Xd p(3, 4);
  p << -h, h, h, -h,  //
      -h, -h, h, h,   //
      0, 0, 0, 0;
  return p;
}
}  // namespace

// Special members out of line: the points are allocated and freed by the library's code only.
Target::Target(const Target&) = default;
Target::Target(Target&&) noexcept = default;
Target& Target::operator=(const Target&) = default;
Target& Target::operator=(Target&&) noexcept = default;
Target::~Target() = default;

Target::Target(Eigen::Matrix3Xd points_, const Pose& pose_) : points(std::move(points_)), pose(pose_) {}

Target Target::paper() {
  Target t;
  t.points = square_points(0.25);
  t.pose = Pose::Identity();
  t.pose(2, 3) = 3.0;
  return t;
}

Target Target::square(double side, const Pose& pose) {
  if (!(side > 0.0) || !std::isfinite(side))
    throw std::invalid_argument("ibvs: side must be finite and > 0, got " + std::to_string(side));
  Target t;
  t.points = square_points(side / 2);
  t.pose = pose;
  t.validate();
  return t;
}

bool Target::planar(double tol) const noexcept {
  for (Eigen::Index i = 0; i < points.cols(); ++i)
    if (std::abs(points(2, i)) > tol) return false;
  return true;
}

Eigen::Matrix3Xd Target::world_points() const {
  return (pose.topLeftCorner<3, 3>() * points).colwise() + pose.topRightCorner<3, 1>();
}

void Target::validate() const {
  if (points.cols() < 1) throw std::invalid_argument("ibvs: target needs at least one point");
  if (!points.allFinite()) throw std::invalid_argument("ibvs: target points must be finite");
  if (!pose.allFinite()) throw std::invalid_argument("ibvs: target pose must be finite");
  const Eigen::Matrix3d R = pose.topLeftCorner<3, 3>();
  if (!(R.transpose() * R).isIdentity(1e-9) || std::abs(R.determinant() - 1.0) > 1e-9 ||
      !pose.bottomRows<1>().isApprox(Eigen::RowVector4d(0, 0, 0, 1)))
    throw std::invalid_argument("ibvs: target pose must be a rigid transform (orthonormal R, last row 0 0 0 1)");
  for (std::size_t k = 0; k < sources.size(); ++k) {
    const std::string name = "target sources[" + std::to_string(k) + "]";
    if (!sources[k]) throw std::invalid_argument("ibvs: " + name + " must not be null");
    sources[k]->validate(points, name + " (" + sources[k]->describe() + ")");
  }
}

Target& Target::add(const FeatureSource& source) {
  const std::string name = "target sources[" + std::to_string(sources.size()) + "] (" + source.describe() + ")";
  source.validate(points, name);
  sources.push_back(std::shared_ptr<const FeatureSource>(source.clone()));
  return *this;
}

std::string Target::describe() const {
  char buf[160];
  std::snprintf(buf, sizeof buf, "Target(%d points, origin at (%g, %g, %g)", size(), pose(0, 3), pose(1, 3),
                pose(2, 3));
  std::string out = buf;
  for (std::size_t k = 0; k < sources.size(); ++k) out += (k ? ", " : "; features ") + sources[k]->describe();
  return out + ")";
}

}  // namespace ibvs::sim
