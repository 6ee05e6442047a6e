// Task: what a Servo drives to zero. Rows 0..point_rows()-1 are the image
// points of a Layout (the paper's Cartesian, polar, hybrid and stacked point
// features, exactly as a Servo of that Layout computes them); the rows after
// them are blocks of any other kind (feature.hpp), in the order they were
// added. Every block may carry a weight (its rows of J and of the error are
// multiplied by it: weighted least squares), and the task may leave camera
// degrees of freedom out (ViSP's vpServo::setCameraDoF): their twist
// components are 0 and the law is solved on the other columns of J.
//
// Why a Task around a Layout rather than a more general Layout: the point
// blocks keep their dedicated, fixed-size kernels (a Layout-only Task is solved
// bit for bit as before, at the same speed), and every other kind plugs in
// through one small interface without changing how point layouts are written.
#pragma once

#include "ibvs/feature.hpp"
#include "ibvs/layout.hpp"

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace ibvs {

/// Which camera twist components (Tx, Ty, Tz, wx, wy, wz) a task may command.
using Dof = std::array<bool, 6>;
inline constexpr Dof all_dof{true, true, true, true, true, true};

class Task {
 public:
  /// The image points of `points` only: the same law as a Servo of that Layout.
  Task(Layout points);  // NOLINT: implicit on purpose, a Layout is a Task
  /// No image points (feature blocks only; add() at least one before use).
  Task();
  Task(const Task&);
  Task(Task&&) noexcept;
  Task& operator=(const Task&);
  Task& operator=(Task&&) noexcept;
  ~Task();

  /// Appends a copy of `feature`; its rows are multiplied by `weight` (in [1e-6, 1e6]: max_task_weight).
  /// Throws std::invalid_argument for a bad weight or more than max_task_rows rows in all.
  Task& add(const Feature& feature, double weight = 1.0);
  /// One weight per block of the Layout (each in [1e-6, 1e6]); default all 1.
  Task& set_point_weights(std::vector<double> weights);
  /// The controlled degrees of freedom (at least one).
  Task& set_dof(const Dof& dof);

  bool has_points() const noexcept { return points_.rows() > 0; }
  const Layout& points() const noexcept { return points_; }
  int n_points() const noexcept { return points_.n_points(); }
  int point_rows() const noexcept { return points_.rows(); }
  int rows() const noexcept { return points_.rows() + feature_rows_; }
  /// Doubles in one measurement of every feature block, concatenated in block order.
  int measurement_size() const noexcept { return measurement_size_; }

  int n_features() const noexcept { return static_cast<int>(blocks_.size()); }
  const Feature& feature(int k) const noexcept { return *blocks_[static_cast<std::size_t>(k)].feature; }
  double weight(int k) const noexcept { return blocks_[static_cast<std::size_t>(k)].weight; }
  int row(int k) const noexcept { return blocks_[static_cast<std::size_t>(k)].row; }  ///< first row of block k
  int offset(int k) const noexcept { return blocks_[static_cast<std::size_t>(k)].offset; }  ///< its measurement
  const std::vector<double>& point_weights() const noexcept { return point_weights_; }  ///< empty = all 1
  const Dof& dof() const noexcept { return dof_; }
  int n_dof() const noexcept;

  /// Points of a Layout only, unit weights, every DOF: solved by the point kernels as before.
  bool points_only() const noexcept { return blocks_.empty() && point_weights_.empty() && dof_ == all_dof; }
  /// The Layout's description, then each block ("stacked(4) + line + moments(...)"), weights and DOF.
  std::string describe() const;

 private:
  struct Block {
    std::shared_ptr<const Feature> feature;  // immutable once added: copies of the Task share it
    double weight = 1.0;
    int row = 0, offset = 0;
  };
  Layout points_;
  std::vector<Block> blocks_;
  std::vector<double> point_weights_;
  Dof dof_ = all_dof;
  int feature_rows_ = 0, measurement_size_ = 0;
};

}  // namespace ibvs
