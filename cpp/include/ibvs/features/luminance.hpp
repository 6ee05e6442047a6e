// Photometric (direct) visual servoing: the feature is the image itself, the intensities I of a grid
// of pixels (every pixel of the image but a border), Collewet & Marchand, "Photometric visual
// servoing", IEEE T-RO 27(4), 2011 (and its report INRIA RR-6631, 2008).
//
// Interaction matrix of one pixel's intensity (Lambertian scene, constant lighting: the optical
// flow constraint dI/dt = 0 along the point's image motion; Collewet & Marchand 2011, Sec. III):
//   L_I = -(I_x L_x + I_y L_y)                                                     (paper, Sec. III)
// where L_x, L_y are the two rows of a point's interaction matrix (features.hpp, the paper's eq. 3)
//   L_x = [-1/Z, 0, x/Z, x y, -(1 + x^2), y],  L_y = [0, -1/Z, y/Z, 1 + y^2, -x y, -x],
// and (I_x, I_y) = (p_x dI/du, p_y dI/dv) the image gradient in normalised coordinates (pixels
// converted by the focal lengths p_x, p_y). Written out (the row ViSP's vpFeatureLuminance forms):
//   L_I = [I_x/Z, I_y/Z, -(x I_x + y I_y)/Z, -x y I_x - (1 + y^2) I_y, (1 + x^2) I_x + x y I_y, x I_y - y I_x].
// Depth: 1/Z = A x + B y + C (a planar scene; a constant depth Z is A = B = 0, C = 1/Z).
// Gradients: the 7-tap derivative filter ViSP uses (vpImageFilter::derivativeFilterX/Y),
//   dI/du(u) = (2047 (I(u+1) - I(u-1)) + 913 (I(u+2) - I(u-2)) + 112 (I(u+3) - I(u-3))) / 8418
// (exact on a linear ramp), after an optional separable Gaussian pre-smoothing (sigma in pixels,
// radius ceil(3 sigma)); the feature s is then the smoothed image.
//
// Control law (Collewet & Marchand 2011, Sec. IV: the Levenberg-Marquardt-type law they use), with
// e = I - I* over the grid and H = L_I^T L_I:
//   levenberg_marquardt:  v = -gain (H + mu diag(H))^-1 L_I^T e
//   gauss_newton:         v = -gain H^-1 L_I^T e
// L_I at the current image, at the desired one (computed once, in set_desired: H and its factor
// then never change), or at the mean of both gradients (InteractionMatrix, as for Servo).
//
// Why a servo of its own rather than a Task block (task.hpp): its rows are the image's pixels
// (tens of thousands: beyond max_realtime_rows, where Servo's solve may allocate), and the law is
// a 6 x 6 solve of the normal equations, not a pseudo-inverse of J. LuminanceServo never forms
// L_I per frame: each grid row's sums of e I_x x^j, e I_y x^j (and, for the current image's J,
// I_x^2 x^j, I_x I_y x^j, I_y^2 x^j) give that row's share of L_I^T e (and H) exactly, because
// every entry of L_I is I_x P(x) + I_y Q(x) with P, Q polynomials of degree <= 2 in x along a row
// (1/Z = A x + (B y + C)). The per-frame sums are in float (the pixels are 8-bit or noisy), each
// row's share in double; interaction() gives L_I itself in double (tests, inspection).
//
// The dense feature that does fit a Task, photometric moments (Bakthavatchalam, Tahri & Chaumette,
// IEEE T-RO 34(5), 2018): photometric_moments() below, fed to MomentsFeature (moments.hpp).
//
// Real-time path: update() is noexcept and allocation-free; a textureless or saturated image
// (H singular or ill-conditioned) returns that status and a zero twist, a non-finite pixel
// (float images) invalid_input. validate() and set_desired() throw std::invalid_argument naming
// the argument.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/features.hpp"
#include "ibvs/features/moments.hpp"
#include "ibvs/servo.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace ibvs {

/// A grey image, row-major (numpy's layout): 8-bit, or double (any scale; finite, |I| <= max_intensity).
using ImageU8 = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using ImageF64 = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Largest |intensity| of a double image (float sums of squared gradients stay finite).
inline constexpr double max_intensity = 1e6;

enum class LuminanceLaw : std::uint8_t {
  levenberg_marquardt = 0,  ///< v = -gain (H + mu diag H)^-1 L^T e
  gauss_newton = 1,         ///< v = -gain H^-1 L^T e
};

/// Outcome of LuminanceServo::update().
enum class LuminanceStatus : std::int8_t {
  ok = 0,
  /// H = L^T L singular or ill-conditioned (too little gradient: a uniform or one-directional
  /// texture, or the target out of view): zero twist.
  textureless = 1,
  /// The same, with half of the grid's pixels or more at the image's extreme values (0 or 255 for
  /// 8-bit images): an over- or under-exposed image. Zero twist.
  saturated = 2,
  invalid_input = -1,  ///< a non-finite or too large pixel (double images): zero twist, NaN error
};

struct LuminanceOptions {
  int border = 10;                   ///< pixels left out on each side (ViSP's default), >= 3 + smoothing radius
  double smoothing = 0.0;            ///< Gaussian pre-smoothing sigma, pixels (0: none), <= 10
  InteractionMatrix jacobian = InteractionMatrix::desired;
  LuminanceLaw law = LuminanceLaw::levenberg_marquardt;
  double gain = 1.0;                 ///< in (0, 1e6], 1/s
  double mu = 0.01;                  ///< Levenberg-Marquardt mu, in [0, 1e6]
  /// Depth of the scene: 1/Z = plane_a x + plane_b y + plane_c; must stay within
  /// [1/max_depth, 1/min_depth] over the grid (a constant depth Z: 0, 0, 1/Z).
  double plane_a = 0.0, plane_b = 0.0, plane_c = 1.0;
  /// H is refused (textureless / saturated) when its Jacobi-scaled form D^-1/2 H D^-1/2 has a
  /// Cholesky pivot below this (an estimate of its reciprocal condition number), in [1e-15, 1).
  double min_conditioning = 1e-9;
};

struct LuminanceOutput {
  Twist twist = Twist::Zero();
  LuminanceStatus status = LuminanceStatus::ok;
  double error_rms = 0.0;  ///< sqrt(|e|^2 / N), intensity units (NaN when refused)
  int pixels = 0;          ///< N, the grid's pixels
};

class LuminanceServo {
 public:
  /// A pinhole camera without distortion (undistort the images first), the image size in pixels
  /// and the options. Throws std::invalid_argument naming the bad argument.
  LuminanceServo(const CameraModel& camera, int width, int height, const LuminanceOptions& options = {});

  /// The goal image. Throws std::invalid_argument for a wrong size, a non-finite pixel or an image
  /// whose H is singular (textureless, saturated).
  void set_desired(const Eigen::Ref<const ImageU8>& image);
  void set_desired(const Eigen::Ref<const ImageF64>& image);
  bool has_desired() const noexcept { return has_desired_; }
  /// Changes mu (in [0, 1e6]; throws otherwise), e.g. to 0 for Gauss-Newton once near the goal (ViSP's
  /// photometric example switches from mu = 0.01 to Gauss-Newton after 90 iterations): the LM damping
  /// slows the nearly degenerate directions (a translation across the axis against the rotation about
  /// the other image axis) to a crawl. Refactors the desired image's law matrix (allocation-free).
  void set_mu(double mu);

  /// Throws std::invalid_argument "ibvs: <name> ..." for what update() refuses as invalid_input.
  void validate(const Eigen::Ref<const ImageU8>& image, const char* name = "image") const;
  void validate(const Eigen::Ref<const ImageF64>& image, const char* name = "image") const;

  /// One control step on the current image (the desired one must be set). noexcept, no allocation.
  LuminanceStatus update(const Eigen::Ref<const ImageU8>& image, LuminanceOutput& out) noexcept;
  LuminanceStatus update(const Eigen::Ref<const ImageF64>& image, LuminanceOutput& out) noexcept;

  /// For tests and inspection (allocate, throw as validate()): L_I over the grid (N x 6, grid
  /// rows in order, double precision) of this image, with the servo's smoothing, filter and plane;
  /// and the intensities s (N) of an image.
  MatrixX6 interaction(const Eigen::Ref<const ImageF64>& image) const;
  Eigen::VectorXd intensities(const Eigen::Ref<const ImageF64>& image) const;

  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  int pixels() const noexcept { return gw_ * gh_; }
  const LuminanceOptions& options() const noexcept { return options_; }
  const CameraModel& camera() const noexcept { return camera_; }
  std::string describe() const;

 private:
  template <class P>
  void set_desired_impl(const P* data, std::ptrdiff_t stride);
  template <class P>
  LuminanceStatus update_impl(const P* data, std::ptrdiff_t stride, bool is_u8, LuminanceOutput& out) noexcept;
  template <class P>
  void load(const P* data, std::ptrdiff_t stride) noexcept;  // into frame_ (smoothed when asked)
  void gradients_of_frame() noexcept;                       // gx_, gy_ of frame_ over the grid
  LuminanceStatus singular_cause(bool is_u8) const noexcept;

  CameraModel camera_;
  int width_, height_;
  LuminanceOptions options_;
  int gw_ = 0, gh_ = 0, radius_ = 0;
  bool has_desired_ = false;
  // Set up once: column x, x^2, x^3, x^4 (float), row y; the Gaussian kernel; the goal's
  // intensities and gradients over the grid; H* and the factor of the desired-J law matrix.
  std::vector<float> x1_, x2_, x3_, x4_, kernel_;
  std::vector<double> y_;
  std::vector<float> desired_, desired_gx_, desired_gy_;
  Eigen::Matrix<double, 6, 6> desired_h_ = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> desired_factor_ = Eigen::Matrix<double, 6, 6>::Zero();  // L of L L^T
  Eigen::Matrix<double, 6, 1> desired_scale_ = Eigen::Matrix<double, 6, 1>::Ones();
  // Per-frame buffers: the frame (float, smoothed), the smoothing pass, the grid's gradients, a row's work.
  std::vector<float> frame_, pass_, gx_, gy_, row_e_, row_a_, row_b_, row_xx_, row_xy_, row_yy_;
};

/// Raw moments m_pq (p + q <= 4, at moment_index(p, q)) of an intensity image in normalised
/// coordinates: m_pq = sum over the pixels of x^p y^q I(u, v) dA, x = (u - u0) / p_x, y = (v - v0) / p_y
/// at the pixel centres (integer u, v), dA = 1 / (p_x p_y) the pixel's area (Bakthavatchalam, Tahri &
/// Chaumette 2018, eq. 1). For a Lambertian planar scene whose intensity is 0 on the image's border
/// (the object seen whole on a dark background), their interaction matrix is the binary region's
/// (Chaumette 2004, eq. 13, as MomentsFeature::Source::region computes it): the brightness-constancy
/// flow integrated by parts, the border term vanishing (2018, Sec. III). Throws std::invalid_argument
/// for a distorted camera, an image larger than the camera's bounds, non-finite or too large pixels.
Moments photometric_moments(const CameraModel& camera, const Eigen::Ref<const ImageU8>& image);
Moments photometric_moments(const CameraModel& camera, const Eigen::Ref<const ImageF64>& image);

/// Names of the statuses ("ok", "textureless", "saturated", "invalid_input").
const char* to_string(LuminanceStatus s) noexcept;

}  // namespace ibvs
