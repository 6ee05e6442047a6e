// The floor of the photometric benchmark (ibvs-bench --sections photometric): one step of the
// luminance law written directly, pixel by pixel, the way one would by hand (and the way the issue's
// "plain Eigen loop" reference is written): for every pixel of the grid its error e = I - I*, its row
// of L_I from the gradient (ViSP's 7-tap filter, scaled by the focal lengths) and the constant depth,
//   L_I = [Ix/Z, Iy/Z, -(x Ix + y Iy)/Z, -x y Ix - (1 + y^2) Iy, (1 + x^2) Ix + x y Iy, x Iy - y Ix],
// accumulated into L^T e (and, for the current image's J, H = L^T L) without storing L; then the
// Levenberg-Marquardt solve v = -gain (H + mu diag H)^-1 L^T e by a 6 x 6 LLT (factored once when J is
// the desired image's). Float pixels and gradients, double accumulators per image row.
// Written independently of cpp/src/features/luminance.cpp; ibvs-bench checks that both give the same
// twist (relative 1e-4: float sums) before timing.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace ibvs_bench::photometric {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

struct Floor {
  int w, h, border;
  double px, py, u0, v0, inv_z, mu, gain;
  std::vector<float> xs, ys, ref, gx_ref, gy_ref;
  Eigen::LLT<Matrix6> desired_llt;

  static float dx7(const std::uint8_t* p, std::ptrdiff_t s) {
    return (2047.0f * float(p[s] - p[-s]) + 913.0f * float(p[2 * s] - p[-2 * s]) +
            112.0f * float(p[3 * s] - p[-3 * s])) / 8418.0f;
  }

  Floor(int w_, int h_, int border_, double px_, double py_, double u0_, double v0_, double z, double mu_,
        double gain_, const std::uint8_t* desired)
      : w(w_), h(h_), border(border_), px(px_), py(py_), u0(u0_), v0(v0_), inv_z(1.0 / z), mu(mu_), gain(gain_) {
    for (int c = border; c < w - border; ++c) xs.push_back(float((c - u0) / px));
    for (int r = border; r < h - border; ++r) ys.push_back(float((r - v0) / py));
    for (int r = border; r < h - border; ++r)
      for (int c = border; c < w - border; ++c) {
        const std::uint8_t* p = desired + r * w + c;
        ref.push_back(float(*p));
        gx_ref.push_back(float(px) * dx7(p, 1));
        gy_ref.push_back(float(py) * dx7(p, w));
      }
    Matrix6 H = Matrix6::Zero();
    Vector6 g;
    accumulate(desired, gx_ref.data(), gy_ref.data(), true, H, g);
    Matrix6 A = H;
    A.diagonal() *= 1.0 + mu;
    desired_llt.compute(A);
  }

  /// Sums L^T e (g) and, with_h, H over the grid; gradients from gx/gy (per grid pixel) or, when they are
  /// null, from the image itself (the current image's J).
  void accumulate(const std::uint8_t* img, const float* gx, const float* gy, bool with_h, Matrix6& H,
                  Vector6& g) const {
    H.setZero();
    g.setZero();
    const float iz = float(inv_z), fpx = float(px), fpy = float(py);
    const int gw = w - 2 * border;
    std::size_t k = 0;
    for (int r = border; r < h - border; ++r) {
      const float y = ys[r - border];
      float gr[6] = {0, 0, 0, 0, 0, 0};
      float hr[21] = {};
      for (int j = 0; j < gw; ++j, ++k) {
        const std::uint8_t* p = img + r * w + border + j;
        const float x = xs[j];
        const float Ix = gx ? gx[k] : fpx * dx7(p, 1);
        const float Iy = gy ? gy[k] : fpy * dx7(p, w);
        const float e = float(*p) - ref[k];
        const float L[6] = {Ix * iz, Iy * iz, -(x * Ix + y * Iy) * iz, -x * y * Ix - (1.0f + y * y) * Iy,
                            (1.0f + x * x) * Ix + x * y * Iy, x * Iy - y * Ix};
        for (int a = 0; a < 6; ++a) gr[a] += L[a] * e;
        if (with_h) {
          int n = 0;
          for (int a = 0; a < 6; ++a)
            for (int b = a; b < 6; ++b) hr[n++] += L[a] * L[b];
        }
      }
      for (int a = 0; a < 6; ++a) g(a) += gr[a];
      if (with_h) {
        int n = 0;
        for (int a = 0; a < 6; ++a)
          for (int b = a; b < 6; ++b) H(a, b) += hr[n++];
      }
    }
    if (with_h) H.triangularView<Eigen::StrictlyLower>() = H.transpose();
  }

  /// One step with J at the desired image (H* factored once).
  Vector6 step_desired(const std::uint8_t* img) const {
    Matrix6 H;
    Vector6 g;
    accumulate(img, gx_ref.data(), gy_ref.data(), false, H, g);
    return -gain * desired_llt.solve(g);
  }

  /// One step with J at the current image: its gradients, H and L^T e in one pass, then LLT.
  Vector6 step_current(const std::uint8_t* img) const {
    Matrix6 H;
    Vector6 g;
    accumulate(img, nullptr, nullptr, true, H, g);
    H.diagonal() *= 1.0 + mu;
    return -gain * H.llt().solve(g);
  }
};

}  // namespace ibvs_bench::photometric
