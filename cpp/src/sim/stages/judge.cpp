#include "judge.hpp"

#include <algorithm>
#include <cmath>

namespace ibvs::sim::stages {

Judge::Judge(const Target& target, const EpisodeOptions& options, int frames)
    : options_(options),
      last_(frames - 1),
      planar_(target.planar()),
      target_rotation_(target.pose.topLeftCorner<3, 3>()),
      world_points_(target.world_points()) {
  const Eigen::Vector3d centroid = target.points.rowwise().mean();  // target frame
  centroid_w_ = target.pose.topLeftCorner<3, 3>() * centroid + target.pose.topRightCorner<3, 1>();
  if (planar_) extent_ = (target.points.colwise() - centroid).colwise().norm().maxCoeff();
}

void Judge::aim(const Pose& goal) noexcept {
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

bool Judge::camera(int k, const Pose& T_wc, const Eigen::Matrix3d& Rcw, const Eigen::Vector3d& tcw,
                   bool kinematics_ok, EpisodeStatus& st) noexcept {
  const double target_depth = (Rcw * centroid_w_ + tcw)(2);  // of the points' centroid
  if (k == 0) depth0_ = target_depth;
  retreat_ = std::max(retreat_, target_depth - depth0_);
  if (!kinematics_ok || !T_wc.allFinite() || target_depth > options_.max_depth_ratio * std::abs(depth0_)) {
    st = {Outcome::diverged, k, -1, -1};
    return true;
  }
  const Eigen::Vector3d c = T_wc.topRightCorner<3, 1>();
  const bool hit = contact(c_prev_, c, k > 0, st);
  c_prev_ = c;
  if (hit) st.frame = k;
  return hit;
}

bool Judge::sighting(int k, const Sighting& s, EpisodeStatus& st) const noexcept {
  if (s.behind >= 0)
    st = {Outcome::behind_camera, k, s.behind, -1};
  else if (s.outside >= 0)
    st = {Outcome::left_image, k, s.outside, -1};
  else if (!s.sensed)  // the sensor itself failed (e.g. a Python sensor raised)
    st = {Outcome::diverged, k, -1, -1};
  else if (s.missing >= 0)
    st = {Outcome::lost_feature, k, s.missing, -1};
  else
    return false;
  return true;
}

bool Judge::view(int k, int lost, EpisodeStatus& st) const noexcept {
  if (lost < 0) return false;
  st = {Outcome::left_image, k, lost, -1};
  return true;
}

bool Judge::control(int k, Status s, const ServoOutput& out, double pixel_error, EpisodeStatus& st) noexcept {
  if (s == Status::invalid_input) {  // e.g. an estimated depth <= 0
    st = {Outcome::diverged, k, -1, -1};
    return true;
  }
  if (k == 0) error0_ = out.error_norm;
  if (out.error_norm < options_.tolerance && (options_.tolerance_px == 0.0 || pixel_error <= options_.tolerance_px))
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

bool Judge::motion(int k, int joint, EpisodeStatus& st) const noexcept {
  if (joint < 0) return false;
  st = {Outcome::joint_limit, k, -1, joint};
  return true;
}

bool Judge::contact(const Eigen::Vector3d& from, const Eigen::Vector3d& to, bool moved,
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
