// Point features on the unit sphere: what a wide-angle camera sees of a point
// at any angle off its axis (beyond 90 degrees too), through its lens model
// (CameraModel::to_bearing) rather than through normalised image coordinates.
//
// Measurement (4 doubles, both kinds): the unit bearing b = P / |P| of the
// point P in the camera frame (bx, by, bz; |b| = 1 to 1e-6) and its distance
// R = |P| (metres, the sphere's counterpart of the depth Z).
// SphericalPointFeature::measure(X, Y, Z) builds it from P.
//
// Spherical point (3 rows, s = b): with the twist convention of features.hpp
// (a static point seen by a camera moving with (v, w)),
//   ds/dt = [ -(I - s s^T) / R ,  [s]_x ] (v, w)
// Hamel & Mahony, "Visual servoing of an under-actuated dynamic rigid-body
// system: an image-based approach", IEEE T-RA 18(2), 2002, eq. (9):
//   p_dot = -Omega x p - pi_p V / r,  pi_p = I - p p^T,
// which is this (-w x s = [s]_x w). The block has rank 2 (s . ds/dt = 0).
//
// Spherical polar (2 rows): the paper's polar coordinates lifted to the
// sphere, colatitude (angle from the optical axis) and azimuth (about it, as
// the paper's theta = atan2(y, x): rotation about the axis moves the azimuth
// alone):
//   beta = atan2(sqrt(bx^2 + by^2), bz) in [0, pi],  phi = atan2(by, bx) in (-pi, pi],
//   d beta/dt = [ -cb cp / R, -cb sp / R,  sb / R,  sp,         -cp,          0 ] (v, w)
//   d phi/dt  = [ sp / (R sb), -cp / (R sb), 0,     cp cb / sb, sp cb / sb,  -1 ] (v, w)
// (cb, sb = cos, sin beta; cp, sp = cos, sin phi). These are the rows of
// P. Corke, "Spherical image-based visual servo and structure estimation",
// ICRA 2010, eq. (11) (MVTB's SphericalCamera.visjac_p / IBVS_sph: longitude
// phi row first, then colatitude theta), in the same twist convention; for a
// small beta they tend to the paper's -(eq. 7) rows of (r, theta). The azimuth
// error is wrapped into (-pi, pi] (wrap_angle, eq. 13) by error(), and it is
// an angle about the optical axis (axis_angle_rows: row 1): in a Servo with
// AngleWrap::consistent (the default) the azimuth errors of all the task's
// spherical-polar blocks join the polar / cylindrical points' angles in one
// circular mean and are re-wrapped about it (angle_wrap.hpp), so an exact
// half-turn about the axis gives four azimuth errors on one branch (all +pi
// or all -pi), not (+pi, -pi, +pi, +pi) and a sideways throw; with
// AngleWrap::per_point each keeps its own wrap. Near the axis (sin beta below
// min_sin, default 1e-3) the azimuth is ill-defined: a current bearing there
// uses the rows (bx, by) of the spherical point instead (error and
// interaction alike, as a polar point block falls back to its Cartesian rows),
// and a goal there has no azimuth to reach: the azimuth error is 0. In both
// cases the row is no angle and stays out of the consistent wrap (as a polar
// point that falls back).
//
// Refused: non-finite entries, |b| not 1 to 1e-6, R outside [min_depth,
// max_depth].
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/feature.hpp"

#include <array>

namespace ibvs {

class SphericalPointFeature final : public Feature {
 public:
  /// The measurement (b, R) of the camera-frame point P = (X, Y, Z) (non-zero, finite).
  static std::array<double, 4> measure(double X, double Y, double Z);

  std::unique_ptr<Feature> clone() const override { return std::make_unique<SphericalPointFeature>(*this); }
  std::string describe() const override { return "spherical_point"; }
  int rows() const noexcept override { return 3; }
  int size() const noexcept override { return 4; }
  const char* check(const double* m, int& entry) const noexcept override;
  void value(const double* m, double* s) const noexcept override;
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override;
};

class SphericalPolarFeature final : public Feature {
 public:
  /// min_sin: below this sin(colatitude) a current bearing uses its (bx, by) rows (finite, in (0, 1)).
  explicit SphericalPolarFeature(double min_sin = default_polar_min_radius);
  double min_sin() const noexcept { return min_sin_; }

  std::unique_ptr<Feature> clone() const override { return std::make_unique<SphericalPolarFeature>(*this); }
  std::string describe() const override;
  int rows() const noexcept override { return 2; }
  int size() const noexcept override { return 4; }
  const char* check(const double* m, int& entry) const noexcept override;
  /// (colatitude, azimuth); (bx, by) near the axis.
  void value(const double* m, double* s) const noexcept override;
  void error(const double* m, const double* m_desired, double* e) const noexcept override;
  /// Row 1 (the azimuth) when both bearings are at least min_sin off the axis; else none.
  std::uint64_t axis_angle_rows(const double* m, const double* m_desired) const noexcept override;
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override;

 private:
  double min_sin_;
};

/// Pixels to spherical measurements through the lens model: the measurements of N spherical blocks
/// (4 doubles each, (bx, by, bz, R), block after block, as a Task of N such blocks takes them) from
/// N pixels (2 x N) by CameraModel::to_bearing (no normalised coordinates: any angle the lens sees,
/// beyond 90 degrees off the axis too) and the N distances R (metres). Returns the number of points
/// refused (a pixel to_bearing refuses, a distance outside [min_depth, max_depth]; their 4 doubles
/// NaN), or N when the sizes disagree (all NaN). noexcept, allocation-free.
int spherical_measurements(const CameraModel& camera, const Eigen::Ref<const Points>& pixels,
                           const Eigen::Ref<const Eigen::VectorXd>& distance,
                           Eigen::Ref<Eigen::VectorXd> measurements) noexcept;

}  // namespace ibvs
