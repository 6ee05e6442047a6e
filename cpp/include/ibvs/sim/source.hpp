// Feature sources: how the simulator measures the feature blocks of a Task
// (feature.hpp, task.hpp) on its target. A Target carries one source per
// feature block of the servo's Task, in the Task's block order; each frame the
// episode hands every source the same SourceFrame and the source writes its
// block's measurement (the doubles its Feature kind documents), which the
// servo then evaluates. The image points of the Task (its Layout) need no
// source: they are the target's points, measured as before.
//
// What a source is given (SourceFrame) separates the image from what the
// depth mode knows, as for points:
//   * cMo: the true pose (camera <- target) of the frame the controller sees
//     (the capture `latency` frames ago), for the image part of geometry that
//     is not made of the target's points (a 3-D circle, a polygon, a pose):
//     project it with its Feature kind's projection function;
//   * uv: the controller's points (2 x N normalised; the sensor's measurement
//     with its noise, distortion and latency), for the image part of features
//     made of the target's points (a line through points i and j);
//   * depth_pose: camera <- target as the episode's depth mode knows it, for
//     the depth inputs (a plane, a depth, a pose):
//       exact      the true cMo,
//       desired    the goal's cMo (constant, as the desired depths z*),
//       pose       ibvs::PlanarPose's estimate from the controller's points
//                  (from their bearings for feature blocks only through a
//                  wide lens: PlanarPose::estimate_bearings),
//       estimated  the rigid fit (Kabsch) of the target's points onto the
//                  points the depth estimate places in the camera frame,
//                  z_i (u_i, v_i, 1) (needs 3 non-collinear target points);
//     its translation times depth_scale (every depth of the scene scaled about
//     the camera centre, as the points' depths are), except for estimated;
//   * depth: the depths the depth mode gave the points (N), for per-point
//     depth inputs (a segment's endpoint depths);
//   * bearings: the controller's points as unit bearings (3 x N; the sensor's
//     pixels, with their noise and latency, through CameraModel::to_bearing:
//     beyond 90 degrees off the axis too), for features on the sphere;
//   * goal: the goal's camera <- target pose c*Mo as the depth mode knew it at
//     the goal (frame -1, teach by showing), for features whose measurement
//     compares the current pose with the desired one (PBVS, 2.5-D) or needs
//     the goal's area and depth (moments):
//       exact, desired  the goal's true pose (given),
//       pose       ibvs::PlanarPose's estimate from the goal's image (times
//                  depth_scale), as the depth pose from every frame's,
//       estimated  the rigid fit to the goal's image at the estimate's prior
//                  depths depth_scale z* (nothing has moved yet).
//     So with a wrong camera model (sim.MiscalibratedCamera) the pose-based
//     laws aim at the goal's image through that model, as IBVS does. With
//     EpisodeOptions::goal_pose = GoalPose::given it is the goal's true pose
//     in every depth mode (a c*Mo measured and given, not times depth_scale),
//     while depth_pose stays the mode's: the current estimate's bias is then
//     not cancelled (PBVS ends where the estimate equals the given pose).
// At the goal (frame -1) cMo = the goal's true pose, depth_pose = goal, uv the
// desired points and depth the goal's depths as the depth mode knows them
// (exact, desired: z*; pose: from the goal's estimate; estimated: its prior).
//
// A source's measure() is noexcept and allocation-free (called every frame);
// returning false, or a measurement its block's Feature::check refuses (a
// plane seen edge-on...), ends the episode as lost_feature with
// EpisodeStatus::feature = the block's index (at the goal: the run throws).
// Whether the feature is in view is judged on the target's points (left_image,
// behind_camera): give the target points on the geometry (e.g. on a circle's
// rim) for that check.
//
// Adding a kind (docs/simulator.md, "Feature sources"): derive from
// FeatureSource, say which Feature it feeds (fits), check its indices against
// the target in validate(), and write measure() with the kind's projection
// function; LineSource below is the model.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/feature.hpp"
#include "ibvs/features/ellipse.hpp"
#include "ibvs/features/moments.hpp"
#include "ibvs/features/pose.hpp"
#include "ibvs/layout.hpp"
#include "ibvs/se3.hpp"

#include <Eigen/Core>

#include <memory>
#include <string>

namespace ibvs::sim {

/// One frame as a feature source sees it (see above). Pointers valid during measure() only.
struct SourceFrame {
  int frame = 0;                                ///< -1: the goal, then 0, 1, ...
  Pose cMo = Pose::Identity();                  ///< true camera <- target of the frame the controller sees
  Pose depth_pose = Pose::Identity();           ///< camera <- target as the depth mode knows it (NaN: unknown)
  Pose goal = Pose::Identity();                 ///< camera <- target at the goal (c*Mo): taught or given (see above)
  const Eigen::Matrix3Xd* points = nullptr;     ///< 3 x N target points, target frame
  const Points* uv = nullptr;                   ///< 2 x N the controller's points, normalised
  const Eigen::VectorXd* depth = nullptr;       ///< N depths the depth mode gave them, metres
  const Bearings* bearings = nullptr;           ///< 3 x N the controller's points as unit bearings (NaN: not mapped)
};

class FeatureSource {
 public:
  virtual ~FeatureSource();
  virtual std::unique_ptr<FeatureSource> clone() const = 0;
  /// Its kind and parameters, e.g. "line(0, 1)".
  virtual std::string describe() const = 0;
  /// Doubles in one measurement (its Feature's size()).
  virtual int size() const noexcept = 0;
  /// Whether it can feed the Task's block `f` (default: the same measurement size).
  virtual bool fits(const Feature& f) const noexcept { return f.size() == size(); }
  /// Throws std::invalid_argument "ibvs: <name>: ..." when it does not fit the target's
  /// points (3 x N, target frame): an index out of range, a degenerate geometry.
  virtual void validate(const Eigen::Matrix3Xd& points, const std::string& name) const;
  /// The block's measurement (size() doubles) into m; false = it cannot be measured here.
  /// noexcept, allocation-free.
  virtual bool measure(const SourceFrame& frame, double* m) const noexcept = 0;

 protected:
  FeatureSource() = default;
  FeatureSource(const FeatureSource&) = default;
  FeatureSource& operator=(const FeatureSource&) = default;
};

/// The plane {X : n . X = d} of the target frame seen from pose cMo (camera <- target), as
/// 1/Z = A x + B y + C of the camera's normalised coordinates: (A, B, C) = R n / (d + (R n) . t).
/// False (plane untouched) when the plane passes through the camera centre or a value is not finite.
bool plane_in_camera(const Pose& cMo, const Eigen::Vector3d& n, double d, double plane[3]) noexcept;

/// An image line (LineFeature) through target points i and j: (rho, theta) from the
/// controller's points uv(i), uv(j) (LineFeature::measure), and the plane (A, B, C) that
/// holds the 3-D line from the depth pose: the target's z = 0 plane (k < 0: both points in
/// it), or the plane through points i, j and k (a non-planar target). Lost when the two
/// image points coincide or the plane passes through the camera centre.
class LineSource final : public FeatureSource {
 public:
  LineSource(int i, int j, int k = -1);
  std::unique_ptr<FeatureSource> clone() const override { return std::make_unique<LineSource>(*this); }
  std::string describe() const override;
  int size() const noexcept override { return 5; }
  bool fits(const Feature& f) const noexcept override;
  void validate(const Eigen::Matrix3Xd& points, const std::string& name) const override;
  bool measure(const SourceFrame& frame, double* m) const noexcept override;

  int i() const noexcept { return i_; }
  int j() const noexcept { return j_; }
  int k() const noexcept { return k_; }  ///< -1: the target's z = 0 plane

 private:
  int i_, j_, k_;
};

/// Image moments (MomentsFeature) of the target's points taken as one planar object: the moments
/// of the controller's points uv (MomentsFeature::of_polygon for source region: the points are the
/// polygon's vertices in order; of_points for source points), the plane (A, B, C) of the target's
/// z = 0 plane from the depth pose, and the goal's a* (the area of the goal's image of the points)
/// and Z* (the goal's depth at that image's centre of gravity). Every target point must be in the
/// z = 0 plane. Lost when the plane passes through the camera centre.
class MomentsSource final : public FeatureSource {
 public:
  explicit MomentsSource(MomentsFeature::Source source = MomentsFeature::Source::region) noexcept : source_(source) {}
  std::unique_ptr<FeatureSource> clone() const override { return std::make_unique<MomentsSource>(*this); }
  std::string describe() const override;
  int size() const noexcept override { return MomentsFeature::measurement_size; }
  bool fits(const Feature& f) const noexcept override;
  void validate(const Eigen::Matrix3Xd& points, const std::string& name) const override;
  bool measure(const SourceFrame& frame, double* m) const noexcept override;
  MomentsFeature::Source source() const noexcept { return source_; }

 private:
  MomentsFeature::Source source_;
};

/// PBVS (PbvsFeature): PbvsFeature::measure(depth_pose, goal, target), i.e. the pose the depth
/// mode gives (exact: the true one; pose: ibvs::PlanarPose's estimate from the image) against the
/// goal's as the same mode knew it (exact: the true one; pose: the estimate from the goal's
/// image). Lost when the depth pose is unknown or not a rigid transform.
class PbvsSource final : public FeatureSource {
 public:
  explicit PbvsSource(PbvsTarget target = PbvsTarget::desired_camera) noexcept : target_(target) {}
  std::unique_ptr<FeatureSource> clone() const override { return std::make_unique<PbvsSource>(*this); }
  std::string describe() const override;
  int size() const noexcept override { return 6; }
  bool fits(const Feature& f) const noexcept override;
  bool measure(const SourceFrame& frame, double* m) const noexcept override;
  PbvsTarget target() const noexcept { return target_; }

 private:
  PbvsTarget target_;
};

/// 2.5-D (Point25DFeature) of target point i as the reference point: (x, y) the controller's
/// point uv(i), Z the depth the depth mode gave it, theta u of c*Rc from the depth pose's rotation
/// against the goal's (SourceFrame::goal; its Z* is the depth the mode gave point i at the goal).
/// Lost when the depth pose is unknown or not a rigid transform.
class Point25DSource final : public FeatureSource {
 public:
  explicit Point25DSource(int i = 0);
  std::unique_ptr<FeatureSource> clone() const override { return std::make_unique<Point25DSource>(*this); }
  std::string describe() const override { return "point25d(" + std::to_string(i_) + ")"; }
  int size() const noexcept override { return 6; }
  bool fits(const Feature& f) const noexcept override;
  void validate(const Eigen::Matrix3Xd& points, const std::string& name) const override;
  bool measure(const SourceFrame& frame, double* m) const noexcept override;
  int i() const noexcept { return i_; }

 private:
  int i_;
};

/// A point on the sphere (SphericalPointFeature or SphericalPolarFeature) of target point i: the
/// bearing b the controller has of it (SourceFrame::bearings: the sensor's pixel through
/// CameraModel::to_bearing, valid over the lens's whole field of view) and its distance
/// R = |R_d p_i + t_d| from the depth pose (exact: the true distance; desired: the goal's; pose,
/// estimated: from their pose). Lost when the pixel has no bearing or the depth pose is unknown.
class SphericalSource final : public FeatureSource {
 public:
  explicit SphericalSource(int i = 0);
  std::unique_ptr<FeatureSource> clone() const override { return std::make_unique<SphericalSource>(*this); }
  std::string describe() const override { return "spherical(" + std::to_string(i_) + ")"; }
  int size() const noexcept override { return 4; }
  bool fits(const Feature& f) const noexcept override;
  void validate(const Eigen::Matrix3Xd& points, const std::string& name) const override;
  bool measure(const SourceFrame& frame, double* m) const noexcept override;
  int i() const noexcept { return i_; }

 private:
  int i_;
};

/// An image segment (SegmentFeature, either set) between target points i and j: (xc, yc, l, alpha)
/// of the controller's points uv(i) -> uv(j) (SegmentFeature::measure) and the end points' depths
/// Z1, Z2 as the depth mode gives them. Lost when the two image points are closer than
/// min_segment_length (the segment seen end-on).
class SegmentSource final : public FeatureSource {
 public:
  SegmentSource(int i, int j);
  std::unique_ptr<FeatureSource> clone() const override { return std::make_unique<SegmentSource>(*this); }
  std::string describe() const override;
  int size() const noexcept override { return 6; }
  bool fits(const Feature& f) const noexcept override;
  void validate(const Eigen::Matrix3Xd& points, const std::string& name) const override;
  bool measure(const SourceFrame& frame, double* m) const noexcept override;

  int i() const noexcept { return i_; }
  int j() const noexcept { return j_; }

 private:
  int i_, j_;
};

/// The image ellipse (EllipseFeature) of a 3-D circle fixed to the target (target frame: centre,
/// normal of its plane, radius, metres): (xg, yg, n20, n11, n02) of the circle's exact image from
/// the true pose cMo (EllipseFeature::project_circle: the geometry, without the sensor's noise),
/// the plane (A, B, C) of the circle from the depth pose. Give the target points on the circle's
/// rim: the episode judges visibility on them. Lost when the circle's image is not an ellipse (its
/// plane seen edge-on, part of it behind the camera) or the depth pose is unknown.
class EllipseSource final : public FeatureSource {
 public:
  /// Throws std::invalid_argument naming the argument: a non-finite centre, a normal of zero length
  /// (or not finite), a radius <= 0 (or not finite).
  EllipseSource(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal, double radius);
  std::unique_ptr<FeatureSource> clone() const override { return std::make_unique<EllipseSource>(*this); }
  std::string describe() const override;
  int size() const noexcept override { return 8; }
  bool fits(const Feature& f) const noexcept override;
  bool measure(const SourceFrame& frame, double* m) const noexcept override;

  const Eigen::Vector3d& centre() const noexcept { return centre_; }
  const Eigen::Vector3d& normal() const noexcept { return normal_; }  ///< unit length
  double radius() const noexcept { return radius_; }

 private:
  Eigen::Vector3d centre_, normal_;
  double radius_;
};

}  // namespace ibvs::sim
