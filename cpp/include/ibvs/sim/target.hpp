// The observed object: N points given in the target's own frame, the
// target's pose in the world, and the sources of the feature blocks a Task
// servoes on besides its points (source.hpp: lines between target points...),
// one per block, in the Task's block order.
#pragma once

#include "ibvs/se3.hpp"
#include "ibvs/sim/source.hpp"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace ibvs::sim {

struct Target {
  Target() = default;
  Target(Eigen::Matrix3Xd points, const Pose& pose = Pose::Identity());  ///< points 3 x N (target frame), world <- target
  // Special members defined in the library (which allocates the points), for consumers built with other flags.
  Target(const Target&);
  Target(Target&&) noexcept;
  Target& operator=(const Target&);
  Target& operator=(Target&&) noexcept;
  ~Target();
  Eigen::Matrix3Xd points;         ///< 3 x N, target frame, metres
  Pose pose = Pose::Identity();    ///< world <- target
  /// The feature blocks' sources, in the Task's block order (shared, immutable: copies of the
  /// Target share them, as copies of a Task share its blocks).
  std::vector<std::shared_ptr<const FeatureSource>> sources;

  /// Appends a copy of `source` (validated against the points: throws std::invalid_argument).
  Target& add(const FeatureSource& source);

  /// Paper Table I: the four points (+-0.25, +-0.25, 3) in the world (target
  /// frame at (0, 0, 3), axes of the world). Order: (-,-), (+,-), (+,+), (-,+).
  static Target paper();
  /// Four dots at the corners of a square of the given side, centred on the
  /// target origin in its z = 0 plane (Section III-B: a 10 cm square), same order.
  static Target square(double side = 0.1, const Pose& pose = Pose::Identity());

  int size() const noexcept { return static_cast<int>(points.cols()); }
  /// All points in the target's z = 0 plane (needed by the pose depth mode).
  bool planar(double tol = 1e-12) const noexcept;
  /// Points in the world frame, 3 x N.
  Eigen::Matrix3Xd world_points() const;

  /// Throws std::invalid_argument naming the bad field (points, pose, sources[k]).
  void validate() const;
  std::string describe() const;
};

}  // namespace ibvs::sim
