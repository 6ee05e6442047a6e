// ibvs-bench: the control loop timed, part by part and whole, and run paced at
// real-time rates. A plain main() program: no benchmark framework.
//
//   ibvs-bench                        components (N=4, each layout), tasks (moments, PBVS, 2.5-D, points +
//                                     moments), growth (N=4..64), paced 60 Hz/1 kHz/10 kHz,
//                                     600-frame simulated gantry episodes, robot (JointMapping, 6/7/16 joints),
//                                     camera model / pixel step / estimators (N=4)
//   ibvs-bench --paced 1000 --duration 10
//   ibvs-bench --sections components --layout stacked --n 4 --iterations 1000000
//   ibvs-bench --sections photometric LuminanceServo (issue 36) beside its per-pixel floor: not in the default
//   ibvs-bench --json                 one JSON line on stdout (the table goes to stderr)
//
// Every timed case: warm-up, then a batched loop (total time / iterations:
// mean and steps/s), then per-call timing with std::chrono::steady_clock
// (median, p99, max; the timer's own median cost is subtracted). Inputs cycle
// through 64 different frames; results go through an optimisation barrier.
#include "kernels.hpp"
#include "luminance_floor.hpp"
#include "task_floors.hpp"

#include "ibvs/ibvs.hpp"
#include "ibvs/sim/sim.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <functional>
#include <new>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#if defined(__linux__)
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <time.h>
#else
#include <thread>
#endif

// ---- allocation counter -----------------------------------------------------
// With glibc, malloc/calloc/realloc are interposed here, so that every heap
// allocation of the process is counted: operator new and Eigen's own
// aligned_malloc both end in malloc. Elsewhere (and under sanitizers, which
// own malloc) only operator new is counted.
namespace {
std::atomic<long> g_allocations{0};
}
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(memory_sanitizer)
#define IBVS_BENCH_SANITIZED 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define IBVS_BENCH_SANITIZED 1
#endif
#if defined(__GLIBC__) && !defined(IBVS_BENCH_SANITIZED)
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* malloc(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, n);
}
}
#else
void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
#endif

namespace {

using Clock = std::chrono::steady_clock;
using ibvs::Layout;
using ibvs::Points;
using ibvs::Twist;
using ibvs_bench::Kind;

/// Keeps a value alive for the optimiser (as Google Benchmark's DoNotOptimize).
template <class T>
inline void keep(T const& value) {
#if defined(__GNUC__)
  asm volatile("" : : "r,m"(value) : "memory");
#else
  static volatile const void* sink;
  sink = &value;
#endif
}

inline double ns_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::nano>(b - a).count();
}

// ---------------------------------------------------------------- options --
struct Options {
  long iterations = 100000;
  long warmup = -1;  // default: iterations / 10, at least 1000
  std::vector<std::string> layouts;
  std::vector<int> ns;
  bool layouts_given = false, ns_given = false;
  double damping = 0.01;
  double gain = 0.5;
  std::vector<double> rates{60.0, 1000.0, 10000.0};
  bool rates_given = false;
  double duration = 10.0;
  double spin_us = 0.0;
  long episodes = 50;
  bool realtime = false;
  std::vector<std::string> sections;
  bool json = false;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) if (!item.empty()) out.push_back(item);
  return out;
}

[[noreturn]] void usage(int code) {
  std::FILE* f = code ? stderr : stdout;
  std::fprintf(f,
               "usage: ibvs-bench [options]\n"
               "  --iterations N     timed calls per case (default 100000)\n"
               "  --warmup N         untimed calls first (default iterations/10, >= 1000)\n"
               "  --layout L[,L..]   cartesian, polar, stacked, hybrid (alternate points cartesian/polar) or all\n"
               "  --n N[,N..]        points (default: components 4, growth 4,8,16,32,64)\n"
               "  --damping L        lambda of the damped cases (default 0.01; must be > 0)\n"
               "  --gain G           gain (default 0.5)\n"
               "  --paced R[,R..]    paced-loop rates in Hz (default 60,1000,10000); alone: paced section only\n"
               "  --duration S       seconds per paced loop (default 10)\n"
               "  --spin US          paced: sleep until US microseconds before each deadline, then spin (default 0)\n"
               "  --realtime         paced: try SCHED_FIFO 80 and mlockall (needs CAP_SYS_NICE)\n"
               "  --episodes K       simulated 600-frame gantry episodes per episode case (default 50)\n"
               "  --sections S[,S..] components, tasks, growth, paced, episode, robot, camera (default all seven);\n"
               "                     photometric (LuminanceServo at 160x120 and 320x240: only when asked)\n"
               "  --json             one JSON line on stdout; the human table goes to stderr\n");
  std::exit(code);
}

Options parse(int argc, char** argv) {
  Options o;
  auto need = [&](int& i) -> std::string {
    if (i + 1 >= argc) {
      std::fprintf(stderr, "ibvs-bench: %s needs a value\n", argv[i]);
      usage(2);
    }
    return argv[++i];
  };
  auto number = [](const std::string& s, const char* what) {
    char* end = nullptr;
    const double x = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || *end != '\0' || !std::isfinite(x)) {
      std::fprintf(stderr, "ibvs-bench: %s: not a number: '%s'\n", what, s.c_str());
      usage(2);
    }
    return x;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") usage(0);
    else if (a == "--iterations") o.iterations = static_cast<long>(number(need(i), "--iterations"));
    else if (a == "--warmup") o.warmup = static_cast<long>(number(need(i), "--warmup"));
    else if (a == "--layout") { o.layouts = split(need(i)); o.layouts_given = true; }
    else if (a == "--n") {
      o.ns.clear();
      for (const auto& s : split(need(i))) o.ns.push_back(static_cast<int>(number(s, "--n")));
      o.ns_given = true;
    } else if (a == "--damping") o.damping = number(need(i), "--damping");
    else if (a == "--gain") o.gain = number(need(i), "--gain");
    else if (a == "--paced") {
      o.rates.clear();
      for (const auto& s : split(need(i))) o.rates.push_back(number(s, "--paced"));
      o.rates_given = true;
    } else if (a == "--duration") o.duration = number(need(i), "--duration");
    else if (a == "--spin") o.spin_us = number(need(i), "--spin");
    else if (a == "--realtime") o.realtime = true;
    else if (a == "--episodes") o.episodes = static_cast<long>(number(need(i), "--episodes"));
    else if (a == "--sections") o.sections = split(need(i));
    else if (a == "--json") o.json = true;
    else {
      std::fprintf(stderr, "ibvs-bench: unknown option '%s'\n", a.c_str());
      usage(2);
    }
  }
  if (o.layouts.size() == 1 && o.layouts[0] == "all") o.layouts = {"cartesian", "polar", "stacked", "hybrid"};
  if (o.layouts.empty()) o.layouts = {"cartesian", "polar", "stacked", "hybrid"};
  for (const auto& l : o.layouts)
    if (l != "cartesian" && l != "polar" && l != "stacked" && l != "hybrid") {
      std::fprintf(stderr, "ibvs-bench: unknown layout '%s'\n", l.c_str());
      usage(2);
    }
  for (int n : o.ns)
    if (n < 1) {
      std::fprintf(stderr, "ibvs-bench: --n must be >= 1\n");
      usage(2);
    }
  if (o.iterations < 1 || o.episodes < 1 || !(o.damping > 0.0) || !(o.gain > 0.0) || !(o.duration > 0.0) || o.spin_us < 0.0) {
    std::fprintf(stderr, "ibvs-bench: need iterations >= 1, episodes >= 1, damping > 0, gain > 0, duration > 0, spin >= 0\n");
    usage(2);
  }
  for (double r : o.rates)
    if (!(r > 0.0)) {
      std::fprintf(stderr, "ibvs-bench: --paced rates must be > 0\n");
      usage(2);
    }
  if (o.warmup < 0) o.warmup = std::max(1000L, o.iterations / 10);
  if (o.sections.empty()) {
    if (o.rates_given && !o.layouts_given && !o.ns_given) o.sections = {"paced"};
    else o.sections = {"components", "tasks", "growth", "paced", "episode", "robot", "camera"};
  }
  for (const auto& s : o.sections)
    if (s != "components" && s != "tasks" && s != "growth" && s != "paced" && s != "episode" && s != "robot" && s != "camera" &&
        s != "photometric") {
      std::fprintf(stderr, "ibvs-bench: unknown section '%s'\n", s.c_str());
      usage(2);
    }
  return o;
}

bool has(const std::vector<std::string>& v, const char* s) { return std::find(v.begin(), v.end(), s) != v.end(); }

// ----------------------------------------------------------------- inputs --
Layout make_layout(const std::string& kind, int n) {
  if (kind == "cartesian") return Layout::cartesian(n);
  if (kind == "polar") return Layout::polar(n);
  if (kind == "stacked") return Layout::stacked(n);
  std::vector<ibvs::Block> blocks;
  for (int i = 0; i < n; ++i)
    blocks.push_back({i, i % 2 ? ibvs::Representation::polar : ibvs::Representation::cartesian});
  return Layout(std::move(blocks), n);
}

Kind kind_of(const std::string& s) {
  return s == "cartesian" ? Kind::cartesian : s == "polar" ? Kind::polar : s == "stacked" ? Kind::stacked : Kind::hybrid;
}

/// A ring of frames: desired points on a circle of radius 0.2 (normalised
/// coordinates), current ones rotated, scaled and shifted by a random amount
/// per frame, depths in [0.7, 1.3] m. No point comes near the principal point.
struct Frames {
  static constexpr int count = 64;
  std::vector<Points> uv, uvd;
  std::vector<Eigen::VectorXd> z, zd;

  explicit Frames(int n, unsigned seed = 7) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    for (int k = 0; k < count; ++k) {
      Points d(2, n), c(2, n);
      Eigen::VectorXd depth(n), depth_d(n);
      const double rot = 0.6 * U(rng), scale = 1.0 + 0.2 * U(rng), tx = 0.03 * U(rng), ty = 0.03 * U(rng);
      for (int i = 0; i < n; ++i) {
        const double a = 2.0 * ibvs::pi * (i + 0.5) / n;
        d(0, i) = 0.2 * std::cos(a);
        d(1, i) = 0.2 * std::sin(a);
        c(0, i) = scale * 0.2 * std::cos(a + rot) + tx + 0.005 * U(rng);
        c(1, i) = scale * 0.2 * std::sin(a + rot) + ty + 0.005 * U(rng);
        depth(i) = 1.0 + 0.3 * U(rng);
        depth_d(i) = 1.0;
      }
      uv.push_back(c);
      uvd.push_back(d);
      z.push_back(depth);
      zd.push_back(depth_d);
    }
  }
};

// ------------------------------------------------------------------ stats --
struct Result {
  std::string section, name, layout, route;
  int n = 0, rows = 0;
  double damping = 0.0;
  int diagnostics = -1;  // -1: not applicable
  long iterations = 0;
  double median_us = 0, p99_us = 0, max_us = 0, mean_us = 0, steps_per_s = 0;
  double allocs_per_call = 0;
  int robust_frames = -1;  // Servo::update rows: frames (of Frames::count) solved by the robust route
};

double percentile(std::vector<double>& sorted, double p) {
  if (sorted.empty()) return 0.0;
  const double idx = p * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(idx));
  const auto hi = std::min(sorted.size() - 1, lo + 1);
  return sorted[lo] + (idx - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

double g_timer_ns = 0.0;  // median cost of an empty timed region

double measure_timer_overhead() {
  std::vector<double> s(200000);
  for (auto& x : s) {
    const auto a = Clock::now();
    keep(a);
    const auto b = Clock::now();
    x = ns_between(a, b);
  }
  std::sort(s.begin(), s.end());
  return percentile(s, 0.5);
}

/// Times f(i) for i = 0..iterations-1: warm-up, batched mean, per-call stats.
template <class F>
void time_case(Result& r, const Options& o, F&& f) {
  for (long i = 0; i < o.warmup; ++i) f(i);
  const long a0 = g_allocations.load();
  const auto t0 = Clock::now();
  for (long i = 0; i < o.iterations; ++i) f(i);
  const auto t1 = Clock::now();
  const long a1 = g_allocations.load();
  std::vector<double> s(static_cast<std::size_t>(o.iterations));
  for (long i = 0; i < o.iterations; ++i) {
    const auto a = Clock::now();
    f(i);
    const auto b = Clock::now();
    s[static_cast<std::size_t>(i)] = std::max(0.0, ns_between(a, b) - g_timer_ns);
  }
  std::sort(s.begin(), s.end());
  r.iterations = o.iterations;
  r.mean_us = ns_between(t0, t1) / static_cast<double>(o.iterations) * 1e-3;
  r.steps_per_s = r.mean_us > 0 ? 1e6 / r.mean_us : 0.0;
  r.median_us = percentile(s, 0.5) * 1e-3;
  r.p99_us = percentile(s, 0.99) * 1e-3;
  r.max_us = s.back() * 1e-3;
  r.allocs_per_call = static_cast<double>(a1 - a0) / static_cast<double>(o.iterations);
}

// -------------------------------------------------------------- the cases --
std::vector<Result> g_results;

ibvs::ServoOptions servo_options(double gain, double damping, bool diagnostics) {
  ibvs::ServoOptions so;
  so.gain = gain;
  so.damping = damping;
  so.diagnostics = diagnostics;
  return so;
}

Result& add(const char* section, const char* name, const std::string& layout, int n, int rows, const char* route,
            double damping, int diagnostics) {
  Result r;
  r.section = section;
  r.name = name;
  r.layout = layout;
  r.n = n;
  r.rows = rows;
  r.route = route;
  r.damping = damping;
  r.diagnostics = diagnostics;
  g_results.push_back(r);
  return g_results.back();
}

void print_row(std::FILE* f, const Result& r);

/// How many of the frames Servo::update solves by the robust route (QR + SVD) rather than the normal equations.
template <int Rows>
int count_robust(const Layout& layout, double damping, const Frames& fr) {
  const int m = layout.rows();
  ibvs_bench::SolveKernel<Rows> w(m);
  int robust = 0;
  for (int k = 0; k < Frames::count; ++k) {
    w.J.topRows(m) = ibvs::jacobian(layout, fr.uv[k], fr.z[k]);
    robust += w.route(damping) == ibvs::detail::Route::robust;
  }
  return robust;
}

void bench_update(const char* section, const char* name, const std::string& kind, int n, double damping,
                  bool diagnostics, const Options& o, const Frames& fr, bool exact = false, bool read_sigma = false,
                  ibvs::AngleWrap wrap = ibvs::AngleWrap::consistent) {
  const Layout layout = make_layout(kind, n);
  ibvs::ServoOptions so = servo_options(o.gain, damping, diagnostics);
  so.exact_diagnostics = exact;
  so.angle_wrap = wrap;
  ibvs::Servo servo(layout, so);
  ibvs::ServoOutput out(layout);
  Result& r = add(section, name, kind, n, layout.rows(), "auto", damping, diagnostics);
  r.robust_frames = layout.rows() == 8    ? count_robust<8>(layout, damping, fr)
                    : layout.rows() == 16 ? count_robust<16>(layout, damping, fr)
                                          : count_robust<Eigen::Dynamic>(layout, damping, fr);
  time_case(r, o, [&](long i) {
    const int k = static_cast<int>(i & (Frames::count - 1));
    servo.update(fr.uv[k], fr.z[k], fr.uvd[k], fr.zd[k], out);
    keep(out.velocity);
    if (read_sigma) keep(out.sigma_min());
  });
}

/// The default update with the smooth law (decay 4/s, acceleration limits) and, with `lost`,
/// one point of the layout marked lost every frame (ServoInput::valid, the masked step).
void bench_smooth(const std::string& kind, int n, const Options& o, const Frames& fr, bool lost) {
  const Layout layout = make_layout(kind, n);
  ibvs::ServoOptions so = servo_options(o.gain, 0.0, true);
  so.smoothing.decay_rate = 4.0;
  so.smoothing.max_linear_acceleration = 1.0;
  so.smoothing.max_angular_acceleration = 2.0;
  so.smoothing.period = 1e-3;
  ibvs::Servo servo(layout, so);
  ibvs::ServoOutput out(layout);
  ibvs::PointMask valid = ibvs::PointMask::Constant(n, true);
  if (lost) valid(n - 1) = false;
  const Eigen::VectorXd none;
  Result& r = add("components", lost ? "Servo::update smooth, 1 point lost" : "Servo::update smooth (mu, accel.)",
                  kind, n, layout.rows(), "auto", 0.0, true);
  time_case(r, o, [&](long i) {
    const int k = static_cast<int>(i & (Frames::count - 1));
    servo.update(fr.uv[k], fr.z[k], fr.uvd[k], fr.zd[k], none, none, valid, out);
    keep(out.velocity);
  });
}

template <int Rows>
void bench_solve(const std::string& kind, int n, const Options& o, const Frames& fr) {
  const Layout layout = make_layout(kind, n);
  const int m = layout.rows();
  // J and e of every frame, computed once by the library.
  std::vector<ibvs::MatrixX6> Js;
  std::vector<Eigen::VectorXd> es;
  for (int k = 0; k < Frames::count; ++k) {
    Js.push_back(ibvs::jacobian(layout, fr.uv[k], fr.z[k]));
    es.push_back(ibvs::feature_error(layout, ibvs::features(layout, fr.uv[k]), ibvs::features(layout, fr.uvd[k])));
  }
  ibvs_bench::SolveKernel<Rows> w(m);
  auto load = [&](long i) {
    const int k = static_cast<int>(i & (Frames::count - 1));
    w.J.topRows(m) = Js[k];
    w.e.head(m) = es[k];
  };
  {
    Result& r = add("components", "solve: normal route, damped", kind, n, m, "normal", o.damping, 0);
    time_case(r, o, [&](long i) {
      load(i);
      keep(w.normal(o.damping));
    });
  }
  {
    Result& r = add("components", "solve: normal route, undamped", kind, n, m, "normal", 0.0, 0);
    time_case(r, o, [&](long i) {
      load(i);
      keep(w.normal(0.0));
    });
  }
  {
    Result& r = add("components", "sigma_min/max on read: eig(J^T J)", kind, n, m, "eig6", 0.0, 1);
    time_case(r, o, [&](long i) {
      load(i);
      keep(w.eigenvalues());
    });
  }
  {
    Result& r = add("components", "diagnostics: exact (QR + SVD of R)", kind, n, m, "exact", 0.0, 1);
    time_case(r, o, [&](long i) {
      load(i);
      keep(w.exact());
    });
  }
  {
    Result& r = add("components", "solve: robust route (QR + SVD of R)", kind, n, m, "robust", 0.0, 1);
    time_case(r, o, [&](long i) {
      load(i);
      keep(w.robust(0.0));
    });
  }
  {
    Result& r = add("components", "damped_pinv() API, allocating", kind, n, m, "JacobiSVD", o.damping, -1);
    time_case(r, o, [&](long i) {
      const int k = static_cast<int>(i & (Frames::count - 1));
      const Eigen::Matrix<double, 6, Eigen::Dynamic> P = ibvs::damped_pinv(Js[k], o.damping);
      const Twist x = -o.gain * (P * es[k]);
      keep(x);
    });
  }
}

template <int NP, Kind K>
void bench_floor(const std::string& kind, const Options& o, const Frames& fr) {
  using F = ibvs_bench::Floor<NP, K>;
  std::vector<typename F::Pts> uv, uvd;
  std::vector<Eigen::Matrix<double, NP, 1>> z;
  for (int k = 0; k < Frames::count; ++k) {
    uv.emplace_back(fr.uv[k]);
    uvd.emplace_back(fr.uvd[k]);
    z.emplace_back(fr.z[k]);
  }
  {
    Result& r = add("components", "Eigen floor: fixed-size LLT step", kind, NP, F::M, "LLT", o.damping, 0);
    time_case(r, o, [&](long i) {
      const int k = static_cast<int>(i & (Frames::count - 1));
      keep(F::step_llt(uv[k], z[k], uvd[k], o.damping, o.gain));
    });
  }
  {
    Result& r = add("components", "SVD step: J, damped_pinv() (ViSP-like)", kind, NP, F::M, "JacobiSVD", o.damping, 0);
    time_case(r, o, [&](long i) {
      const int k = static_cast<int>(i & (Frames::count - 1));
      keep(F::step_svd(uv[k], z[k], uvd[k], o.damping, o.gain));
    });
  }
}

void check_floor_agrees(const std::string& kind, const Options& o, const Frames& fr);

/// JointMapping::update (robot_mapping.hpp): camera twist -> joint velocities
/// for n joints, over 64 random end-effector Jacobians and twists (speed limits
/// on), undamped and damped. Random Jacobians are well conditioned: the normal
/// route (Cholesky of Jc Jc^T). near_singular: two rows of J nearly equal
/// (1e-7 apart, cond(Jc) ~ 1e7: a direction the arm can hardly move in), so that every frame
/// takes the SVD route, the cost of the route before the normal one existed.
void bench_robot(int n, double damping, const Options& o, bool near_singular = false) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<ibvs::JointMappingInput> in(Frames::count, ibvs::JointMappingInput(n));
  for (auto& x : in) {
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < 6; ++i) x.jacobian(i, j) = g(rng);
    for (int i = 0; i < 6; ++i) x.twist(i) = 0.1 * g(rng);
    if (near_singular)
      for (int j = 0; j < n; ++j) x.jacobian(5, j) = x.jacobian(4, j) + 1e-7 * g(rng);
  }
  ibvs::Pose eMc = ibvs::Pose::Identity();
  eMc.topRightCorner<3, 1>() << 0.05, -0.03, 0.04;
  ibvs::JointMappingOptions jo;
  jo.damping = damping;
  jo.max_joint_speed = ibvs::JointVector::Constant(n, 2.0);
  ibvs::JointMapping map(n, eMc, jo);
  ibvs::JointMappingOutput out(n);
  const std::string name = std::string(damping > 0 ? "JointMapping::update damped" : "JointMapping::update") +
                           (near_singular ? ", near-singular (SVD)" : "");
  Result& r = add("robot", name.c_str(), "joints", n, 6, near_singular ? "SVD" : "normal", damping, -1);
  time_case(r, o, [&](long i) {
    map.update(in[static_cast<std::size_t>(i & (Frames::count - 1))], out);
    keep(out.qdot(0));
  });
}

/// The eye-to-hand JointMapping (robot_mapping.hpp eq. 5: the end effector's pose each frame) and
/// SecondaryTask::update (secondary_task.hpp: large projector, joint-limit avoidance with about half the
/// joints in their zones, a task- and a joint-space motion, speed and acceleration caps) over the same
/// kind of random frames as bench_robot.
void bench_robot_extras(int n, const Options& o) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<ibvs::JointMappingInput> in(Frames::count, ibvs::JointMappingInput(n));
  std::vector<ibvs::SecondaryTaskInput> sin(Frames::count, ibvs::SecondaryTaskInput(n));
  for (std::size_t k = 0; k < in.size(); ++k) {
    auto& x = in[k];
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < 6; ++i) x.jacobian(i, j) = g(rng);
    for (int i = 0; i < 6; ++i) x.twist(i) = 0.1 * g(rng);
    x.base_pose.topLeftCorner<3, 3>() = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    x.base_pose.topRightCorner<3, 1>() << g(rng), g(rng), g(rng);
    auto& y = sin[k];
    Eigen::Matrix<double, 8, 6> L;
    Eigen::Matrix<double, 8, 1> e;
    for (int i = 0; i < 8; ++i) {
      e(i) = 0.3 * g(rng);
      for (int j = 0; j < 6; ++j) L(i, j) = g(rng);
    }
    y.task_gram = L.transpose() * L;
    y.task_gradient = L.transpose() * e;
    y.error_norm = e.norm();
    for (int j = 0; j < n; ++j) {
      y.q(j) = u(rng);
      y.joints(j) = 0.1 * g(rng);
      y.qdot_previous(j) = 0.1 * g(rng);
    }
    for (int i = 0; i < 6; ++i) y.twist(i) = 0.05 * g(rng);
  }
  ibvs::Pose bMc = ibvs::Pose::Identity();
  bMc.topRightCorner<3, 1>() << 0.5, -0.2, 1.0;
  ibvs::JointMappingOptions jo;
  jo.mounting = ibvs::Mounting::eye_to_hand;
  ibvs::JointMapping map(n, bMc, jo);
  ibvs::JointMappingOutput out(n);
  {
    Result& r = add("robot", "JointMapping::update eye_to_hand", "joints", n, 6, "normal", 0.0, -1);
    time_case(r, o, [&](long i) {
      map.update(in[static_cast<std::size_t>(i & (Frames::count - 1))], out);
      keep(out.qdot(0));
    });
  }
  for (std::size_t k = 0; k < in.size(); ++k) {  // each frame's primary: the mapping's Jc and qdot
    map.update(in[k], out);
    sin[k].camera_jacobian = out.camera_jacobian;
    sin[k].qdot = out.qdot;
  }
  ibvs::SecondaryTaskOptions so;
  so.projector = ibvs::Projector::large;
  so.q_min = ibvs::JointVector::Constant(n, -1.0);
  so.q_max = ibvs::JointVector::Constant(n, 1.0);
  so.max_joint_speed = ibvs::JointVector::Constant(n, 2.0);
  so.max_joint_acceleration = ibvs::JointVector::Constant(n, 10.0);
  so.period = 0.01;
  ibvs::SecondaryTask task(n, so);
  ibvs::SecondaryTaskOutput sout(n);
  Result& r = add("robot", "SecondaryTask::update large + limits + caps", "joints", n, 6, "SVD", 0.0, -1);
  time_case(r, o, [&](long i) {
    task.update(sin[static_cast<std::size_t>(i & (Frames::count - 1))], sout);
    keep(sout.qdot(0));
  });
}

void bench_components(const std::string& kind, int n, const Options& o) {
  const Frames fr(n);
  const Layout layout = make_layout(kind, n);
  const int m = layout.rows();
  ibvs::MatrixX6 J = ibvs::MatrixX6::Zero(m, 6);
  Eigen::VectorXd f(m), fd(m), e(m);
  {
    Result& r = add("components", "jacobian (stacked_jacobian)", kind, n, m, "-", 0.0, -1);
    time_case(r, o, [&](long i) {
      const int k = static_cast<int>(i & (Frames::count - 1));
      ibvs::stacked_jacobian(layout, fr.uv[k], fr.z[k], J);
      keep(J(0, 0));
    });
  }
  {
    Result& r = add("components", "error (features + wrapped error)", kind, n, m, "-", 0.0, -1);
    time_case(r, o, [&](long i) {
      const int k = static_cast<int>(i & (Frames::count - 1));
      ibvs::stacked_features(layout, fr.uv[k], f);
      ibvs::stacked_features(layout, fr.uvd[k], fd);
      ibvs::stacked_error(layout, f, fd, e);
      keep(e(0));
    });
  }
  if (m == 8) bench_solve<8>(kind, n, o, fr);
  else if (m == 16) bench_solve<16>(kind, n, o, fr);
  else bench_solve<Eigen::Dynamic>(kind, n, o, fr);
  bench_update("components", "Servo::update default (damping 0, diag.)", kind, n, 0.0, true, o, fr);
  {  // the goal's values are cached while uv_desired is unchanged: the cost without that cache
    Frames moved = fr;
    for (int k = 0; k < Frames::count; ++k) moved.uvd[static_cast<std::size_t>(k)] *= 1.0 + 1e-3 * (k + 1);
    bench_update("components", "Servo::update default, goal moved every frame", kind, n, 0.0, true, o, moved);
  }
  bench_update("components", "Servo::update default, sigma_min() read", kind, n, 0.0, true, o, fr, false, true);
  bench_update("components", "Servo::update tuned (damped, no diag.)", kind, n, o.damping, false, o, fr);
  if (kind != "cartesian")  // the default consistent angle wrap against eq. (13) point by point
    bench_update("components", "Servo::update tuned, per-point wrap", kind, n, o.damping, false, o, fr, false, false,
                 ibvs::AngleWrap::per_point);
  bench_update("components", "Servo::update damped + diagnostics", kind, n, o.damping, true, o, fr);
  bench_update("components", "Servo::update default, exact diagnostics", kind, n, 0.0, true, o, fr, true);
  bench_smooth(kind, n, o, fr, false);
  if (n >= 4) bench_smooth(kind, n, o, fr, true);
  if (n == 4) {
    check_floor_agrees(kind, o, fr);
    switch (kind_of(kind)) {
      case Kind::cartesian: bench_floor<4, Kind::cartesian>(kind, o, fr); break;
      case Kind::polar: bench_floor<4, Kind::polar>(kind, o, fr); break;
      case Kind::stacked: bench_floor<4, Kind::stacked>(kind, o, fr); break;
      case Kind::hybrid: bench_floor<4, Kind::hybrid>(kind, o, fr); break;
    }
  }
}

/// The floor must compute the same twist as Servo::update, or it is no floor.
template <Kind K>
double floor_difference(const std::string& kind, const Options& o, const Frames& fr) {
  using F = ibvs_bench::Floor<4, K>;
  const Layout layout = make_layout(kind, 4);
  ibvs::Servo servo(layout, servo_options(o.gain, o.damping, false));
  ibvs::ServoOutput out(layout);
  double worst = 0.0;
  for (int k = 0; k < Frames::count; ++k) {
    servo.update(fr.uv[k], fr.z[k], fr.uvd[k], fr.zd[k], out);
    const Twist a = F::step_llt(fr.uv[k], fr.z[k], fr.uvd[k], o.damping, o.gain);
    const Twist b = F::step_svd(fr.uv[k], fr.z[k], fr.uvd[k], o.damping, o.gain);
    worst = std::max({worst, (a - out.velocity).norm() / out.velocity.norm(),
                      (b - out.velocity).norm() / out.velocity.norm()});
  }
  return worst;
}

void check_floor_agrees(const std::string& kind, const Options& o, const Frames& fr) {
  double d = 0.0;
  switch (kind_of(kind)) {
    case Kind::cartesian: d = floor_difference<Kind::cartesian>(kind, o, fr); break;
    case Kind::polar: d = floor_difference<Kind::polar>(kind, o, fr); break;
    case Kind::stacked: d = floor_difference<Kind::stacked>(kind, o, fr); break;
    case Kind::hybrid: d = floor_difference<Kind::hybrid>(kind, o, fr); break;
  }
  if (!(d < 1e-9)) {
    std::fprintf(stderr, "ibvs-bench: the floor kernel disagrees with Servo::update for %s(4): %g\n", kind.c_str(), d);
    std::exit(1);
  }
}

// ---------------------------------------------------------------- tasks ---
/// Frames of the task benchmarks: an irregular planar quadrilateral (no symmetry, so alpha from
/// the third-order moments is defined) seen from 64 random camera poses around the goal pose (the
/// object 0.6 m in front, facing the camera): theta u up to ~0.5 rad, offsets of 5 cm, depths
/// 0.45..0.75 m. Each kind's measurements (current, goal) and, for the mixed task, the corners'
/// image points and depths.
struct TaskFrames {
  std::vector<Eigen::VectorXd> moments, moments_d, pbvs, pbvs_d, pbvs_object, pbvs_object_d, p25, p25_d;
  std::vector<Points> uv, uvd;
  std::vector<Eigen::VectorXd> z, zd;

  TaskFrames() {
    Eigen::Matrix<double, 3, 4> P;  // the object, in its own frame (plane z = 0)
    P << -0.07, 0.08, 0.05, -0.05, -0.05, -0.04, 0.06, 0.04, 0.0, 0.0, 0.0, 0.0;
    const Eigen::Vector3d reference(0.08, -0.04, 0.0);  // the 2.5-D reference point (a corner)
    ibvs::Pose cdMo = ibvs::Pose::Identity();
    cdMo(2, 3) = 0.6;
    const auto camera_points = [&](const ibvs::Pose& T) {
      Eigen::Matrix3Xd Q = (T.topLeftCorner<3, 3>() * P).colwise() + T.topRightCorner<3, 1>();
      return Q;
    };
    using MF = ibvs::MomentsFeature;
    const auto vec = [](const auto& a) { return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(a.data(), a.size())); };
    const Eigen::Matrix3Xd Qd = camera_points(cdMo);
    const auto goal = MF::project(Qd, MF::Source::region, 0.0, 0.6);
    const double ad = MF::area(goal.data(), MF::Source::region);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    for (int k = 0; k < Frames::count; ++k) {
      ibvs::Twist xi;
      xi << 0.0, 0.0, 0.0, 0.25 * U(rng), 0.25 * U(rng), 0.5 * U(rng);
      ibvs::Pose cMo = ibvs::se3_exp(xi);
      cMo.topRightCorner<3, 1>() << 0.05 * U(rng), 0.05 * U(rng), 0.6 + 0.15 * U(rng);
      const Eigen::Matrix3Xd Q = camera_points(cMo);
      moments.push_back(vec(MF::project(Q, MF::Source::region, ad, 0.6)));
      moments_d.push_back(vec(goal));
      pbvs.push_back(vec(ibvs::PbvsFeature::measure(cMo, cdMo, ibvs::PbvsTarget::desired_camera)));
      pbvs_d.push_back(vec(ibvs::PbvsFeature::measure(cdMo, cdMo, ibvs::PbvsTarget::desired_camera)));
      pbvs_object.push_back(vec(ibvs::PbvsFeature::measure(cMo, cdMo, ibvs::PbvsTarget::object)));
      pbvs_object_d.push_back(vec(ibvs::PbvsFeature::measure(cdMo, cdMo, ibvs::PbvsTarget::object)));
      p25.push_back(vec(ibvs::Point25DFeature::measure(cMo, cdMo, reference)));
      p25_d.push_back(vec(ibvs::Point25DFeature::measure(cdMo, cdMo, reference)));
      uv.push_back(Q.topRows<2>().array().rowwise() / Q.row(2).array());
      uvd.push_back(Qd.topRows<2>().array().rowwise() / Qd.row(2).array());
      z.push_back(Q.row(2).transpose());
      zd.push_back(Qd.row(2).transpose());
    }
  }
};

/// One task of the benchmark: its Task, the frames' measurements, and its floor.
struct TaskCase {
  const char* name;  // the layout column
  ibvs::Task task;
  const std::vector<Eigen::VectorXd>* m;
  const std::vector<Eigen::VectorXd>* md;
  std::function<Twist(int k, double lambda, double gain)> floor;
};

/// Servo::update of a task over the frames (default: damping 0 and diagnostics; tuned: damped,
/// diagnostics off), the frames its solve takes the robust route, and the floor beside it.
void bench_task(const TaskCase& c, const TaskFrames& tf, const Options& o) {
  const ibvs::Task& task = c.task;
  const int n = task.n_points(), m = task.rows();
  const Eigen::VectorXd none;
  const auto meas = [&](int k) -> const Eigen::VectorXd& { return c.m ? (*c.m)[static_cast<std::size_t>(k)] : none; };
  const auto meas_d = [&](int k) -> const Eigen::VectorXd& { return c.md ? (*c.md)[static_cast<std::size_t>(k)] : none; };
  const Points no_points(2, 0);
  const Eigen::VectorXd no_depth(0);
  const auto uv = [&](int k) -> const Points& { return n ? tf.uv[static_cast<std::size_t>(k)] : no_points; };
  const auto uvd = [&](int k) -> const Points& { return n ? tf.uvd[static_cast<std::size_t>(k)] : no_points; };
  const auto z = [&](int k) -> const Eigen::VectorXd& { return n ? tf.z[static_cast<std::size_t>(k)] : no_depth; };
  const auto zd = [&](int k) -> const Eigen::VectorXd& { return n ? tf.zd[static_cast<std::size_t>(k)] : no_depth; };
  // The floor must give Servo::update's twist (tuned: the same damped normal equations), or it is no floor.
  {
    ibvs::Servo servo(task, servo_options(o.gain, o.damping, false));
    ibvs::ServoOutput out(task);
    double worst = 0.0;
    for (int k = 0; k < Frames::count; ++k) {
      servo.validate(uv(k), z(k), uvd(k), zd(k), meas(k), meas_d(k));  // throws: a frame the task refuses
      servo.update(uv(k), z(k), uvd(k), zd(k), meas(k), meas_d(k), out);
      const Twist f = c.floor(k, o.damping, o.gain);
      worst = std::max(worst, (f - out.velocity).norm() / out.velocity.norm());
    }
    if (!(worst < 1e-9)) {
      std::fprintf(stderr, "ibvs-bench: the floor kernel disagrees with Servo::update for the %s task: %g\n", c.name,
                   worst);
      std::exit(1);
    }
  }
  for (int tuned = 0; tuned < 2; ++tuned) {
    const double damping = tuned ? o.damping : 0.0;
    ibvs::Servo servo(task, servo_options(o.gain, damping, !tuned));
    ibvs::ServoOutput out(task);
    Result& r = add("tasks", tuned ? "Servo::update tuned (damped, no diag.)" : "Servo::update default (damping 0, diag.)",
                    c.name, n, m, "auto", damping, !tuned);
    ibvs_bench::SolveKernel<Eigen::Dynamic> w(m);
    r.robust_frames = 0;
    for (int k = 0; k < Frames::count; ++k) {
      servo.update(uv(k), z(k), uvd(k), zd(k), meas(k), meas_d(k), out);
      w.J.topRows(m) = out.jacobian;
      r.robust_frames += w.route(damping) == ibvs::detail::Route::robust;
    }
    time_case(r, o, [&](long i) {
      const int k = static_cast<int>(i & (Frames::count - 1));
      servo.update(uv(k), z(k), uvd(k), zd(k), meas(k), meas_d(k), out);
      keep(out.velocity);
    });
  }
  Result& r = add("tasks", "Eigen floor: fixed-size LLT step", c.name, n, m, "LLT", o.damping, 0);
  time_case(r, o, [&](long i) { keep(c.floor(static_cast<int>(i & (Frames::count - 1)), o.damping, o.gain)); });
}

void print_floor_ratio(std::FILE* f, const char* section, const std::string& layout, const std::string& label);

/// The tasks of issue 21 beside their floors: image moments (Tahri & Chaumette's six features of
/// a region), PBVS (both variants; the floor for camera to desired camera), 2.5-D, and the mixed
/// task stacked(4) + moments.
void bench_tasks(const Options& o, std::FILE* table) {
  namespace T = ibvs_bench::tasks;
  const TaskFrames tf;
  std::vector<Eigen::Matrix<double, 2, 4>> uv, uvd;
  std::vector<Eigen::Matrix<double, 4, 1>> z;
  for (int k = 0; k < Frames::count; ++k) {
    uv.emplace_back(tf.uv[static_cast<std::size_t>(k)]);
    uvd.emplace_back(tf.uvd[static_cast<std::size_t>(k)]);
    z.emplace_back(tf.z[static_cast<std::size_t>(k)]);
  }
  const auto at = [](const std::vector<Eigen::VectorXd>& v, int k) { return v[static_cast<std::size_t>(k)].data(); };
  ibvs::Task moments, pbvs, pbvs_object, p25;
  moments.add(ibvs::MomentsFeature());
  pbvs.add(ibvs::PbvsFeature(ibvs::PbvsTarget::desired_camera));
  pbvs_object.add(ibvs::PbvsFeature(ibvs::PbvsTarget::object));
  p25.add(ibvs::Point25DFeature());
  ibvs::Task mixed(Layout::stacked(4));
  mixed.add(ibvs::MomentsFeature());
  const TaskCase cases[] = {
      {"moments", moments, &tf.moments, &tf.moments_d,
       [&](int k, double l, double g) { return T::moments_step(at(tf.moments, k), at(tf.moments_d, k), l, g); }},
      {"pbvs", pbvs, &tf.pbvs, &tf.pbvs_d,
       [&](int k, double l, double g) { return T::pbvs_step(at(tf.pbvs, k), at(tf.pbvs_d, k), l, g); }},
      {"pbvs(object)", pbvs_object, &tf.pbvs_object, &tf.pbvs_object_d,
       [&](int k, double l, double g) {
         return T::pbvs_object_step(at(tf.pbvs_object, k), at(tf.pbvs_object_d, k), l, g);
       }},
      {"2.5-D", p25, &tf.p25, &tf.p25_d,
       [&](int k, double l, double g) { return T::point25d_step(at(tf.p25, k), at(tf.p25_d, k), l, g); }},
      {"stacked+moments", mixed, &tf.moments, &tf.moments_d,
       [&](int k, double l, double g) {
         const auto s = static_cast<std::size_t>(k);
         return T::mixed_step(uv[s], z[s], uvd[s], at(tf.moments, k), at(tf.moments_d, k), l, g);
       }},
  };
  for (const TaskCase& c : cases) {
    const std::size_t first = g_results.size();
    bench_task(c, tf, o);
    for (std::size_t i = first; i < g_results.size(); ++i) print_row(table, g_results[i]);
    print_floor_ratio(table, "tasks", c.name, c.name);
    std::fflush(table);
  }
}

// ---------------------------------------------------------------- paced ---
struct Paced {
  double rate_hz = 0, duration_s = 0, spin_us = 0;
  std::string layout;
  int n = 0;
  bool diagnostics = true;
  bool realtime = false;
  long steps = 0, misses = 0;
  double late_median_us = 0, late_p99_us = 0, late_max_us = 0;
  double step_median_us = 0, step_p99_us = 0, step_max_us = 0;
};
std::vector<Paced> g_paced;

#if defined(__linux__)
timespec to_timespec(std::int64_t ns) {
  timespec ts;
  ts.tv_sec = static_cast<time_t>(ns / 1000000000);
  ts.tv_nsec = static_cast<long>(ns % 1000000000);
  return ts;
}
std::int64_t mono_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}
void sleep_until_ns(std::int64_t t) {
  const timespec ts = to_timespec(t);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}
#else
std::int64_t mono_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}
void sleep_until_ns(std::int64_t t) {
  std::this_thread::sleep_until(Clock::time_point(std::chrono::nanoseconds(t)));
}
#endif

/// A control loop released at absolute deadlines t0 + k T (no drift):
/// lateness = wake-up time - release time; a deadline miss = a step that ends
/// after the next release (then the loop skips to the next future release,
/// counting every skipped period as a miss too).
void bench_paced(double rate, const Options& o, bool realtime) {
  const std::string kind = "stacked";
  const int n = 4;
  const Frames fr(n);
  const Layout layout = make_layout(kind, n);
  ibvs::Servo servo(layout, servo_options(o.gain, o.damping, true));
  ibvs::ServoOutput out(layout);
  const auto period = static_cast<std::int64_t>(std::llround(1e9 / rate));
  const auto spin = static_cast<std::int64_t>(o.spin_us * 1e3);
  const long planned = std::max(1L, static_cast<long>(std::llround(o.duration * rate)));
  std::vector<double> late, step;
  late.reserve(static_cast<std::size_t>(planned));
  step.reserve(static_cast<std::size_t>(planned));
  Paced p;
  p.rate_hz = rate;
  p.duration_s = o.duration;
  p.spin_us = o.spin_us;
  p.layout = kind;
  p.n = n;
  p.realtime = realtime;
  std::int64_t release = mono_ns() + period;
  long k = 0;
  for (long s = 0; s < planned; ++s) {
    if (spin > 0) {
      sleep_until_ns(release - spin);
      while (mono_ns() < release) {
      }
    } else {
      sleep_until_ns(release);
    }
    const std::int64_t woke = mono_ns();
    const int f = static_cast<int>(k++ & (Frames::count - 1));
    servo.update(fr.uv[f], fr.z[f], fr.uvd[f], fr.zd[f], out);
    keep(out.velocity);
    const std::int64_t done = mono_ns();
    late.push_back(static_cast<double>(woke - release) * 1e-3);
    step.push_back(static_cast<double>(done - woke) * 1e-3);
    std::int64_t next = release + period;
    if (done > next) {
      ++p.misses;
      const std::int64_t skipped = (done - next) / period;  // releases already past as well
      p.misses += skipped;
      s += skipped;
      next += (skipped + 1) * period;
    }
    release = next;
  }
  p.steps = static_cast<long>(step.size());
  std::sort(late.begin(), late.end());
  std::sort(step.begin(), step.end());
  p.late_median_us = percentile(late, 0.5);
  p.late_p99_us = percentile(late, 0.99);
  p.late_max_us = late.back();
  p.step_median_us = percentile(step, 0.5);
  p.step_p99_us = percentile(step, 0.99);
  p.step_max_us = step.back();
  g_paced.push_back(p);
}

bool try_realtime() {
#if defined(__linux__)
  sched_param sp{};
  sp.sched_priority = 80;
  const bool fifo = sched_setscheduler(0, SCHED_FIFO, &sp) == 0;
  if (!fifo) std::fprintf(stderr, "ibvs-bench: SCHED_FIFO refused (%s); running at normal priority\n", std::strerror(errno));
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
    std::fprintf(stderr, "ibvs-bench: mlockall refused (%s)\n", std::strerror(errno));
  return fifo;
#else
  return false;
#endif
}

// -------------------------------------------------------------- episode ---
struct EpisodeCase {
  std::string name, layout, outcome;
  int n = 0, frames = 0;
  double damping = 0, noise = 0;
  int latency = 0;
  std::string depth;
  long episodes = 0;
  double median_ms = 0, p99_ms = 0, max_ms = 0, mean_ms = 0, episodes_per_s = 0, us_per_frame = 0;
  double allocs_per_episode = 0;
};
std::vector<EpisodeCase> g_episodes;

/// A whole closed-loop episode in C++ (ibvs::sim::Episode::run): Afma6 camera
/// (640x480, radial distortion both ways, 60 fps) on the Afma6-like gantry,
/// stacked(4) servo, tolerance 0 so that all 600 frames (10 s) run. The set-up
/// is the simulator's gantry "general motion" case (tests/cpp/sim_cases.hpp).
void bench_episode(const char* name, double damping, double noise, int latency, ibvs::sim::DepthMode depth,
                   const Options& o) {
  using namespace ibvs::sim;
  const Gantry g = Gantry::afma6();
  const Joints q_goal = (Joints() << 0, 0, 0, 0, 0.4, 0).finished();
  const Joints q_start = (Joints() << 0.18835158467582477, 0.13029503186413266, -0.08642184066403318,
                          0.8211754709024601, 0.24154253183929314, -0.4579106120861423)
                             .finished();
  ibvs::Pose in_front = ibvs::Pose::Identity();
  in_front(2, 3) = 0.6;
  const Target target = Target::square(0.1, g.camera(q_goal) * in_front);
  EpisodeOptions eo;
  eo.duration = 10.0;
  eo.tolerance = 0.0;
  eo.noise = noise;
  eo.latency = latency;
  eo.depth = depth;
  eo.seed = 1;
  ibvs::ServoOptions so = servo_options(2.0, damping, true);
  Episode episode(ibvs::Servo(Layout::stacked(4), so), ibvs::CameraModel::afma6(), target, g, eo);
  for (int i = 0; i < 3; ++i) episode.run(q_start, q_goal);  // warm-up
  std::vector<double> t(static_cast<std::size_t>(o.episodes));
  const long a0 = g_allocations.load();
  for (auto& x : t) {
    const auto a = Clock::now();
    episode.run(q_start, q_goal);
    x = ns_between(a, Clock::now()) * 1e-6;
  }
  const long a1 = g_allocations.load();
  EpisodeCase c;
  c.name = name;
  c.layout = "stacked";
  c.n = 4;
  c.damping = damping;
  c.noise = noise;
  c.latency = latency;
  c.depth = to_string(depth);
  c.frames = episode.result().history.frames;
  c.outcome = to_string(episode.result().status.outcome);
  c.episodes = o.episodes;
  double sum = 0;
  for (double x : t) sum += x;
  std::sort(t.begin(), t.end());
  c.median_ms = percentile(t, 0.5);
  c.p99_ms = percentile(t, 0.99);
  c.max_ms = t.back();
  c.mean_ms = sum / static_cast<double>(t.size());
  c.episodes_per_s = 1e3 / c.mean_ms;
  c.us_per_frame = c.frames > 0 ? c.median_ms * 1e3 / c.frames : 0.0;
  c.allocs_per_episode = static_cast<double>(a1 - a0) / static_cast<double>(o.episodes);
  g_episodes.push_back(c);
}

// ---------------------------------------------------------- camera / estimators --
/// The per-frame perception path around Servo::update, N = 4 points: the
/// camera model both ways (ViSP's closed forms, plumb_bob and equidistant by
/// Newton), the pixel step Servo::update_pixels, DepthEstimator::update and
/// PlanarPose::estimate; frames vary (Frames), so the filters never settle.
void bench_camera(const Options& o) {
  const Frames fr(4);
  Eigen::Matrix3d K;
  K << 600, 0, 320, 0, 601, 240, 0, 0, 1;
  Eigen::VectorXd pb(5), fe(4);
  pb << -0.28, 0.07, 0.001, -0.0005, 0.01;
  fe << -0.013, 0.021, -0.012, 0.003;
  const ibvs::CameraModel cams[3] = {ibvs::CameraModel::afma6(), ibvs::CameraModel::from_opencv(K, pb, 640, 480),
                                     ibvs::CameraModel::from_opencv(K, fe, 640, 480, true)};
  std::vector<ibvs::Points> px[3];
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < Frames::count; ++k) {
      ibvs::Points p(2, 4);
      cams[c].project(fr.uv[k], p);
      px[c].push_back(p);
    }
  ibvs::Points out(2, 4);
  for (int c = 0; c < 3; ++c) {
    const char* d = to_string(cams[c].distortion());
    const char* route = c == 0 ? "closed form" : "Newton";
    Result& r = add("camera", "CameraModel::normalize", d, 4, 0, route, 0.0, -1);
    time_case(r, o, [&](long i) {
      keep(cams[c].normalize(px[c][static_cast<std::size_t>(i & (Frames::count - 1))], out));
      keep(out);
    });
    Result& q = add("camera", "CameraModel::project", d, 4, 0, "closed form", 0.0, -1);
    time_case(q, o, [&](long i) {
      keep(cams[c].project(fr.uv[static_cast<std::size_t>(i & (Frames::count - 1))], out));
      keep(out);
    });
  }
  // Pixels -> unit bearings (the wide-angle front end) per model: the three above, a 200-degree
  // fisheye's and Mei's omnidirectional model's, on the pixels of directions up to 0.9 max_angle
  // (for plumb_bob, 81 degrees: far outside its sensor, where Newton needs its bracketed path).
  {
    Eigen::Matrix3d Kw, Ko;
    Kw << 300, 0, 640, 0, 300.5, 512, 0, 0, 1;
    Ko << 700, 0, 640, 0, 701, 512, 0, 0, 1;
    const ibvs::CameraModel wide[2] = {
        ibvs::CameraModel::from_opencv(Kw, Eigen::Vector4d(-0.013, 0.02, -0.012, 0.002), 1280, 1024, true),
        ibvs::CameraModel::from_omnidir(Ko, 1.6,
                                        Eigen::Vector4d(-0.2, 0.05, 1e-4, 2e-4), 1280, 1024)};
    const ibvs::CameraModel* all[5] = {&cams[0], &cams[1], &cams[2], &wide[0], &wide[1]};
    for (int c = 0; c < 5; ++c) {
      const ibvs::CameraModel& cam = *all[c];
      std::vector<ibvs::Points> pxb;
      for (int k = 0; k < Frames::count; ++k) {  // directions up to 0.9 max_angle, at the frames' azimuths
        ibvs::Points p(2, 4);
        for (int j = 0; j < 4; ++j) {
          const double a = 0.9 * cam.max_angle() * (0.1 + 0.9 * ((k * 4 + j) % 17) / 16.0);
          const double az = std::atan2(fr.uv[static_cast<std::size_t>(k)](1, j), fr.uv[static_cast<std::size_t>(k)](0, j));
          Eigen::Vector2d q;
          if (!cam.from_bearing(std::sin(a) * std::cos(az), std::sin(a) * std::sin(az), std::cos(a), q))
            q << cam.u0(), cam.v0();
          p.col(j) = q;
        }
        pxb.push_back(p);
      }
      ibvs::Bearings b(3, 4);
      const char* name = c == 3 ? "fisheye 200deg" : c == 4 ? "omnidir" : to_string(cam.distortion());
      Result& r = add("camera", "CameraModel::to_bearing", name, 4, 0, c == 0 ? "closed form" : "Newton", 0.0, -1);
      time_case(r, o, [&](long i) {
        keep(cam.to_bearing(pxb[static_cast<std::size_t>(i & (Frames::count - 1))], b));
        keep(b);
      });
    }
    // One spherical servo step from fisheye pixels: spherical_measurements (to_bearing) + Servo::update
    // of a Task of 4 spherical-polar blocks.
    ibvs::Task task;
    for (int j = 0; j < 4; ++j) task.add(ibvs::SphericalPolarFeature());
    ibvs::Servo servo(task, servo_options(o.gain, o.damping, false));
    ibvs::ServoInput in(task);
    ibvs::ServoOutput so(task);
    std::vector<ibvs::Points> pxs, pxd;
    for (int k = 0; k < Frames::count; ++k) {
      ibvs::Points p(2, 4), q(2, 4);
      for (int j = 0; j < 4; ++j) {
        const auto& u = fr.uv[static_cast<std::size_t>(k)];
        const auto& ud = fr.uvd[static_cast<std::size_t>(k)];
        Eigen::Vector2d a, d;
        wide[0].from_bearing(u(0, j), u(1, j), 0.3, a);  // the frames' points, ~70 degrees and more off the axis
        wide[0].from_bearing(ud(0, j), ud(1, j), 1.0, d);
        p.col(j) = a;
        q.col(j) = d;
      }
      pxs.push_back(p);
      pxd.push_back(q);
    }
    Result& r = add("camera", "spherical servo step (fisheye pixels)", "spherical_polar", 4, task.rows(),
                    "Newton+LLT", o.damping, 0);
    time_case(r, o, [&](long i) {
      const auto k = static_cast<std::size_t>(i & (Frames::count - 1));
      ibvs::spherical_measurements(wide[0], pxs[k], fr.z[k], in.measurements);
      ibvs::spherical_measurements(wide[0], pxd[k], fr.zd[k], in.measurements_desired);
      servo.update(in, so);
      keep(so.velocity);
    });
  }
  {
    const Layout layout = make_layout("stacked", 4);
    ibvs::Servo servo(layout, servo_options(o.gain, o.damping, false));
    servo.set_camera(cams[1]);
    ibvs::ServoOutput so(layout);
    std::vector<ibvs::Points> pxd;
    for (int k = 0; k < Frames::count; ++k) {
      ibvs::Points p(2, 4);
      cams[1].project(fr.uvd[k], p);
      pxd.push_back(p);
    }
    Result& r = add("camera", "Servo::update_pixels damped", "stacked", 4, layout.rows(), "Newton+LLT", o.damping, 0);
    time_case(r, o, [&](long i) {
      const auto k = static_cast<std::size_t>(i & (Frames::count - 1));
      servo.update_pixels(px[1][k], fr.z[k], pxd[k], fr.zd[k], so);
      keep(so.velocity);
    });
  }
  {
    ibvs::DepthEstimatorOptions eo;
    eo.point_noise = 0.5 / 600.0;
    ibvs::DepthEstimator est(Eigen::VectorXd::Constant(4, 0.8), eo);
    ibvs::Twist d;
    d << 0.004, -0.002, 0.003, 0.001, -0.002, 0.004;  // twist * dt
    const ibvs::Pose M = ibvs::se3_exp(d);
    Result& r = add("camera", "DepthEstimator::update (4x4 motion)", "-", 4, 0, "EKF", 0.0, -1);
    time_case(r, o, [&](long i) {
      keep(est.update(fr.uv[static_cast<std::size_t>(i & (Frames::count - 1))], M));
      keep(est.depth());
    });
  }
  {
    const ibvs::sim::Target t = ibvs::sim::Target::square(0.1);
    const ibvs::PlanarPose pp(t.points);
    std::vector<ibvs::Points> seen;
    for (int k = 0; k < Frames::count; ++k) {  // the square seen from frame-dependent poses
      const double a = 0.1 * k;
      ibvs::Twist x;
      x << 0.02 * std::cos(a), 0.02 * std::sin(a), 0.6, 0.1 * std::sin(a), 0.1 * std::cos(a), a;
      ibvs::Pose T = ibvs::Pose::Identity();
      T.topLeftCorner<3, 3>() = ibvs::se3_exp(x).topLeftCorner<3, 3>();
      T.topRightCorner<3, 1>() = x.head<3>();
      ibvs::Points p(2, 4);
      for (int i = 0; i < 4; ++i) {
        const Eigen::Vector3d q = T.topLeftCorner<3, 3>() * t.points.col(i) + T.topRightCorner<3, 1>();
        p.col(i) = q.head<2>() / q(2);
      }
      seen.push_back(p);
    }
    ibvs::Pose T;
    Eigen::VectorXd z(4);
    Result& r = add("camera", "PlanarPose::estimate", "-", 4, 0, "DLT+GN", 0.0, -1);
    time_case(r, o, [&](long i) {
      keep(pp.estimate(seen[static_cast<std::size_t>(i & (Frames::count - 1))], T, z));
      keep(z);
    });
  }
}

// ---------------------------------------------------------------- output ---
std::string cpu_model() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("model name", 0) == 0) {
      const auto c = line.find(':');
      if (c != std::string::npos) return line.substr(c + 2);
    }
  return "unknown";
}

std::string json_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    o += c;
  }
  return o;
}

void print_row(std::FILE* f, const Result& r) {
  char what[48], robust[16] = "n/a";  // n/a: not a Servo::update row (print_header says so)
  if (r.section == "robot")
    std::snprintf(what, sizeof what, "%d joints, J 6x%d", r.n, r.n);
  else if (r.section == "tasks")
    std::snprintf(what, sizeof what, "%s %dx6", r.layout.c_str(), r.rows);
  else if (r.rows > 0)
    std::snprintf(what, sizeof what, "%s(%d) %dx6", r.layout.c_str(), r.n, r.rows);
  else if (r.layout == "-")
    std::snprintf(what, sizeof what, "N = %d", r.n);
  else
    std::snprintf(what, sizeof what, "%s, N = %d", r.layout.c_str(), r.n);
  if (r.robust_frames >= 0) std::snprintf(robust, sizeof robust, "%d/%d", r.robust_frames, Frames::count);
  std::fprintf(f, "  %-45s %-20s %9.3f %9.3f %9.2f %9.3f %12.0f %7.2g %7s\n", r.name.c_str(), what, r.median_us,
               r.p99_us, r.max_us, r.mean_us, r.steps_per_s, r.allocs_per_call, robust);
}

// ------------------------------------------------------------ photometric --
/// Photometric servoing (issue 36): LuminanceServo::update on 8-bit images of a smooth texture at
/// 160x120 and 320x240 (border 10, constant depth, Levenberg-Marquardt), J at the desired image (the
/// default) and at the current one, beside the per-pixel floor (luminance_floor.hpp) and its parts:
/// the 7-tap gradients of the grid, the error e = I - I*, and the 6 x 6 solve. Fewer calls than the
/// point sections (each is 0.05-1 ms): min(iterations, 2000).
void bench_photometric(const Options& o_in, std::FILE* table) {
  namespace ph = ibvs_bench::photometric;
  Options o = o_in;
  o.iterations = std::min(o.iterations, 2000L);
  o.warmup = std::min(o.warmup, 200L);
  for (const auto& size : {std::pair<int, int>{160, 120}, std::pair<int, int>{320, 240}}) {
    const int w = size.first, h = size.second, border = 10;
    const double f = 0.9 * w, z = 0.6, mu = 0.01, gain = 1.0;
    const ibvs::CameraModel cam = ibvs::CameraModel::pinhole(f, f, 0.5 * (w - 1), 0.5 * (h - 1), w, h);
    // A goal image and 8 current ones (the texture shifted by up to ~2 px and slightly rotated).
    const auto texture = [&](double shift, double turn) {
      ibvs::ImageU8 im(h, w);
      for (int r = 0; r < h; ++r)
        for (int c = 0; c < w; ++c) {
          const double X = (c - 0.5 * w) * std::cos(turn) - (r - 0.5 * h) * std::sin(turn) + shift;
          const double Y = (c - 0.5 * w) * std::sin(turn) + (r - 0.5 * h) * std::cos(turn) - 0.5 * shift;
          const double s = 0.32 * 160.0 / w;  // the same pattern in both sizes
          im(r, c) = static_cast<std::uint8_t>(std::lround(
              128.0 + 50.0 * std::sin(s * X * 0.9 + 0.3) + 40.0 * std::sin(s * (0.6 * Y - 0.3 * X)) +
              25.0 * std::cos(s * 0.5 * (X + Y))));
        }
      return im;
    };
    const ibvs::ImageU8 goal = texture(0.0, 0.0);
    std::vector<ibvs::ImageU8> frames;
    for (int k = 0; k < 8; ++k) frames.push_back(texture(0.25 * (k + 1), 0.002 * (k - 4)));
    const std::string layout = std::to_string(w) + "x" + std::to_string(h);
    for (const auto jac : {ibvs::InteractionMatrix::desired, ibvs::InteractionMatrix::current}) {
      ibvs::LuminanceOptions lo;
      lo.border = border;
      lo.jacobian = jac;
      lo.mu = mu;
      lo.gain = gain;
      lo.plane_c = 1.0 / z;
      ibvs::LuminanceServo servo(cam, w, h, lo);
      servo.set_desired(goal);
      const ph::Floor floor(w, h, border, f, f, 0.5 * (w - 1), 0.5 * (h - 1), z, mu, gain, goal.data());
      const bool desired = jac == ibvs::InteractionMatrix::desired;
      // The floor must give the servo's twist (float sums: relative 1e-4), or it is no floor.
      ibvs::LuminanceOutput out;
      for (const auto& im : frames) {
        servo.update(im, out);
        const ph::Vector6 v = desired ? floor.step_desired(im.data()) : floor.step_current(im.data());
        if (out.status != ibvs::LuminanceStatus::ok || !((v - out.twist).norm() <= 1e-4 * v.norm())) {
          std::fprintf(stderr, "ibvs-bench: the photometric floor disagrees with LuminanceServo::update (%s, J %s): %g\n",
                       layout.c_str(), desired ? "desired" : "current", (v - out.twist).norm() / v.norm());
          std::exit(1);
        }
      }
      const int n = servo.pixels();
      Result& r = add("photometric", desired ? "LuminanceServo::update J desired (LM)"
                                             : "LuminanceServo::update J current (LM)",
                      layout, n, n, "LM", mu, -1);
      time_case(r, o, [&](long i) {
        servo.update(frames[static_cast<std::size_t>(i & 7)], out);
        keep(out.twist);
      });
      Result& rf = add("photometric", desired ? "floor: per-pixel L^T e, J desired" : "floor: per-pixel H, L^T e, J current",
                       layout, n, n, "LM", mu, -1);
      time_case(rf, o, [&](long i) {
        const auto& im = frames[static_cast<std::size_t>(i & 7)];
        keep(desired ? floor.step_desired(im.data()) : floor.step_current(im.data()));
      });
    }
    // The floor's parts: the gradients of the grid, the error, the 6 x 6 LM solve.
    const ph::Floor floor(w, h, border, f, f, 0.5 * (w - 1), 0.5 * (h - 1), z, mu, gain, goal.data());
    const int gw = w - 2 * border, gh = h - 2 * border, n = gw * gh;
    std::vector<float> gx(static_cast<std::size_t>(n)), gy(gx), e(gx);
    Result& rg = add("photometric", "part: 7-tap gradients of the grid", layout, n, n, "-", 0.0, -1);
    time_case(rg, o, [&](long i) {
      const std::uint8_t* img = frames[static_cast<std::size_t>(i & 7)].data();
      for (int r = 0; r < gh; ++r)
        for (int c = 0; c < gw; ++c) {
          const std::uint8_t* p = img + (r + border) * w + c + border;
          gx[static_cast<std::size_t>(r * gw + c)] = float(f) * ph::Floor::dx7(p, 1);
          gy[static_cast<std::size_t>(r * gw + c)] = float(f) * ph::Floor::dx7(p, w);
        }
      keep(gx[0]);
      keep(gy[static_cast<std::size_t>(n - 1)]);
    });
    Result& re = add("photometric", "part: error e = I - I*", layout, n, n, "-", 0.0, -1);
    time_case(re, o, [&](long i) {
      const std::uint8_t* img = frames[static_cast<std::size_t>(i & 7)].data();
      for (int r = 0; r < gh; ++r)
        for (int c = 0; c < gw; ++c)
          e[static_cast<std::size_t>(r * gw + c)] =
              float(img[(r + border) * w + c + border]) - floor.ref[static_cast<std::size_t>(r * gw + c)];
      keep(e[0]);
    });
    ph::Matrix6 H = ph::Matrix6::Identity() * 3.0;
    H(0, 1) = H(1, 0) = 0.5;
    const ph::Vector6 g = ph::Vector6::LinSpaced(1.0, 2.0);
    Result& rs = add("photometric", "part: 6x6 LM solve (LLT of H + mu diag H)", layout, 6, 6, "LLT", mu, -1);
    time_case(rs, o, [&](long i) {
      ph::Matrix6 A = H;
      A(0, 0) += 1e-9 * double(i & 7);
      A.diagonal() *= 1.0 + mu;
      keep(A.llt().solve(g));
    });
    for (std::size_t k = g_results.size() - 7; k < g_results.size(); ++k) print_row(table, g_results[k]);
    const auto median = [&](const char* name) {
      for (const Result& r : g_results)
        if (r.section == "photometric" && r.layout == layout && r.name == name) return r.median_us;
      return 0.0;
    };
    std::fprintf(table, "  LuminanceServo::update / floor (medians), %s: J desired %.2fx, J current %.2fx\n",
                 layout.c_str(),
                 median("LuminanceServo::update J desired (LM)") / median("floor: per-pixel L^T e, J desired"),
                 median("LuminanceServo::update J current (LM)") / median("floor: per-pixel H, L^T e, J current"));
    std::fflush(table);
  }
}

void print_header(std::FILE* f, const char* title) {
  std::fprintf(f, "\n%s\n  %-45s %-20s %9s %9s %9s %9s %12s %7s %7s\n", title, "case", "layout", "median", "p99",
               "max", "mean", "steps/s", "allocs", "robust");
  std::fprintf(f, "  %-45s %-20s %9s %9s %9s %9s %12s %7s %7s\n", "", "", "us", "us", "us", "us", "", "/call",
               "route");
  std::fprintf(f, "  (robust route: frames of %d that Servo::update solves by QR + SVD; n/a: not a Servo::update "
               "row)\n", Frames::count);
}

/// The ViSP stand-in ratio of one N = 4 layout: the SVD step (a JacobiSVD of J
/// on heap matrices per frame, as vpServo's vpMatrix::pseudoInverse) over the
/// default Servo::update, medians of the same run.
void print_visp_ratio(std::FILE* f, const std::string& kind) {
  const Result *svd = nullptr, *def = nullptr;
  for (const Result& r : g_results)
    if (r.section == "components" && r.layout == kind && r.n == 4) {
      if (r.name == "SVD step: J, damped_pinv() (ViSP-like)") svd = &r;
      if (r.name == "Servo::update default (damping 0, diag.)") def = &r;
    }
  if (svd && def && def->median_us > 0)
    std::fprintf(f, "  ViSP stand-in (ViSP not found): SVD step / default Servo::update, %s(4): %.1fx\n",
                 kind.c_str(), svd->median_us / def->median_us);
}

/// Servo::update over its floor, default and tuned (medians of the same run), for one layout or task.
void print_floor_ratio(std::FILE* f, const char* section, const std::string& layout, const std::string& label) {
  const Result *def = nullptr, *tuned = nullptr, *floor = nullptr;
  for (const Result& r : g_results)
    if (r.section == section && r.layout == layout && (r.section == std::string("tasks") || r.n == 4)) {
      if (r.name == "Servo::update default (damping 0, diag.)") def = &r;
      if (r.name == "Servo::update tuned (damped, no diag.)") tuned = &r;
      if (r.name == "Eigen floor: fixed-size LLT step") floor = &r;
    }
  if (def && tuned && floor && floor->median_us > 0)
    std::fprintf(f, "  Servo::update / floor (medians), %s: default %.2fx, tuned %.2fx\n", label.c_str(),
                 def->median_us / floor->median_us, tuned->median_us / floor->median_us);
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  std::FILE* table = o.json ? stderr : stdout;
#if defined(__linux__)
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);  // 1 ns instead of the default 50 us
#endif
  g_timer_ns = measure_timer_overhead();
  std::fprintf(table, "ibvs-bench %s | %s | Eigen %d.%d.%d | %s | steady_clock cost %.1f ns (subtracted)\n",
               IBVS_VERSION, cpu_model().c_str(), EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION,
#if defined(__clang__)
               "clang " __clang_version__,
#elif defined(__GNUC__)
               "gcc " __VERSION__,
#else
               "unknown compiler",
#endif
               g_timer_ns);
  std::fprintf(table, "iterations %ld (warm-up %ld), damping %g, gain %g; times per call in microseconds\n",
               o.iterations, o.warmup, o.damping, o.gain);

  if (has(o.sections, "components")) {
    const std::vector<int> ns = o.ns_given ? o.ns : std::vector<int>{4};
    print_header(table, "Components and whole step (N points; the floor is fixed-size Eigen written directly)");
    for (int n : ns)
      for (const auto& kind : o.layouts) {
        const std::size_t first = g_results.size();
        bench_components(kind, n, o);
        for (std::size_t i = first; i < g_results.size(); ++i) print_row(table, g_results[i]);
        if (n == 4) {
          print_visp_ratio(table, kind);
          print_floor_ratio(table, "components", kind, kind + "(4)");
        }
        std::fflush(table);
      }
  }
  if (has(o.sections, "tasks")) {
    print_header(table, "Tasks of feature blocks (issue 21): Servo::update beside a fixed-size Eigen floor of the same "
                        "features and size");
    bench_tasks(o, table);
  }
  if (has(o.sections, "growth")) {
    const std::vector<int> ns = o.ns_given ? o.ns : std::vector<int>{4, 8, 16, 32, 64};
    print_header(table, "Cost growth: Servo::update (damped = LLT, diagnostics off; undamped = QR+SVD)");
    for (const auto& kind : o.layouts)
      for (int n : ns) {
        const Frames fr(n);
        bench_update("growth", "Servo::update default (damping 0, diag.)", kind, n, 0.0, true, o, fr);
        print_row(table, g_results.back());
        bench_update("growth", "Servo::update tuned (damped, no diag.)", kind, n, o.damping, false, o, fr);
        print_row(table, g_results.back());
        std::fflush(table);
      }
  }
  if (has(o.sections, "paced")) {
    const bool rt = o.realtime && try_realtime();
    std::fprintf(table,
                 "\nPaced loops: Servo::update stacked(4) damped + diagnostics, released at absolute deadlines "
                 "(clock_nanosleep TIMER_ABSTIME%s%s)\n",
                 o.spin_us > 0 ? ", then spin" : "", rt ? ", SCHED_FIFO 80" : ", normal priority");
    std::fprintf(table, "  %8s %9s %9s %7s %12s %12s %12s %10s %10s %10s\n", "rate Hz", "duration", "steps", "misses",
                 "late med us", "late p99 us", "late max us", "step med", "step p99", "step max");
    for (double rate : o.rates) {
      bench_paced(rate, o, rt);
      const Paced& p = g_paced.back();
      std::fprintf(table, "  %8g %8gs %9ld %7ld %12.1f %12.1f %12.1f %10.3f %10.3f %10.2f\n", p.rate_hz, p.duration_s,
                   p.steps, p.misses, p.late_median_us, p.late_p99_us, p.late_max_us, p.step_median_us, p.step_p99_us,
                   p.step_max_us);
      std::fflush(table);
    }
  }

  if (has(o.sections, "episode")) {
    std::fprintf(table,
                 "\nSimulated episodes: 600 frames (10 s at 60 Hz), Afma6 camera with distortion on the Afma6-like "
                 "gantry, stacked(4), one core\n");
    std::fprintf(table, "  %-44s %7s %9s %9s %9s %9s %10s %9s %7s %s\n", "case", "frames", "median", "p99", "max",
                 "mean", "episodes/s", "us/frame", "allocs", "outcome");
    std::fprintf(table, "  %-44s %7s %9s %9s %9s %9s %10s %9s %7s\n", "", "", "ms", "ms", "ms", "ms", "", "", "/run");
    using ibvs::sim::DepthMode;
    const std::pair<const char*, std::function<void()>> cases[] = {
        {"damped LLT + diagnostics, exact depth", [&] { bench_episode("damped LLT + diagnostics, exact depth", o.damping, 0.0, 0, DepthMode::exact, o); }},
        {"undamped QR+SVD, exact depth", [&] { bench_episode("undamped QR+SVD, exact depth", 0.0, 0.0, 0, DepthMode::exact, o); }},
        {"damped, noise 0.5 px, latency 1, pose depth", [&] { bench_episode("damped, noise 0.5 px, latency 1, pose depth", o.damping, 0.5, 1, DepthMode::pose, o); }},
    };
    for (const auto& c : cases) {
      c.second();
      const EpisodeCase& e = g_episodes.back();
      std::fprintf(table, "  %-44s %7d %9.3f %9.3f %9.3f %9.3f %10.0f %9.3f %7.2g %s\n", e.name.c_str(), e.frames,
                   e.median_ms, e.p99_ms, e.max_ms, e.mean_ms, e.episodes_per_s, e.us_per_frame, e.allocs_per_episode,
                   e.outcome.c_str());
      std::fflush(table);
    }
  }

  if (has(o.sections, "robot")) {
    print_header(table, "Robot mapping: JointMapping::update, camera twist -> joint velocities (n joints)");
    for (int n : {6, 7, 16})
      for (double damping : {0.0, o.damping}) {
        bench_robot(n, damping, o);
        print_row(table, g_results.back());
        bench_robot(n, damping, o, true);
        print_row(table, g_results.back());
        std::fflush(table);
      }
    for (int n : {6, 7, 16}) {
      bench_robot_extras(n, o);
      print_row(table, g_results[g_results.size() - 2]);
      print_row(table, g_results.back());
      std::fflush(table);
    }
  }

  if (has(o.sections, "camera")) {
    print_header(table, "Camera model, pixel step and estimators (N = 4; camera models: ViSP afma6, plumb_bob, equidistant; to_bearing also a 200-degree fisheye and omnidir)");
    const std::size_t first = g_results.size();
    bench_camera(o);
    for (std::size_t i = first; i < g_results.size(); ++i) print_row(table, g_results[i]);
    std::fflush(table);
  }

  if (has(o.sections, "photometric")) {
    print_header(table, "Photometric servoing (issue 36): LuminanceServo::update on 8-bit images, border 10, beside a "
                        "per-pixel floor (N = the grid's pixels)");
    bench_photometric(o, table);
  }

  if (o.json) {
    std::string s = "{\"benchmark\":\"ibvs-bench\",\"version\":\"" IBVS_VERSION "\",\"cpu\":\"" +
                    json_escape(cpu_model()) + "\",\"timer_overhead_ns\":" + std::to_string(g_timer_ns) +
                    ",\"iterations\":" + std::to_string(o.iterations) + ",\"cases\":[";
    char buf[640];
    for (std::size_t i = 0; i < g_results.size(); ++i) {
      const Result& r = g_results[i];
      std::snprintf(buf, sizeof buf,
                    "%s{\"section\":\"%s\",\"name\":\"%s\",\"layout\":\"%s\",\"n\":%d,\"rows\":%d,\"route\":\"%s\","
                    "\"damping\":%g,\"diagnostics\":%s,\"iterations\":%ld,\"median_us\":%.4f,\"p99_us\":%.4f,"
                    "\"max_us\":%.3f,\"mean_us\":%.4f,\"steps_per_s\":%.0f,\"allocs_per_call\":%g,"
                    "\"robust_frames\":%d}",
                    i ? "," : "", r.section.c_str(), json_escape(r.name).c_str(), r.layout.c_str(), r.n, r.rows,
                    r.route.c_str(), r.damping,
                    r.diagnostics < 0 ? "null" : (r.diagnostics ? "true" : "false"), r.iterations, r.median_us,
                    r.p99_us, r.max_us, r.mean_us, r.steps_per_s, r.allocs_per_call, r.robust_frames);
      s += buf;
    }
    s += "],\"paced\":[";
    for (std::size_t i = 0; i < g_paced.size(); ++i) {
      const Paced& p = g_paced[i];
      std::snprintf(buf, sizeof buf,
                    "%s{\"rate_hz\":%g,\"duration_s\":%g,\"layout\":\"%s\",\"n\":%d,\"spin_us\":%g,\"realtime\":%s,"
                    "\"steps\":%ld,\"misses\":%ld,\"lateness_median_us\":%.2f,\"lateness_p99_us\":%.2f,"
                    "\"lateness_max_us\":%.2f,\"step_median_us\":%.4f,\"step_p99_us\":%.4f,\"step_max_us\":%.3f}",
                    i ? "," : "", p.rate_hz, p.duration_s, p.layout.c_str(), p.n, p.spin_us,
                    p.realtime ? "true" : "false", p.steps, p.misses, p.late_median_us, p.late_p99_us,
                    p.late_max_us, p.step_median_us, p.step_p99_us, p.step_max_us);
      s += buf;
    }
    s += "],\"episodes\":[";
    for (std::size_t i = 0; i < g_episodes.size(); ++i) {
      const EpisodeCase& e = g_episodes[i];
      std::snprintf(buf, sizeof buf,
                    "%s{\"name\":\"%s\",\"layout\":\"%s\",\"n\":%d,\"damping\":%g,\"noise_px\":%g,\"latency\":%d,"
                    "\"depth\":\"%s\",\"frames\":%d,\"outcome\":\"%s\",\"episodes\":%ld,\"median_ms\":%.4f,"
                    "\"p99_ms\":%.4f,\"max_ms\":%.4f,\"mean_ms\":%.4f,\"episodes_per_s\":%.1f,\"us_per_frame\":%.4f,"
                    "\"allocs_per_episode\":%g}",
                    i ? "," : "", json_escape(e.name).c_str(), e.layout.c_str(), e.n, e.damping, e.noise, e.latency,
                    e.depth.c_str(), e.frames, e.outcome.c_str(), e.episodes, e.median_ms, e.p99_ms, e.max_ms,
                    e.mean_ms, e.episodes_per_s, e.us_per_frame, e.allocs_per_episode);
      s += buf;
    }
    s += "]}";
    std::printf("%s\n", s.c_str());
  }
  return 0;
}
