// Camera models: normalised image coordinates (the core's unit) <-> pixels,
// a pinhole K with one of four lens distortions. Used by users for their
// calibrated camera and by the simulator for its sensor: one class.
//
// Frames and units. A point (X, Y, Z) in the camera frame (x right, y down,
// z forward, metres) has normalised coordinates (x, y) = (X/Z, Y/Z) (eq. 1).
// Distortion maps (x, y) to distorted normalised coordinates (xd, yd), then
//   u = u0 + px xd,  v = v0 + py yd               (pixels; px, py focal lengths in px)
// with u to the right and v down, the origin where the sensor bounds put it
// (pixel cameras: [0, width] x [0, height]). Distortions:
//  * none:        xd = x.
//  * visp:        ViSP's vpCameraParameters pair of one-term radial models,
//                 calibrated separately (so the round trip is close, not exact):
//                   project:   u = u0 + px x (1 + kud r^2),  r^2 = x^2 + y^2
//                   normalize: x = (u - u0)/px (1 + kdu r'^2), r'^2 the same of ((u - u0)/px, (v - v0)/py)
//  * plumb_bob:   OpenCV / ROS radial-tangential, coefficients (k1, k2, p1, p2, k3):
//                   xd = x R + 2 p1 x y + p2 (r^2 + 2 x^2),  yd = y R + p1 (r^2 + 2 y^2) + 2 p2 x y,
//                   R = 1 + k1 r^2 + k2 r^4 + k3 r^6
//  * equidistant: OpenCV fisheye / ROS equidistant, coefficients (k1, k2, k3, k4):
//                   theta = atan(r),  theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8),
//                   (xd, yd) = (theta_d / r) (x, y)
// normalize() inverts the plumb_bob and equidistant models by Newton's method
// to below 1e-9 px (bracketed on the radius first, so that it cannot jump to
// a folded solution), and ViSP's by its kdu formula.
//
// Where a model has no inverse. A radial distortion r -> rd = r D(r) is
// one-to-one only while d rd / dr > 0; beyond the first radius where that
// derivative vanishes the image folds back (a point at 60 degrees off-axis can
// land near the image centre). max_radius() is that radius in normalised
// (undistorted) units, computed per model from the first positive root of
// d rd / dr (ViSP's in closed form, the others from the eigenvalues of a
// companion matrix checked by a scan): infinite when the derivative never
// vanishes (plumb_bob: below r = 1e4, 89.994 degrees; equidistant: in front of
// the camera, theta < pi/2). plumb_bob's tangential terms (p1, p2) move the
// fold by O(p): inside max_radius its domain is where the Jacobian determinant
// of the map is positive, checked per point. project() refuses points outside
// the domain, normalize() pixels whose preimage would lie outside it (visp: the
// kdu map's own fold, when kdu < 0). Refused points are reported per point
// (false / a count) and written as NaN: the real-time path never throws.
//
// Bearings: the whole field of view. to_bearing() maps a pixel to the unit
// vector b = P / |P| of the rays that image there, from_bearing() a direction
// (any finite non-zero length) to its pixel; they hold wherever the lens
// does, beyond 90 degrees off the axis too, where normalised coordinates do
// not exist. max_angle() is the largest angle off the optical axis (z) below
// which a model is one-to-one (the lens's field of view is twice it) and
// fold_radius() the distorted normalised radius it images to (the image
// circle: px fold_radius() pixels along u); directions at or beyond
// max_angle() and pixels at or beyond fold_radius() are refused.
//  * none, visp, plumb_bob: through project() / normalize() of x = X/Z
//    (max_angle() = atan(max_radius()) <= 90 degrees);
//  * equidistant: theta = angle(b, z) directly (theta_d = |(xd, yd)|, eq.
//    above), up to the first fold of theta_d or 180 degrees;
//  * omnidir: Mei's unified model (C. Mei & P. Rives, "Single view point
//    omnidirectional camera calibration from planar grids", ICRA 2007, eqs.
//    1-4; OpenCV's cv2.omnidir), parameters xi >= 0 and (k1, k2, p1, p2):
//      (x, y) = (bx, by) / (bz + xi),  then plumb_bob's map with k3 = 0,  then K.
//    The inverse lifts (x, y) back onto the sphere (Mei & Rives eq. 7):
//      b = (f x, f y, f - xi),  f = (xi + sqrt(1 + (1 - xi^2) r^2)) / (1 + r^2).
//    The map b -> (x, y) is one-to-one while bz > -min(xi, 1/xi) (xi > 1:
//    the fold at bz = -1/xi; xi <= 1: (x, y) -> infinity at bz = -xi), and
//    the radial-tangential part while its radius is below its own fold.
//    project() / normalize() of omnidir go through the bearing (X/Z, Y/Z), so
//    they hold in front of the camera only (Z > 0).
#pragma once

#include "ibvs/layout.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <limits>
#include <string>

namespace ibvs {

/// Lens distortion model of a CameraModel.
enum class Distortion : std::uint8_t {
  none = 0,         ///< pinhole only
  visp = 1,         ///< ViSP's pair (kud, kdu): project with kud, normalize with kdu
  plumb_bob = 2,    ///< OpenCV / ROS radial-tangential (k1, k2, p1, p2, k3)
  equidistant = 3,  ///< OpenCV fisheye / ROS equidistant (k1, k2, k3, k4)
  omnidir = 4,      ///< Mei's unified omnidirectional model (xi; k1, k2, p1, p2), OpenCV's cv2.omnidir
};

/// Unit bearing vectors, one column per point (3 x N).
using Bearings = Eigen::Matrix3Xd;
const char* to_string(Distortion d) noexcept;

/// Pinhole camera with lens distortion, sensor bounds and frame rate.
/// Immutable once built; every constructor validates (throws
/// std::invalid_argument naming the bad argument); project / normalize are
/// noexcept and allocation-free.
class CameraModel {
 public:
  /// Normalised coordinates in and out (unit focal length, principal point 0,
  /// no distortion), sensor +-1, 60 fps.
  CameraModel() = default;

  /// Pinhole without distortion; sensor [0, width] x [0, height] pixels.
  static CameraModel pinhole(double px, double py, double u0, double v0, double width, double height,
                             double fps = 60.0);
  /// ViSP's model (vpCameraParameters with distortion); kud = kdu = 0 gives distortion none.
  static CameraModel from_visp(double px, double py, double u0, double v0, double kud, double kdu, double width,
                               double height, double fps = 60.0);
  /// OpenCV's camera matrix K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew) and distortion
  /// coefficients: (k1, k2, p1, p2[, k3]) (plumb_bob), or with fisheye (k1, k2, k3, k4) (equidistant).
  /// All-zero plumb_bob coefficients (or none at all) give distortion none.
  static CameraModel from_opencv(const Eigen::Matrix3d& K, const Eigen::Ref<const Eigen::VectorXd>& dist,
                                 double width, double height, bool fisheye = false, double fps = 60.0);
  /// Mei's unified omnidirectional model as cv2.omnidir.calibrate returns it: K (no skew: K[0][1]
  /// must be 0), xi >= 0 and D = (k1, k2, p1, p2).
  static CameraModel from_omnidir(const Eigen::Matrix3d& K, double xi, const Eigen::Ref<const Eigen::VectorXd>& D,
                                  double width, double height, double fps = 60.0);
  /// Every field at once (the constructors above are shorthands for it; pickling stores these):
  /// intrinsics, a distortion with its coefficients as coefficients() gives them (none 0, visp 2,
  /// plumb_bob 5, equidistant 4, omnidir 5), sensor bounds and frame rate.
  static CameraModel make(double px, double py, double u0, double v0, Distortion distortion,
                          const Eigen::Ref<const Eigen::VectorXd>& coefficients, double u_min, double u_max,
                          double v_min, double v_max, double fps);
  /// Paper Table I: the unit-focal camera of normalised coordinates, sensor +-bounds, no distortion.
  static CameraModel normalized(double bounds = 0.3, double fps = 60.0);
  /// Paper Section III-B (ViSP's Afma6 camera with distortion): 640x480,
  /// px 1090.6, py 1090.0, u0 310.1, v0 260.8, kud -0.2114, kdu 0.2217, 60 fps.
  static CameraModel afma6();

  double px() const noexcept { return px_; }  ///< focal length along u, pixels per normalised unit
  double py() const noexcept { return py_; }  ///< focal length along v
  double u0() const noexcept { return u0_; }  ///< principal point, pixels
  double v0() const noexcept { return v0_; }
  Distortion distortion() const noexcept { return distortion_; }
  /// The model's coefficients: none (), visp (kud, kdu), plumb_bob (k1, k2, p1, p2, k3),
  /// equidistant (k1, k2, k3, k4), omnidir (xi, k1, k2, p1, p2).
  Eigen::VectorXd coefficients() const;
  /// Mei's xi (omnidir; 0 for the other models).
  double xi() const noexcept { return xi_; }
  /// Sensor bounds in pixels (measurement units): u in [u_min, u_max], v in [v_min, v_max].
  double u_min() const noexcept { return u_min_; }
  double u_max() const noexcept { return u_max_; }
  double v_min() const noexcept { return v_min_; }
  double v_max() const noexcept { return v_max_; }
  double width() const noexcept { return u_max_ - u_min_; }
  double height() const noexcept { return v_max_ - v_min_; }
  double fps() const noexcept { return fps_; }  ///< frames per second (the simulator's control period is 1 / fps)
  /// OpenCV's 3x3 camera matrix [[px, 0, u0], [0, py, v0], [0, 0, 1]].
  Eigen::Matrix3d K() const noexcept;
  /// Normalised radius r = |(x, y)| up to which project() is one-to-one (infinite when everywhere).
  double max_radius() const noexcept { return r_max_; }
  /// Angle off the optical axis (radians, <= pi) below which to_bearing / from_bearing are
  /// one-to-one: the lens's field of view is 2 max_angle().
  double max_angle() const noexcept { return angle_max_; }
  /// The distorted normalised radius max_angle() images to (the image circle; its radius in pixels
  /// is px() fold_radius() along u, py() fold_radius() along v); infinite when there is none.
  double fold_radius() const noexcept { return fold_rd_; }
  /// Full angle (radians) that the sensor sees: twice the largest angle off the axis of its
  /// border's pixels (scanned), or 2 max_angle() when the image circle lies inside the sensor.
  double field_of_view() const noexcept;

  /// Normalised (x, y) -> pixels. False (pixel set to NaN) for a non-finite
  /// point or one at or beyond max_radius().
  bool project(double x, double y, Eigen::Vector2d& pixel) const noexcept;
  /// Pixels (u, v) -> normalised (x, y). False (uv set to NaN) for a non-finite
  /// pixel or one without an inverse (see above).
  bool normalize(double u, double v, Eigen::Vector2d& uv) const noexcept;
  /// Batched (2 x N, one column per point): returns the number of points that
  /// could not be mapped (0 = all), each written as NaN. Sizes must agree
  /// (else every output column is NaN and N is returned).
  int project(const Eigen::Ref<const Points>& uv, Eigen::Ref<Points> pixels) const noexcept;
  int normalize(const Eigen::Ref<const Points>& pixels, Eigen::Ref<Points> uv) const noexcept;
  /// Pixel (u, v) -> unit bearing b. False (b set to NaN) for a non-finite pixel or one at or
  /// beyond the image circle (fold_radius()) or without an inverse.
  bool to_bearing(double u, double v, Eigen::Vector3d& b) const noexcept;
  /// Direction (X, Y, Z) (any finite, non-zero length) -> pixel. False (pixel set to NaN) for a
  /// zero or non-finite vector or one at or beyond max_angle() off the axis.
  bool from_bearing(double X, double Y, double Z, Eigen::Vector2d& pixel) const noexcept;
  /// Batched (2 x N pixels, 3 x N bearings): the number of points refused (each written as NaN);
  /// sizes that disagree: every output column NaN and N returned.
  int to_bearing(const Eigen::Ref<const Points>& pixels, Eigen::Ref<Bearings> bearings) const noexcept;
  int from_bearing(const Eigen::Ref<const Bearings>& bearings, Eigen::Ref<Points> pixels) const noexcept;
  /// The throwing path of the two above: std::invalid_argument "ibvs: name[i] ..." for the first
  /// point to_bearing / from_bearing refuses (or sizes, for bearings not 3 x N).
  void validate_pixels(const Eigen::Ref<const Points>& pixels, const char* name) const;
  void validate_bearings(const Eigen::Ref<const Bearings>& bearings, const char* name) const;
  /// Inside the sensor bounds (inclusive).
  bool contains(double u, double v) const noexcept {
    return u >= u_min_ && u <= u_max_ && v >= v_min_ && v <= v_max_;
  }

  /// The OpenCV (K, dist) of this model: plumb_bob its 5 coefficients, equidistant its 4
  /// (use cv2.fisheye), omnidir its D = (k1, k2, p1, p2) (with xi(), use cv2.omnidir), none 5 zeros, visp (kud, 0, 0, 0, 0): exact for project(), while
  /// OpenCV's undistortion then inverts kud exactly where normalize() applies kdu.
  Eigen::VectorXd opencv_coefficients() const;

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
  std::string describe() const;
  /// Same intrinsics, distortion, coefficients, bounds and fps.
  bool operator==(const CameraModel& o) const noexcept {
    return px_ == o.px_ && py_ == o.py_ && u0_ == o.u0_ && v0_ == o.v0_ && distortion_ == o.distortion_ &&
           k_ == o.k_ && xi_ == o.xi_ && u_min_ == o.u_min_ && u_max_ == o.u_max_ && v_min_ == o.v_min_ && v_max_ == o.v_max_ &&
           fps_ == o.fps_;
  }
  bool operator!=(const CameraModel& o) const noexcept { return !(*this == o); }

 private:
  // The radial-tangential inverse (plumb_bob, and omnidir's on Mei's plane) within radius r_hi
  // (squared r2_hi; rd_hi its distorted radius).
  bool undistort_radtan(double xd, double yd, double r_hi, double r2_hi, double rd_hi,
                        Eigen::Vector2d& uv) const noexcept;
  int normalize_radtan_batch(const Eigen::Ref<const Points>& pixels, Eigen::Ref<Points> uv) const noexcept;
  bool lift_omnidir(double u, double v, Eigen::Vector3d& b) const noexcept;
  bool equidistant_bearing(double u, double v, Eigen::Vector3d& b) const noexcept;
  bool undistort_equidistant(double xd, double yd, Eigen::Vector2d& uv) const noexcept;
  void set_domain();  // r_max_ and the radii it implies, from the coefficients

  double px_ = 1.0, py_ = 1.0, u0_ = 0.0, v0_ = 0.0;
  Distortion distortion_ = Distortion::none;
  std::array<double, 5> k_{};  // visp: kud, kdu; plumb_bob: k1, k2, p1, p2, k3; equidistant: k1..k4;
                               // omnidir: k1, k2, p1, p2, 0 (plumb_bob's layout, k3 = 0)
  double xi_ = 0.0;            // omnidir's xi
  double u_min_ = -1.0, u_max_ = 1.0, v_min_ = -1.0, v_max_ = 1.0;
  double fps_ = 60.0;
  double r_max_ = std::numeric_limits<double>::infinity();   // project's domain, normalised radius
  double r2_max_ = std::numeric_limits<double>::infinity();  // its square
  double rd_max_ = std::numeric_limits<double>::infinity();  // distorted radius (plumb_bob radial part, visp kdu
                                                             // domain) or theta_d (equidistant) normalize accepts
  double theta_max_ = 0.0;                                    // equidistant: atan(r_max)
  double angle_max_ = 0.5 * 3.14159265358979323846;           // max_angle()
  double cos_angle_max_ = 0.0;                                // its cosine
  double fold_rd_ = std::numeric_limits<double>::infinity();  // fold_radius()
  double plane_r_max_ = std::numeric_limits<double>::infinity();  // omnidir: Mei-plane radius of max_angle
  double plane_rd_max_ = std::numeric_limits<double>::infinity(); // its distorted radius
};

}  // namespace ibvs
