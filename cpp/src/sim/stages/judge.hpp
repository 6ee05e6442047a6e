// Stage 5 of an episode's frame, judge: whether the episode ends at this frame,
// and how (Outcome; ibvs/sim/episode.hpp). The loop asks it after each stage,
// in this order, and stops at the first verdict:
//   camera()    the camera where it now is: diverged (the robot's kinematics
//               failed, a non-finite pose, the target farther than
//               max_depth_ratio times its start depth), then the camera against
//               the target's faces: collision, target_backside (contact());
//   sighting()  what measure captured: behind_camera, left_image (off the
//               sensor or the model's domain), diverged (the sensor failed),
//               lost_feature (the sensor lost a point);
//   view()      left_image (a pixel the model cannot normalise);
//   features()  lost_feature (a feature block its source could not measure);
//   control()   diverged (the servo refused its input), converged (error norm
//               under tolerance and, with tolerance_px > 0, the frame's worst
//               measured point within tolerance_px of its goal), singular (stop_on_singular), diverged (a
//               non-finite twist or error, or the error beyond max_error_ratio
//               times its first value), timeout (the last frame);
//   motion()    joint_limit (a joint would leave its range).
// Each fills the status (outcome, frame, point or joint) and returns true when
// the episode ends. The judge also keeps the camera's retreat (the target's
// depth beyond its start depth), which it measures anyway.
//
// Target faces (contact(); the rules are in episode.hpp): a planar target is
// a plate, its front the side of its plane the goal camera's centre is on, its
// extent the disc about the points' centroid through the farthest point; a
// non-planar target has no front, only a standoff around each point.
#pragma once

#include "ibvs/sim/episode.hpp"
#include "measure.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>

namespace ibvs::sim::stages {

class Judge {
 public:
  /// frames: the history's capacity (timeout at frame frames - 1); by_distance: max_depth_ratio
  /// bounds the target centroid's distance from the camera centre, not its z (a wide lens,
  /// wide_lens(), whose target may start beside or behind the camera). The retreat is along z.
  Judge(const Target& target, const EpisodeOptions& options, int frames, bool by_distance = false);

  /// The faces from the goal camera (world <- camera): the front, the standoff.
  void aim(const Pose& goal) noexcept;
  /// A new run: the retreat restarts (the references, start depth and first error, are taken at frame 0).
  void start() noexcept { retreat_ = 0.0; }

  /// The verdicts, in the loop's order (above): true when the episode ends at frame k, st filled.
  /// camera() also keeps the retreat and the last camera centre (for the next contact()).
  bool camera(int k, const Pose& T_wc, const Eigen::Matrix3d& Rcw, const Eigen::Vector3d& tcw, bool kinematics_ok,
              EpisodeStatus& st) noexcept;
  bool sighting(int k, const Sighting& s, EpisodeStatus& st) const noexcept;
  bool view(int k, int lost, EpisodeStatus& st) const noexcept;
  /// lost: the sources stage's first block it could not measure (-1: none).
  bool features(int k, int lost, EpisodeStatus& st) const noexcept;
  /// pixel_error: the frame's Sighting::pixel_error (used when tolerance_px > 0; NaN never passes).
  /// With keep_lost: lost_point is the first point the controller lacks (-1: none); not converged
  /// while one is lost, and lost_feature once Status::features_lost has ramped the twist to zero.
  bool control(int k, Status s, const ServoOutput& out, double pixel_error, EpisodeStatus& st,
               int lost_point = -1) noexcept;
  bool motion(int k, int joint, EpisodeStatus& st) const noexcept;

  /// Collision or target_backside for the camera centre moving from `from` (the last frame's;
  /// ignored unless `moved`) to `to`: fills st's outcome and point (frame -1) and returns true.
  bool contact(const Eigen::Vector3d& from, const Eigen::Vector3d& to, bool moved, EpisodeStatus& st) const noexcept;

  double retreat() const noexcept { return retreat_; }  ///< max over the frames so far of depth - start depth, >= 0
  const Eigen::Vector3d& front() const noexcept { return front_; }  ///< unit normal of the plate's front (0: none)
  double extent() const noexcept { return extent_; }    ///< radius of the plate's disc, metres
  double standoff() const noexcept { return standoff_; }  ///< metres

 private:
  EpisodeOptions options_;
  int last_ = 0;  // the last frame (timeout)
  bool planar_ = false, by_distance_ = false;
  Eigen::Matrix3d target_rotation_ = Eigen::Matrix3d::Identity();  // world <- target
  Eigen::Matrix3Xd world_points_;
  Eigen::Vector3d centroid_w_ = Eigen::Vector3d::Zero();  // of the points, in the world
  Eigen::Vector3d front_ = Eigen::Vector3d::Zero();
  double extent_ = 0.0, standoff_ = 0.0;
  // references of the run: the target's depth at frame 0, the error norm at frame 0
  double depth0_ = 0.0, range0_ = 0.0, error0_ = 0.0, retreat_ = 0.0;
  Eigen::Vector3d c_prev_ = Eigen::Vector3d::Zero();  // the camera centre at the last frame judged
};

// ---------------------------------------------------------------- implementation

inline Judge::Judge(const Target& target, const EpisodeOptions& options, int frames, bool by_distance)
    : options_(options),
      last_(frames - 1),
      planar_(target.planar()),
      by_distance_(by_distance),
      target_rotation_(target.pose.topLeftCorner<3, 3>()),
      world_points_(target.world_points()) {
  const Eigen::Vector3d centroid = target.points.rowwise().mean();  // target frame
  centroid_w_ = target.pose.topLeftCorner<3, 3>() * centroid + target.pose.topRightCorner<3, 1>();
  if (planar_) extent_ = (target.points.colwise() - centroid).colwise().norm().maxCoeff();
}

inline void Judge::aim(const Pose& goal) noexcept {
  const Pose T_cw = se3_inverse(goal);
  const Eigen::Vector3d to_goal = goal.topRightCorner<3, 1>() - centroid_w_;
  standoff_ = options_.standoff_ratio * (T_cw.topLeftCorner<3, 3>() * centroid_w_ + T_cw.topRightCorner<3, 1>())(2);
  // The front is the goal camera's side of a planar target's plane (none if the goal is in the plane).
  front_.setZero();
  if (planar_) {
    const Eigen::Vector3d n = target_rotation_.col(2);
    const double side = n.dot(to_goal);
    if (std::abs(side) > 1e-9 * std::max(1.0, to_goal.norm())) front_ = side > 0.0 ? n : Eigen::Vector3d(-n);
  }
}

inline bool Judge::camera(int k, const Pose& T_wc, const Eigen::Matrix3d& Rcw, const Eigen::Vector3d& tcw,
                          bool kinematics_ok, EpisodeStatus& st) noexcept {
  const Eigen::Vector3d centroid = Rcw * centroid_w_ + tcw;  // of the points, camera frame
  const double target_depth = centroid(2), range = by_distance_ ? centroid.norm() : target_depth;
  if (k == 0) {
    depth0_ = target_depth;
    range0_ = range;
  }
  retreat_ = std::max(retreat_, target_depth - depth0_);
  if (!kinematics_ok || !T_wc.allFinite() || range > options_.max_depth_ratio * std::abs(range0_)) {
    st = {Outcome::diverged, k, -1, -1};
    return true;
  }
  const Eigen::Vector3d c = T_wc.topRightCorner<3, 1>();
  const bool hit = contact(c_prev_, c, k > 0, st);
  c_prev_ = c;
  if (hit) st.frame = k;
  return hit;
}

inline bool Judge::sighting(int k, const Sighting& s, EpisodeStatus& st) const noexcept {
  if (s.behind >= 0)
    st = {Outcome::behind_camera, k, s.behind, -1};
  else if (s.outside >= 0)
    st = {Outcome::left_image, k, s.outside, -1};
  else if (!s.sensed)  // the sensor itself failed (e.g. a Python sensor raised)
    st = {Outcome::diverged, k, -1, -1};
  else if (s.missing >= 0 && !options_.keep_lost)  // keep_lost: the servo decides (control())
    st = {Outcome::lost_feature, k, s.missing, -1};
  else
    return false;
  return true;
}

inline bool Judge::view(int k, int lost, EpisodeStatus& st) const noexcept {
  if (lost < 0) return false;
  st = {Outcome::left_image, k, lost, -1};
  return true;
}

inline bool Judge::features(int k, int lost, EpisodeStatus& st) const noexcept {
  if (lost < 0) return false;
  st = {Outcome::lost_feature, k, -1, -1, lost};
  return true;
}

inline bool Judge::control(int k, Status s, const ServoOutput& out, double pixel_error, EpisodeStatus& st,
                           int lost_point) noexcept {
  if (s == Status::invalid_input) {  // e.g. an estimated depth <= 0
    st = {Outcome::diverged, k, -1, -1};
    return true;
  }
  if (k == 0) error0_ = out.error_norm;
  if (s == Status::features_lost && out.velocity.isZero(0.0))
    st = {Outcome::lost_feature, k, lost_point, -1};
  else if (s != Status::features_lost && out.lost_points == 0 && out.error_norm < options_.tolerance &&
           (options_.tolerance_px == 0.0 || pixel_error <= options_.tolerance_px))
    st = {Outcome::converged, k, -1, -1};
  else if (s == Status::singular && options_.stop_on_singular)
    st = {Outcome::singular, k, -1, -1};
  else if (!out.velocity.allFinite() || !std::isfinite(out.error_norm) ||
           out.error_norm > options_.max_error_ratio * error0_)
    st = {Outcome::diverged, k, -1, -1};
  else if (k == last_)
    st = {Outcome::timeout, k, -1, -1};
  else
    return false;
  return true;
}

inline bool Judge::motion(int k, int joint, EpisodeStatus& st) const noexcept {
  if (joint < 0) return false;
  st = {Outcome::joint_limit, k, -1, joint};
  return true;
}

inline bool Judge::contact(const Eigen::Vector3d& from, const Eigen::Vector3d& to, bool moved,
                           EpisodeStatus& st) const noexcept {
  if (front_.isZero()) {  // no plate: the standoff around each point
    for (Eigen::Index i = 0; i < world_points_.cols(); ++i)
      if ((to - world_points_.col(i)).norm() < standoff_) {
        st = {Outcome::collision, -1, static_cast<int>(i), -1};
        return true;
      }
    return false;
  }
  // Height above the plane (> 0 in front) and distance from the centroid within it.
  const auto height = [&](const Eigen::Vector3d& c) { return front_.dot(c - centroid_w_); };
  const auto radial = [&](const Eigen::Vector3d& c, double hc) { return (c - centroid_w_ - hc * front_).norm(); };
  const double h1 = height(to);
  if (moved) {
    const double h0 = height(from);
    if (h0 > 0.0 && h1 <= 0.0) {  // crossed the plane since the last frame: where?
      const Eigen::Vector3d x = from + (h0 / (h0 - h1)) * (to - from);
      st = {radial(x, 0.0) <= extent_ ? Outcome::collision : Outcome::target_backside, -1, -1, -1};
      return true;
    }
  }
  if (!(h1 > 0.0)) {  // behind the plane: every point is seen from behind its plate
    st = {Outcome::target_backside, -1, -1, -1};
    return true;
  }
  if (std::hypot(h1, std::max(0.0, radial(to, h1) - extent_)) < standoff_) {  // distance to the disc
    st = {Outcome::collision, -1, -1, -1};
    return true;
  }
  return false;
}

}  // namespace ibvs::sim::stages
