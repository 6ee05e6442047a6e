// An image segment: centre (xc, yc), length l and orientation alpha of the
// segment between two image points p1, p2 (normalised coordinates), the
// projection of a 3-D segment whose end points have depths Z1, Z2.
//
// Features (ViSP's vpFeatureSegment, both of its sets):
//  * normalised (default): s = (xn, yn, ln, alpha) = (xc / l, yc / l, 1 / l, alpha).
//    For a segment parallel to the image plane 1/l is proportional to its depth
//    and (xn, yn) to its centre's (X, Y), which decouples the translations
//    (the segment analogue of the normalised centroid and area of Tahri &
//    Chaumette, IEEE T-RO 2005; ViSP's source cites no paper for it);
//  * plain: s = (xc, yc, l, alpha).
// with xc = (x1 + x2) / 2, yc = (y1 + y2) / 2, l = |p2 - p1| and
// alpha = atan2(y2 - y1, x2 - x1), the direction from p1 to p2.
//
// Interaction matrix: from the point rows of the two end points (Chaumette &
// Hutchinson, IEEE RAM 2006, eq. 11; cartesian_jacobian in features.hpp),
// p1 = c - (l/2) u, p2 = c + (l/2) u, u = (cos alpha, sin alpha), u' = (-sin alpha, cos alpha):
//   L_c = (L_p1 + L_p2) / 2,  L_l = u^T (L_p2 - L_p1),  L_alpha = u'^T (L_p2 - L_p1) / l,
//   L_xn = L_xc / l - xc L_l / l^2,  L_yn = L_yc / l - yc L_l / l^2,  L_ln = -L_l / l^2.
// This is ViSP's closed form (vpFeatureSegment::interaction, with
// lambda1 = (Z1 - Z2) / (Z1 Z2) and lambda2 = (Z1 + Z2) / (2 Z1 Z2)) once its
// orientation convention is matched: ViSP measures alpha from p2 to p1, so its
// (Z1, Z2) are our (Z2, Z1); tests/cpp/test_segment.cpp checks both.
//
// Measurement (6 doubles): xc, yc, l, alpha, Z1, Z2 (SegmentFeature::measure
// from the two image points and their depths; project() from two 3-D points).
// A segment is also its reverse (xc, yc, l, alpha + pi, Z2, Z1): it is treated
// as unoriented, like the image line. align() takes the form whose alpha is
// nearest the goal's, so the alpha error, wrapped into (-pi, pi], is at most
// pi/2 in magnitude; a camera turned half a turn about a segment's centre sees
// the same segment and has nothing to correct. (To servo on an ordered pair of
// points, whose half-turn is a real error, servo on the points themselves.)
//
// Refused: non-finite entries; |xc|, |yc| above max_normalized_coordinate; l
// below min_segment_length (a segment of zero length has no orientation and
// its normalised features are infinite) or above 4 max_normalized_coordinate;
// |alpha| above 2 pi; depths outside [min_depth, max_depth].
#pragma once

#include "ibvs/feature.hpp"

#include <Eigen/Core>

#include <array>

namespace ibvs {

/// Shortest segment a SegmentFeature accepts, normalised units (1e-6 pixel at
/// a focal length of 1000 px): 1/l and xc/l stay below ~1e10, the rows of L
/// below ~1e30.
inline constexpr double min_segment_length = 1e-9;

class SegmentFeature final : public Feature {
 public:
  /// normalized: the features (xc/l, yc/l, 1/l, alpha) (default) or (xc, yc, l, alpha).
  explicit SegmentFeature(bool normalized = true) : normalized_(normalized) {}

  /// The measurement (xc, yc, l, alpha, Z1, Z2) of the segment from image point (x1, y1) at
  /// depth Z1 to (x2, y2) at depth Z2. Throws std::invalid_argument (naming the argument) for
  /// points beyond max_normalized_coordinate, coincident points (l < min_segment_length) or
  /// depths outside [min_depth, max_depth].
  static std::array<double, 6> measure(double x1, double y1, double Z1, double x2, double y2, double Z2);
  /// The measurement of the segment between two 3-D points of the camera frame (in front of
  /// the camera): measure() of their projections (X/Z, Y/Z) and depths Z.
  static std::array<double, 6> project(const Eigen::Vector3d& P1, const Eigen::Vector3d& P2);

  bool normalized() const noexcept { return normalized_; }

  std::unique_ptr<Feature> clone() const override { return std::make_unique<SegmentFeature>(*this); }
  std::string describe() const override { return normalized_ ? "segment" : "segment(plain)"; }
  int rows() const noexcept override { return 4; }
  int size() const noexcept override { return 6; }
  const char* check(const double* m, int& entry) const noexcept override;
  void align(double* m, const double* m_desired) const noexcept override;
  void value(const double* m, double* s) const noexcept override;
  void error(const double* m, const double* m_desired, double* e) const noexcept override;
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override;

 private:
  bool normalized_ = true;
};

}  // namespace ibvs
