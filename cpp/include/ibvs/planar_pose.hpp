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
//
// From unit bearings (estimate_bearings: a fisheye's or omnidirectional
// camera's CameraModel::to_bearing, at any angle off the axis, beyond 90
// degrees too): the same DLT on the bearings as homogeneous image points (the
// constraint b x (H X) = 0 holds for any direction, z < 0 included; Hartley
// & Zisserman, Multiple View Geometry, 2nd ed., eq. 4.1 and Section 4.4 for
// the normalisation, here a rotation of the mean bearing onto z and a scale
// of the spread about it), the sign of H that puts every point in front along
// its bearing (b . (R X + t) > 0, not z > 0), then Gauss-Newton steps on each
// bearing's tangent-plane residual B^T P/|P| (B an orthonormal basis of the
// plane orthogonal to b), with the spherical point's Jacobian (Hamel & Mahony,
// IEEE T-RA 18(2) 2002, eq. 9; features/spherical.hpp). Its range output is
// each point's distance |P| from the camera centre (the R of the spherical
// features and of sim::SphericalSource).
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

  /// Throws std::invalid_argument naming bearings when estimate_bearings() would refuse them
  /// (not 3 x N, a column not finite or of zero length).
  void validate_bearings(const Eigen::Ref<const Eigen::Matrix3Xd>& bearings) const;
  /// Camera <- target pose from the points' bearings (3 x N directions in the camera frame, any
  /// non-zero length: CameraModel::to_bearing of the pixels), at any angle off the optical axis.
  /// Returns false when validate_bearings() would refuse them or the estimate is degenerate (the
  /// DLT's homography not determined: e.g. four points whose bearings lie in one plane, i.e. the
  /// camera centre in the target's plane, where five or more still determine it; a point not in
  /// front along its bearing); T is then unchanged. noexcept, allocation-free.
  bool estimate_bearings(const Eigen::Ref<const Eigen::Matrix3Xd>& bearings, Pose& T) const noexcept;
  /// The same, and each point's range |R p_i + t| (N, metres: its distance from the camera centre
  /// along its bearing; unchanged when degenerate).
  bool estimate_bearings(const Eigen::Ref<const Eigen::Matrix3Xd>& bearings, Pose& T,
                         Eigen::Ref<Eigen::VectorXd> range) const noexcept;

 private:
  Eigen::Matrix3Xd points_;
  int iterations_;
};

}  // namespace ibvs
