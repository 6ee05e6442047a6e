// A user's own feature block from one callable that gives its value and its
// interaction matrix (ViSP's vpGenericFeature, without its per-frame copies):
//
//   ibvs::FunctionFeature f(3, 6, [](const double* m, double* s, Eigen::Ref<ibvs::MatrixX6> L) noexcept {
//     ...;          // s (rows doubles) and L (rows x 6, d s/dt = L v) from the measurement m (size doubles)
//     return true;  // false: the measurement is refused
//   });
//   task.add(f);
//
// The callable is stored by value (no std::function, nothing allocated per
// frame); the Servo calls it from check() (to decide the refusal: false, or a
// non-finite or huge s or L), value() and interaction(), so it must be a pure
// function of m and should be noexcept. For a feature of several files, derive
// from ibvs::Feature instead (see features/line.hpp). At most max_function_rows
// rows (its check() evaluates it into stack buffers).
#pragma once

#include "ibvs/feature.hpp"
#include "ibvs/finite.hpp"
#include "ibvs/limits.hpp"

#include <Eigen/Core>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace ibvs {

inline constexpr int max_function_rows = 64;

template <class F>
class FunctionFeature final : public Feature {
 public:
  /// rows in [1, max_function_rows], size >= 1 doubles per measurement; name for describe().
  FunctionFeature(int rows, int size, F f, std::string name = "function")
      : rows_(rows), size_(size), f_(std::move(f)), name_(std::move(name)) {
    if (rows < 1 || rows > max_function_rows)
      throw std::invalid_argument("ibvs: rows must be in [1, " + std::to_string(max_function_rows) + "], got " +
                                  std::to_string(rows));
    if (size < 1) throw std::invalid_argument("ibvs: size must be at least 1, got " + std::to_string(size));
  }

  std::unique_ptr<Feature> clone() const override { return std::make_unique<FunctionFeature>(*this); }
  std::string describe() const override { return name_ + "(rows=" + std::to_string(rows_) + ")"; }
  int rows() const noexcept override { return rows_; }
  int size() const noexcept override { return size_; }

  const char* check(const double* m, int& entry) const noexcept override {
    for (entry = 0; entry < size_; ++entry)
      if (!std::isfinite(m[entry])) return "is not finite";
    entry = -1;
    double s[max_function_rows];
    Eigen::Matrix<double, Eigen::Dynamic, 6, 0, max_function_rows, 6> L(rows_, 6);
    Eigen::Map<MatrixX6> Lmap(L.data(), rows_, 6);
    if (!f_(m, s, Lmap)) return "refused by the feature's function";
    if (!finite_within(Eigen::Map<const Eigen::VectorXd>(s, rows_), max_matrix_entry))
      return "the feature's function gave a non-finite or huge value";
    if (!finite_within(L, max_matrix_entry))
      return "the feature's function gave a non-finite or huge interaction matrix";
    return nullptr;
  }
  void value(const double* m, double* s) const noexcept override {
    Eigen::Matrix<double, Eigen::Dynamic, 6, 0, max_function_rows, 6> L(rows_, 6);
    Eigen::Map<MatrixX6> Lmap(L.data(), rows_, 6);
    f_(m, s, Lmap);
  }
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override {
    double s[max_function_rows];
    f_(m, s, L.topRows(rows_));
  }

 private:
  int rows_, size_;
  F f_;
  std::string name_;
};

}  // namespace ibvs
