#include "ibvs/camera_model.hpp"

#include "ibvs/limits.hpp"

#include "checks.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace ibvs {

const char* to_string(Distortion d) noexcept {
  switch (d) {
    case Distortion::none: return "none";
    case Distortion::visp: return "visp";
    case Distortion::plumb_bob: return "plumb_bob";
    case Distortion::equidistant: return "equidistant";
    case Distortion::omnidir: return "omnidir";
  }
  return "unknown";
}

namespace {

constexpr double inf = std::numeric_limits<double>::infinity();
constexpr double nan = std::numeric_limits<double>::quiet_NaN();
// normalize() accepts a Newton solution whose residual is below this many pixels
// (rounding leaves ~1e-13 px at a focal length of 1000 px; the contract is 1e-6 px).
constexpr double newton_tolerance_px = 1e-9;

using detail::fail;

std::string num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

// Smallest s in (0, cap] with p(s) = c[0] + c[1] s + ... + c[d] s^d = 0 (c[0] = 1 > 0),
// or +inf when p > 0 on the whole range. Two witnesses: the roots t = 1/s of the
// reversed, monic polynomial t^d + c[1] t^(d-1) + ... + c[d] (the eigenvalues of its
// companion matrix, whose entries are the coefficients: well scaled), kept when p
// nearly vanishes there (a nearly real pair, a tangency, counts: it only shrinks the
// domain); and a geometric scan of p from 1e-8 up, which cannot be fooled by
// coefficients spanning hundreds of orders of magnitude. Bisection pins a sign change.
double smallest_positive_root(const std::array<double, 5>& c, int degree, double cap) {
  const auto p = [&](double s) {
    double v = 0.0;
    for (int i = degree; i >= 0; --i) v = v * s + c[static_cast<std::size_t>(i)];
    return v;
  };
  const auto scale = [&](double s) {  // size of the terms p sums, for "nearly vanishes"
    double v = 0.0, si = 1.0;
    for (int i = 0; i <= degree; ++i, si *= s) v += std::abs(c[static_cast<std::size_t>(i)]) * si;
    return v;
  };
  double best = inf;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(degree, degree);
  for (int i = 0; i < degree; ++i) C(0, i) = -c[static_cast<std::size_t>(i + 1)];
  for (int i = 1; i < degree; ++i) C(i, i - 1) = 1.0;
  const Eigen::EigenSolver<Eigen::MatrixXd> es(C, false);
  for (Eigen::Index i = 0; i < es.eigenvalues().size(); ++i) {
    const std::complex<double> t = es.eigenvalues()(i);
    if (!(t.real() > 0.0) || std::abs(t.imag()) > 1e-6 * std::abs(t)) continue;
    const double s = 1.0 / t.real();
    if (s <= cap && std::abs(p(s)) <= 1e-9 * scale(s)) best = std::min(best, s);
  }
  // The first sign change on a 1 % geometric grid below that; bisect it (or polish the eigenvalue's root).
  double lo = 0.0, hi = best;
  for (double s = 1e-8; s < std::min(best, cap); s *= 1.01) {
    if (!(p(s) > 0.0)) {
      hi = s;
      break;
    }
    lo = s;
  }
  if (!std::isfinite(hi)) return inf;
  if (!(p(hi) > 0.0))
    for (int it = 0; it < 200 && hi - lo > 1e-16 * hi; ++it) {
      const double mid = 0.5 * (lo + hi);
      (p(mid) > 0.0 ? lo : hi) = mid;
    }
  return hi;
}

// The equidistant (Kannala-Brandt) lens: theta_d(theta) = theta (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8),
// t = theta, and its derivative; k = k_[0..3]. One place for the polynomial that projection, inversion
// and the model's limits all use.
double equidistant_theta_d(const std::array<double, 5>& k, double th) noexcept {
  const double t2 = th * th;
  return th * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
}
double equidistant_slope(const std::array<double, 5>& k, double th) noexcept {
  const double t2 = th * th;
  return 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
}

// Root of f(r) = target for f increasing on [0, hi) with f(0) = 0 <= target:
// Newton's steps kept inside a shrinking bracket (bisection when one leaves it).
template <class F, class DF>
double bracketed_newton(F f, DF df, double target, double hi) noexcept {
  double lo = 0.0;
  if (!std::isfinite(hi)) {  // grow an upper bracket
    hi = std::max(1.0, 2.0 * target);
    for (int i = 0; i < 200 && f(hi) < target; ++i) hi *= 2.0;
  }
  double r = std::min(target, 0.5 * (lo + hi));
  for (int it = 0; it < 100; ++it) {
    const double h = f(r) - target;
    if (h == 0.0) return r;
    if (h < 0.0) lo = r;
    else hi = r;
    const double d = df(r);
    double next = d > 0.0 ? r - h / d : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - r) <= 1e-16 * std::max(1.0, r)) return next;
    r = next;
  }
  return r;
}

// Determinant of the Jacobian of the plumb_bob map (x, y) -> (xd, yd) (k = k1, k2, p1, p2, k3).
double plumb_bob_det(const std::array<double, 5>& k, double x, double y) noexcept {
  const double r2 = x * x + y * y, R = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
  const double dR = k[0] + r2 * (2.0 * k[1] + r2 * 3.0 * k[4]);
  const double a = R + 2.0 * x * x * dR + 2.0 * k[2] * y + 6.0 * k[3] * x;
  const double b = 2.0 * x * y * dR + 2.0 * k[2] * x + 2.0 * k[3] * y;
  const double d = R + 2.0 * y * y * dR + 6.0 * k[2] * y + 2.0 * k[3] * x;
  return a * d - b * b;
}

}  // namespace

CameraModel CameraModel::pinhole(double px, double py, double u0, double v0, double width, double height,
                                 double fps) {
  return from_visp(px, py, u0, v0, 0.0, 0.0, width, height, fps);
}

CameraModel CameraModel::from_visp(double px, double py, double u0, double v0, double kud, double kdu, double width,
                                   double height, double fps) {
  CameraModel c;
  c.px_ = px;
  c.py_ = py;
  c.u0_ = u0;
  c.v0_ = v0;
  c.distortion_ = kud == 0.0 && kdu == 0.0 ? Distortion::none : Distortion::visp;
  c.k_ = {kud, kdu, 0.0, 0.0, 0.0};
  if (c.distortion_ == Distortion::none) c.k_ = {};
  c.u_min_ = c.v_min_ = 0.0;
  c.u_max_ = width;
  c.v_max_ = height;
  c.fps_ = fps;
  if (!(width > 0.0 && width <= max_pixel_coordinate))
    fail("width must be in (0, " + num(max_pixel_coordinate) + "] px, got " + num(width));
  if (!(height > 0.0 && height <= max_pixel_coordinate))
    fail("height must be in (0, " + num(max_pixel_coordinate) + "] px, got " + num(height));
  if (!(std::abs(kud) <= max_distortion_coefficient))
    fail("kud must be finite and within +-" + num(max_distortion_coefficient) + ", got " + num(kud));
  if (!(std::abs(kdu) <= max_distortion_coefficient))
    fail("kdu must be finite and within +-" + num(max_distortion_coefficient) + ", got " + num(kdu));
  c.validate();
  c.set_domain();
  return c;
}

CameraModel CameraModel::from_opencv(const Eigen::Matrix3d& K, const Eigen::Ref<const Eigen::VectorXd>& dist,
                                     double width, double height, bool fisheye, double fps) {
  if (!K.allFinite()) fail("K must be finite");
  if (K(0, 1) != 0.0) fail("K: skew K[0][1] must be 0 (skewed pixels are not supported), got " + num(K(0, 1)));
  if (K(1, 0) != 0.0 || K(2, 0) != 0.0 || K(2, 1) != 0.0 || K(2, 2) != 1.0)
    fail("K must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]");
  if (!dist.allFinite()) fail("dist must be finite");
  for (Eigen::Index i = 0; i < dist.size(); ++i)
    if (!(std::abs(dist(i)) <= max_distortion_coefficient))
      fail("dist[" + std::to_string(i) + "] must be within +-" + num(max_distortion_coefficient) + ", got " +
           num(dist(i)));
  CameraModel c = pinhole(K(0, 0), K(1, 1), K(0, 2), K(1, 2), width, height, fps);
  const Eigen::Index n = dist.size();
  if (fisheye) {
    if (n != 4) fail("dist: the fisheye (equidistant) model takes 4 coefficients (k1, k2, k3, k4), got " + std::to_string(n));
    c.distortion_ = Distortion::equidistant;
    c.k_ = {dist(0), dist(1), dist(2), dist(3), 0.0};
  } else {
    if (n != 0 && n != 4 && n != 5 && n != 8 && n != 12 && n != 14)
      fail("dist: plumb_bob takes (k1, k2, p1, p2[, k3]) (OpenCV's 4, 5, 8, 12 or 14 entries), got " +
           std::to_string(n));
    for (Eigen::Index i = 5; i < n; ++i)
      if (dist(i) != 0.0)
        fail("dist[" + std::to_string(i) + "] = " + num(dist(i)) +
             ": only (k1, k2, p1, p2, k3) are supported (OpenCV's rational, thin-prism and tilt terms must be 0)");
    for (Eigen::Index i = 0; i < std::min<Eigen::Index>(n, 5); ++i) c.k_[static_cast<std::size_t>(i)] = dist(i);
    const bool any = std::any_of(c.k_.begin(), c.k_.end(), [](double k) { return k != 0.0; });
    c.distortion_ = any ? Distortion::plumb_bob : Distortion::none;
  }
  c.validate();
  c.set_domain();
  return c;
}

CameraModel CameraModel::from_omnidir(const Eigen::Matrix3d& K, double xi, const Eigen::Ref<const Eigen::VectorXd>& D,
                                      double width, double height, double fps) {
  if (!(xi >= 0.0 && xi <= max_distortion_coefficient))
    fail("xi must be finite and in [0, " + num(max_distortion_coefficient) + "], got " + num(xi));
  if (D.size() != 4) fail("D: the omnidir model takes 4 coefficients (k1, k2, p1, p2), got " + std::to_string(D.size()));
  CameraModel c = from_opencv(K, Eigen::VectorXd::Zero(5), width, height, false, fps);  // checks K and the rest
  if (!D.allFinite()) fail("D must be finite");
  for (Eigen::Index i = 0; i < 4; ++i)
    if (!(std::abs(D(i)) <= max_distortion_coefficient))
      fail("D[" + std::to_string(i) + "] must be within +-" + num(max_distortion_coefficient) + ", got " + num(D(i)));
  c.distortion_ = Distortion::omnidir;
  c.xi_ = xi;
  c.k_ = {D(0), D(1), D(2), D(3), 0.0};
  c.validate();
  c.set_domain();
  return c;
}

CameraModel CameraModel::make(double px, double py, double u0, double v0, Distortion distortion,
                              const Eigen::Ref<const Eigen::VectorXd>& coefficients, double u_min, double u_max,
                              double v_min, double v_max, double fps) {
  const int count[5] = {0, 2, 5, 4, 5};
  const int d = static_cast<int>(distortion);
  if (d < 0 || d > 4) fail("distortion must be none, visp, plumb_bob, equidistant or omnidir");
  if (coefficients.size() != count[d])
    fail(std::string("coefficients: the ") + to_string(distortion) + " model takes " + std::to_string(count[d]) +
         ", got " + std::to_string(coefficients.size()));
  for (Eigen::Index i = 0; i < coefficients.size(); ++i)
    if (!(std::abs(coefficients(i)) <= max_distortion_coefficient))
      fail("coefficients[" + std::to_string(i) + "] must be finite and within +-" + num(max_distortion_coefficient) +
           ", got " + num(coefficients(i)));
  CameraModel c;
  c.px_ = px;
  c.py_ = py;
  c.u0_ = u0;
  c.v0_ = v0;
  c.distortion_ = distortion;
  if (distortion == Distortion::omnidir) {
    if (!(coefficients(0) >= 0.0)) fail("coefficients[0]: omnidir's xi must be >= 0, got " + num(coefficients(0)));
    c.xi_ = coefficients(0);
    for (std::size_t i = 0; i < 4; ++i) c.k_[i] = coefficients(static_cast<Eigen::Index>(i) + 1);
  } else {
    for (Eigen::Index i = 0; i < coefficients.size(); ++i) c.k_[static_cast<std::size_t>(i)] = coefficients(i);
  }
  c.u_min_ = u_min;
  c.u_max_ = u_max;
  c.v_min_ = v_min;
  c.v_max_ = v_max;
  c.fps_ = fps;
  c.validate();
  c.set_domain();
  return c;
}

CameraModel CameraModel::normalized(double bounds, double fps) {
  if (!(bounds > 0.0 && bounds <= max_pixel_coordinate))
    fail("bounds must be in (0, " + num(max_pixel_coordinate) + "], got " + num(bounds));
  CameraModel c;
  c.u_min_ = c.v_min_ = -bounds;
  c.u_max_ = c.v_max_ = bounds;
  c.fps_ = fps;
  c.validate();
  return c;
}

CameraModel CameraModel::afma6() { return from_visp(1090.6, 1090.0, 310.1, 260.8, -0.2114, 0.2217, 640.0, 480.0); }

Eigen::VectorXd CameraModel::coefficients() const {
  switch (distortion_) {
    case Distortion::none: return Eigen::VectorXd(0);
    case Distortion::visp: return Eigen::Vector2d(k_[0], k_[1]);
    case Distortion::plumb_bob: return Eigen::Map<const Eigen::VectorXd>(k_.data(), 5);
    case Distortion::equidistant: return Eigen::Map<const Eigen::VectorXd>(k_.data(), 4);
    case Distortion::omnidir: {
      Eigen::VectorXd c(5);
      c << xi_, k_[0], k_[1], k_[2], k_[3];
      return c;
    }
  }
  return {};
}

Eigen::VectorXd CameraModel::opencv_coefficients() const {
  if (distortion_ == Distortion::equidistant) return coefficients();
  if (distortion_ == Distortion::omnidir) return Eigen::Map<const Eigen::VectorXd>(k_.data(), 4);
  Eigen::VectorXd d = Eigen::VectorXd::Zero(5);
  if (distortion_ == Distortion::plumb_bob) d = coefficients();
  if (distortion_ == Distortion::visp) d(0) = k_[0];
  return d;
}

Eigen::Matrix3d CameraModel::K() const noexcept {
  Eigen::Matrix3d K;
  K << px_, 0.0, u0_, 0.0, py_, v0_, 0.0, 0.0, 1.0;
  return K;
}

void CameraModel::validate() const {
  const auto focal = [](double f, const char* name) {
    if (!(f >= min_focal_length && f <= max_focal_length))
      fail(std::string("camera ") + name + " must be in [" + num(min_focal_length) + ", " + num(max_focal_length) +
           "] px, got " + num(f));
  };
  const auto pixel = [](double x, const char* name) {
    if (!(std::abs(x) <= max_pixel_coordinate))
      fail(std::string("camera ") + name + " must be finite and within +-" + num(max_pixel_coordinate) + " px, got " +
           num(x));
  };
  focal(px_, "px (fx)");
  focal(py_, "py (fy)");
  pixel(u0_, "u0 (cx)");
  pixel(v0_, "v0 (cy)");
  if (!(xi_ >= 0.0 && xi_ <= max_distortion_coefficient))
    fail("camera xi must be finite and in [0, " + num(max_distortion_coefficient) + "], got " + num(xi_));
  for (double k : k_)
    if (!(std::abs(k) <= max_distortion_coefficient))
      fail("camera distortion coefficients must be finite and within +-" + num(max_distortion_coefficient) + ", got " +
           num(k));
  pixel(u_min_, "bound u_min");
  pixel(u_max_, "bound u_max");
  pixel(v_min_, "bound v_min");
  pixel(v_max_, "bound v_max");
  if (!(u_min_ < u_max_)) fail("camera bounds need u_min < u_max (width > 0)");
  if (!(v_min_ < v_max_)) fail("camera bounds need v_min < v_max (height > 0)");
  if (!(fps_ > 0.0 && fps_ <= max_frame_rate))
    fail("camera fps must be in (0, " + num(max_frame_rate) + "], got " + num(fps_));
}

// The radius where each model's radial map stops increasing, and the angle
// off the axis where its bearings stop being one-to-one (see the header).
void CameraModel::set_domain() {
  r_max_ = r2_max_ = rd_max_ = inf;
  plane_r_max_ = plane_rd_max_ = fold_rd_ = inf;
  theta_max_ = 0.5 * pi;
  angle_max_ = 0.5 * pi;
  // The radial part r (1 + k1 r^2 + k2 r^4 + k3 r^6) of plumb_bob (and of omnidir, k3 = 0) and its fold.
  const auto radial_fold = [&]() { return smallest_positive_root({1.0, 3.0 * k_[0], 5.0 * k_[1], 7.0 * k_[4], 0.0}, 3, 1e8); };
  const auto radial = [&](double r) { const double s = r * r; return r * (1.0 + s * (k_[0] + s * (k_[1] + s * k_[4]))); };
  switch (distortion_) {
    case Distortion::none: break;
    case Distortion::visp:
      // d/dr [r (1 + k r^2)] = 1 + 3 k r^2: folds at r^2 = -1 / (3 k) when k < 0.
      if (k_[0] < 0.0) r2_max_ = -1.0 / (3.0 * k_[0]);
      if (k_[1] < 0.0) rd_max_ = std::sqrt(-1.0 / (3.0 * k_[1]));  // the kdu map's own fold, distorted radius
      r_max_ = std::sqrt(r2_max_);
      fold_rd_ = rd_max_;  // what normalize (kdu) accepts: kud's and kdu's folds are separate calibrations
      break;
    case Distortion::plumb_bob: {
      // d/dr [r R(r^2)] = 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3, s = r^2 (radial part).
      r2_max_ = radial_fold();
      r_max_ = std::sqrt(r2_max_);
      if (std::isfinite(r2_max_)) rd_max_ = radial(r_max_);
      fold_rd_ = rd_max_;
      break;
    }
    case Distortion::equidistant: {
      // d/dtheta [theta (1 + k1 t + k2 t^2 + k3 t^3 + k4 t^4)], t = theta^2: bearings up to its
      // first root or pi; normalised coordinates up to that or pi/2 (in front).
      const double t = smallest_positive_root({1.0, 3.0 * k_[0], 5.0 * k_[1], 7.0 * k_[2], 9.0 * k_[3]}, 4, pi * pi);
      angle_max_ = std::min(pi, std::sqrt(t));
      theta_max_ = std::min(0.5 * pi, angle_max_);
      if (theta_max_ < 0.5 * pi) {
        r_max_ = std::tan(theta_max_);
        r2_max_ = r_max_ * r_max_;
      }
      rd_max_ = equidistant_theta_d(k_, theta_max_);
      fold_rd_ = equidistant_theta_d(k_, angle_max_);
      break;
    }
    case Distortion::omnidir: {
      // Mei's plane: r = sin(a) / (cos(a) + xi) grows with the angle a while 1 + xi cos(a) > 0 and
      // cos(a) + xi > 0; the radial-tangential part folds at its own radius. The smaller wins.
      const double mei = xi_ > 1.0 ? 1.0 / std::sqrt(xi_ * xi_ - 1.0) : inf;
      plane_r_max_ = std::min(mei, std::sqrt(radial_fold()));
      if (std::isfinite(plane_r_max_)) {
        const double r2 = plane_r_max_ * plane_r_max_;
        const double f = (xi_ + std::sqrt(std::max(0.0, 1.0 + (1.0 - xi_ * xi_) * r2))) / (1.0 + r2);
        angle_max_ = std::acos(std::clamp(f - xi_, -1.0, 1.0));
        plane_rd_max_ = radial(plane_r_max_);
      } else {
        angle_max_ = std::acos(-std::min(xi_, 1.0));
      }
      fold_rd_ = plane_rd_max_;
      if (angle_max_ < 0.5 * pi) {
        r_max_ = std::tan(angle_max_);
        r2_max_ = r_max_ * r_max_;
      }
      break;
    }
  }
  if (distortion_ != Distortion::equidistant && distortion_ != Distortion::omnidir)
    angle_max_ = std::isfinite(r_max_) ? std::atan(r_max_) : 0.5 * pi;
  cos_angle_max_ = std::cos(angle_max_);
}

double CameraModel::field_of_view() const noexcept {
  constexpr int n = 512;  // per side of the sensor's border
  double widest = 0.0;
  Eigen::Vector3d b;
  for (int side = 0; side < 4; ++side)
    for (int i = 0; i <= n; ++i) {
      const double t = static_cast<double>(i) / n;
      const double u = side < 2 ? u_min_ + t * (u_max_ - u_min_) : (side == 2 ? u_min_ : u_max_);
      const double v = side < 2 ? (side == 0 ? v_min_ : v_max_) : v_min_ + t * (v_max_ - v_min_);
      if (!to_bearing(u, v, b)) return 2.0 * angle_max_;  // the image circle lies inside the sensor
      widest = std::max(widest, std::acos(std::clamp(b.z(), -1.0, 1.0)));
    }
  return 2.0 * widest;
}

bool CameraModel::project(double x, double y, Eigen::Vector2d& pixel) const noexcept {
  const double r2 = x * x + y * y;
  if (!(r2 < r2_max_) || !std::isfinite(r2)) {  // also catches NaN
    pixel.setConstant(nan);
    return false;
  }
  switch (distortion_) {
    case Distortion::none: pixel << u0_ + px_ * x, v0_ + py_ * y; break;
    case Distortion::visp: {  // written exactly as ViSP (and the simulator before) evaluate it
      const double k = 1.0 + k_[0] * r2;
      pixel << u0_ + px_ * x * k, v0_ + py_ * y * k;
      break;
    }
    case Distortion::plumb_bob: {
      const double k1 = k_[0], k2 = k_[1], p1 = k_[2], p2 = k_[3], k3 = k_[4];
      const double R = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
      const double xd = x * R + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
      const double yd = y * R + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
      pixel << u0_ + px_ * xd, v0_ + py_ * yd;
      if ((p1 != 0.0 || p2 != 0.0) && !(plumb_bob_det(k_, x, y) > 0.0)) {  // the tangential terms' fold
        pixel.setConstant(nan);
        return false;
      }
      break;
    }
    case Distortion::equidistant: {
      const double r = std::sqrt(r2), th = std::atan(r);
      const double thd = equidistant_theta_d(k_, th);
      const double s = r > 0.0 ? thd / r : 1.0;
      pixel << u0_ + px_ * (x * s), v0_ + py_ * (y * s);
      break;
    }
    case Distortion::omnidir: return from_bearing(x, y, 1.0, pixel);
  }
  return true;
}

bool CameraModel::normalize(double u, double v, Eigen::Vector2d& uv) const noexcept {
  if (!std::isfinite(u) || !std::isfinite(v)) {
    uv.setConstant(nan);
    return false;
  }
  const double xd = (u - u0_) / px_, yd = (v - v0_) / py_;
  bool ok = true;
  switch (distortion_) {
    case Distortion::none: uv << xd, yd; break;
    case Distortion::visp: {
      const double r2 = xd * xd + yd * yd;
      ok = r2 < rd_max_ * rd_max_;
      const double k = 1.0 + k_[1] * r2;
      uv << xd * k, yd * k;
      break;
    }
    case Distortion::plumb_bob: ok = undistort_radtan(xd, yd, r_max_, r2_max_, rd_max_, uv); break;
    case Distortion::equidistant: ok = undistort_equidistant(xd, yd, uv); break;
    case Distortion::omnidir: {
      Eigen::Vector3d b;
      ok = lift_omnidir(u, v, b) && b.z() > 0.0;
      if (ok) uv << b.x() / b.z(), b.y() / b.z();
      break;
    }
  }
  if (!ok) uv.setConstant(nan);
  return ok;
}

// Newton's method on the full (radial + tangential) map, started from the
// exact inverse of its radial part (bracketed, so it stays in the one-to-one
// disc); the answer must reproduce (xd, yd) to newton_tolerance_px and lie
// inside max_radius.
bool CameraModel::undistort_radtan(double xd, double yd, double r_hi, double r2_hi, double rd_hi,
                                   Eigen::Vector2d& uv) const noexcept {
  const double k1 = k_[0], k2 = k_[1], p1 = k_[2], p2 = k_[3], k3 = k_[4];
  const auto radial = [&](double r2) { return 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3)); };
  const double f = std::max(px_, py_);
  // Fast path (the usual pixel of a usual lens): Newton's method on the full map started from
  // (xd, yd) itself, no bracket. Its answer is kept only when it passes the same acceptance test
  // as the bracketed path below (inside r_hi, residual below newton_tolerance_px, Jacobian
  // determinant > 0, where the map is one-to-one); otherwise the bracketed path decides.
  {
    const double s0 = radial(xd * xd + yd * yd);  // one fixed-point step of the radial part: a closer start
    const double g0 = s0 > 0.5 && s0 < 2.0 ? 1.0 / s0 : 1.0;
    double x = xd * g0, y = yd * g0, e2 = 0.0, r2 = 0.0;
    const double tol2 = (1e-3 * newton_tolerance_px / f) * (1e-3 * newton_tolerance_px / f);
    for (int it = 0; it < 12; ++it) {
      r2 = x * x + y * y;
      const double R = radial(r2), dR = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
      const double ex = x * R + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - xd;
      const double ey = y * R + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - yd;
      e2 = ex * ex + ey * ey;
      if (e2 <= tol2 || !(r2 < r2_hi)) break;
      const double a = R + 2.0 * x * x * dR + 2.0 * p1 * y + 6.0 * p2 * x;
      const double b = 2.0 * x * y * dR + 2.0 * p1 * x + 2.0 * p2 * y;
      const double d = R + 2.0 * y * y * dR + 6.0 * p1 * y + 2.0 * p2 * x;
      const double det = a * d - b * b;
      if (!(det > 0.0)) break;
      const double idet = 1.0 / det;
      x -= (d * ex - b * ey) * idet;
      y -= (a * ey - b * ex) * idet;
    }
    if (e2 <= tol2 && r2 < r2_hi && plumb_bob_det(k_, x, y) > 0.0) {
      uv << x, y;
      return true;
    }
  }
  const double rho = std::sqrt(xd * xd + yd * yd);
  double x = 0.0, y = 0.0;
  if (rho > 0.0) {
    const double target = std::min(rho, rd_hi);
    const double r = bracketed_newton([&](double r) { return r * radial(r * r); },
                                      [&](double r) {
                                        const double s = r * r;
                                        return 1.0 + s * (3.0 * k1 + s * (5.0 * k2 + s * 7.0 * k3));
                                      },
                                      target, r_hi);
    x = xd * r / rho;
    y = yd * r / rho;
  }
  for (int it = 0; it < 30; ++it) {
    const double r2 = x * x + y * y, R = radial(r2), dR = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
    const double ex = x * R + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - xd;
    const double ey = y * R + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - yd;
    if (f * std::hypot(ex, ey) <= 1e-3 * newton_tolerance_px) break;
    const double a = R + 2.0 * x * x * dR + 2.0 * p1 * y + 6.0 * p2 * x;  // d xd / dx
    const double b = 2.0 * x * y * dR + 2.0 * p1 * x + 2.0 * p2 * y;      // d xd / dy = d yd / dx
    const double d = R + 2.0 * y * y * dR + 6.0 * p1 * y + 2.0 * p2 * x;  // d yd / dy
    const double det = a * d - b * b;
    if (!(std::abs(det) > 0.0)) break;
    const double dx = (d * ex - b * ey) / det, dy = (a * ey - b * ex) / det;
    x -= dx;
    y -= dy;
    if (std::abs(dx) + std::abs(dy) <= 1e-17 * (1.0 + std::abs(x) + std::abs(y))) break;
  }
  const double r2 = x * x + y * y, R = radial(r2);
  const double ex = x * R + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - xd;
  const double ey = y * R + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - yd;
  uv << x, y;
  return r2 < r2_hi && f * std::hypot(ex, ey) <= newton_tolerance_px && plumb_bob_det(k_, x, y) > 0.0;
}

// theta_d = |(xd, yd)| is a function of theta alone: invert it by bracketed
// Newton on [0, theta_max), then r = tan(theta) along the same direction.
bool CameraModel::undistort_equidistant(double xd, double yd, Eigen::Vector2d& uv) const noexcept {
  const double thd = std::sqrt(xd * xd + yd * yd);
  if (thd == 0.0) {
    uv.setZero();
    return true;
  }
  if (!(thd < rd_max_)) return false;
  const auto g = [&](double th) { return equidistant_theta_d(k_, th); };
  const auto dg = [&](double th) { return equidistant_slope(k_, th); };
  const double th = bracketed_newton(g, dg, thd, theta_max_);
  const double s = std::tan(th) / thd;
  uv << xd * s, yd * s;
  return th < theta_max_ && std::max(px_, py_) * std::abs(g(th) - thd) <= newton_tolerance_px;
}

// Mei & Rives eq. 7: undistort onto Mei's plane, then lift to the unit sphere.
bool CameraModel::lift_omnidir(double u, double v, Eigen::Vector3d& b) const noexcept {
  Eigen::Vector2d p;
  if (!undistort_radtan((u - u0_) / px_, (v - v0_) / py_, plane_r_max_, plane_r_max_ * plane_r_max_, plane_rd_max_, p))
    return false;
  const double r2 = p.squaredNorm();
  const double f = (xi_ + std::sqrt(std::max(0.0, 1.0 + (1.0 - xi_ * xi_) * r2))) / (1.0 + r2);
  b << f * p.x(), f * p.y(), f - xi_;
  b /= b.norm();  // unit to rounding already; this removes the last ulps
  return b.z() > cos_angle_max_;
}

// theta_d = |(xd, yd)| -> theta by bracketed Newton on [0, max_angle), along the same direction.
bool CameraModel::equidistant_bearing(double u, double v, Eigen::Vector3d& b) const noexcept {
  const double xd = (u - u0_) / px_, yd = (v - v0_) / py_, thd = std::sqrt(xd * xd + yd * yd);
  if (thd == 0.0) {
    b << 0.0, 0.0, 1.0;
    return true;
  }
  if (!(thd < fold_rd_)) return false;
  const auto g = [&](double th) { return equidistant_theta_d(k_, th); };
  const auto dg = [&](double th) { return equidistant_slope(k_, th); };
  const double th = bracketed_newton(g, dg, thd, angle_max_);
  const double s = std::sin(th) / thd;
  b << xd * s, yd * s, std::cos(th);
  return th < angle_max_ && std::max(px_, py_) * std::abs(g(th) - thd) <= newton_tolerance_px;
}

bool CameraModel::to_bearing(double u, double v, Eigen::Vector3d& b) const noexcept {
  bool ok = std::isfinite(u) && std::isfinite(v);
  if (ok) switch (distortion_) {
      case Distortion::equidistant: ok = equidistant_bearing(u, v, b); break;
      case Distortion::omnidir: ok = lift_omnidir(u, v, b); break;
      default: {
        Eigen::Vector2d x;
        ok = normalize(u, v, x);
        if (ok) {
          b << x.x(), x.y(), 1.0;
          b /= b.norm();
        }
      }
    }
  if (!ok) b.setConstant(nan);
  return ok;
}

bool CameraModel::from_bearing(double X, double Y, double Z, Eigen::Vector2d& pixel) const noexcept {
  const double m = std::max({std::abs(X), std::abs(Y), std::abs(Z)});
  if (!(m > 0.0) || !std::isfinite(m)) {  // zero length, NaN or infinite
    pixel.setConstant(nan);
    return false;
  }
  X /= m;
  Y /= m;
  Z /= m;
  const double n = std::sqrt(X * X + Y * Y + Z * Z);
  X /= n;
  Y /= n;
  Z /= n;
  if (!(Z > cos_angle_max_)) {  // at or beyond max_angle() off the axis
    pixel.setConstant(nan);
    return false;
  }
  switch (distortion_) {
    case Distortion::equidistant: {
      const double rho = std::sqrt(X * X + Y * Y), th = std::atan2(rho, Z);
      const double thd = equidistant_theta_d(k_, th);
      const double s = rho > 0.0 ? thd / rho : 0.0;
      pixel << u0_ + px_ * (X * s), v0_ + py_ * (Y * s);
      return true;
    }
    case Distortion::omnidir: {
      const double w = 1.0 / (Z + xi_), x = X * w, y = Y * w;  // Mei's plane (Z + xi > 0 inside max_angle)
      const double r2 = x * x + y * y, R = 1.0 + r2 * (k_[0] + r2 * k_[1]);
      const double xd = x * R + 2.0 * k_[2] * x * y + k_[3] * (r2 + 2.0 * x * x);
      const double yd = y * R + k_[2] * (r2 + 2.0 * y * y) + 2.0 * k_[3] * x * y;
      if ((k_[2] != 0.0 || k_[3] != 0.0) && !(plumb_bob_det(k_, x, y) > 0.0)) {  // the tangential terms' fold
        pixel.setConstant(nan);
        return false;
      }
      pixel << u0_ + px_ * xd, v0_ + py_ * yd;
      return true;
    }
    default: return project(X / Z, Y / Z, pixel);
  }
}

int CameraModel::to_bearing(const Eigen::Ref<const Points>& pixels, Eigen::Ref<Bearings> bearings) const noexcept {
  if (pixels.cols() != bearings.cols()) {
    bearings.setConstant(nan);
    return static_cast<int>(bearings.cols());
  }
  if (distortion_ != Distortion::equidistant && distortion_ != Distortion::omnidir) {
    // Through the batched normalize, written into the bearings' first two rows, then (x, y, 1) / |.|.
    const int failed = normalize(pixels, bearings.topRows<2>());
    for (Eigen::Index i = 0; i < pixels.cols(); ++i) {
      const double x = bearings(0, i), y = bearings(1, i), w = 1.0 / std::sqrt(x * x + y * y + 1.0);
      bearings.col(i) << x * w, y * w, std::isnan(x) ? nan : w;
    }
    return failed;
  }
  int failed = 0;
  Eigen::Vector3d b;
  for (Eigen::Index i = 0; i < pixels.cols(); ++i) {
    failed += !to_bearing(pixels(0, i), pixels(1, i), b);
    bearings.col(i) = b;
  }
  return failed;
}

int CameraModel::from_bearing(const Eigen::Ref<const Bearings>& bearings, Eigen::Ref<Points> pixels) const noexcept {
  if (pixels.cols() != bearings.cols()) {
    pixels.setConstant(nan);
    return static_cast<int>(pixels.cols());
  }
  int failed = 0;
  Eigen::Vector2d p;
  for (Eigen::Index i = 0; i < bearings.cols(); ++i) {
    failed += !from_bearing(bearings(0, i), bearings(1, i), bearings(2, i), p);
    pixels.col(i) = p;
  }
  return failed;
}

void CameraModel::validate_pixels(const Eigen::Ref<const Points>& pixels, const char* name) const {
  Eigen::Vector3d b;
  for (Eigen::Index i = 0; i < pixels.cols(); ++i) {
    if (to_bearing(pixels(0, i), pixels(1, i), b)) continue;
    const std::string which = std::string(name) + "[" + std::to_string(i) + "]";
    if (!std::isfinite(pixels(0, i)) || !std::isfinite(pixels(1, i))) fail(which + " is not finite");
    fail(which + " = (" + num(pixels(0, i)) + ", " + num(pixels(1, i)) + ") lies beyond the image circle of the " +
         to_string(distortion_) + " model (max_angle " + num(angle_max_ * 180.0 / pi) +
         " degrees off the axis, fold_radius " + num(fold_rd_) + ") or where its distortion is not one-to-one");
  }
}

void CameraModel::validate_bearings(const Eigen::Ref<const Bearings>& bearings, const char* name) const {
  Eigen::Vector2d p;
  for (Eigen::Index i = 0; i < bearings.cols(); ++i) {
    const Eigen::Vector3d b = bearings.col(i);
    if (from_bearing(b.x(), b.y(), b.z(), p)) continue;
    const std::string which = std::string(name) + "[" + std::to_string(i) + "]";
    if (!b.allFinite()) fail(which + " is not finite");
    if (b.isZero(0.0)) fail(which + " has zero length (a bearing is a direction)");
    const Eigen::Vector3d d = b / largest_magnitude(b);  // scaled: its norm cannot overflow
    const double angle = std::acos(std::clamp(d.z() / d.norm(), -1.0, 1.0));
    if (angle < angle_max_)  // omnidir's tangential terms fold inside max_angle
      fail(which + " lies " + num(angle * 180.0 / pi) + " degrees off the axis, where the " + to_string(distortion_) +
           " model's tangential distortion folds (not one-to-one)");
    fail(which + " lies " + num(angle * 180.0 / pi) + " degrees off the axis, at or beyond the " +
         to_string(distortion_) + " model's max_angle " + num(angle_max_ * 180.0 / pi) + " degrees");
  }
}

int CameraModel::project(const Eigen::Ref<const Points>& uv, Eigen::Ref<Points> pixels) const noexcept {
  if (uv.cols() != pixels.cols()) {
    pixels.setConstant(nan);
    return static_cast<int>(pixels.cols());
  }
  int failed = 0;
  Eigen::Vector2d p;
  for (Eigen::Index i = 0; i < uv.cols(); ++i) {
    failed += !project(uv(0, i), uv(1, i), p);
    pixels.col(i) = p;
  }
  return failed;
}

int CameraModel::normalize(const Eigen::Ref<const Points>& pixels, Eigen::Ref<Points> uv) const noexcept {
  if (uv.cols() != pixels.cols()) {
    uv.setConstant(nan);
    return static_cast<int>(uv.cols());
  }
  if (distortion_ == Distortion::plumb_bob) return normalize_radtan_batch(pixels, uv);
  int failed = 0;
  Eigen::Vector2d p;
  for (Eigen::Index i = 0; i < pixels.cols(); ++i) {
    failed += !normalize(pixels(0, i), pixels(1, i), p);
    uv.col(i) = p;
  }
  return failed;
}

// The batch of plumb_bob pixels: the fast path of undistort_radtan with a fixed number of Newton
// steps on every point (no data-dependent branch, so independent points overlap in the pipeline),
// then each point's acceptance test (the same as the single-point paths'); a point that fails it
// (not converged, outside the one-to-one domain, not finite) takes the single-point path.
int CameraModel::normalize_radtan_batch(const Eigen::Ref<const Points>& pixels, Eigen::Ref<Points> uv) const noexcept {
  const double k1 = k_[0], k2 = k_[1], p1 = k_[2], p2 = k_[3], k3 = k_[4];
  const double ipx = 1.0 / px_, ipy = 1.0 / py_, f = std::max(px_, py_);
  const double tol2 = (1e-3 * newton_tolerance_px / f) * (1e-3 * newton_tolerance_px / f);
  const Eigen::Index n = pixels.cols();
  constexpr int steps = 3;  // from the radial first guess: enough for usual lenses at 1e-12 px
  for (Eigen::Index i = 0; i < n; ++i) {
    const double xd = (pixels(0, i) - u0_) * ipx, yd = (pixels(1, i) - v0_) * ipy;
    const double rd2 = xd * xd + yd * yd, s0 = 1.0 + rd2 * (k1 + rd2 * (k2 + rd2 * k3));
    const double g0 = s0 > 0.5 && s0 < 2.0 ? 1.0 / s0 : 1.0;
    double x = xd * g0, y = yd * g0;
    for (int it = 0; it < steps; ++it) {
      const double r2 = x * x + y * y, R = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
      const double dR = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
      const double ex = x * R + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - xd;
      const double ey = y * R + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - yd;
      const double a = R + 2.0 * x * x * dR + 2.0 * p1 * y + 6.0 * p2 * x;
      const double b = 2.0 * x * y * dR + 2.0 * p1 * x + 2.0 * p2 * y;
      const double d = R + 2.0 * y * y * dR + 6.0 * p1 * y + 2.0 * p2 * x;
      const double idet = 1.0 / (a * d - b * b);
      x -= (d * ex - b * ey) * idet;
      y -= (a * ey - b * ex) * idet;
    }
    uv(0, i) = x;
    uv(1, i) = y;
  }
  int failed = 0;
  Eigen::Vector2d p;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = uv(0, i), y = uv(1, i);
    const double xd = (pixels(0, i) - u0_) * ipx, yd = (pixels(1, i) - v0_) * ipy;
    const double r2 = x * x + y * y, R = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double ex = x * R + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - xd;
    const double ey = y * R + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - yd;
    if (ex * ex + ey * ey <= tol2 && r2 < r2_max_ && plumb_bob_det(k_, x, y) > 0.0) continue;
    failed += !normalize(pixels(0, i), pixels(1, i), p);
    uv.col(i) = p;
  }
  return failed;
}

std::string CameraModel::describe() const {
  std::string s;
  char buf[320];
  if (px_ == 1.0 && py_ == 1.0 && u0_ == 0.0 && v0_ == 0.0 && distortion_ == Distortion::none) {
    std::snprintf(buf, sizeof buf, "CameraModel(normalized, u in [%g, %g], v in [%g, %g], fps=%g)", u_min_, u_max_,
                  v_min_, v_max_, fps_);
    return buf;
  }
  std::snprintf(buf, sizeof buf, "CameraModel(px=%g, py=%g, u0=%g, v0=%g, distortion=%s", px_, py_, u0_, v0_,
                to_string(distortion_));
  s = buf;
  const Eigen::VectorXd k = coefficients();
  const char* names[5][5] = {
      {}, {"kud", "kdu"}, {"k1", "k2", "p1", "p2", "k3"}, {"k1", "k2", "k3", "k4"}, {"xi", "k1", "k2", "p1", "p2"}};
  for (Eigen::Index i = 0; i < k.size(); ++i) {
    std::snprintf(buf, sizeof buf, ", %s=%g", names[static_cast<int>(distortion_)][i], k(i));
    s += buf;
  }
  std::snprintf(buf, sizeof buf, ", %gx%g, fps=%g)", width(), height(), fps_);
  return s + buf;
}

}  // namespace ibvs
