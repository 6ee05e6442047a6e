// Pose of a planar target from its image points (depth mode "pose", the
// paper's experiments: "the actual point depth based on pose estimation").
//
// Linear start: the homography H ~ [r1 r2 t] between the target plane (z = 0)
// and the normalised image (DLT on the 4+ points, smallest eigenvector of
// A^T A), decomposed and re-orthonormalised; then a few Gauss-Newton steps on
// the reprojection error in normalised coordinates. Fixed-size algebra: no
// heap allocation after construction.
#pragma once

#include "ibvs/layout.hpp"
#include "ibvs/se3.hpp"

#include <Eigen/Core>

namespace ibvs::sim {

class PlanarPose {
 public:
  /// points: 3 x N in the target frame, all with z = 0, N >= 4
  /// (throws std::invalid_argument otherwise).
  explicit PlanarPose(const Eigen::Matrix3Xd& points, int iterations = 5);

  /// Camera <- target pose from normalised image points uv (2 x N).
  /// Returns false when the estimate is degenerate (then T is unchanged).
  bool estimate(const Eigen::Ref<const Points>& uv, Pose& T) const noexcept;

 private:
  Eigen::Matrix3Xd points_;
  int iterations_;
};

}  // namespace ibvs::sim
