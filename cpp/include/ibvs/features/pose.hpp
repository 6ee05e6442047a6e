// 3-D and 2.5-D feature blocks on a pose: position-based visual servoing
// (PBVS) in its two classic variants and the 2.5-D features of a reference
// point. Frames: c the current camera, c* the desired camera, o the object;
// aMb maps b coordinates into a (PlanarPose gives cMo). The rotation error is
// always theta u of c*Rc (the current camera's orientation in the desired
// camera's frame), 0 at the goal.
//
// theta u and its interaction matrix. A camera turning with angular velocity w
// (its own frame) changes c*Rc by d(c*Rc)/dt = c*Rc [w]x, so that
//   d(theta u)/dt = L_tu w,
//   L_tu = I + (theta/2) [u]x + (1 - sinc(theta) / sinc^2(theta/2)) [u]x^2     (1)
// (Malis, Chaumette & Boudet, IEEE T-RA 15(2) 1999, Sec. III; ViSP's
// vpFeatureThetaU with its cdRc rotation). Chaumette & Hutchinson (IEEE RAM
// 13(4) 2006, Sec. IV) print the [u]x term with a minus sign, which is L_tu of
// the inverse rotation's axis; the finite-difference tests decide for (1).
// The coefficient of [u]x^2 is 1 - (theta/2) cot(theta/2) = theta^2/12 +
// theta^4/720 + ...: below theta = 1e-2 its series keeps L_tu exact to 1 ulp
// as theta -> 0 (no 0/0); at theta = pi it is 1 (L_tu is invertible there,
// det = 1 / sinc^2(theta/2)); it grows without bound only as theta -> 2 pi.
//
// theta at pi, and beyond. A rotation vector theta u with theta in (pi, 2 pi]
// is the same rotation as (2 pi - theta)(-u): value(), error() and
// interaction() use that principal form (theta <= pi), so a measurement of
// angle up to 2 pi is handled; beyond 2 pi it is refused. At theta = pi
// exactly, +pi u and -pi u are the same rotation (the axis' sign is
// ambiguous): the measurement's sign is kept (theta_u() below picks the one
// whose largest component is positive), and either drives the camera by pi
// about the axis to the goal with the error decreasing at the same rate, so
// both are correct; from any start the angle leaves pi at once.
#pragma once

#include "ibvs/feature.hpp"
#include "ibvs/se3.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>

namespace ibvs {

/// theta u of a rotation matrix, theta in [0, pi] (through its unit quaternion:
/// exact near 0 and near pi). At theta = pi the axis' sign is chosen so that its
/// largest component in magnitude is positive (within 2e-12 rad of pi, where the
/// rotation matrix cannot tell the two apart).
Eigen::Vector3d theta_u(const Eigen::Matrix3d& R) noexcept;
/// The rotation matrix exp([theta u]x) (Rodrigues).
Eigen::Matrix3d rotation_of(const Eigen::Vector3d& tu) noexcept;
/// theta u in its principal form: the same rotation with theta <= pi.
Eigen::Vector3d principal_theta_u(const Eigen::Vector3d& tu) noexcept;
/// L_tu of eq. (1) at theta u (principal form taken first).
Eigen::Matrix3d theta_u_interaction(const Eigen::Vector3d& tu) noexcept;

/// Which translation a PBVS block regulates (Chaumette & Hutchinson 2006, Sec. IV).
enum class PbvsTarget : std::uint8_t {
  /// s = (c*t_c, theta u): the current camera's centre in the desired camera's
  /// frame; s* = 0. L = [c*Rc 0; 0 L_tu]. The law v = -gain L^-1 s drives c*t_c
  /// to 0 along a straight line: the camera centre moves on a straight line.
  /// (ViSP: vpFeatureTranslation cdMc with vpFeatureThetaU cdRc.)
  desired_camera = 0,
  /// s = (c t_o, theta u): the object origin in the current camera's frame;
  /// s* = (c*t_o, 0). L = [-I [c t_o]x; 0 L_tu]. c t_o moves on a straight line
  /// in the camera frame, so the object origin's image moves on a straight line.
  /// (ViSP: vpFeatureTranslation cMo with vpFeatureThetaU cdRc.)
  object = 1,
};

/// PBVS: a 6-row block (translation, theta u) on a pose. Measurement (6):
/// t (3, metres) then theta u of c*Rc (3, radians), with t = c*t_c
/// (desired_camera) or c t_o (object); measure() builds it from the poses cMo
/// and c*Mo, e.g. from ibvs::PlanarPose. The goal's measurement is measure(c*Mo,
/// c*Mo): zeros (desired_camera) or (c*t_o, 0) (object).
/// Refused: non-finite entries, |t_i| above max_depth, |theta u| above 2 pi.
class PbvsFeature final : public Feature {
 public:
  explicit PbvsFeature(PbvsTarget target = PbvsTarget::desired_camera) noexcept : target_(target) {}
  /// The measurement from the current pose cMo and the desired one c*Mo (camera <- object, 4x4
  /// rigid transforms; throws std::invalid_argument naming the argument when one is not finite
  /// or its rotation block is not a rotation to 1e-6).
  static std::array<double, 6> measure(const Pose& cMo, const Pose& cdMo, PbvsTarget target);

  PbvsTarget target() const noexcept { return target_; }
  std::unique_ptr<Feature> clone() const override { return std::make_unique<PbvsFeature>(*this); }
  std::string describe() const override;
  int rows() const noexcept override { return 6; }
  int size() const noexcept override { return 6; }
  const char* check(const double* m, int& entry) const noexcept override;
  void value(const double* m, double* s) const noexcept override;
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override;

 private:
  PbvsTarget target_;
};

/// 2.5-D visual servoing (Malis, Chaumette & Boudet 1999): the image point
/// (x, y) of a reference point, log Z of its depth and theta u of c*Rc; the
/// error is (x - x*, y - y*, log(Z / Z*), theta u). Measurement (6): x, y
/// (normalised), Z (metres, > 0), theta u of c*Rc (3). Interaction matrix
/// (Malis et al. 1999, Sec. III; Chaumette & Hutchinson, IEEE RAM 14(1) 2007,
/// Sec. on 2 1/2-D visual servoing):
///   rows x, y : the point's L_x (paper eq. 3; ViSP vpFeaturePoint)
///   row log Z : [0, 0, -1/Z, -y, x, 0]            (ViSP vpFeatureDepth)
///   rows theta u: [0, L_tu]                        (eq. 1)
/// L is block triangular and invertible wherever the measurement is accepted,
/// and e decays exponentially under v = -gain L^-1 e: the reference point's
/// image moves on a straight line. With a homography one knows Z / Z* rather
/// than Z: give Z = (Z / Z*) Z*_estimate (the error does not depend on the
/// estimate, only the translation rows' gain does, as in Malis et al.).
/// Refused: non-finite entries, |x| or |y| above max_normalized_coordinate,
/// Z outside [min_depth, max_depth], |theta u| above 2 pi.
class Point25DFeature final : public Feature {
 public:
  /// The measurement of the reference point P (object frame, metres) seen with camera <- object
  /// pose cMo, the desired one being c*Mo (throws as PbvsFeature::measure, and when P is behind
  /// the camera).
  static std::array<double, 6> measure(const Pose& cMo, const Pose& cdMo, const Eigen::Vector3d& P);

  std::unique_ptr<Feature> clone() const override { return std::make_unique<Point25DFeature>(*this); }
  std::string describe() const override { return "2.5-D point"; }
  int rows() const noexcept override { return 6; }
  int size() const noexcept override { return 6; }
  const char* check(const double* m, int& entry) const noexcept override;
  void value(const double* m, double* s) const noexcept override;
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override;
};

}  // namespace ibvs
