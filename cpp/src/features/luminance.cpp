// LuminanceServo and photometric_moments (features/luminance.hpp).
#include "ibvs/features/luminance.hpp"

#include "ibvs/limits.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ibvs {

namespace {

using Matrix66 = Eigen::Matrix<double, 6, 6>;
using Vector66 = Eigen::Matrix<double, 6, 1>;
using RowF = Eigen::Map<Eigen::ArrayXf>;
using ConstRowF = Eigen::Map<const Eigen::ArrayXf>;

[[noreturn]] void lum_fail(const std::string& what) { throw std::invalid_argument("ibvs: " + what); }

std::string lum_number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

// The 7-tap derivative filter (ViSP's vpImageFilter::derivativeFilterX/Y weights) at p along `step`.
template <class T>
inline T derivative7(const T* p, std::ptrdiff_t step) noexcept {
  return (T(2047) * (p[step] - p[-step]) + T(913) * (p[2 * step] - p[-2 * step]) +
          T(112) * (p[3 * step] - p[-3 * step])) /
         T(8418);
}

// The coefficients of one grid row (ordinate y, 1/Z = alpha x + beta): entry k of L_I is
// I_x (c_k0 + c_k1 x + c_k2 x^2) + I_y (c_k3 + c_k4 x + c_k5 x^2) (header, "never forms L_I").
Matrix66 row_coefficients(double y, double alpha, double beta) noexcept {
  Matrix66 c = Matrix66::Zero();
  c(0, 0) = beta, c(0, 1) = alpha;                                        // I_x / Z
  c(1, 3) = beta, c(1, 4) = alpha;                                        // I_y / Z
  c(2, 1) = -beta, c(2, 2) = -alpha, c(2, 3) = -y * beta, c(2, 4) = -y * alpha;  // -(x I_x + y I_y) / Z
  c(3, 1) = -y, c(3, 3) = -(1.0 + y * y);                                 // -x y I_x - (1 + y^2) I_y
  c(4, 0) = 1.0, c(4, 2) = 1.0, c(4, 4) = y;                              // (1 + x^2) I_x + x y I_y
  c(5, 0) = -y, c(5, 4) = 1.0;                                            // x I_y - y I_x
  return c;
}

std::vector<double> gaussian_kernel(double sigma, int radius) {
  std::vector<double> k(static_cast<std::size_t>(2 * radius + 1), 1.0);
  double sum = 0.0;
  for (int i = -radius; i <= radius; ++i) {
    const double w = sigma > 0.0 ? std::exp(-0.5 * i * i / (sigma * sigma)) : 1.0;
    k[static_cast<std::size_t>(i + radius)] = w;
    sum += w;
  }
  for (double& w : k) w /= sum;
  return k;
}

// Solves (Hn + mu I) z = b for the Jacobi-scaled Hn (unit diagonal) by Cholesky; false when a pivot of
// Hn itself is below `tol` (singular or ill-conditioned). `factor` receives the factor of Hn + mu I.
bool factor_law(const Matrix66& Hn, double mu, double tol, Matrix66& factor) noexcept {
  // Pivots of Hn (the conditioning test), then of Hn + mu I (the law).
  for (int pass = 0; pass < 2; ++pass) {
    Matrix66 a = Hn;
    if (pass == 1) a.diagonal().array() += mu;
    Matrix66 l = Matrix66::Zero();
    for (int j = 0; j < 6; ++j) {
      double d = a(j, j) - l.row(j).head(j).squaredNorm();
      if (pass == 0 && !(d >= tol)) return false;
      if (!(d > 0.0)) return false;
      l(j, j) = std::sqrt(d);
      for (int i = j + 1; i < 6; ++i) l(i, j) = (a(i, j) - l.row(i).head(j).dot(l.row(j).head(j))) / l(j, j);
    }
    if (pass == 1) factor = l;
  }
  return true;
}

Vector66 cholesky_solve(const Matrix66& l, Vector66 b) noexcept {
  for (int i = 0; i < 6; ++i) b(i) = (b(i) - l.row(i).head(i).dot(b.head(i))) / l(i, i);
  for (int i = 5; i >= 0; --i) b(i) = (b(i) - l.col(i).tail(5 - i).dot(b.tail(5 - i))) / l(i, i);
  return b;
}

template <class P>
inline float lum_pixel(P p) noexcept {
  return static_cast<float>(p);
}

}  // namespace

const char* to_string(LuminanceStatus s) noexcept {
  switch (s) {
    case LuminanceStatus::ok: return "ok";
    case LuminanceStatus::textureless: return "textureless";
    case LuminanceStatus::saturated: return "saturated";
    case LuminanceStatus::invalid_input: return "invalid_input";
  }
  return "unknown";
}

LuminanceServo::LuminanceServo(const CameraModel& camera, int width, int height, const LuminanceOptions& options)
    : camera_(camera), width_(width), height_(height), options_(options) {
  const LuminanceOptions& o = options;
  if (camera.distortion() != Distortion::none)
    lum_fail("LuminanceServo: camera must be a pinhole without distortion (undistort the images first)");
  if (!(o.smoothing >= 0.0 && o.smoothing <= 10.0))
    lum_fail("LuminanceServo: smoothing must be within [0, 10] pixels, got " + lum_number(o.smoothing));
  radius_ = static_cast<int>(std::ceil(3.0 * o.smoothing));
  if (o.border < 3 + radius_ || o.border > 100000)
    lum_fail("LuminanceServo: border must be >= 3 + the smoothing radius (" + std::to_string(3 + radius_) +
             "), got " + std::to_string(o.border));
  if (width < 2 * o.border + 1 || height < 2 * o.border + 1 || width > 100000 || height > 100000)
    lum_fail("LuminanceServo: width and height must leave a grid inside the border (> 2 border) and be <= 100000, "
             "got " +
             std::to_string(width) + " x " + std::to_string(height));
  if (!(o.gain > 0.0 && o.gain <= 1e6))
    lum_fail("LuminanceServo: gain must be in (0, 1e6], got " + lum_number(o.gain));
  if (!(o.mu >= 0.0 && o.mu <= 1e6)) lum_fail("LuminanceServo: mu must be in [0, 1e6], got " + lum_number(o.mu));
  if (!(o.min_conditioning >= 1e-15 && o.min_conditioning < 1.0))
    lum_fail("LuminanceServo: min_conditioning must be in [1e-15, 1), got " + lum_number(o.min_conditioning));
  if (static_cast<unsigned>(o.jacobian) > 2u) lum_fail("LuminanceServo: jacobian is not a known value");
  if (static_cast<unsigned>(o.law) > 1u) lum_fail("LuminanceServo: law is not a known value");
  gw_ = width - 2 * o.border;
  gh_ = height - 2 * o.border;
  const double px = camera.px(), py = camera.py(), u0 = camera.u0(), v0 = camera.v0();
  x1_.resize(static_cast<std::size_t>(gw_));
  x2_ = x3_ = x4_ = x1_;
  for (int j = 0; j < gw_; ++j) {
    const double x = (o.border + j - u0) / px;
    x1_[j] = static_cast<float>(x), x2_[j] = static_cast<float>(x * x);
    x3_[j] = static_cast<float>(x * x * x), x4_[j] = static_cast<float>(x * x * x * x);
  }
  y_.resize(static_cast<std::size_t>(gh_));
  for (int i = 0; i < gh_; ++i) y_[i] = (o.border + i - v0) / py;
  // The grid's normalised coordinates within max_normalized_coordinate (x^4 then stays within float).
  for (const double c : {(o.border - u0) / px, (width - 1 - o.border - u0) / px, y_.front(), y_.back()})
    if (!(std::abs(c) <= max_normalized_coordinate))
      lum_fail("LuminanceServo: camera: the grid's normalised coordinates must be within +-" +
               lum_number(max_normalized_coordinate) + " (pixels beyond 84 degrees off the axis), got " +
               lum_number(c) + " (camera for another image size?)");
  // 1/Z is linear: its extremes over the grid are at the corners.
  for (const double x : {double(x1_.front()), double(x1_.back())})
    for (const double y : {y_.front(), y_.back()}) {
      const double iz = o.plane_a * x + o.plane_b * y + o.plane_c;
      if (!(iz >= 1.0 / max_depth && iz <= 1.0 / min_depth))
        lum_fail("LuminanceServo: plane: 1/Z = A x + B y + C must be within [1/max_depth, "
                 "1/min_depth] over the grid (got " + lum_number(iz) + " at a corner)");
    }
  const std::vector<double> k = gaussian_kernel(o.smoothing, radius_);
  kernel_.assign(k.begin(), k.end());
  const auto n = static_cast<std::size_t>(gw_) * static_cast<std::size_t>(gh_);
  desired_.assign(n, 0.0f);
  desired_gx_ = desired_gy_ = gx_ = gy_ = desired_;
  frame_.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0.0f);
  if (radius_ > 0) pass_ = frame_;
  row_e_.assign(static_cast<std::size_t>(gw_), 0.0f);
  row_a_ = row_b_ = row_xx_ = row_xy_ = row_yy_ = row_e_;
}

std::string LuminanceServo::describe() const {
  static const char* jac[] = {"current", "desired", "mean"};
  return "LuminanceServo(" + std::to_string(width_) + "x" + std::to_string(height_) + ", border " +
         std::to_string(options_.border) + ", " + std::to_string(pixels()) + " pixels, J " +
         jac[static_cast<int>(options_.jacobian)] + ", " +
         (options_.law == LuminanceLaw::levenberg_marquardt ? "levenberg_marquardt mu " + lum_number(options_.mu)
                                                             : std::string("gauss_newton")) +
         (radius_ > 0 ? ", smoothing " + lum_number(options_.smoothing) : std::string()) + ")";
}

void LuminanceServo::validate(const Eigen::Ref<const ImageU8>& image, const char* name) const {
  if (image.rows() != height_ || image.cols() != width_)
    lum_fail(std::string(name) + ": must be " + std::to_string(height_) + " x " + std::to_string(width_) +
             " (rows x columns), got " + std::to_string(image.rows()) + " x " + std::to_string(image.cols()));
}

void LuminanceServo::validate(const Eigen::Ref<const ImageF64>& image, const char* name) const {
  if (image.rows() != height_ || image.cols() != width_)
    lum_fail(std::string(name) + ": must be " + std::to_string(height_) + " x " + std::to_string(width_) +
             " (rows x columns), got " + std::to_string(image.rows()) + " x " + std::to_string(image.cols()));
  for (Eigen::Index r = 0; r < image.rows(); ++r)
    for (Eigen::Index c = 0; c < image.cols(); ++c)
      if (!(std::abs(image(r, c)) <= max_intensity))
        lum_fail(std::string(name) + "[" + std::to_string(r) + ", " + std::to_string(c) +
                 "]: must be finite and within +-" + lum_number(max_intensity) + ", got " + lum_number(image(r, c)));
}

template <class P>
void LuminanceServo::load(const P* data, std::ptrdiff_t stride) noexcept {
  // The region the grid's gradients read: the grid and 3 pixels around it (the border is >= 3 + radius).
  const int b = options_.border - 3, r0 = b, r1 = height_ - b, c0 = b, c1 = width_ - b;
  const std::ptrdiff_t w = width_;
  if (radius_ == 0) {
    for (int r = r0; r < r1; ++r) {
      const P* src = data + r * stride;
      float* dst = frame_.data() + r * w;
      for (int c = c0; c < c1; ++c) dst[c] = lum_pixel(src[c]);
    }
    return;
  }
  const int R = radius_;
  const float* k = kernel_.data() + R;
  for (int r = r0 - R; r < r1 + R; ++r) {  // along rows
    const P* src = data + r * stride;
    float* dst = pass_.data() + r * w;
    for (int c = c0; c < c1; ++c) {
      float s = 0.0f;
      for (int i = -R; i <= R; ++i) s += k[i] * lum_pixel(src[c + i]);
      dst[c] = s;
    }
  }
  for (int r = r0; r < r1; ++r) {  // along columns
    float* dst = frame_.data() + r * w;
    for (int c = c0; c < c1; ++c) dst[c] = 0.0f;
    for (int i = -R; i <= R; ++i) {
      const float* src = pass_.data() + (r + i) * w;
      const float ki = k[i];
      for (int c = c0; c < c1; ++c) dst[c] += ki * src[c];
    }
  }
}

void LuminanceServo::gradients_of_frame() noexcept {
  const int b = options_.border;
  const std::ptrdiff_t w = width_;
  const auto px = static_cast<float>(camera_.px()), py = static_cast<float>(camera_.py());
  for (int i = 0; i < gh_; ++i) {
    const float* f = frame_.data() + (b + i) * w + b;
    float* gx = gx_.data() + static_cast<std::ptrdiff_t>(i) * gw_;
    float* gy = gy_.data() + static_cast<std::ptrdiff_t>(i) * gw_;
    for (int j = 0; j < gw_; ++j) {
      gx[j] = px * derivative7(f + j, 1);
      gy[j] = py * derivative7(f + j, w);
    }
  }
}

namespace {

// One grid row's share of L^T e (g) and, when `with_h`, of H, from its error e and gradients (gx, gy).
struct RowKernel {
  const float *x1, *x2, *x3, *x4;
  float *a, *b, *xx, *xy, *yy;
  int n;
  void run(const float* e, const float* gx, const float* gy, const Matrix66& c, bool with_h, Vector66& g,
           Matrix66& H) const noexcept {
    ConstRowF E(e, n), GX(gx, n), GY(gy, n), X1(x1, n), X2(x2, n);
    RowF A(a, n), B(b, n);
    A = E * GX;
    B = E * GY;
    Vector66 s;
    s << A.sum(), (A * X1).sum(), (A * X2).sum(), B.sum(), (B * X1).sum(), (B * X2).sum();
    g.noalias() += c * s;
    if (!with_h) return;
    ConstRowF X3(x3, n), X4(x4, n);
    RowF XX(xx, n), XY(xy, n), YY(yy, n);
    XX = GX * GX;
    XY = GX * GY;
    YY = GY * GY;
    double sxx[5], sxy[5], syy[5];
    sxx[0] = XX.sum(), sxx[1] = (XX * X1).sum(), sxx[2] = (XX * X2).sum(), sxx[3] = (XX * X3).sum();
    sxx[4] = (XX * X4).sum();
    sxy[0] = XY.sum(), sxy[1] = (XY * X1).sum(), sxy[2] = (XY * X2).sum(), sxy[3] = (XY * X3).sum();
    sxy[4] = (XY * X4).sum();
    syy[0] = YY.sum(), syy[1] = (YY * X1).sum(), syy[2] = (YY * X2).sum(), syy[3] = (YY * X3).sum();
    syy[4] = (YY * X4).sum();
    Matrix66 m;  // sum of phi phi^T, phi = (gx, gx x, gx x^2, gy, gy x, gy x^2)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        m(i, j) = sxx[i + j];
        m(i, j + 3) = m(j + 3, i) = sxy[i + j];
        m(i + 3, j + 3) = syy[i + j];
      }
    H.noalias() += c * m * c.transpose();
  }
};

}  // namespace

template <class P>
void LuminanceServo::set_desired_impl(const P* data, std::ptrdiff_t stride) {
  load(data, stride);
  gradients_of_frame();
  const int b = options_.border;
  for (int i = 0; i < gh_; ++i)
    for (int j = 0; j < gw_; ++j) desired_[i * static_cast<std::size_t>(gw_) + j] = frame_[(b + i) * width_ + b + j];
  desired_gx_ = gx_;
  desired_gy_ = gy_;
  // H* (its factor serves the desired-image law), from the same row sums as update(); e = 0.
  const RowKernel k{x1_.data(), x2_.data(), x3_.data(), x4_.data(), row_a_.data(), row_b_.data(),
                    row_xx_.data(), row_xy_.data(), row_yy_.data(), gw_};
  Vector66 g = Vector66::Zero();
  Matrix66 H = Matrix66::Zero();
  for (int i = 0; i < gh_; ++i) {
    const Matrix66 c = row_coefficients(y_[i], options_.plane_a, options_.plane_b * y_[i] + options_.plane_c);
    const std::size_t o = i * static_cast<std::size_t>(gw_);
    k.run(row_e_.data(), desired_gx_.data() + o, desired_gy_.data() + o, c, true, g, H);
  }
  const Vector66 d = H.diagonal();
  bool ok = d.allFinite() && (d.array() > 0.0).all();
  Vector66 scale = Vector66::Ones();
  Matrix66 factor;
  if (ok) {
    scale = d.cwiseSqrt().cwiseInverse();
    const double mu = options_.law == LuminanceLaw::levenberg_marquardt ? options_.mu : 0.0;
    ok = factor_law(scale.asDiagonal() * H * scale.asDiagonal(), mu, options_.min_conditioning, factor);
  }
  if (!ok) {
    has_desired_ = false;
    lum_fail("LuminanceServo.set_desired: image has too little texture: H = L^T L over the grid is singular or "
             "ill-conditioned (a uniform, saturated or one-directional image)");
  }
  desired_h_ = H;
  desired_scale_ = scale;
  desired_factor_ = factor;
  has_desired_ = true;
}

void LuminanceServo::set_mu(double mu) {
  if (!(mu >= 0.0 && mu <= 1e6)) lum_fail("LuminanceServo.set_mu: mu must be in [0, 1e6], got " + lum_number(mu));
  if (has_desired_) {
    const double m = options_.law == LuminanceLaw::levenberg_marquardt ? mu : 0.0;
    Matrix66 factor;
    if (!factor_law(desired_scale_.asDiagonal() * desired_h_ * desired_scale_.asDiagonal(), m,
                    options_.min_conditioning, factor))
      lum_fail("LuminanceServo.set_mu: the goal's H is singular");  // set_desired accepted it: not reached
    desired_factor_ = factor;
  }
  options_.mu = mu;
}

void LuminanceServo::set_desired(const Eigen::Ref<const ImageU8>& image) {
  validate(image, "image");
  set_desired_impl(image.data(), image.outerStride());
}

void LuminanceServo::set_desired(const Eigen::Ref<const ImageF64>& image) {
  validate(image, "image");
  set_desired_impl(image.data(), image.outerStride());
}

template <class P>
LuminanceStatus LuminanceServo::update_impl(const P* data, std::ptrdiff_t stride, bool is_u8,
                                            LuminanceOutput& out) noexcept {
  out.pixels = pixels();
  const auto refuse = [&out](LuminanceStatus s) {
    out.twist.setZero();
    out.error_rms = s == LuminanceStatus::invalid_input ? std::numeric_limits<double>::quiet_NaN() : out.error_rms;
    out.status = s;
    return s;
  };
  if (!has_desired_) {
    out.error_rms = std::numeric_limits<double>::quiet_NaN();
    return refuse(LuminanceStatus::invalid_input);
  }
  const InteractionMatrix jac = options_.jacobian;
  const bool with_h = jac != InteractionMatrix::desired, use_frame = with_h || radius_ > 0;
  if (use_frame) load(data, stride);
  if (with_h) gradients_of_frame();
  if (jac == InteractionMatrix::mean) {
    Eigen::Map<Eigen::ArrayXf>(gx_.data(), static_cast<Eigen::Index>(gx_.size())) +=
        Eigen::Map<const Eigen::ArrayXf>(desired_gx_.data(), static_cast<Eigen::Index>(gx_.size()));
    Eigen::Map<Eigen::ArrayXf>(gx_.data(), static_cast<Eigen::Index>(gx_.size())) *= 0.5f;
    Eigen::Map<Eigen::ArrayXf>(gy_.data(), static_cast<Eigen::Index>(gy_.size())) +=
        Eigen::Map<const Eigen::ArrayXf>(desired_gy_.data(), static_cast<Eigen::Index>(gy_.size()));
    Eigen::Map<Eigen::ArrayXf>(gy_.data(), static_cast<Eigen::Index>(gy_.size())) *= 0.5f;
  }
  const float* gxs = with_h ? gx_.data() : desired_gx_.data();
  const float* gys = with_h ? gy_.data() : desired_gy_.data();
  const RowKernel k{x1_.data(), x2_.data(), x3_.data(), x4_.data(), row_a_.data(), row_b_.data(),
                    row_xx_.data(), row_xy_.data(), row_yy_.data(), gw_};
  const int b = options_.border;
  Vector66 g = Vector66::Zero();
  Matrix66 H = Matrix66::Zero();
  double ss = 0.0;
  for (int i = 0; i < gh_; ++i) {
    const std::size_t o = i * static_cast<std::size_t>(gw_);
    const float* ref = desired_.data() + o;
    float* e = row_e_.data();
    if (use_frame) {
      const float* f = frame_.data() + (b + i) * static_cast<std::ptrdiff_t>(width_) + b;
      for (int j = 0; j < gw_; ++j) e[j] = f[j] - ref[j];
    } else {
      const P* f = data + (b + i) * stride + b;
      for (int j = 0; j < gw_; ++j) e[j] = lum_pixel(f[j]) - ref[j];
    }
    ss += static_cast<double>(ConstRowF(e, gw_).square().sum());
    const Matrix66 c = row_coefficients(y_[i], options_.plane_a, options_.plane_b * y_[i] + options_.plane_c);
    k.run(e, gxs + o, gys + o, c, with_h, g, H);
  }
  out.error_rms = std::sqrt(ss / pixels());
  if (!g.allFinite() || !std::isfinite(ss)) {
    out.error_rms = std::numeric_limits<double>::quiet_NaN();
    return refuse(LuminanceStatus::invalid_input);
  }
  Vector66 scale = desired_scale_;
  Matrix66 factor = desired_factor_;
  if (with_h) {
    const Vector66 d = H.diagonal();
    bool ok = d.allFinite() && (d.array() > 0.0).all();
    if (ok) {
      scale = d.cwiseSqrt().cwiseInverse();
      const double mu = options_.law == LuminanceLaw::levenberg_marquardt ? options_.mu : 0.0;
      ok = factor_law(scale.asDiagonal() * H * scale.asDiagonal(), mu, options_.min_conditioning, factor);
    }
    if (!ok) {
      // Which cause: half of the grid or more at the image's extreme values, or else too little texture.
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      long extreme = 0;
      for (int i = 0; i < gh_; ++i)
        for (int j = 0; j < gw_; ++j) {
          const float v = lum_pixel(data[(b + i) * stride + b + j]);
          lo = std::min(lo, v), hi = std::max(hi, v);
        }
      for (int i = 0; i < gh_; ++i)
        for (int j = 0; j < gw_; ++j) {
          const float v = lum_pixel(data[(b + i) * stride + b + j]);
          extreme += is_u8 ? (v <= 0.0f || v >= 255.0f) : (hi > lo && (v <= lo || v >= hi));
        }
      return refuse(2 * extreme >= pixels() ? LuminanceStatus::saturated : LuminanceStatus::textureless);
    }
  }
  // |scale_k g_k| <= |e| (Cauchy-Schwarz), so a non-finite twist can only come from a column of L_I
  // nearly zero against the others (scale_k huge): an ill-conditioned H, reported as such.
  const Twist v = -options_.gain * scale.cwiseProduct(cholesky_solve(factor, scale.cwiseProduct(g)));
  if (!v.allFinite()) return refuse(LuminanceStatus::textureless);
  out.twist = v;
  out.status = LuminanceStatus::ok;
  return LuminanceStatus::ok;
}

LuminanceStatus LuminanceServo::update(const Eigen::Ref<const ImageU8>& image, LuminanceOutput& out) noexcept {
  if (image.rows() != height_ || image.cols() != width_) {
    out.error_rms = std::numeric_limits<double>::quiet_NaN();
    out.twist.setZero();
    out.pixels = pixels();
    return out.status = LuminanceStatus::invalid_input;
  }
  return update_impl(image.data(), image.outerStride(), true, out);
}

LuminanceStatus LuminanceServo::update(const Eigen::Ref<const ImageF64>& image, LuminanceOutput& out) noexcept {
  // The whole image must be finite and within max_intensity (as validate() demands).
  if (image.rows() != height_ || image.cols() != width_ || !(image.array().abs() <= max_intensity).all()) {
    out.error_rms = std::numeric_limits<double>::quiet_NaN();
    out.twist.setZero();
    out.pixels = pixels();
    return out.status = LuminanceStatus::invalid_input;
  }
  return update_impl(image.data(), image.outerStride(), false, out);
}

namespace {

// The image smoothed as the servo does (Gaussian of radius R over the region the grid's gradients read), in double.
ImageF64 smoothed(const Eigen::Ref<const ImageF64>& image, const std::vector<float>& kernel, int radius, int border) {
  ImageF64 f = image;
  if (radius == 0) return f;
  const int b = border - 3, h = static_cast<int>(image.rows()), w = static_cast<int>(image.cols());
  ImageF64 pass = image;
  for (int r = b - radius; r < h - b + radius; ++r)
    for (int c = b; c < w - b; ++c) {
      double s = 0.0;
      for (int i = -radius; i <= radius; ++i) s += double(kernel[i + radius]) * image(r, c + i);
      pass(r, c) = s;
    }
  for (int r = b; r < h - b; ++r)
    for (int c = b; c < w - b; ++c) {
      double s = 0.0;
      for (int i = -radius; i <= radius; ++i) s += double(kernel[i + radius]) * pass(r + i, c);
      f(r, c) = s;
    }
  return f;
}

}  // namespace

MatrixX6 LuminanceServo::interaction(const Eigen::Ref<const ImageF64>& image) const {
  validate(image, "image");
  const ImageF64 f = smoothed(image, kernel_, radius_, options_.border);
  const int b = options_.border;
  MatrixX6 L(pixels(), 6);
  const double px = camera_.px(), py = camera_.py();
  for (int i = 0; i < gh_; ++i)
    for (int j = 0; j < gw_; ++j) {
      const double* p = &f(b + i, b + j);
      const double Ix = px * derivative7(p, 1), Iy = py * derivative7(p, f.outerStride());
      const double x = (b + j - camera_.u0()) / px, y = y_[i];
      const double iz = options_.plane_a * x + options_.plane_b * y + options_.plane_c;
      L.row(static_cast<Eigen::Index>(i) * gw_ + j) << Ix * iz, Iy * iz, -(x * Ix + y * Iy) * iz,
          -x * y * Ix - (1.0 + y * y) * Iy, (1.0 + x * x) * Ix + x * y * Iy, x * Iy - y * Ix;
    }
  return L;
}

Eigen::VectorXd LuminanceServo::intensities(const Eigen::Ref<const ImageF64>& image) const {
  validate(image, "image");
  const ImageF64 f = smoothed(image, kernel_, radius_, options_.border);
  Eigen::VectorXd s(pixels());
  for (int i = 0; i < gh_; ++i)
    for (int j = 0; j < gw_; ++j)
      s(static_cast<Eigen::Index>(i) * gw_ + j) = f(options_.border + i, options_.border + j);
  return s;
}

namespace {

template <class P>
Moments moments_of(const CameraModel& camera, const P* data, std::ptrdiff_t stride, int h, int w) {
  const double px = camera.px(), py = camera.py(), u0 = camera.u0(), v0 = camera.v0();
  Moments m{};
  for (int v = 0; v < h; ++v) {
    double r[5] = {0, 0, 0, 0, 0};  // sums of x^p I along the row
    const P* row = data + v * stride;
    for (int u = 0; u < w; ++u) {
      const double I = static_cast<double>(row[u]), x = (u - u0) / px;
      r[0] += I, r[1] += x * I, r[2] += x * x * I, r[3] += x * x * x * I, r[4] += x * x * x * x * I;
    }
    const double y = (v - v0) / py;
    double yq = 1.0;
    for (int q = 0; q <= 4; ++q, yq *= y)
      for (int p = 0; p + q <= 4; ++p) m[static_cast<std::size_t>(moment_index(p, q))] += yq * r[p];
  }
  for (double& x : m) x /= px * py;
  return m;
}

void check_moment_camera(const CameraModel& camera) {
  if (camera.distortion() != Distortion::none)
    lum_fail("photometric_moments: camera must be a pinhole without distortion (undistort the image first)");
}

}  // namespace

Moments photometric_moments(const CameraModel& camera, const Eigen::Ref<const ImageU8>& image) {
  check_moment_camera(camera);
  if (image.size() == 0) lum_fail("photometric_moments: image must not be empty");
  return moments_of(camera, image.data(), image.outerStride(), static_cast<int>(image.rows()),
                    static_cast<int>(image.cols()));
}

Moments photometric_moments(const CameraModel& camera, const Eigen::Ref<const ImageF64>& image) {
  check_moment_camera(camera);
  if (image.size() == 0) lum_fail("photometric_moments: image must not be empty");
  for (Eigen::Index r = 0; r < image.rows(); ++r)
    for (Eigen::Index c = 0; c < image.cols(); ++c)
      if (!(std::abs(image(r, c)) <= max_intensity))
        lum_fail("image[" + std::to_string(r) + ", " + std::to_string(c) + "]: must be finite and within +-" +
                 lum_number(max_intensity) + ", got " + lum_number(image(r, c)));
  return moments_of(camera, image.data(), image.outerStride(), static_cast<int>(image.rows()),
                    static_cast<int>(image.cols()));
}

}  // namespace ibvs
