// Feature: one block of rows of a servoing task beside its image points (see
// task.hpp): an image line, a segment, an ellipse, image moments, a 3-D
// translation or rotation, a 2.5-D point, or a user's own feature.
//
// A block is evaluated from a *measurement*: a fixed number of doubles that a
// frame gives it (documented by each kind: e.g. a line's rho, theta and the
// plane 1/Z = A x + B y + C that holds it), for the current frame and for the
// goal. From a measurement it computes its value s (rows()), its interaction
// matrix L (rows() x 6, ds/dt = L v for the camera twist v of features.hpp)
// and, from two measurements, the error s (-) s* (angles wrapped, equivalent
// representations matched). Evaluation is noexcept and allocation-free (the
// Servo calls it every frame); check() decides what is refused, so that
// validate() (throws, naming the entry) and the real-time path (refuses with
// Status::invalid_input) refuse exactly the same measurements.
#pragma once

#include "ibvs/features.hpp"

#include <Eigen/Core>

#include <cstdint>

#include <memory>
#include <string>

namespace ibvs {

class Feature {
 public:
  virtual ~Feature();
  /// A copy (a Task owns its blocks; a Servo copies its Task).
  virtual std::unique_ptr<Feature> clone() const = 0;
  /// Its kind and parameters, e.g. "line", "segment", "moments(points=4)".
  virtual std::string describe() const = 0;
  /// Rows of the block (size of s).
  virtual int rows() const noexcept = 0;
  /// Doubles in one measurement.
  virtual int size() const noexcept = 0;

  /// Why the measurement m (size() doubles) is refused, or nullptr when it is
  /// accepted; `entry` is then set to the index of the offending double (or
  /// -1 when the measurement as a whole is refused). Refusals: non-finite
  /// entries, values outside ibvs/limits.hpp, degenerate cases (a segment of
  /// zero length, a plane seen edge-on, ...; each kind documents its own).
  virtual const char* check(const double* m, int& entry) const noexcept = 0;

  /// Rewrites an accepted measurement m into the representation nearest to the
  /// goal's, m_desired, where a feature has several (a line (rho, theta) is also
  /// (-rho, theta + pi)); the Servo calls it on a copy of the current measurement
  /// before error() and interaction(), so that both use the same one. Default: none.
  virtual void align(double* m, const double* m_desired) const noexcept;
  /// s (rows()) of an accepted measurement.
  virtual void value(const double* m, double* s) const noexcept = 0;
  /// e = s (-) s* of two accepted measurements (m aligned to m_desired): s - s*
  /// by default (for at most 64 rows; larger kinds override it); kinds with
  /// angles wrap their difference into (-pi, pi].
  virtual void error(const double* m, const double* m_desired, double* e) const noexcept;
  /// The error rows that are angles about the optical axis at these two accepted measurements
  /// (m aligned to m_desired): bit i set for row i (rows 0..63). The Servo's consistent wrap
  /// (angle_wrap.hpp, paper eq. 13) takes their differences, as error() gives them in (-pi, pi],
  /// into its circular mean with the polar and cylindrical points' angles and re-wraps them about
  /// its centre, so that one rotation about the axis turns every angle the same way (per point
  /// under AngleWrap::per_point: error() as it is). Only full-turn angles that a rotation w_z
  /// about the axis moves as -w_z (as the polar theta) belong here. Default: none (0).
  virtual std::uint64_t axis_angle_rows(const double* m, const double* m_desired) const noexcept;
  /// L (rows() x 6) at an accepted measurement, written into the first rows() rows of L.
  virtual void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept = 0;

  /// The Servo's per-frame work on the block with the current interaction matrix, in one call:
  /// check() of m and of m_desired (the refusal of the first one refused; nullptr when both are
  /// accepted), then align(m, m_desired) in place, e = error(m, m_desired) and L = interaction(m).
  /// The default makes those calls in turn; a kind whose calls would evaluate the same quantities
  /// again (image moments: five evaluations, two needed) overrides it with the same results, bit
  /// for bit. Nothing is written to e and L when a measurement is refused.
  virtual const char* evaluate(double* m, const double* m_desired, double* e, Eigen::Ref<MatrixX6> L) const noexcept;

  /// Throws std::invalid_argument "ibvs: <name>[<entry>] ..." when check() refuses m.
  void validate(const double* m, const std::string& name) const;
};

}  // namespace ibvs
