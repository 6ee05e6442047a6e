// Eigen's JacobiSVD types the library compiles once (explicit instantiation) and
// other translation units only declare (extern template): each instantiation of
// the QR preconditioner and the Jacobi sweeps costs 1-8 s of compile time.
//
// * JacobiSVD<MatrixXd>: instantiated in pinv.cpp (damped_pinv, singular_values);
//   declared here for robot_mapping.cpp and secondary_task.cpp (the thin SVD of the
//   6 x n camera Jacobian, in storage sized once by their constructors) and for the
//   C++ tests' independent SVDs (tests/CMakeLists.txt puts this header in their
//   precompiled header). A bounded 6 x max_joints type of its own cost 8 s more;
// * JacobiSVD<Matrix3d> (full U, V: the rotation nearest a 3 x 3 matrix): instantiated in
//   planar_pose.cpp, declared here for the simulator's planar-target source (sim/stages/sources.hpp).
// The same code runs as if each translation unit instantiated it.
#pragma once

#include <Eigen/Core>
#include <Eigen/SVD>

extern template class Eigen::JacobiSVD<Eigen::MatrixXd>;
extern template class Eigen::JacobiSVD<Eigen::Matrix3d>;
