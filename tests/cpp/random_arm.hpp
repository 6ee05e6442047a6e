// A random serial arm for the robot-mapping tests, written independently of
// the library's kinematics: forward kinematics as a product of exponentials,
// T_be(q) = exp(xi_1 q_1) ... exp(xi_n q_n) M, with random revolute screw axes
// (one in four prismatic, at most two, so that the arm is not singular
// everywhere), and Jacobians only by central differences.
#pragma once

#include "ibvs/robot_mapping.hpp"
#include "ibvs/se3.hpp"

#include <Eigen/Geometry>

#include <random>
#include <vector>

namespace ibvs_test {

class RandomArm {
 public:
  RandomArm(int n, std::mt19937& rng) : n_(n), M_(random_pose(rng)) {
    std::normal_distribution<double> g(0.0, 1.0);
    std::uniform_int_distribution<int> kind(0, 3);
    int prismatic = 0;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
      const Eigen::Vector3d point(0.3 * g(rng), 0.3 * g(rng), 0.3 * g(rng));
      ibvs::Twist xi;
      if (kind(rng) == 0 && prismatic++ < 2) xi << axis, Eigen::Vector3d::Zero();  // prismatic (at most 2)
      else xi << -axis.cross(point), axis;                                         // revolute through `point`
      axes_.push_back(xi);
    }
  }

  static ibvs::Pose random_pose(std::mt19937& rng) {
    std::normal_distribution<double> g(0.0, 1.0);
    ibvs::Pose T = ibvs::Pose::Identity();
    T.topLeftCorner<3, 3>() = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    T.topRightCorner<3, 1>() << 0.2 * g(rng), 0.2 * g(rng), 0.2 * g(rng);
    return T;
  }

  ibvs::JointVector random_q(std::mt19937& rng) const {
    std::uniform_real_distribution<double> u(-2.0, 2.0);
    ibvs::JointVector q(n_);
    for (int i = 0; i < n_; ++i) q(i) = u(rng);
    return q;
  }

  /// base <- end effector
  ibvs::Pose fk(const ibvs::JointVector& q) const {
    ibvs::Pose T = ibvs::Pose::Identity();
    for (int i = 0; i < n_; ++i) T = T * ibvs::se3_exp(axes_[static_cast<std::size_t>(i)] * q(i));
    return T * M_;
  }

  /// Body Jacobian of the frame fk(q) * X by central differences: column j is
  /// (T^-1 dT/dq_j)^vee, the frame's linear and angular velocity in itself.
  ibvs::RobotJacobian body_jacobian_fd(const ibvs::JointVector& q, const ibvs::Pose& X, double h = 1e-6) const {
    ibvs::RobotJacobian J(6, n_);
    const ibvs::Pose Ti = ibvs::se3_inverse(fk(q) * X);
    for (int j = 0; j < n_; ++j) {
      ibvs::JointVector dq = ibvs::JointVector::Zero(n_);
      dq(j) = h;
      const ibvs::Pose D = Ti * (fk(q + dq) * X - fk(q - dq) * X) / (2 * h);
      J.col(j) << D(0, 3), D(1, 3), D(2, 3), D(2, 1), D(0, 2), D(1, 0);
    }
    return J;
  }

 private:
  int n_;
  ibvs::Pose M_;
  std::vector<ibvs::Twist> axes_;
};

}  // namespace ibvs_test
