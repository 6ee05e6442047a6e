// An image line (rho, theta): the points of the image plane with
// x cos(theta) + y sin(theta) = rho (normalised coordinates), the projection of
// a 3-D line that lies in the plane 1/Z = A x + B y + C (a plane through the
// line but not through the camera centre; C = 1/Z of the point of the plane
// on the optical axis).
//
// Interaction matrix (Espiau, Chaumette & Rives, IEEE T-RA 1992, Sec. 4.4;
// Chaumette & Hutchinson, IEEE RAM 2006), in the twist convention of
// features.hpp:
//   L_rho   = [ l_r c, l_r s, -l_r rho, (1 + rho^2) s, -(1 + rho^2) c,  0 ]
//   L_theta = [ l_t c, l_t s, -l_t rho, -rho c,        -rho s,         -1 ]
// with c = cos(theta), s = sin(theta), l_r = -(A rho c + B rho s + C) and
// l_t = B c - A s. ViSP's vpFeatureLine writes the plane as
// A' X + B' Y + C' Z + D' = 0, i.e. A = -A'/D', B = -B'/D', C = -C'/D'.
//
// Measurement (5 doubles): rho, theta, A, B, C. A line is also (-rho, theta + pi):
// align() takes the one whose theta is nearest the goal's, and the theta error
// is wrapped into (-pi, pi]. Refused: non-finite entries, |rho| above
// max_normalized_coordinate, |theta| above 2 pi, A, B, C above 1 / min_depth
// in magnitude, and a plane with A rho c + B rho s + C = 0 at the line's foot
// (the plane contains the camera centre's ray through the line: seen edge-on,
// the line's depth is undefined).
#pragma once

#include "ibvs/feature.hpp"

#include <array>

namespace ibvs {

class LineFeature final : public Feature {
 public:
  /// The measurement of the line through two image points (x1, y1), (x2, y2)
  /// (normalised; distinct) in the plane (A, B, C): rho >= 0 and theta in (-pi, pi].
  static std::array<double, 5> measure(double x1, double y1, double x2, double y2, double A, double B, double C);
  /// The same into m (5 doubles), noexcept and allocation-free (the simulator's LineSource
  /// calls it every frame); false (m untouched) when the points coincide or a value is not finite.
  static bool measure(double x1, double y1, double x2, double y2, double A, double B, double C, double* m) noexcept;

  std::unique_ptr<Feature> clone() const override { return std::make_unique<LineFeature>(*this); }
  std::string describe() const override { return "line"; }
  int rows() const noexcept override { return 2; }
  int size() const noexcept override { return 5; }
  const char* check(const double* m, int& entry) const noexcept override;
  void align(double* m, const double* m_desired) const noexcept override;
  void value(const double* m, double* s) const noexcept override;
  void error(const double* m, const double* m_desired, double* e) const noexcept override;
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override;
};

}  // namespace ibvs
