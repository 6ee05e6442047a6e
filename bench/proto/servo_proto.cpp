// Prototype, not shipped: a copy of the damped path of cpp/src/servo.cpp
// (Work<Rows>::assemble + solve + output copies) with the optimisations
// proposed in docs/benchmarks.md switchable, timed against the real
// ibvs::Servo::update on the same frames and checked to give the same twist.
//
//   cmake -DIBVS_BUILD_BENCH_PROTO=ON ...; bench_servo_proto [iterations]
#include "ibvs/ibvs.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

namespace {

using namespace ibvs;
using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Clock = std::chrono::steady_clock;

template <class T>
inline void keep(T const& v) { asm volatile("" : : "r,m"(v) : "memory"); }

enum class Diag { off, eig };

template <int Rows>
struct Proto {
  Eigen::Matrix<double, Rows, 6> J = Eigen::Matrix<double, Rows, 6>::Zero();
  Eigen::Matrix<double, Rows, 1> e = Eigen::Matrix<double, Rows, 1>::Zero();
  Matrix6 A;
  Eigen::LLT<Matrix6> llt;
  Eigen::SelfAdjointEigenSolver<Matrix6> eig;
  bool fast_assemble = false;
  Diag diag = Diag::off;
  double smin = 0, smax = 0;

  // As servo.cpp (jacobian = current).
  void assemble_copy(const Layout& layout, double rmin, const Eigen::Ref<const Points>& uv,
                     const Eigen::Ref<const Eigen::VectorXd>& z, const Eigen::Ref<const Points>& uvd) noexcept {
    Eigen::Index row = 0;
    for (const Block& b : layout.blocks()) {
      const double u = uv(0, b.point), v = uv(1, b.point), ud = uvd(0, b.point), vd = uvd(1, b.point);
      bool polar = b.representation == Representation::polar;
      if (polar && (std::hypot(u, v) < rmin || std::hypot(ud, vd) < rmin)) polar = false;
      if (polar) {
        const Eigen::Vector2d f = polar_features(u, v), fd = polar_features(ud, vd);
        e(row) = f(0) - fd(0);
        e(row + 1) = wrap_angle(f(1) - fd(1));
        J.template middleRows<2>(row) = polar_jacobian(u, v, z(b.point));
      } else {
        e(row) = u - ud;
        e(row + 1) = v - vd;
        J.template middleRows<2>(row) = cartesian_jacobian(u, v, z(b.point));
      }
      row += 2;
    }
  }

  // Proposed: r by sqrt once per point (no std::hypot: normalised coordinates
  // cannot overflow), r^2 against rmin^2, theta difference wrapped by a branch
  // (both thetas are in (-pi, pi], so the difference is in (-2pi, 2pi)), the
  // polar rows written from r, c, s directly.
  void assemble_fast(const Layout& layout, double rmin, const Eigen::Ref<const Points>& uv,
                     const Eigen::Ref<const Eigen::VectorXd>& z, const Eigen::Ref<const Points>& uvd) noexcept {
    const double rmin2 = rmin * rmin;
    Eigen::Index row = 0;
    for (const Block& b : layout.blocks()) {
      const double u = uv(0, b.point), v = uv(1, b.point), ud = uvd(0, b.point), vd = uvd(1, b.point);
      const double iz = 1.0 / z(b.point);
      const double r2 = u * u + v * v, rd2 = ud * ud + vd * vd;
      if (b.representation == Representation::polar && !(r2 < rmin2) && !(rd2 < rmin2)) {
        const double r = std::sqrt(r2), ir = 1.0 / r, c = u * ir, s = v * ir, k = 1.0 + r2;
        e(row) = r - std::sqrt(rd2);
        double d = std::atan2(v, u) - std::atan2(vd, ud);
        if (d > pi) d -= 2.0 * pi;
        else if (d <= -pi) d += 2.0 * pi;
        e(row + 1) = d;
        J.row(row) << -c * iz, -s * iz, r * iz, k * s, -k * c, 0.0;
        J.row(row + 1) << s * ir * iz, -c * ir * iz, 0.0, c * ir, s * ir, -1.0;
      } else {
        e(row) = u - ud;
        e(row + 1) = v - vd;
        J.row(row) << -iz, 0.0, u * iz, u * v, -(1.0 + u * u), v;
        J.row(row + 1) << 0.0, -iz, v * iz, 1.0 + v * v, -u * v, -u;
      }
      row += 2;
    }
  }

  Twist solve(double lambda) noexcept {
    A.noalias() = J.transpose().lazyProduct(J);
    if (diag == Diag::eig) {
      eig.compute(A, Eigen::EigenvaluesOnly);
      smin = std::sqrt(std::max(eig.eigenvalues()(0), 0.0));
      smax = std::sqrt(std::max(eig.eigenvalues()(5), 0.0));
    }
    A.diagonal().array() += lambda * lambda;
    llt.compute(A);
    Twist x;
    x.noalias() = J.transpose().lazyProduct(e);
    llt.solveInPlace(x);
    return x;
  }

  Twist update(const Layout& layout, double gain, double lambda, double rmin, const Eigen::Ref<const Points>& uv,
               const Eigen::Ref<const Eigen::VectorXd>& z, const Eigen::Ref<const Points>& uvd,
               const Eigen::Ref<const Eigen::VectorXd>& zd, ServoOutput& out) noexcept {
    const Eigen::Index m = layout.rows(), n = layout.n_points();
    bool ok = uv.cols() == n && uvd.cols() == n && z.size() == n && zd.size() == n && uv.allFinite() &&
              uvd.allFinite();
    for (Eigen::Index i = 0; i < n; ++i) ok = ok && z(i) > 0.0 && std::isfinite(z(i));
    if (!ok) return Twist::Zero();
    if (fast_assemble) assemble_fast(layout, rmin, uv, z, uvd);
    else assemble_copy(layout, rmin, uv, z, uvd);
    out.velocity = -gain * solve(lambda);
    out.error = e.head(m);
    out.error_norm = out.error.norm();
    out.jacobian = J.topRows(m);
    out.set_singular_values(smin, smax);
    return out.velocity;
  }
};

struct Stat { double median, p99, mean; };

template <class F>
Stat time_it(long iters, F&& f) {
  for (long i = 0; i < iters / 10 + 1000; ++i) f(i);
  std::vector<double> s(iters);
  const auto t0 = Clock::now();
  for (long i = 0; i < iters; ++i) f(i);
  const auto t1 = Clock::now();
  for (long i = 0; i < iters; ++i) {
    const auto a = Clock::now();
    f(i);
    s[i] = std::chrono::duration<double, std::micro>(Clock::now() - a).count();
  }
  std::sort(s.begin(), s.end());
  return {s[s.size() / 2], s[static_cast<std::size_t>(0.99 * (s.size() - 1))],
          std::chrono::duration<double, std::micro>(t1 - t0).count() / iters};
}

template <int Rows>
void run(const char* name, const Layout& layout, long iters) {
  const int n = layout.n_points();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  std::vector<Points> uv, uvd;
  std::vector<Eigen::VectorXd> z, zd;
  for (int k = 0; k < 64; ++k) {
    Points c(2, n), d(2, n);
    Eigen::VectorXd zz(n);
    const double rot = 0.6 * U(rng), sc = 1 + 0.2 * U(rng), tx = 0.03 * U(rng), ty = 0.03 * U(rng);
    for (int i = 0; i < n; ++i) {
      const double a = 2 * pi * (i + 0.5) / n;
      d(0, i) = 0.2 * std::cos(a);
      d(1, i) = 0.2 * std::sin(a);
      c(0, i) = sc * 0.2 * std::cos(a + rot) + tx + 0.005 * U(rng);
      c(1, i) = sc * 0.2 * std::sin(a + rot) + ty + 0.005 * U(rng);
      zz(i) = 1 + 0.3 * U(rng);
    }
    uv.push_back(c);
    uvd.push_back(d);
    z.push_back(zz);
    zd.push_back(Eigen::VectorXd::Ones(n));
  }
  const double lambda = 0.01, gain = 0.5, rmin = default_polar_min_radius;
  struct Variant { const char* name; bool fast; Diag diag; bool lib_diag; };
  const Variant variants[] = {
      {"copy of servo.cpp, diagnostics off", false, Diag::off, false},
      {"fast assemble, diagnostics off", true, Diag::off, false},
      {"copy of servo.cpp, diagnostics = eig", false, Diag::eig, true},
      {"fast assemble, diagnostics = eig", true, Diag::eig, true},
  };
  std::printf("\n%s (%dx6), lambda %g: median / p99 / mean us\n", name, layout.rows(), lambda);
  for (bool diag : {false, true}) {
    ServoOptions so;
    so.gain = gain;
    so.damping = lambda;
    so.diagnostics = diag;
    Servo servo(layout, so);
    ServoOutput out(layout);
    const Stat s = time_it(iters, [&](long i) {
      const int k = i & 63;
      servo.update(uv[k], z[k], uvd[k], zd[k], out);
      keep(out.velocity);
    });
    std::printf("  %-55s %7.3f %7.3f %7.3f\n", diag ? "ibvs::Servo::update, diagnostics on" : "ibvs::Servo::update, diagnostics off",
                s.median, s.p99, s.mean);
  }
  ServoOptions so;
  so.gain = gain;
  so.damping = lambda;
  Servo ref(layout, so);
  ServoOutput rout(layout), out(layout);
  for (const Variant& v : variants) {
    Proto<Rows> p;
    p.fast_assemble = v.fast;
    p.diag = v.diag;
    double dv = 0, dmin = 0, dmax = 0;
    for (int k = 0; k < 64; ++k) {
      ref.update(uv[k], z[k], uvd[k], zd[k], rout);
      p.update(layout, gain, lambda, rmin, uv[k], z[k], uvd[k], zd[k], out);
      dv = std::max(dv, (out.velocity - rout.velocity).norm() / rout.velocity.norm());
      if (v.lib_diag) {
        dmin = std::max(dmin, std::abs(out.sigma_min() - rout.sigma_min()) / rout.sigma_min());
        dmax = std::max(dmax, std::abs(out.sigma_max() - rout.sigma_max()) / rout.sigma_max());
      }
    }
    if (!(dv < 1e-9)) {
      std::printf("  %s: twist differs from Servo::update by %g\n", v.name, dv);
      std::exit(1);
    }
    const Stat s = time_it(iters, [&](long i) {
      const int k = i & 63;
      keep(p.update(layout, gain, lambda, rmin, uv[k], z[k], uvd[k], zd[k], out));
    });
    std::printf("  %-55s %7.3f %7.3f %7.3f   twist rel diff %.1e", v.name, s.median, s.p99, s.mean, dv);
    if (v.lib_diag) std::printf(", sigma_min/max rel diff %.1e / %.1e", dmin, dmax);
    std::printf("\n");
  }
}

}  // namespace

int main(int argc, char** argv) {
  const long iters = argc > 1 ? std::atol(argv[1]) : 200000;
  run<8>("cartesian(4)", Layout::cartesian(4), iters);
  run<8>("polar(4)", Layout::polar(4), iters);
  run<16>("stacked(4)", Layout::stacked(4), iters);
  return 0;
}
