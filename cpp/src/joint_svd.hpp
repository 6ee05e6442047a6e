// The thin SVD of a 6 x n Jacobian (n <= max_joints), compiled in one translation unit.
//
// JointMapping and SecondaryTask each hold an Eigen::JacobiSVD of this matrix type (the
// private SvdMatrix of both classes). Its instantiation (the QR preconditioner and the
// Jacobi sweeps) costs ~12 s of compile time; robot_mapping.cpp instantiates it once
// (explicit instantiation definition) and secondary_task.cpp only declares it (extern
// template): the same code runs, so results are bit for bit as before.
#pragma once

#include "ibvs/robot_mapping.hpp"

#include <Eigen/Core>
#include <Eigen/SVD>

namespace ibvs::detail {
using JointSvdMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, max_joints>;
}  // namespace ibvs::detail

extern template class Eigen::JacobiSVD<ibvs::detail::JointSvdMatrix>;
