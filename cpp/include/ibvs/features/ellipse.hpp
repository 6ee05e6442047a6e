// An image ellipse (or any planar blob) by its centroid and normalised centred
// second-order moments, s = (xg, yg, n20, n11, n02) (ViSP's vpFeatureEllipse):
// xg, yg the centroid and n_ij = mu_ij / a the centred moments divided by the
// area a (normalised coordinates). For a uniform ellipse {u : u^T S^-1 u <= 1}
// about its centroid, [n20 n11; n11 n02] = S / 4 (a disc of radius R: R^2 / 4).
// The region lies on the plane 1/Z = A x + B y + C (a 3-D circle's plane, or a
// planar blob's).
//
// Interaction matrix: Chaumette, "Image moments: a general and useful set of
// features for visual servoing", IEEE T-RO 20(4) 2004: the centroid rows are
// eq. (14) and the n_ij rows eq. (26) (the numbers ViSP's vpFeatureEllipse
// cites), with zg = A xg + B yg + C (1/Z at the centroid):
//   L_xg  = [ -zg, 0, xg zg + 4(A n20 + B n11), xg yg + 4 n11, -(1 + xg^2 + 4 n20), yg ]
//   L_yg  = [ 0, -zg, yg zg + 4(A n11 + B n02), 1 + yg^2 + 4 n02, -xg yg - 4 n11, -xg ]
//   L_n20 = [ -2(A n20 + B n11), 0, 2((zg + A xg) n20 + B xg n11), 2(yg n20 + xg n11), -4 xg n20, 2 n11 ]
//   L_n11 = [ -(A n11 + B n02), -(A n20 + B n11), A yg n20 + (3 zg - C) n11 + B xg n02,
//             3 yg n11 + xg n02, -(yg n20 + 3 xg n11), n02 - n20 ]
//   L_n02 = [ 0, -2(A n11 + B n02), 2((zg + B yg) n02 + A yg n11), 4 yg n02, -2(yg n11 + xg n02), -2 n11 ]
// Exact for the image of a 3-D circle (its third-order centred moments vanish:
// the image is an ellipse); for any other planar blob these rows drop its
// third-order centred moments, which the paper's general rows for mu_ij keep.
//
// Measurement (8 doubles): xg, yg, n20, n11, n02, A, B, C. From a 3-D circle:
// project_circle(); from an image blob's moments (cv2.moments): measure_moments().
// The error is s - s* (no angle: the ellipse's orientation is carried by n11).
//
// Refused: non-finite entries; |xg|, |yg| above max_normalized_coordinate;
// n20, n02 not in (0, max_normalized_coordinate^2]; zero or negative area
// (n20 n02 - n11^2 <= 0: a segment, a point or no ellipse at all); A, B, C
// above 1 / min_depth in magnitude; and a plane seen edge-on or behind the
// camera over the ellipse: 1/Z = A x + B y + C must be at least 1 / max_depth
// on every point of it (its least value there is zg - 2 sqrt(p^T N p),
// p = (A, B), N = [n20 n11; n11 n02]).
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/feature.hpp"

#include <Eigen/Core>

#include <array>

namespace ibvs {

class EllipseFeature final : public Feature {
 public:
  /// The measurement of the image of a 3-D circle (camera frame): its centre, the normal of
  /// its plane (any length > 0, either sign) and its radius > 0, in metres. The image is the
  /// ellipse cut from the image plane by the cone through the camera centre and the circle
  /// (centroid and moments of that ellipse, not the projection of the circle's centre), the
  /// plane is the circle's. Throws std::invalid_argument (naming the argument) for non-finite
  /// input, a plane within min_depth of the camera centre (seen edge-on), a circle not wholly
  /// at depths in [min_depth, max_depth], or an image the measurement would refuse.
  static std::array<double, 8> project_circle(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal,
                                              double radius);
  /// The same measurement into m (8 doubles), noexcept and allocation-free (the simulator's
  /// per-frame path): false (m untouched) where project_circle throws, except that the
  /// measurement is not checked (Feature::check does that).
  static bool project_circle(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal, double radius,
                             double* m) noexcept;
  /// The measurement of a planar blob from its image moments: `moments` = (m00, m10, m01, mu20,
  /// mu11, mu02), the area, the first-order moments and the centred second-order moments (as
  /// cv2.moments names them), in the units of `camera`: pixels of a camera without lens
  /// distortion (undistort the image first), or normalised coordinates with the default
  /// CameraModel(). The blob lies on the plane 1/Z = A x + B y + C (normalised x, y). Throws
  /// std::invalid_argument for m00 <= 0, a distorted camera, or a measurement check() refuses.
  static std::array<double, 8> measure_moments(const std::array<double, 6>& moments, double A, double B, double C,
                                               const CameraModel& camera = CameraModel());

  std::unique_ptr<Feature> clone() const override { return std::make_unique<EllipseFeature>(*this); }
  std::string describe() const override { return "ellipse"; }
  int rows() const noexcept override { return 5; }
  int size() const noexcept override { return 8; }
  const char* check(const double* m, int& entry) const noexcept override;
  void value(const double* m, double* s) const noexcept override;
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override;
};

}  // namespace ibvs
