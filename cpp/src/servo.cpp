#include "ibvs/servo.hpp"

#include "ibvs/features/pose.hpp"

#include "checks.hpp"
#include "servo_caches.hpp"
#include "features/moments_goal.hpp"
#include "solve.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <algorithm>
#include <array>
#include <variant>
#include <vector>

namespace ibvs {
namespace {


// theta - theta* (both in (-pi, pi]) into (-pi, pi] (eq. 13, one turn at most),
// then about the consistent-wrap centre unless that is NaN (angle_wrap.hpp).
inline double wrap_difference(double d, double centre) noexcept {
  if (d > pi) d -= 2.0 * pi;
  else if (d <= -pi) d += 2.0 * pi;
  return std::isnan(centre) ? d : wrap_about(d, centre);
}

// Angle differences within +-1.5 rad are not moved by a wrap about a centre within +-pi / 2: their
// distance to it is below 1.5 + pi / 2 < pi with a margin (0.07) far above rounding.
constexpr double small_angle_difference = 1.5;

// A 64-bit hash of a row or point index (splitmix64's finaliser): sets of them are xored.
inline std::uint64_t mix(std::uint64_t x) noexcept {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// The rows of the lost points' blocks zeroed (out of the law); returns a hash of the lost points.
template <class Jac, class Vec>
[[gnu::noinline]] std::uint64_t drop_lost(const Layout& layout, const PointMask& valid, Jac& J, Vec& e) noexcept {
  Eigen::Index row = 0;
  for (const Block& b : layout.blocks()) {
    if (!valid(b.point)) {
      J.template middleRows<2>(row).setZero();
      e.template segment<2>(row).setZero();
    }
    row += 2;
  }
  std::uint64_t key = 0;
  for (Eigen::Index i = 0; i < valid.size(); ++i)
    if (!valid(i)) key ^= mix(~static_cast<std::uint64_t>(i));
  return key;
}

// The polar blocks computed as Cartesian this step, one bit per block (modulo 64): for the smooth
// law, to which a change of them is a change of law (computed only when it is on, so that the
// plain step's assembly is untouched).
std::uint64_t fallback_pattern(const Layout& layout, double polar_min_radius, const Eigen::Ref<const Points>& uv,
                               const Eigen::Ref<const Points>& uvd) noexcept {
  std::uint64_t bits = 0;
  int k = 0;
  for (const Block& b : layout.blocks()) {
    if (b.representation == Representation::polar) {
      const double u = uv(0, b.point), v = uv(1, b.point), ud = uvd(0, b.point), vd = uvd(1, b.point);
      if (polar_falls_back(u * u + v * v, polar_min_radius) || polar_falls_back(ud * ud + vd * vd, polar_min_radius))
        bits ^= std::uint64_t{1} << (k & 63);
    }
    ++k;
  }
  return bits;
}

// The goal side of a point's polar and cylindrical blocks, r* = sqrt(u*^2 + v*^2) and
// theta* = atan2(v*, u*), kept while the goal point's bits are unchanged (the goal is usually
// fixed for many frames: this saves an atan2 and a sqrt per block). Both are functions of
// (u*, v*) alone (no option enters them), computed from the caller's r*^2 by the same
// expressions as before, so a cached value is the uncached one bit for bit; keyed on the exact
// bits, so -0 and +0 (atan2 tells them apart) are different goals.
struct GoalPoint {
  std::uint64_t ud = ~std::uint64_t{0}, vd = ~std::uint64_t{0};  // the bits of (u*, v*); a NaN: none yet
  double rd = 0.0, theta = 0.0;

  inline static std::uint64_t bits(double x) noexcept {
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    return b;
  }
  // This goal point's (r*, theta*), refilled when (u*, v*) changed; rd2 = u* u* + v* v*.
  const GoalPoint& at(double u_d, double v_d, double rd2) noexcept {
    const std::uint64_t bu = bits(u_d), bv = bits(v_d);
    if (bu != ud || bv != vd) {
      ud = bu;
      vd = bv;
      rd = std::sqrt(rd2);
      theta = std::atan2(v_d, u_d);
    }
    return *this;
  }
};

// The goal's side of a feature block of a kind the library knows, kept while the bits of the
// block's goal measurement are unchanged: image moments (the goal's check and evaluation,
// detail::moments_goal), PBVS and 2.5-D (the goal's check and value: their alignment, error and
// evaluation are Feature's defaults, so their error is value(m) - value(m*) and their step is
// check(m), check(m*), that error and interaction(m)). Other kinds are evaluated as they are.
struct FeatureGoal {
  const MomentsFeature* moments = nullptr;  // the block, when it is image moments
  const PbvsFeature* pbvs = nullptr;        // ... PBVS
  const Point25DFeature* point25d = nullptr;  // ... 2.5-D
  bool filled = false;
  std::array<double, MomentsFeature::measurement_size> key{};  // the goal measurement it is from
  detail::MomentsGoal goal;      // moments
  bool refused = false;          // PBVS, 2.5-D: check(m*) refused m*
  std::array<double, 6> sd{};    // PBVS, 2.5-D: value(m*)

  // Refilled when the goal measurement (size doubles) changed.
  template <class Fill>
  void keep(const double* md, int size, Fill&& fill) noexcept {
    const std::size_t bytes = sizeof(double) * static_cast<std::size_t>(size);
    if (filled && std::memcmp(key.data(), md, bytes) == 0) return;
    std::memcpy(key.data(), md, bytes);
    fill();
    filled = true;
  }
};

// Feature::evaluate (its default: check(m), check(m*), align (none), error = value(m) - value(m*),
// interaction(m)) for a kind F that keeps all the defaults, with the goal's check and value given.
template <class F>
bool evaluate_with_goal(const F& f, const FeatureGoal& g, double* m, double* e, Eigen::Ref<MatrixX6> L) noexcept {
  int entry = -1;
  if (f.check(m, entry) || g.refused) return false;
  double s[6];
  f.value(m, s);
  for (int i = 0; i < 6; ++i) e[i] = s[i] - g.sd[i];
  f.interaction(m, L);
  return true;
}

// Workspace for one row count: the assembled J and e, and the solver (see
// solve.hpp for the sizes: Rows = 8 or 16, or Dynamic bounded by MaxRows).
template <int Rows, int MaxRows = Rows>
struct Work {
  using Solve = detail::Solver<Rows, MaxRows>;
  using Jac = typename Solve::Jac;
  using Vec = typename Solve::Vec;

  explicit Work(Eigen::Index m)
      : J(Jac::Zero(std::max<Eigen::Index>(m, 6), 6)),
        e(Vec::Zero(J.rows())),
        solver(J.rows()),
        waiting(static_cast<std::size_t>(m / 2)) {}

  Jac J;
  Vec e;
  Solve solver;

  // Writes rows (row, row+1) of J as the chosen interaction matrix.
  template <class Current, class Desired>
  void put(Eigen::Index row, InteractionMatrix which, const Current& cur, const Desired& des) noexcept {
    switch (which) {
      case InteractionMatrix::current: J.template middleRows<2>(row) = cur(); break;
      case InteractionMatrix::desired: J.template middleRows<2>(row) = des(); break;
      case InteractionMatrix::mean: J.template middleRows<2>(row) = 0.5 * (cur() + des()); break;
    }
  }

  // Cylindrical block (Iwatsuki & Okiyama): error (r - r*, r wrap(theta - theta*)) and its
  // Jacobian, the rows of (r, r alpha) with the angle alpha measured from theta*:
  // alpha = wrap(theta - theta*) at the current point, 0 at the desired one. A point
  // at r = 0 takes the other point's direction (alpha = 0 there): its block is then
  // the Cartesian block in a rotated basis, so no fallback is needed.
  void put_cylindrical(Eigen::Index row, InteractionMatrix which, double u, double v, double r2, double z, double ud,
                       double vd, double rd2, double zd, double centre, GoalPoint& goal) noexcept {
    const GoalPoint& g = goal.at(ud, vd, rd2);
    const double r = std::sqrt(r2), rd = g.rd;
    double dth = 0.0;
    if (r2 > 0.0 && rd2 > 0.0) {
      dth = wrap_difference(std::atan2(v, u) - g.theta, centre);
    }
    e(row) = r - rd;
    e(row + 1) = r * dth;
    // Directions: own when r > 0, else the other point's, else (1, 0).
    const double c = r > 0.0 ? u / r : rd > 0.0 ? ud / rd : 1.0, s = r > 0.0 ? v / r : rd > 0.0 ? vd / rd : 0.0;
    const double cd = rd > 0.0 ? ud / rd : c, sd = rd > 0.0 ? vd / rd : s;
    const auto cur = [&] { return cylindrical_jacobian(r, c, s, dth, z); };
    const auto des = [&] { return cylindrical_jacobian(rd, cd, sd, 0.0, zd); };
    put(row, which, cur, des);
  }

  // A hash of the lost points of this step (drop_lost), for the smooth law.
  std::uint64_t key = 0;

  // The blocks whose angle waits for the consistent wrap's centre (assemble() with a resultant):
  // the row of each polar angle difference, or the index of each cylindrical block (~row: its
  // rows depend on the wrapped angle); `n_waiting` of them this frame.
  std::vector<Eigen::Index> waiting;
  std::size_t n_waiting = 0;

  // Fills J and e for this frame; returns the number of polar fallbacks. goal: one GoalPoint per
  // point (the cache). Without `sum` (AngleWrap::per_point) angle differences are wrapped by eq.
  // 13 alone. With it (consistent wrap), in the same pass, the unit vector of the angle difference
  // of each block that has an angle this frame (polar blocks that do not fall back, cylindrical
  // blocks with both radii > 0; of the points marked valid only) is added to `sum` in block order,
  // the polar angle rows are left at eq. 13 and the cylindrical blocks are left out:
  // wrap_about_centre() completes them once the centre is known.
  int assemble(const Layout& layout, const ServoOptions& o, const Eigen::Ref<const Points>& uv,
               const Eigen::Ref<const Eigen::VectorXd>& z, const Eigen::Ref<const Points>& uvd,
               const Eigen::Ref<const Eigen::VectorXd>& zd, GoalPoint* goal, const PointMask* valid,
               AngleResultant* sum) noexcept {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    int fallbacks = 0;
    n_waiting = 0;
    Eigen::Index row = 0;
    for (const Block& b : layout.blocks()) {
      const double u = uv(0, b.point), v = uv(1, b.point), ud = uvd(0, b.point), vd = uvd(1, b.point);
      const double r2 = u * u + v * v, rd2 = ud * ud + vd * vd;
      if (b.representation == Representation::cylindrical) {
        if (sum) {
          if ((!valid || (*valid)(b.point)) && r2 > 0.0 && rd2 > 0.0) add_direction(*sum, u, v, r2, ud, vd, rd2);
          waiting[n_waiting++] = ~row;
        } else {
          put_cylindrical(row, o.jacobian, u, v, r2, z(b.point), ud, vd, rd2, zd(b.point), nan, goal[b.point]);
        }
        row += 2;
        continue;
      }
      bool polar = b.representation == Representation::polar;
      if (polar && (polar_falls_back(r2, o.polar_min_radius) || polar_falls_back(rd2, o.polar_min_radius))) {
        polar = false;
        ++fallbacks;
      }
      if (polar) {
        if (sum) {
          if (!valid || (*valid)(b.point)) add_direction(*sum, u, v, r2, ud, vd, rd2);
          waiting[n_waiting++] = row + 1;
        }
        // Each radius and angle once: error (eq. 13) and rows -(eq. 7) from (r, c, s).
        const GoalPoint& g = goal[b.point].at(ud, vd, rd2);
        const double r = std::sqrt(r2), rd = g.rd;
        e(row) = r - rd;
        e(row + 1) = wrap_difference(std::atan2(v, u) - g.theta, nan);
        const auto cur = [&] { return polar_jacobian(r, u / r, v / r, z(b.point)); };
        const auto des = [&] { return polar_jacobian(rd, ud / rd, vd / rd, zd(b.point)); };
        put(row, o.jacobian, cur, des);
      } else {
        e(row) = u - ud;
        e(row + 1) = v - vd;
        const auto cur = [&] { return cartesian_jacobian(u, v, z(b.point)); };
        const auto des = [&] { return cartesian_jacobian(ud, vd, zd(b.point)); };
        put(row, o.jacobian, cur, des);
      }
      row += 2;
    }
    return fallbacks;
  }

  // The resultant's term of one block, from the points' directions: (cos, sin)(theta - theta*) =
  // (u u* + v v*, v u* - u v*) / (r r*), no trigonometric call.
  static void add_direction(AngleResultant& sum, double u, double v, double r2, double ud, double vd,
                            double rd2) noexcept {
    const double k = 1.0 / std::sqrt(r2 * rd2);  // inf only if r2 * rd2 underflows: that block is left out
    if (std::isfinite(k)) sum.add((u * ud + v * vd) * k, (v * ud - u * vd) * k);
  }

  // After assemble() with a resultant: whether every block waiting for the centre is a polar
  // angle row within +-limit (eq. 13) (a cylindrical block waits to be computed).
  bool angles_within(double limit) const noexcept {
    for (std::size_t i = 0; i < n_waiting; ++i)
      if (waiting[i] < 0 || !(std::abs(e(waiting[i])) <= limit)) return false;
    return true;
  }

  // After assemble() with a resultant: the polar angle rows wrapped about the centre (NaN: as
  // they are, eq. 13) and the cylindrical blocks computed, with the same values as a single pass
  // that knew the centre (wrap_difference() is eq. 13, then wrap_about the centre).
  void wrap_about_centre(const Layout& layout, const ServoOptions& o, const Eigen::Ref<const Points>& uv,
                         const Eigen::Ref<const Eigen::VectorXd>& z, const Eigen::Ref<const Points>& uvd,
                         const Eigen::Ref<const Eigen::VectorXd>& zd, GoalPoint* goal, double centre) noexcept {
    const bool wrap = !std::isnan(centre);
    for (std::size_t i = 0; i < n_waiting; ++i) {
      const Eigen::Index w = waiting[i];
      if (w >= 0) {
        if (wrap) e(w) = wrap_about(e(w), centre);
        continue;
      }
      const Eigen::Index row = ~w;
      const Block& b = layout.blocks()[static_cast<std::size_t>(row / 2)];
      const double u = uv(0, b.point), v = uv(1, b.point), ud = uvd(0, b.point), vd = uvd(1, b.point);
      const double r2 = u * u + v * v, rd2 = ud * ud + vd * vd;
      put_cylindrical(row, o.jacobian, u, v, r2, z(b.point), ud, vd, rd2, zd(b.point), centre, goal[b.point]);
    }
  }

  // Rows after the points: each feature block's error and interaction matrix, from the current
  // measurement aligned to the goal's (a copy in `aligned`); `spare` holds the goal's rows for
  // InteractionMatrix::mean. Then (weigh) the task's weights and degrees of freedom.
  void assemble_features(const Task& task, InteractionMatrix which, const double* m, const double* md,
                         double* aligned, MatrixX6& spare) noexcept {
    for (int k = 0; k < task.n_features(); ++k) {
      const Feature& f = task.feature(k);
      const int row = task.row(k), off = task.offset(k), r = f.rows();
      double* mc = aligned + off;
      std::copy(m + off, m + off + f.size(), mc);
      f.align(mc, md + off);
      f.error(mc, md + off, e.data() + row);
      auto rows = J.middleRows(row, r);
      switch (which) {
        case InteractionMatrix::current: f.interaction(mc, rows); break;
        case InteractionMatrix::desired: f.interaction(md + off, rows); break;
        case InteractionMatrix::mean:
          f.interaction(mc, rows);
          f.interaction(md + off, spare);
          rows = 0.5 * (rows + spare.topRows(r));
          break;
      }
    }
  }

  // The consistent wrap of the feature blocks' angle rows about the optical axis: each block's
  // (Feature::axis_angle_rows of its aligned measurement, recorded in `angles`; returns whether
  // there are any), their differences (error() gives them in (-pi, pi]) added to the points'
  // resultant ...
  static bool record_feature_angles(const Task& task, const double* aligned, const double* md,
                                    std::uint64_t* angles) noexcept {
    std::uint64_t any = 0;
    for (int k = 0; k < task.n_features(); ++k)
      any |= angles[k] = task.feature(k).axis_angle_rows(aligned + task.offset(k), md + task.offset(k));
    return any != 0;
  }
  void add_feature_angles(const Task& task, const std::uint64_t* angles, AngleResultant& sum) const noexcept {
    for (int k = 0; k < task.n_features(); ++k)
      for (int i = 0; i < std::min(task.feature(k).rows(), 64); ++i)
        if (angles[k] >> i & 1U) {
          const double d = e(task.row(k) + i);
          sum.add(std::cos(d), std::sin(d));
        }
  }
  // ... and, once the centre is known, re-wrapped about it as the points' are.
  void wrap_feature_angles(const Task& task, const std::uint64_t* angles, double centre) noexcept {
    for (int k = 0; k < task.n_features(); ++k)
      for (int i = 0; i < std::min(task.feature(k).rows(), 64); ++i)
        if (angles[k] >> i & 1U) e(task.row(k) + i) = wrap_about(e(task.row(k) + i), centre);
  }
  // assemble_features() for InteractionMatrix::current with each block's check folded in
  // (Feature::evaluate: the same rows, bit for bit, each measurement evaluated once where a kind
  // can); false, with nothing more computed, when a measurement is refused.
  // goal: each block's FeatureGoal (the goal cache).
  bool evaluate_features(const Task& task, const double* m, const double* md, double* aligned,
                         FeatureGoal* goal) noexcept {
    for (int k = 0; k < task.n_features(); ++k) {
      const Feature& f = task.feature(k);
      const int row = task.row(k), off = task.offset(k);
      double* mc = aligned + off;
      std::copy(m + off, m + off + f.size(), mc);
      FeatureGoal& g = goal[k];
      const double* gd = md + off;
      if (g.moments) {
        g.keep(gd, f.size(), [&] { detail::moments_goal(*g.moments, gd, g.goal); });
        if (detail::moments_evaluate(*g.moments, mc, g.goal, e.data() + row, J.middleRows(row, f.rows())))
          return false;
      } else if (g.pbvs || g.point25d) {
        const auto fill = [&](const auto& kind) {
          int entry = -1;
          g.refused = kind.check(gd, entry) != nullptr;
          if (!g.refused) kind.value(gd, g.sd.data());
        };
        if (g.pbvs) {
          g.keep(gd, f.size(), [&] { fill(*g.pbvs); });
          if (!evaluate_with_goal(*g.pbvs, g, mc, e.data() + row, J.middleRows(row, 6))) return false;
        } else {
          g.keep(gd, f.size(), [&] { fill(*g.point25d); });
          if (!evaluate_with_goal(*g.point25d, g, mc, e.data() + row, J.middleRows(row, 6))) return false;
        }
      } else if (f.evaluate(mc, gd, e.data() + row, J.middleRows(row, f.rows()))) {
        return false;
      }
    }
    return true;
  }
  void weigh(const Task& task) noexcept {
    const std::vector<double>& pw = task.point_weights();
    for (std::size_t b = 0; b < pw.size(); ++b) {
      const auto row = static_cast<Eigen::Index>(2 * b);
      J.template middleRows<2>(row) *= pw[b];
      e.template segment<2>(row) *= pw[b];
    }
    for (int k = 0; k < task.n_features(); ++k)
      if (task.weight(k) != 1.0) {
        J.middleRows(task.row(k), task.feature(k).rows()) *= task.weight(k);
        e.segment(task.row(k), task.feature(k).rows()) *= task.weight(k);
      }
    for (int i = 0; i < 6; ++i)
      if (!task.dof()[static_cast<std::size_t>(i)]) J.col(i).setZero();
  }

  // x = J+ e by the route of solve.hpp, and what the options ask about J's singular values
  // (with degrees of freedom left out: computed now, of the kept columns).
  detail::Route solve(const ServoOptions& o, Eigen::Index m, Twist& x, detail::Spectrum& spectrum,
                      const Dof* dof = nullptr) noexcept {
    const detail::Diagnostics d = !o.diagnostics                 ? detail::Diagnostics::off
                                  : o.exact_diagnostics || dof ? detail::Diagnostics::exact
                                                               : detail::Diagnostics::lazy;
    return solver.solve(J, e, m, o.damping, d, x, spectrum, dof);
  }
};

}  // namespace

struct Servo::Kernel {
  // Built in place (the workspaces are large and never move).
  std::variant<std::monostate, Work<8>, Work<16>, Work<Eigen::Dynamic, max_realtime_rows>,
               Work<Eigen::Dynamic, Eigen::Dynamic>>
      work;

  Eigen::VectorXd aligned;  // the current measurements, aligned to the goal's (feature blocks)
  std::vector<std::uint64_t> angles;  // each feature block's angle rows this frame (consistent wrap)
  MatrixX6 spare;           // a feature block's rows at the goal (InteractionMatrix::mean)
  Points uv_valid;          // uv and depth with the lost points at their goal (ServoInput::valid)
  Eigen::VectorXd z_valid;
  std::vector<GoalPoint> goal;  // each point's goal-side polar values (sized here: no allocation per frame)
  std::vector<FeatureGoal> feature_goal;  // each feature block's goal side (image moments)

  explicit Kernel(const Task& task) {
    const int rows = task.rows();
    if (rows == 8 && task.points_only())  // the fixed-size kernels serve the point layouts
      work.emplace<Work<8>>(8);
    else if (rows == 16 && task.points_only())
      work.emplace<Work<16>>(16);
    else if (rows <= max_realtime_rows)
      work.emplace<Work<Eigen::Dynamic, max_realtime_rows>>(rows);
    else
      work.emplace<Work<Eigen::Dynamic, Eigen::Dynamic>>(rows);
    int largest = 0;
    for (int k = 0; k < task.n_features(); ++k) largest = std::max(largest, task.feature(k).rows());
    aligned = Eigen::VectorXd::Zero(task.measurement_size());
    angles.assign(static_cast<std::size_t>(task.n_features()), 0);
    spare = MatrixX6::Zero(largest, 6);
    uv_valid = Points::Zero(2, task.n_points());
    z_valid = Eigen::VectorXd::Ones(task.n_points());
    goal.assign(static_cast<std::size_t>(task.n_points()), GoalPoint{});
    feature_goal.assign(static_cast<std::size_t>(task.n_features()), FeatureGoal{});
    for (int k = 0; k < task.n_features(); ++k) {  // the kinds are final classes: these are exact
      FeatureGoal& g = feature_goal[static_cast<std::size_t>(k)];
      g.moments = dynamic_cast<const MomentsFeature*>(&task.feature(k));
      g.pbvs = dynamic_cast<const PbvsFeature*>(&task.feature(k));
      g.point25d = dynamic_cast<const Point25DFeature*>(&task.feature(k));
    }
  }
};

void detail::ServoCaches::forget(Servo& servo) noexcept {
  for (GoalPoint& g : servo.kernel_->goal) g = GoalPoint{};
  for (FeatureGoal& g : servo.kernel_->feature_goal) g.filled = false;
}

ServoInput::ServoInput(const Task& task)
    : uv(Points::Zero(2, task.n_points())),
      depth(Eigen::VectorXd::Ones(task.n_points())),
      uv_desired(Points::Zero(2, task.n_points())),
      depth_desired(Eigen::VectorXd::Ones(task.n_points())),
      measurements(Eigen::VectorXd::Zero(task.measurement_size())),
      measurements_desired(Eigen::VectorXd::Zero(task.measurement_size())),
      valid(PointMask::Constant(task.n_points(), true)) {}

ServoOutput::ServoOutput(const Task& task)
    : error(Eigen::VectorXd::Zero(task.rows())), jacobian(MatrixX6::Zero(task.rows(), 6)) {}

// Special members out of line: the buffers are allocated and freed by the library's code only.
ServoInput::ServoInput(const ServoInput&) = default;
ServoInput::ServoInput(ServoInput&&) noexcept = default;
ServoInput& ServoInput::operator=(const ServoInput&) = default;
ServoInput& ServoInput::operator=(ServoInput&&) noexcept = default;
ServoInput::~ServoInput() = default;
ServoOutput::ServoOutput(const ServoOutput&) = default;
ServoOutput::ServoOutput(ServoOutput&&) noexcept = default;
ServoOutput& ServoOutput::operator=(const ServoOutput&) = default;
ServoOutput& ServoOutput::operator=(ServoOutput&&) noexcept = default;
ServoOutput::~ServoOutput() = default;

void ServoOutput::set_singular_values(double smin, double smax) noexcept {
  sigma_min_ = smin;
  sigma_max_ = smax;
  pending_ = false;
}

void ServoOutput::set_gram(const Eigen::Matrix<double, 6, 6>& gram) noexcept {
  gram_ = gram;
  pending_ = true;
}

void ServoOutput::clear_singular_values() noexcept {
  set_singular_values(std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN());
}

// The lazy part of the diagnostics: the exact eigenvalues of the kept J^T J (solve.hpp).
void ServoOutput::resolve() const noexcept {
  if (!pending_) return;
  pending_ = false;
  double smin = std::numeric_limits<double>::quiet_NaN(), smax = smin;
  detail::Solver<6>::from_gram(gram_, smin, smax);
  sigma_min_ = smin;
  sigma_max_ = smax;
}

double ServoOutput::sigma_min() const noexcept {
  resolve();
  return sigma_min_;
}

double ServoOutput::sigma_max() const noexcept {
  resolve();
  return sigma_max_;
}

double ServoOutput::condition() const noexcept {
  resolve();
  if (std::isnan(sigma_min_) || std::isnan(sigma_max_)) return std::numeric_limits<double>::quiet_NaN();
  return sigma_min_ > 0.0 ? sigma_max_ / sigma_min_ : std::numeric_limits<double>::infinity();
}

Servo::Servo(Task task, ServoOptions options)
    : task_(std::move(task)) {
  if (task_.rows() == 0) throw std::invalid_argument("ibvs: task: no points and no feature blocks (nothing to servo)");
  set_options(options);
  kernel_ = std::make_unique<Kernel>(task_);
}

Servo::~Servo() = default;
Servo::Servo(Servo&&) noexcept = default;
Servo& Servo::operator=(Servo&&) noexcept = default;

void Servo::validate(const ServoOptions& o) {
  detail::check_gain(o.gain, "gain");
  detail::check_nonnegative(o.damping, "damping");
  if (o.damping > max_matrix_entry)
    throw std::invalid_argument("ibvs: damping = " + detail::number(o.damping) + " is above the limit " +
                                detail::number(max_matrix_entry));
  detail::check_nonnegative(o.polar_min_radius, "polar_min_radius");
  const AdaptiveGain& a = o.adaptive_gain;
  if (a.enabled() || a.at_infinity != 0.0 || a.slope_at_zero != 0.0) {
    detail::check_gain(a.at_zero, "adaptive_gain.at_zero");
    if (!(a.at_infinity > 0.0) || !(a.at_infinity <= a.at_zero))
      throw std::invalid_argument("ibvs: adaptive_gain.at_infinity must be > 0 and <= at_zero, got " +
                                  detail::number(a.at_infinity));
    detail::check_nonnegative(a.slope_at_zero, "adaptive_gain.slope_at_zero");
  }
  if (!(o.max_linear_speed > 0.0))
    throw std::invalid_argument("ibvs: max_linear_speed must be > 0 (inf = no limit), got " +
                                detail::number(o.max_linear_speed));
  if (!(o.max_angular_speed > 0.0))
    throw std::invalid_argument("ibvs: max_angular_speed must be > 0 (inf = no limit), got " +
                                detail::number(o.max_angular_speed));
  if (o.jacobian != InteractionMatrix::current && o.jacobian != InteractionMatrix::desired &&
      o.jacobian != InteractionMatrix::mean)
    throw std::invalid_argument("ibvs: jacobian must be current, desired or mean");
  detail::check_angle_wrap(o.angle_wrap);
  const Smoothing& sm = o.smoothing;
  detail::check_nonnegative(sm.decay_rate, "smoothing.decay_rate");
  if (!(sm.max_linear_acceleration > 0.0))
    throw std::invalid_argument("ibvs: smoothing.max_linear_acceleration must be > 0 (inf = no limit), got " +
                                detail::number(sm.max_linear_acceleration));
  if (!(sm.max_angular_acceleration > 0.0))
    throw std::invalid_argument("ibvs: smoothing.max_angular_acceleration must be > 0 (inf = no limit), got " +
                                detail::number(sm.max_angular_acceleration));
  detail::check_nonnegative(sm.period, "smoothing.period");
  detail::check_nonnegative(o.cartesian_near_goal, "cartesian_near_goal");
  detail::check_nonnegative(o.stop_time, "stop_time");
  if ((sm.enabled() || o.stop_time > 0.0) && !(sm.period > 0.0))
    throw std::invalid_argument(
        "ibvs: smoothing.period must be > 0 (the control period, s) with a decay_rate, an acceleration limit or a "
        "stop_time");
}

void Servo::set_options(const ServoOptions& options) {
  validate(options);
  if (options.angle_wrap != options_.angle_wrap) wrap_centre_.set(std::numeric_limits<double>::quiet_NaN());
  // A change of the law (not of a gain or a limit, which may be scheduled every frame): a transition.
  if (options.angle_wrap != options_.angle_wrap || options.jacobian != options_.jacobian ||
      options.polar_min_radius != options_.polar_min_radius || options.cartesian_near_goal != options_.cartesian_near_goal)
    smoother_.switch_law();
  options_ = options;
  extras_ = options.smoothing.enabled() || options.cartesian_near_goal > 0.0 || options.stop_time > 0.0;
  near_options_ = options;
  near_options_.polar_min_radius = std::numeric_limits<double>::infinity();
}

void Servo::continue_turn(double centre) {
  if (!std::isnan(centre) && !(std::abs(centre) <= pi + wrap_hysteresis))
    throw std::invalid_argument("ibvs: continue_turn: centre must be NaN or within pi + pi/4 of 0 (radians), got " +
                                detail::number(centre));
  wrap_centre_.set(centre);
}

void Servo::reset(const Twist& current) noexcept {
  wrap_centre_.set(std::numeric_limits<double>::quiet_NaN());
  smoother_.switch_law(current);
  near_goal_ = stopping_ = false;
}

void Servo::switch_law(const Twist& from) noexcept { smoother_.switch_law(from); }

void Servo::validate(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                     const Eigen::Ref<const Points>& uv_desired,
                     const Eigen::Ref<const Eigen::VectorXd>& depth_desired) const {
  const int n = task_.n_points();
  detail::check_points(uv, "uv", n);
  detail::check_depth(depth, "depth", n);
  detail::check_points(uv_desired, "uv_desired", n);
  // depth_desired: its size always (as update() checks it), its values when the mode uses them.
  if (options_.jacobian != InteractionMatrix::current) detail::check_depth(depth_desired, "depth_desired", n);
  else if (depth_desired.size() != n)
    throw std::invalid_argument("ibvs: depth_desired must hold " + std::to_string(n) + " depths for this layout, got " +
                                std::to_string(depth_desired.size()));
}

void Servo::validate(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                     const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                     const Eigen::Ref<const Eigen::VectorXd>& measurements,
                     const Eigen::Ref<const Eigen::VectorXd>& measurements_desired) const {
  validate(uv, depth, uv_desired, depth_desired);
  const Eigen::Index size = task_.measurement_size();
  if (measurements.size() != size || measurements_desired.size() != size)
    throw std::invalid_argument("ibvs: measurements and measurements_desired must hold " + std::to_string(size) +
                                " values for this task's feature blocks, got " + std::to_string(measurements.size()) +
                                " and " + std::to_string(measurements_desired.size()));
  for (int k = 0; k < task_.n_features(); ++k) {
    const Feature& f = task_.feature(k);
    const std::string block = "[block " + std::to_string(k) + ", " + f.describe() + "]";
    f.validate(measurements.data() + task_.offset(k), "measurements" + block);
    f.validate(measurements_desired.data() + task_.offset(k), "measurements_desired" + block);
  }
}

void Servo::validate(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                     const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                     const Eigen::Ref<const Eigen::VectorXd>& measurements,
                     const Eigen::Ref<const Eigen::VectorXd>& measurements_desired, const PointMask& valid) const {
  const int n = task_.n_points();
  if (valid.size() != n)
    throw std::invalid_argument("ibvs: valid must hold " + std::to_string(n) + " flags for this task, got " +
                                std::to_string(valid.size()));
  if (valid.all()) return validate(uv, depth, uv_desired, depth_desired, measurements, measurements_desired);
  // The sizes first (these throw their size messages), before the valid columns are read.
  if (uv.cols() != n) detail::check_points(uv, "uv", n);
  if (depth.size() != n) detail::check_depth(depth, "depth", n);
  // The valid points' values, then everything else as above with the lost points at their goal.
  Points uv_v = uv;
  Eigen::VectorXd z_v = depth;
  for (int i = 0; i < n; ++i)
    if (!valid(i)) {
      if (uv_desired.cols() == n && uv_desired.col(i).allFinite()) uv_v.col(i) = uv_desired.col(i);
      else uv_v.col(i).setZero();
      z_v(i) = 1.0;
    }
  validate(uv_v, z_v, uv_desired, depth_desired, measurements, measurements_desired);
}

Servo automatic_hybrid(int n_points, ServoOptions options, double switch_radius) {
  detail::check_nonnegative(switch_radius, "switch_radius");
  options.polar_min_radius = switch_radius;
  return Servo(Layout::polar(n_points), options);
}

Status Servo::update(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                     const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                     ServoOutput& out) noexcept {
  const Eigen::VectorXd none;  // no measurements: right for a task of points only, refused otherwise
  return update(uv, depth, uv_desired, depth_desired, none, none, out);
}

namespace {
// Every feature block's measurement accepted (Feature::check: what validate() refuses).
bool valid_measurements(const Task& task, const Eigen::Ref<const Eigen::VectorXd>& m) noexcept {
  if (m.size() != task.measurement_size()) return false;
  int entry = 0;
  for (int k = 0; k < task.n_features(); ++k)
    if (task.feature(k).check(m.data() + task.offset(k), entry)) return false;
  return true;
}
}  // namespace

Status Servo::update(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                     const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                     const Eigen::Ref<const Eigen::VectorXd>& measurements,
                     const Eigen::Ref<const Eigen::VectorXd>& measurements_desired, ServoOutput& out) noexcept {
  return step(uv, depth, uv_desired, depth_desired, measurements, measurements_desired, nullptr, 0, out);
}

Status Servo::update(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                     const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                     const Eigen::Ref<const Eigen::VectorXd>& measurements,
                     const Eigen::Ref<const Eigen::VectorXd>& measurements_desired, const PointMask& valid,
                     ServoOutput& out) noexcept {
  const int n = task_.n_points();
  // All valid: the plain step (bit for bit). Otherwise the lost points are put at their goal
  // (finite, zero error) in the kernel's copies, and their rows are zeroed after assembly.
  if (valid.size() == n && valid.all())
    return step(uv, depth, uv_desired, depth_desired, measurements, measurements_desired, nullptr, 0, out);
  Kernel& kernel = *kernel_;
  if (valid.size() != n || uv.cols() != n || depth.size() != n || uv_desired.cols() != n) {
    smoother_.note(Twist::Zero());
    return detail::refuse(out);
  }
  kernel.uv_valid = uv;
  kernel.z_valid = depth;
  int lost = 0;
  for (int i = 0; i < n; ++i)
    if (!valid(i)) {
      kernel.uv_valid.col(i) = uv_desired.col(i);
      kernel.z_valid(i) = 1.0;
      ++lost;
    }
  return step(kernel.uv_valid, kernel.z_valid, uv_desired, depth_desired, measurements, measurements_desired, &valid,
              lost, out);
}

// The step; valid: null (every point), or the points measured (lost of them are not).
Status Servo::step(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                   const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                   const Eigen::Ref<const Eigen::VectorXd>& measurements,
                   const Eigen::Ref<const Eigen::VectorXd>& measurements_desired, const PointMask* valid, int lost,
                   ServoOutput& out) noexcept {
  out.pixel_error = std::numeric_limits<double>::quiet_NaN();  // set by update_pixels() after this
  const Layout& layout = task_.points();
  const int n = layout.n_points();
  const Eigen::Index m = task_.rows();
  const bool uses_zd = options_.jacobian != InteractionMatrix::current;
  Kernel& kernel = *kernel_;
  const bool plain = task_.points_only();
  // With the current interaction matrix the feature blocks are checked and evaluated in one
  // pass (Feature::evaluate), first, so that a refused frame changes no state.
  const bool fused = !plain && !uses_zd;
  const Eigen::Index size = task_.measurement_size();
  // Exactly what validate() refuses (tests/cpp/test_fuzz.cpp checks that the two agree).
  const bool ok =
      uv.cols() == n && uv_desired.cols() == n && depth.size() == n && depth_desired.size() == n &&
      out.error.size() == m && out.jacobian.rows() == m && detail::valid_points(uv) &&
      detail::valid_points(uv_desired) && detail::valid_depths(depth) &&
      (!uses_zd || detail::valid_depths(depth_desired)) &&
      (plain || fused ? measurements.size() == size && measurements_desired.size() == size  // (plain: no blocks)
                      : valid_measurements(task_, measurements) && valid_measurements(task_, measurements_desired)) &&
      (!fused || std::visit(
                     [&](auto& w) noexcept {
                       if constexpr (std::is_same_v<std::decay_t<decltype(w)>, std::monostate>) return false;
                       else return w.evaluate_features(task_, measurements.data(), measurements_desired.data(),
                                                       kernel.aligned.data(), kernel.feature_goal.data());
                     },
                     kernel.work));
  if (!ok) {
    smoother_.note(Twist::Zero());  // the refusal's zero twist: a later law starts from rest
    return detail::refuse(out);
  }
  // The automatic law switch: every polar block Cartesian near the goal (with hysteresis).
  if (extras_ && options_.cartesian_near_goal > 0.0) switch_near_goal(uv, uv_desired, valid);
  const ServoOptions& o = near_goal_ ? near_options_ : options_;
  return std::visit(
      [&](auto& w) noexcept {
        if constexpr (std::is_same_v<std::decay_t<decltype(w)>, std::monostate>) {
          return detail::refuse(out);  // unreachable: the constructor always builds a kernel
        } else {
        const bool consistent = o.angle_wrap == AngleWrap::consistent;
        // The feature blocks before the points (when not fused: evaluated already), and their
        // angle rows about the axis, which join the consistent wrap.
        if (!plain && !fused)
          w.assemble_features(task_, o.jacobian, measurements.data(), measurements_desired.data(),
                              kernel.aligned.data(), kernel.spare);
        const bool feature_angles = !plain && consistent &&
                                    w.record_feature_angles(task_, kernel.aligned.data(), measurements_desired.data(),
                                                            kernel.angles.data());
        // Consistent wrap: this frame's circular mean (the points' resultant summed by assemble()),
        // continued from the previous frame's centre; then the angles wrapped about it.
        double centre = std::numeric_limits<double>::quiet_NaN();
        AngleResultant sum;
        out.polar_fallbacks = w.assemble(layout, o, uv, depth, uv_desired, depth_desired, kernel.goal.data(), valid,
                                         consistent ? &sum : nullptr);
        if (consistent) {
          if (feature_angles) w.add_feature_angles(task_, kernel.angles.data(), sum);
          if (sum.defined() && !feature_angles && sum.c > 0.0 && w.angles_within(small_angle_difference)) {
            // The centre is this frame's mean (continued_centre's choice when |mean| < pi / 2) and
            // wrapping about it moves no angle (each |difference| <= 1.5 and |centre| <= pi / 2):
            // its atan2 waits until a frame reads it.
            wrap_centre_.defer(sum);
          } else {
            if (sum.defined()) {
              centre = continued_centre(sum.mean(), wrap_centre_.get());
              wrap_centre_.set(centre);
            }
            w.wrap_about_centre(layout, o, uv, depth, uv_desired, depth_desired, kernel.goal.data(), centre);
          }
        }
        if (!plain) {
          if (feature_angles && !std::isnan(centre)) w.wrap_feature_angles(task_, kernel.angles.data(), centre);
          w.weigh(task_);
        }
        out.lost_points = lost;
        bool enough = true;
        if (valid) {  // the lost points' rows out of the law; enough rows left for the task's DOF?
          w.key ^= drop_lost(layout, *valid, w.J, w.e);
          enough = 2 * (n - lost) + (m - task_.point_rows()) >= task_.n_dof();
        }
        constexpr int rows = std::decay_t<decltype(w)>::Jac::RowsAtCompileTime;
        if constexpr (rows >= 16) {
          // The fixed 16-row kernel (m = rows): both column-major, so one block copy each: libc's
          // memcpy (wider moves than the library is compiled to) beat the element copies by ~4 %
          // of the stacked(4) step; in the 8-row kernels it lost ~8 % (ibvs-bench, alternate runs).
          std::memcpy(out.error.data(), w.e.data(), sizeof(double) * rows);
          std::memcpy(out.jacobian.data(), w.J.data(), sizeof(double) * rows * 6);
        } else if constexpr (rows != Eigen::Dynamic) {  // the 8-row kernels: fixed-size copies (m = rows)
          Eigen::Map<Eigen::Matrix<double, rows, 1>>(out.error.data()) = w.e;
          Eigen::Map<Eigen::Matrix<double, rows, 6>>(out.jacobian.data()) = w.J;
        } else {
          out.error = w.e.head(m);
          out.jacobian = w.J.topRows(m);
        }
        out.error_norm = out.error.norm();
        const AdaptiveGain& ag = o.adaptive_gain;
        out.gain = ag.enabled() ? ag(out.error_norm) : o.gain;
        out.law_switched = out.acceleration_limited = false;
        if (!enough) {
          pattern_ = w.key;
          w.key = 0;
          return stop(out);
        }
        stopping_ = false;
        Twist x;
        detail::Spectrum spectrum;
        w.solve(o, m, x, spectrum, plain || task_.dof() == all_dof ? nullptr : &task_.dof());
        if (spectrum.known) out.set_singular_values(spectrum.smin, spectrum.smax);
        else if (o.diagnostics) out.set_gram(w.solver.N0);  // computed when read
        else out.clear_singular_values();
        out.velocity = -out.gain * x;
        out.saturation_scale = saturation_scale(out.velocity, o.max_linear_speed, o.max_angular_speed);
        out.saturated = out.saturation_scale < 1.0;
        if (out.saturated) out.velocity *= out.saturation_scale;
        if (extras_) {  // smoothing, the near-goal switch or a stop ramp: the twist's history matters
          smooth(w.key ^ fallback_pattern(layout, o.polar_min_radius, uv, uv_desired), out);
          w.key = 0;
        }
        return out.status = spectrum.singular ? Status::singular : Status::ok;
        }
      },
      kernel.work);
}

// The automatic law switch: every polar block Cartesian near the goal (with hysteresis).
[[gnu::noinline]] void Servo::switch_near_goal(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Points>& uv_desired,
                             const PointMask* valid) noexcept {
  double far = 0.0;
  for (Eigen::Index i = 0; i < uv.cols(); ++i)
    if (!valid || (*valid)(i)) far = std::max(far, (uv.col(i) - uv_desired.col(i)).norm());
  near_goal_ = far < options_.cartesian_near_goal * (near_goal_ ? near_goal_hysteresis : 1.0);
}

// The smooth law (smoothing.hpp) on the step's twist; key: this step's Cartesian / polar choices
// and lost points (a change of them is a change of law).
[[gnu::noinline]] void Servo::smooth(std::uint64_t key, ServoOutput& out) noexcept {
  const ServoOptions& o = options_;
  const Smoothing& sm = o.smoothing;
  if (sm.enabled()) {
    if (key != pattern_) smoother_.switch_law();
    out.law_switched = smoother_.switching() && sm.decay_rate > 0.0;
    out.acceleration_limited = smoother_.apply(sm, o.max_linear_speed, o.max_angular_speed, out.velocity);
  } else {
    smoother_.note(out.velocity);
  }
  pattern_ = key;
}

// Too few valid points: the twist ramps linearly to zero from the one commanded when the stop began.
[[gnu::noinline]] Status Servo::stop(ServoOutput& out) noexcept {
  if (!stopping_) {
    stopping_ = true;
    stop_elapsed_ = 0.0;
    stop_from_ = smoother_.last();
  }
  stop_elapsed_ += options_.smoothing.period;
  const double left = options_.stop_time > 0.0 ? std::max(0.0, 1.0 - stop_elapsed_ / options_.stop_time) : 0.0;
  out.velocity = left * stop_from_;
  out.saturated = false;
  out.saturation_scale = 1.0;
  out.clear_singular_values();
  smoother_.note(out.velocity);
  smoother_.switch_law();  // when the points return, the law starts from the twist of the ramp
  return out.status = Status::features_lost;
}

Status detail::refuse(ServoOutput& out) noexcept {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.velocity.setZero();
  out.error.setConstant(nan);
  out.error_norm = nan;
  out.jacobian.setConstant(nan);
  out.clear_singular_values();
  out.polar_fallbacks = 0;
  out.lost_points = 0;
  out.law_switched = out.acceleration_limited = false;
  out.gain = 0.0;
  out.saturated = false;
  out.saturation_scale = 1.0;
  return out.status = Status::invalid_input;
}

}  // namespace ibvs
