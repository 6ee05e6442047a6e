// A user's own feature source (docs/simulator.md, "Your own source"): an image
// line between target points i and j projected from the 3-D points with the
// true pose (no pixel noise: the geometry, not the points the sensor reports),
// its plane, the target's z = 0 plane, from the pose the depth mode gives.
// tests/cpp/test_sim_features.cpp runs it.
#pragma once

#include "ibvs/features/line.hpp"
#include "ibvs/sim/source.hpp"

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>

class ProjectedLineSource final : public ibvs::sim::FeatureSource {
 public:
  ProjectedLineSource(int i, int j) : i_(i), j_(j) {}
  std::unique_ptr<FeatureSource> clone() const override { return std::make_unique<ProjectedLineSource>(*this); }
  std::string describe() const override { return "projected line"; }
  int size() const noexcept override { return 5; }  // rho, theta, A, B, C (features/line.hpp)
  bool fits(const ibvs::Feature& f) const noexcept override {
    return dynamic_cast<const ibvs::LineFeature*>(&f) != nullptr;
  }
  void validate(const Eigen::Matrix3Xd& points, const std::string& name) const override {
    if (i_ < 0 || j_ < 0 || i_ == j_ || std::max(i_, j_) >= points.cols())
      throw std::invalid_argument("ibvs: " + name + ": needs two distinct target points");
  }
  // Every frame: noexcept, no allocation; false = it cannot be measured (lost_feature).
  bool measure(const ibvs::sim::SourceFrame& f, double* m) const noexcept override {
    const Eigen::Vector3d a = f.cMo.topLeftCorner<3, 3>() * f.points->col(i_) + f.cMo.topRightCorner<3, 1>();
    const Eigen::Vector3d b = f.cMo.topLeftCorner<3, 3>() * f.points->col(j_) + f.cMo.topRightCorner<3, 1>();
    double plane[3];
    return ibvs::sim::plane_in_camera(f.depth_pose, Eigen::Vector3d::UnitZ(), 0.0, plane) &&
           ibvs::LineFeature::measure(a(0) / a(2), a(1) / a(2), b(0) / b(2), b(1) / b(2), plane[0], plane[1],
                                      plane[2], m);
  }

 private:
  int i_, j_;
};
