// The paper's cases for the C++ simulator tests: the same numbers as
// python/ibvs/sim/cases.py (which documents how they were chosen).
#pragma once

#include "ibvs/ibvs.hpp"
#include "ibvs/sim/sim.hpp"

#include <Eigen/Geometry>

namespace sim_cases {

using namespace ibvs;
using namespace ibvs::sim;

inline Pose make_pose(double tx, double ty, double tz, double rx, double ry, double rz) {
  Pose T = Pose::Identity();
  T.topLeftCorner<3, 3>() = rxyz(rx, ry, rz);
  T.topRightCorner<3, 1>() << tx, ty, tz;
  return T;
}

inline Pose half_turn_z() {  // exact diag(-1, -1, 1), as cases.z_rotation() builds it
  Pose T = Pose::Identity();
  T(0, 0) = T(1, 1) = -1.0;
  return T;
}

inline Pose x_translation() { return make_pose(0.2, 0, 0, 0, 0, 0); }
inline Pose general_motion() { return make_pose(0.15, -0.1, -0.6, 0.12, -0.1, 0.6); }

inline Joints gantry_goal() { return (Joints() << 0, 0, 0, 0, 0.4, 0).finished(); }
// cases.gantry_general_motion().start (camera moved by (0.04, -0.03, -0.12), rxyz (0.1, -0.15, 0.8))
inline Joints gantry_start() {
  return (Joints() << 0.18835158467582477, 0.13029503186413266, -0.08642184066403318, 0.8211754709024601,
          0.24154253183929314, -0.4579106120861423)
      .finished();
}
// cases.gantry_joint_limit().start
inline Joints gantry_joint_limit_start() {
  return (Joints() << -0.17402027717582613, 0.0410626054118219, -0.04178406077186157, -0.6130717302227199,
          0.1973306775960816, 0.24484268338397025)
      .finished();
}
inline Target gantry_target(const Gantry& g) {
  return Target::square(0.1, g.camera(gantry_goal()) * make_pose(0, 0, 0.6, 0, 0, 0));
}

/// A redundant robot for the episode tests (n = 7): the gantry with a second
/// z slide q7 stacked on the first (its FK sees q3 + q7; Jacobian column 7 =
/// column 3), and a failure switch for kinematics().
struct StackedGantry final : Robot {
  Gantry g = Gantry::afma6();
  bool fail = false;
  StackedGantry() {
    q_min.resize(7);
    q_max.resize(7);
    qdot_max.resize(7);
    q_min << g.q_min, -0.5;
    q_max << g.q_max, 0.5;
    qdot_max << g.qdot_max, 0.2;
    mount = g.mount;
    mapping = g.mapping;
  }
  static Joints folded(const JointVector& q) {
    Joints q6 = q.head<6>();
    q6(2) += q(6);
    return q6;
  }
  bool kinematics(const JointVector& q, Pose& T_we, RobotJacobian& J) const noexcept override {
    RobotJacobian J6;
    if (fail || !g.kinematics(folded(q), T_we, J6)) return false;
    J.resize(6, 7);
    J << J6, J6.col(2);
    return true;
  }
};

inline JointVector stacked_start() { return (JointVector(7) << gantry_start(), 0.0).finished(); }
inline JointVector stacked_goal() { return (JointVector(7) << gantry_goal(), 0.0).finished(); }

/// Episode options with a duration (s) and a convergence tolerance, the rest default.
inline EpisodeOptions opts(double duration, double tolerance) {
  EpisodeOptions o;
  o.duration = duration;
  o.tolerance = tolerance;
  return o;
}

/// Frame k's world <- camera pose of a recorded episode.
inline Pose row_pose(const History& h, int k) {
  return Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(h.pose.row(k).data());
}

}  // namespace sim_cases
