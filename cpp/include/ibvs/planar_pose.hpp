// Pose of a planar target from its image points: camera <- target and the
// points' depths, for the "pose" depth of the simulator (the paper's "actual
// point depth based on pose estimation") and for users with a planar target.
//
// Linear start: the homography H ~ [r1 r2 t] between the target plane (z = 0)
// and the normalised image (DLT on the 4+ points, smallest eigenvector of
// A^T A), decomposed and re-orthonormalised; then a few Gauss-Newton steps on
// the reprojection error in normalised coordinates. Fixed-size algebra: no
// heap allocation after construction.
//
// Frames and units: target points in the target's own frame (metres, all with
// z = 0); image points in normalised coordinates (CameraModel::normalize of the
// pixels); the pose T maps target coordinates into the camera frame
// (camera <- target, 4x4, metres); depths are the points' z in the camera frame.
#pragma once

#include "ibvs/layout.hpp"
#include "ibvs/se3.hpp"

#include <Eigen/Core>

namespace ibvs {

class PlanarPose {
 public:
  /// points: 3 x N in the target frame, all with z = 0, N >= 4, not all on one
  /// line; iterations >= 0 Gauss-Newton steps (throws std::invalid_argument).
  explicit PlanarPose(const Eigen::Matrix3Xd& points, int iterations = 5);
  // Special members defined in the library (which allocates the points), for consumers built with other flags.
  PlanarPose(const PlanarPose&);
  PlanarPose(PlanarPose&&) noexcept;
  PlanarPose& operator=(const PlanarPose&);
  PlanarPose& operator=(PlanarPose&&) noexcept;
  ~PlanarPose();

  int n_points() const noexcept { return static_cast<int>(points_.cols()); }
  const Eigen::Matrix3Xd& points() const noexcept { return points_; }
  int iterations() const noexcept { return iterations_; }

  /// Throws std::invalid_argument naming uv when estimate() would refuse it
  /// (wrong size, a point not finite or beyond ibvs::max_normalized_coordinate).
  void validate(const Eigen::Ref<const Points>& uv) const;
  /// Camera <- target pose from normalised image points uv (2 x N). Returns
  /// false when validate() would refuse uv or the estimate is degenerate
  /// (collinear image, a point behind the camera); T is then unchanged.
  bool estimate(const Eigen::Ref<const Points>& uv, Pose& T) const noexcept;
  /// The same, and the points' depths (N) in the camera frame (unchanged when degenerate).
  bool estimate(const Eigen::Ref<const Points>& uv, Pose& T, Eigen::Ref<Eigen::VectorXd> depth) const noexcept;

 private:
  Eigen::Matrix3Xd points_;
  int iterations_;
};

}  // namespace ibvs
