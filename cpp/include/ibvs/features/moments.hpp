// Image moments of a planar object: the six features of Tahri & Chaumette
// (IEEE T-RO 21(6), 2005, "Point-based and region-based image moments for
// visual servoing of planar objects"), rows selectable:
//   xn = an xg, yn = an yg          normalised centre of gravity (xg = m10/m00, yg = m01/m00)
//   an = Z* sqrt(a* / a)            normalised area (a = m00 for a region, mu20 + mu02 for points)
//   r1, r2                          two invariants to 2-D translation, rotation and scale, for wx, wy
//   alpha                           orientation, for wz
// Two pairs (r1, r2), as Tahri & Chaumette (2005, Sec. V) define them from the
// centred moments mu_pq, with c1 = mu20 - mu02, s1 = 2 mu11, c2 = mu03 - 3 mu21,
// s2 = mu30 - 3 mu12, c3 = c1^2 - s1^2, s3 = 2 s1 c1, I1 = c1^2 + s1^2,
// I2 = c2^2 + s2^2, I3 = mu20 + mu02:
//   Invariants::p:  px = I1 / I3^2,  py = a I2 / I3^3
//     rotation invariant, hence decoupled from wz: a turn about the optical axis changes alpha
//     alone (the half-turn test). ViSP's vpMomentCInvariant names them for non-symmetric objects:
//     for an object with an axis of symmetry their rows lose wx or wy at the parallel pose (rank 5),
//     and for a centrally symmetric one (py = 0, px constant) both.
//   Invariants::s:  sx = (c2 c3 + s2 s3) / K,  sy = (s2 c3 - c2 s3) / K,  K = I1 I3^(3/2) / sqrt(a)
//     for symmetric objects (ViSP's documentation; full rank for a kite, an isosceles triangle, a
//     rectangle): they turn with the object (by -theta when it turns by theta), so a large turn
//     about the optical axis couples them with wz and the law leaves the axis (docs/features.md).
// and two orientations:
//   Alpha::second_order: alpha = atan2(2 mu11, mu20 - mu02) / 2 (Chaumette 2004, Sec. V), the
//     direction of the principal axis: defined modulo pi (its error wrapped into (-pi/2, pi/2]) and
//     undefined when I1 = 0 (mu20 = mu02, mu11 = 0: a square, a disc, a regular polygon).
//   Alpha::third_order: the same axis oriented by the third-order moments over the full turn, in
//     (-pi, pi] (ViSP's vpMomentAlpha flips alpha by pi when the third-order moments disagree in
//     sign with a reference's; here a fixed rule needs no reference): of alpha and alpha + pi, the
//     one whose rotated third-order moment Re(z3 e^{-3 i alpha}) is > 0, with
//     z3 = (mu30 - 3 mu12) + i (3 mu21 - mu03); its error is wrapped into (-pi, pi]. Undefined, as
//     well, where that moment vanishes: centrally symmetric objects (a rectangle, an ellipse,
//     a square) have all their odd centred moments 0. Use it for non-symmetric objects, so that a
//     rotation about the optical axis beyond pi/2 is not taken for its complement.
// An undefined quantity of a selected row is refused (check()); leave the row out (`rows`) when
// the object's symmetry makes it undefined (alpha of a square; the S invariants of a square too).
//
// Interaction matrices (equation numbers as cited from the papers' published versions; the tests
// check the formulas themselves). Of a moment m_ij (i + j <= 3), for the plane 1/Z = A x + B y + C:
//  * a region (m_ij = integral of x^i y^j over the object; Chaumette 2004, eq. (13)):
//      vx = -i (A m_ij + B m_{i-1,j+1} + C m_{i-1,j}) - A m_ij
//      vy = -j (A m_{i+1,j-1} + B m_ij + C m_{i,j-1}) - B m_ij
//      vz = (i+j+3) (A m_{i+1,j} + B m_{i,j+1} + C m_ij) - C m_ij
//      wx = (i+j+3) m_{i,j+1} + j m_{i,j-1}
//      wy = -(i+j+3) m_{i+1,j} - i m_{i-1,j}
//      wz = i m_{i-1,j+1} - j m_{i+1,j-1}
//  * discrete points (m_ij = sum of x^i y^j over the points; Tahri & Chaumette 2005, Sec. III):
//    the same without the terms of the area element's change (the -A m_ij, -B m_ij and -C m_ij
//    terms and the 3 of i+j+3), i.e. the sum of the points' own interaction matrices.
// The features' rows are the exact chain rule through their definitions above (forward-mode
// derivatives of the same expressions that compute the values: one implementation of each). The
// tests check them against central differences of the projection and against the published
// closed forms of xn, yn, an and alpha (Tahri & Chaumette 2005, as ViSP's
// vpFeatureMomentGravityCenterNormalized, vpFeatureMomentAreaNormalized and vpFeatureMomentAlpha
// write them) and the centred moments' interaction matrices (vpFeatureMomentCentered) chained
// through the invariants.
//
// Measurement (20 doubles): the raw moments m_ij of order 0 to 4 (order 4 enters the interaction
// matrix of order 3), indexed by moment_index(i, j) = n (n + 1) / 2 + j with n = i + j:
//   m00, m10, m01, m20, m11, m02, m30, m21, m12, m03, m40, m31, m22, m13, m04,
// then a* (the goal's area a, > 0), Z* (the goal's depth, metres) and the plane A, B, C.
// Refused: non-finite entries; m00 <= 0 (no object: zero area, no points) or m00 > max_points; a
// moment larger than m00 10^(i+j) (an object beyond the normalised-coordinate limit); a*, Z* out of
// (0, 1e12] and [min_depth, max_depth]; |A|, |B|, |C| > 1 / min_depth; 1/Z at the centre of gravity
// below 1 / max_depth (the plane seen edge-on or behind the camera); a flat object
// (4 (mu20 mu02 - mu11^2) / I3^2 < 1e-9: collinear points, a zero-width region); an undefined
// alpha or S invariant (I1 / I3^2 < 1e-12) or third-order orientation (|Re(z3 e^{-3 i alpha})|
// sqrt(m00) / I3^(3/2) < 1e-9) when their row is selected; and any value or interaction entry
// beyond 1e20 (a measurement that is not the moments of an object; the weighted J^T J stays finite).
#pragma once

#include "ibvs/feature.hpp"
#include "ibvs/layout.hpp"

#include <array>
#include <cstdint>

namespace ibvs {

/// Raw moments m_ij of order 0 to 4, at moment_index(i, j).
using Moments = std::array<double, 15>;
constexpr int moment_index(int i, int j) noexcept { return (i + j) * (i + j + 1) / 2 + j; }

class MomentsFeature final : public Feature {
 public:
  /// How the moments were computed: over a region (integrals) or over discrete points (sums).
  enum class Source : std::uint8_t { region = 0, points = 1 };
  /// The pair of invariants for wx, wy.
  enum class Invariants : std::uint8_t { p = 0, s = 1 };
  /// The orientation: modulo pi from second-order moments, or over the full turn with the third-order ones.
  enum class Alpha : std::uint8_t { second_order = 0, third_order = 1 };
  /// Row selection bits, in row order.
  enum Row : unsigned { xn = 1, yn = 2, an = 4, r1 = 8, r2 = 16, alpha = 32, all = 63 };
  static constexpr int measurement_size = 20;

  /// Throws std::invalid_argument for an empty or unknown row selection.
  explicit MomentsFeature(Source source = Source::region, Invariants invariants = Invariants::p,
                          Alpha alpha = Alpha::third_order, unsigned rows = Row::all);

  /// Moments of discrete image points (2 x N, normalised): m_ij = sum of x^i y^j.
  static Moments of_points(const Eigen::Ref<const Points>& xy);
  /// Moments of the region inside a simple polygon (2 x N vertices, normalised, either
  /// orientation), closed form by Green's theorem (Steger 1996): for each edge (x0, y0)-(x1, y1),
  ///   m_pq += (x0 y1 - x1 y0) sum_{k<=p, l<=q} C(k+l, k) C(p+q-k-l, q-l) x1^k x0^(p-k) y1^l y0^(q-l)
  /// divided by (p+q+2)(p+q+1) C(p+q, p); made positive for a clockwise polygon.
  static Moments of_polygon(const Eigen::Ref<const Points>& xy);
  /// The measurement of an object with moments m, in the plane (A, B, C), for the goal (a*, Z*);
  /// a_desired = 0: this measurement's own area (use it for the goal's measurement).
  static std::array<double, 20> measure(const Moments& m, Source source, double a_desired, double depth_desired,
                                        double A, double B, double C);
  /// The projection of a 3-D planar polygon (source region) or point set (source points) given in the
  /// camera frame (3 x N, in front of the camera): its image moments and its plane, measured.
  /// Throws std::invalid_argument for fewer than 3 points, points not in front of the camera,
  /// points not on one plane (relative 1e-9) or a plane through the camera centre.
  static std::array<double, 20> project(const Eigen::Ref<const Eigen::Matrix3Xd>& P, Source source,
                                        double a_desired, double depth_desired);
  /// The object's area a of a measurement (m00 for a region, mu20 + mu02 for points).
  static double area(const double* m, Source source) noexcept;

  Source source() const noexcept { return source_; }
  Invariants invariants() const noexcept { return invariants_; }
  Alpha alpha_kind() const noexcept { return alpha_; }
  unsigned selected() const noexcept { return rows_; }

  std::unique_ptr<Feature> clone() const override { return std::make_unique<MomentsFeature>(*this); }
  std::string describe() const override;
  int rows() const noexcept override { return n_rows_; }
  int size() const noexcept override { return measurement_size; }
  const char* check(const double* m, int& entry) const noexcept override;
  void value(const double* m, double* s) const noexcept override;
  void error(const double* m, const double* m_desired, double* e) const noexcept override;
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override;
  const char* evaluate(double* m, const double* m_desired, double* e, Eigen::Ref<MatrixX6> L) const noexcept override;

 private:
  Source source_;
  Invariants invariants_;
  Alpha alpha_;
  unsigned rows_;
  int n_rows_;
};

}  // namespace ibvs
