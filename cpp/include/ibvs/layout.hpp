// Layout: which feature blocks are stacked, in which row order (paper eqs. 9-10
// and Section V), and the stacked features, Jacobian and error it defines.
#pragma once

#include "ibvs/angle_wrap.hpp"
#include "ibvs/features.hpp"
#include "ibvs/limits.hpp"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace ibvs {

/// Image points, one column (u, v) per point: 2xN, column-major. Its memory is
/// that of a C-ordered numpy array of shape (N, 2).
using Points = Eigen::Matrix2Xd;

/// One 2-row block of the stacked feature vector / Jacobian.
struct Block {
  int point = 0;  ///< index of the image point, 0 <= point < n_points
  Representation representation = Representation::cartesian;
};

/// An ordered list of blocks; block k fills rows 2k and 2k+1.
class Layout {
 public:
  /// Every block of point `point` is distinct; indices in [0, n_points),
  /// n_points <= max_points. n_points < 0 means "largest index + 1". Linear
  /// time. Throws std::invalid_argument.
  explicit Layout(std::vector<Block> blocks, int n_points = -1);
  Layout(const Layout&);
  Layout(Layout&&) noexcept;
  Layout& operator=(const Layout&);
  Layout& operator=(Layout&&) noexcept;
  ~Layout();

  // n in [1, max_points]:
  static Layout cartesian(int n);  ///< (u_i, v_i) for i = 0..n-1: 2N x 6
  static Layout polar(int n);      ///< (r_i, theta_i): 2N x 6, IBVS-P
  static Layout stacked(int n);    ///< (u_i, v_i, r_i, theta_i) per point: 4N x 6
  static Layout cylindrical(int n);  ///< (r_i, r_i theta_i) (Iwatsuki & Okiyama): 2N x 6
  /// No blocks and no points: the point part of a Task of other features only (task.hpp).
  static Layout none();

  int n_points() const noexcept { return n_points_; }
  int rows() const noexcept { return static_cast<int>(2 * blocks_.size()); }
  const std::vector<Block>& blocks() const noexcept { return blocks_; }
  /// "cartesian(4)", "polar(4)", "stacked(4)" or the explicit block list, followed by
  /// ", n_points=N" when N is more than the largest point index + 1.
  std::string describe() const;

  bool operator==(const Layout& o) const noexcept;

 private:
  Layout() = default;  // none()
  std::vector<Block> blocks_;
  int n_points_ = 0;
};

// ---- stacked quantities (allocation-free; outputs must already be sized) ----
// Inputs are not validated here; the allocating wrappers in interaction.hpp and
// Servo::validate() do that.

/// Feature vector f (rows): (u, v), (r, theta) or (r, r theta) per block.
void stacked_features(const Layout& layout, const Eigen::Ref<const Points>& uv,
                      Eigen::Ref<Eigen::VectorXd> f) noexcept;

/// Stacked Jacobian (rows x 6) at the given points and depths. A polar block
/// whose point has r < polar_min_radius is given its Cartesian rows instead
/// (theta and its 1/r rows are undefined at the principal point). A
/// cylindrical block is the derivative of (r, r theta) (angle origin 0); its
/// rows are bounded, so it never falls back; at r = 0 it takes direction (1, 0).
void stacked_jacobian(const Layout& layout, const Eigen::Ref<const Points>& uv,
                      const Eigen::Ref<const Eigen::VectorXd>& depth,
                      Eigen::Ref<MatrixX6> J,
                      double polar_min_radius = default_polar_min_radius) noexcept;

/// Feature error f (-) f*: plain difference, theta rows wrapped (eq. 13).
/// Cylindrical blocks: (r - r*, r wrap(theta - theta*)), the arc from the
/// desired direction at the current radius (0 when r or r* is 0). This is the
/// difference of (r, r alpha) features whose angle alpha is measured from theta*:
/// independent of where the image's angle origin lies, continuous except
/// opposite the desired direction (like eq. 13), and -> 0 as r -> 0.
/// The angle differences of all polar and cylindrical blocks are wrapped as one
/// rotation (AngleWrap::consistent, see angle_wrap.hpp; blocks with r or r* = 0
/// do not take part in the mean) or each into (-pi, pi] (AngleWrap::per_point).
/// The mean is taken from (cos, sin) of the differences here; Servo takes it from
/// the points' unit vectors, so the two agree except for a difference within
/// rounding of phi -/+ pi.
void stacked_error(const Layout& layout, const Eigen::Ref<const Eigen::VectorXd>& f,
                   const Eigen::Ref<const Eigen::VectorXd>& f_desired, Eigen::Ref<Eigen::VectorXd> e,
                   AngleWrap wrap = AngleWrap::consistent) noexcept;

// ---- allocating versions that validate first (throw std::invalid_argument) ----
// Points: finite, |u|, |v| <= max_normalized_coordinate; depths in [min_depth,
// max_depth]; features: values features() can give for such points.

/// Throw std::invalid_argument naming `name` unless every point is finite and
/// within max_normalized_coordinate (the message points to CameraModel::normalize
/// for pixels) / unless there are n depths, each in [min_depth, max_depth].
void validate_points(const Eigen::Ref<const Points>& uv, const char* name);
void validate_depths(const Eigen::Ref<const Eigen::VectorXd>& depth, const char* name, Eigen::Index n);

Eigen::VectorXd features(const Layout& layout, const Eigen::Ref<const Points>& uv);
MatrixX6 jacobian(const Layout& layout, const Eigen::Ref<const Points>& uv,
                  const Eigen::Ref<const Eigen::VectorXd>& depth,
                  double polar_min_radius = default_polar_min_radius);
Eigen::VectorXd feature_error(const Layout& layout, const Eigen::Ref<const Eigen::VectorXd>& f,
                              const Eigen::Ref<const Eigen::VectorXd>& f_desired,
                              AngleWrap wrap = AngleWrap::consistent);

}  // namespace ibvs
