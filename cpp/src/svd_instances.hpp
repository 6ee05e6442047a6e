// Eigen's JacobiSVD types the library compiles once (explicit instantiation) and
// other translation units only declare (extern template): each instantiation of
// the QR preconditioner and the Jacobi sweeps costs 10-25 s of compile time.
//
// * the thin SVD of a 6 x n Jacobian (n <= max_joints), held by JointMapping and
//   SecondaryTask (the private SvdMatrix of both): instantiated in robot_mapping.cpp,
//   declared here for secondary_task.cpp;
// * JacobiSVD<MatrixXd>: instantiated in pinv.cpp (damped_pinv, singular_values),
//   declared here for the C++ tests' independent SVDs (tests/CMakeLists.txt puts this
//   header in their precompiled header);
// * JacobiSVD<Matrix3d> (full U, V: the rotation nearest a 3 x 3 matrix): instantiated in
//   planar_pose.cpp, declared here for the simulator's planar-target source (sim/stages/sources.hpp).
// The same code runs as if each translation unit instantiated it: results bit for bit.
#pragma once

#include "ibvs/robot_mapping.hpp"

#include <Eigen/Core>
#include <Eigen/SVD>

namespace ibvs::detail {
using JointSvdMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, max_joints>;
}  // namespace ibvs::detail

extern template class Eigen::JacobiSVD<ibvs::detail::JointSvdMatrix>;
extern template class Eigen::JacobiSVD<Eigen::MatrixXd>;
extern template class Eigen::JacobiSVD<Eigen::Matrix3d>;
