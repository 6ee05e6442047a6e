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

namespace ibvs::sim::stages {

class Judge {
 public:
  Judge() = default;
  /// frames: the history's capacity (timeout at frame frames - 1).
  Judge(const Target& target, const EpisodeOptions& options, int frames);

  /// The faces from the goal camera (world <- camera): the front, the standoff.
  void aim(const Pose& goal) noexcept;
  /// A new run: the references (start depth, first error) and the retreat restart.
  void start() noexcept { retreat_ = 0.0; }

  bool camera(int k, const Pose& T_wc, const Eigen::Matrix3d& Rcw, const Eigen::Vector3d& tcw, bool kinematics_ok,
              EpisodeStatus& st) noexcept;
  bool sighting(int k, const Sighting& s, EpisodeStatus& st) const noexcept;
  bool view(int k, int lost, EpisodeStatus& st) const noexcept;
  /// pixel_error: the frame's Sighting::pixel_error (used when tolerance_px > 0; NaN never passes).
  bool control(int k, Status s, const ServoOutput& out, double pixel_error, EpisodeStatus& st) noexcept;
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
  bool planar_ = false;
  Eigen::Matrix3d target_rotation_ = Eigen::Matrix3d::Identity();  // world <- target
  Eigen::Matrix3Xd world_points_;
  Eigen::Vector3d centroid_w_ = Eigen::Vector3d::Zero();  // of the points, in the world
  Eigen::Vector3d front_ = Eigen::Vector3d::Zero();
  double extent_ = 0.0, standoff_ = 0.0;
  // references of the run: the target's depth at frame 0, the error norm at frame 0
  double depth0_ = 0.0, error0_ = 0.0, retreat_ = 0.0;
  Eigen::Vector3d c_prev_ = Eigen::Vector3d::Zero();  // the camera centre at the last frame judged
};

}  // namespace ibvs::sim::stages
