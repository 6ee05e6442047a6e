// Camera model of the simulator: pinhole with ViSP's first-order radial
// distortion, in both directions, plus the sensor bounds and frame rate.
//
// Measurement coordinates are what the sensor delivers: pixels for a pixel
// camera, normalised coordinates for the unit-focal camera of paper Table I.
// ViSP's model (vpCameraParameters, "projection with distortion"):
//   normalised -> pixel (kud):  u = u0 + px x (1 + kud r^2),  r^2 = x^2 + y^2
//   pixel -> normalised (kdu):  x = (u - u0)(1 + kdu r'^2) / px,
//                               r'^2 = ((u - u0)/px)^2 + ((v - v0)/py)^2
// The two coefficients are calibrated separately, so the round trip is only
// approximately the identity: the simulator projects with kud and the
// controller undistorts with kdu, as the real one did.
#pragma once

#include <Eigen/Core>

#include <string>

namespace ibvs::sim {

struct Camera {
  double px = 1.0, py = 1.0;    ///< focal lengths in measurement units per normalised unit
  double u0 = 0.0, v0 = 0.0;    ///< principal point, measurement units
  double kud = 0.0;             ///< distortion used to project (normalised -> measurement)
  double kdu = 0.0;             ///< distortion used to undistort (measurement -> normalised)
  double u_min = -1.0, u_max = 1.0, v_min = -1.0, v_max = 1.0;  ///< sensor bounds, measurement units
  double fps = 60.0;            ///< frames per second; the control period is 1 / fps

  /// Paper Table I: unit focal length, image plane bounds +-bounds, no distortion.
  static Camera normalized(double bounds = 0.3, double fps = 60.0);
  /// Paper Section III-B (ViSP's Afma6 camera with distortion): 640x480,
  /// px 1090.6, py 1090.0, u0 310.1, v0 260.8, kud -0.2114, kdu 0.2217, 60 fps.
  static Camera afma6();

  /// Normalised (x, y) -> measurement (u, v), with kud.
  Eigen::Vector2d project(double x, double y) const noexcept {
    const double k = 1.0 + kud * (x * x + y * y);
    return {u0 + px * x * k, v0 + py * y * k};
  }
  /// Measurement (u, v) -> normalised (x, y), with kdu.
  Eigen::Vector2d normalize(double u, double v) const noexcept {
    const double x = (u - u0) / px, y = (v - v0) / py;
    const double k = 1.0 + kdu * (x * x + y * y);
    return {x * k, y * k};
  }
  /// Inside the sensor bounds (inclusive).
  bool contains(double u, double v) const noexcept { return u >= u_min && u <= u_max && v >= v_min && v <= v_max; }

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
  std::string describe() const;
};

}  // namespace ibvs::sim
