// Servo::update's goal caches (cpp/src/servo_caches.hpp) change no output: two servos of the
// same task and options see the same random frames, one keeping its caches, the other emptying
// them before every step (the uncached computation), and every output agrees bit for bit:
// status, twist, error, Jacobian, the sigma values, counts and flags. The frames hold what the
// caches must survive: goals that stay, move (all points, one point, one coordinate, a zero's sign), lost points,
// polar fallbacks near r = 0 (goal or current point), goal points at r = 0 exactly (the
// cylindrical blocks borrow a direction), the exact half-turn, the near-goal law switch,
// smoothing and stop ramps, reset(), refused frames, and every interaction matrix and wrap; and
// image-moment, PBVS and 2.5-D blocks (alone or beside points) whose goal measurement stays, moves
// or is refused.
#include "check.hpp"
#include "ibvs/ibvs.hpp"
#include "features/moments_goal.hpp"
#include "servo_caches.hpp"

#include <cstring>
#include <random>
#include <vector>

namespace {

using ibvs::Points;

template <class A>
bool same_bits(const A& a, const A& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Every output of the two steps, bit for bit (the sigma values read, so computed, on both).
void check_same(ibvs::Status sa, const ibvs::ServoOutput& a, ibvs::Status sb, const ibvs::ServoOutput& b) {
  CHECK(sa == sb);
  CHECK(a.status == b.status);
  CHECK(same_bits(a.velocity, b.velocity));
  CHECK(same_bits(a.error, b.error));
  CHECK(same_bits(a.jacobian, b.jacobian));
  CHECK(same_bits(a.error_norm, b.error_norm));
  CHECK(same_bits(a.gain, b.gain));
  CHECK(same_bits(a.saturation_scale, b.saturation_scale));
  CHECK(same_bits(a.sigma_min(), b.sigma_min()));
  CHECK(same_bits(a.sigma_max(), b.sigma_max()));
  CHECK(a.polar_fallbacks == b.polar_fallbacks);
  CHECK(a.lost_points == b.lost_points);
  CHECK(a.saturated == b.saturated);
  CHECK(a.law_switched == b.law_switched);
  CHECK(a.acceleration_limited == b.acceleration_limited);
}

ibvs::Layout random_layout(std::mt19937& rng, int n) {
  using R = ibvs::Representation;
  switch (std::uniform_int_distribution<int>(0, 4)(rng)) {
    case 0: return ibvs::Layout::cartesian(n);
    case 1: return ibvs::Layout::polar(n);
    case 2: return ibvs::Layout::stacked(n);
    case 3: return ibvs::Layout::cylindrical(n);
    default: {  // each point one or two of the three kinds
      std::vector<ibvs::Block> blocks;
      const R kinds[3] = {R::cartesian, R::polar, R::cylindrical};
      for (int i = 0; i < n; ++i) {
        const int k = std::uniform_int_distribution<int>(0, 2)(rng);
        blocks.push_back({i, kinds[k]});
        if (rng() % 2) blocks.push_back({i, kinds[(k + 1) % 3]});
      }
      return ibvs::Layout(blocks, n);
    }
  }
}

ibvs::ServoOptions random_options(std::mt19937& rng) {
  ibvs::ServoOptions o;
  const ibvs::InteractionMatrix which[3] = {ibvs::InteractionMatrix::current, ibvs::InteractionMatrix::desired,
                                            ibvs::InteractionMatrix::mean};
  o.jacobian = which[rng() % 3];
  o.angle_wrap = rng() % 4 ? ibvs::AngleWrap::consistent : ibvs::AngleWrap::per_point;
  o.damping = rng() % 2 ? 0.0 : 0.01;
  o.diagnostics = rng() % 3 != 0;
  o.exact_diagnostics = rng() % 5 == 0;
  const double radii[3] = {ibvs::default_polar_min_radius, 0.05, 0.3};
  o.polar_min_radius = radii[rng() % 3];
  if (rng() % 3 == 0) o.cartesian_near_goal = 0.05;
  if (rng() % 3 == 0) {
    o.smoothing.decay_rate = 4.0;
    o.smoothing.max_linear_acceleration = 1.0;
    o.smoothing.period = 1e-2;
    o.stop_time = 0.1;
  }
  return o;
}

// A goal point: usually on a ring, sometimes at the principal point exactly (either zero's sign)
// or near it (a polar fallback).
Eigen::Vector2d goal_point(std::mt19937& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  switch (rng() % 8) {
    case 0: return {rng() % 2 ? 0.0 : -0.0, rng() % 2 ? 0.0 : -0.0};
    case 1: return {0.01 * U(rng), 0.01 * U(rng)};
    default: {
      const double a = ibvs::pi * U(rng), r = 0.1 + 0.2 * std::abs(U(rng));
      return {r * std::cos(a), r * std::sin(a)};
    }
  }
}

void random_episode(std::mt19937& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const int n = std::uniform_int_distribution<int>(1, 6)(rng);
  const ibvs::Layout layout = random_layout(rng, n);
  const ibvs::ServoOptions options = random_options(rng);
  ibvs::Servo cached(layout, options), fresh(layout, options);
  ibvs::ServoOutput a(layout), b(layout);
  Points uvd(2, n);
  for (int i = 0; i < n; ++i) uvd.col(i) = goal_point(rng);
  Eigen::VectorXd zd = Eigen::VectorXd::Constant(n, 0.8 + 0.4 * std::abs(U(rng)));
  const Eigen::VectorXd none;
  for (int frame = 0; frame < 30; ++frame) {
    // The goal moves now and then: every point, one point, a zero's sign, a desired depth, one coordinate.
    switch (rng() % 10) {
      case 0:
        for (int i = 0; i < n; ++i) uvd.col(i) = goal_point(rng);
        break;
      case 1: uvd.col(static_cast<int>(rng() % n)) = goal_point(rng); break;
      case 2: {
        double& x = uvd(static_cast<int>(rng() % 2), static_cast<int>(rng() % n));
        if (x == 0.0) x = -x;
        break;
      }
      case 3: zd(static_cast<int>(rng() % n)) = 0.8 + 0.4 * std::abs(U(rng)); break;
      case 4: uvd(static_cast<int>(rng() % 2), static_cast<int>(rng() % n)) *= 1.0 + 0.1 * U(rng); break;  // one coordinate
      default: break;
    }
    // The current points: the goal turned about the axis (the exact half-turn, u = -u*, now and
    // then), scaled and shifted, or at the goal, or near the principal point.
    Points uv(2, n);
    const int turn = static_cast<int>(rng() % 6);
    const double phi = ibvs::pi * U(rng), scale = 1.0 + 0.2 * U(rng);
    for (int i = 0; i < n; ++i) {
      if (turn == 0) uv.col(i) = -uvd.col(i);
      else if (turn == 1) uv.col(i) = uvd.col(i);
      else if (rng() % 10 == 0) uv.col(i) << 0.01 * U(rng), 0.01 * U(rng);
      else
        uv.col(i) << scale * (std::cos(phi) * uvd(0, i) - std::sin(phi) * uvd(1, i)) + 0.02 * U(rng),
            scale * (std::sin(phi) * uvd(0, i) + std::cos(phi) * uvd(1, i)) + 0.02 * U(rng);
    }
    Eigen::VectorXd z(n);
    for (int i = 0; i < n; ++i) z(i) = 1.0 + 0.3 * U(rng);
    if (rng() % 25 == 0) uv(0, 0) = std::numeric_limits<double>::quiet_NaN();  // refused
    ibvs::PointMask valid = ibvs::PointMask::Constant(n, true);
    for (int i = 0; i < n; ++i)
      if (rng() % 7 == 0) valid(i) = false;
    if (rng() % 20 == 0) {
      cached.reset();
      fresh.reset();
    }
    ibvs::detail::ServoCaches::forget(fresh);
    if (rng() % 2) {
      const ibvs::Status sa = cached.update(uv, z, uvd, zd, none, none, valid, a);
      const ibvs::Status sb = fresh.update(uv, z, uvd, zd, none, none, valid, b);
      check_same(sa, a, sb, b);
    } else {
      const ibvs::Status sa = cached.update(uv, z, uvd, zd, a);
      const ibvs::Status sb = fresh.update(uv, z, uvd, zd, b);
      check_same(sa, a, sb, b);
    }
  }
}

// Image moments of an irregular quadrilateral seen from a random pose about the goal pose (the
// object 0.6 m in front), or at the goal pose itself; a measurement the block refuses now and then.
Eigen::VectorXd moments_measurement(std::mt19937& rng, const ibvs::MomentsFeature& f, bool at_goal, double spread) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::Matrix<double, 3, 4> P;
  P << -0.07, 0.08, 0.05, -0.05, -0.05, -0.04, 0.06, 0.04, 0.0, 0.0, 0.0, 0.0;
  ibvs::Twist xi = ibvs::Twist::Zero();
  if (!at_goal) xi << 0.0, 0.0, 0.0, 0.25 * spread * U(rng), 0.25 * spread * U(rng), (rng() % 8 ? 1.0 : 6.0) * U(rng);
  ibvs::Pose cMo = ibvs::se3_exp(xi);
  cMo.topRightCorner<3, 1>() << (at_goal ? 0.0 : 0.05 * spread * U(rng)), (at_goal ? 0.0 : 0.05 * spread * U(rng)),
      0.6 + (at_goal ? 0.0 : 0.15 * spread * U(rng));
  const Eigen::Matrix3Xd Q = (cMo.topLeftCorner<3, 3>() * P).colwise() + cMo.topRightCorner<3, 1>();
  const auto m = ibvs::MomentsFeature::project(Q, f.source(), 0.0, 0.6);
  Eigen::VectorXd v = Eigen::Map<const Eigen::VectorXd>(m.data(), static_cast<Eigen::Index>(m.size()));
  if (rng() % 30 == 0) v(0) = -1.0;  // zero area: refused
  return v;
}

// Image moments alone, or beside points (stacked, cylindrical...), with the goal's measurement
// kept, moved or refused, and every option as above.
void moments_episode(std::mt19937& rng) {
  using MF = ibvs::MomentsFeature;
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const MF f(rng() % 2 ? MF::Source::region : MF::Source::points, rng() % 2 ? MF::Invariants::p : MF::Invariants::s,
             rng() % 2 ? MF::Alpha::third_order : MF::Alpha::second_order,
             rng() % 3 ? static_cast<unsigned>(MF::Row::all) : 1u + static_cast<unsigned>(rng() % 63));
  const int n = static_cast<int>(rng() % 4);
  ibvs::Task task(n ? random_layout(rng, n) : ibvs::Layout::none());
  task.add(f);
  if (rng() % 3 == 0) task.add(f);  // two blocks
  const ibvs::ServoOptions options = random_options(rng);
  ibvs::Servo cached(task, options), fresh(task, options);
  ibvs::ServoOutput a(task), b(task);
  const Eigen::Index size = task.measurement_size();
  const auto measurements = [&](bool at_goal, double spread) {
    Eigen::VectorXd m(size);
    for (int k = 0; k < task.n_features(); ++k)
      m.segment(task.offset(k), MF::measurement_size) = moments_measurement(rng, f, at_goal, spread);
    return m;
  };
  Eigen::VectorXd md = measurements(true, 0.0);
  Points uvd(2, n);
  for (int i = 0; i < n; ++i) uvd.col(i) = goal_point(rng);
  const Eigen::VectorXd zd = Eigen::VectorXd::Ones(n);
  for (int frame = 0; frame < 20; ++frame) {
    if (rng() % 6 == 0) md = measurements(rng() % 2 == 0, 0.3);  // the goal moves (or is refused)
    if (n > 0 && rng() % 10 == 0) uvd.col(0) = -uvd.col(0);  // a goal point moved
    const Eigen::VectorXd m = rng() % 8 ? measurements(false, 1.0) : md;
    Points uv(2, n);
    for (int i = 0; i < n; ++i) uv.col(i) = uvd.col(i) + Eigen::Vector2d(0.05 * U(rng), 0.05 * U(rng));
    const Eigen::VectorXd z = Eigen::VectorXd::Constant(n, 1.0 + 0.2 * U(rng));
    ibvs::PointMask valid = ibvs::PointMask::Constant(n, true);
    for (int i = 0; i < n; ++i)
      if (rng() % 7 == 0) valid(i) = false;
    ibvs::detail::ServoCaches::forget(fresh);
    const ibvs::Status sa = cached.update(uv, z, uvd, zd, m, md, valid, a);
    const ibvs::Status sb = fresh.update(uv, z, uvd, zd, m, md, valid, b);
    check_same(sa, a, sb, b);
  }
}

// PBVS (both targets) and 2.5-D blocks, alone, together or beside points, with the goal pose kept,
// moved or refused (a NaN), and every option as above.
void pose_episode(std::mt19937& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const int n = static_cast<int>(rng() % 4);
  ibvs::Task task(n ? random_layout(rng, n) : ibvs::Layout::none());
  const int kinds = 1 + static_cast<int>(rng() % 7);  // bits: PBVS to the goal camera, to the object, 2.5-D
  if (kinds & 1) task.add(ibvs::PbvsFeature(ibvs::PbvsTarget::desired_camera));
  if (kinds & 2) task.add(ibvs::PbvsFeature(ibvs::PbvsTarget::object));
  if (kinds & 4) task.add(ibvs::Point25DFeature());
  const ibvs::ServoOptions options = random_options(rng);
  ibvs::Servo cached(task, options), fresh(task, options);
  ibvs::ServoOutput a(task), b(task);
  const Eigen::Vector3d P(0.08, -0.04, 0.0);
  const auto pose = [&](double spread) {
    ibvs::Twist xi;
    xi << 0.05 * spread * U(rng), 0.05 * spread * U(rng), 0.1 * spread * U(rng), 0.3 * spread * U(rng),
        0.3 * spread * U(rng), (rng() % 8 ? 1.0 : 3.1) * spread * U(rng);
    ibvs::Pose T = ibvs::se3_exp(xi);
    T(2, 3) += 0.6;
    return T;
  };
  const auto measurements = [&](const ibvs::Pose& cMo, const ibvs::Pose& cdMo) {
    Eigen::VectorXd m(task.measurement_size());
    int k = 0;
    const auto put = [&](const std::array<double, 6>& v) {
      m.segment<6>(task.offset(k++)) = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(v.data());
    };
    if (kinds & 1) put(ibvs::PbvsFeature::measure(cMo, cdMo, ibvs::PbvsTarget::desired_camera));
    if (kinds & 2) put(ibvs::PbvsFeature::measure(cMo, cdMo, ibvs::PbvsTarget::object));
    if (kinds & 4) put(ibvs::Point25DFeature::measure(cMo, cdMo, P));
    return m;
  };
  ibvs::Pose goal = pose(0.5);
  Eigen::VectorXd md = measurements(goal, goal);
  Points uvd(2, n);
  for (int i = 0; i < n; ++i) uvd.col(i) = goal_point(rng);
  const Eigen::VectorXd zd = Eigen::VectorXd::Ones(n);
  for (int frame = 0; frame < 20; ++frame) {
    if (rng() % 6 == 0) {  // the goal moves, or one of its values is refused
      goal = pose(0.5);
      md = measurements(goal, goal);
      if (rng() % 4 == 0) md(static_cast<Eigen::Index>(rng() % md.size())) = std::numeric_limits<double>::quiet_NaN();
    }
    const Eigen::VectorXd m = rng() % 8 ? measurements(pose(1.0), goal) : md;
    Points uv(2, n);
    for (int i = 0; i < n; ++i) uv.col(i) = uvd.col(i) + Eigen::Vector2d(0.05 * U(rng), 0.05 * U(rng));
    const Eigen::VectorXd z = Eigen::VectorXd::Constant(n, 1.0 + 0.2 * U(rng));
    ibvs::PointMask valid = ibvs::PointMask::Constant(n, true);
    for (int i = 0; i < n; ++i)
      if (rng() % 7 == 0) valid(i) = false;
    ibvs::detail::ServoCaches::forget(fresh);
    const ibvs::Status sa = cached.update(uv, z, uvd, zd, m, md, valid, a);
    const ibvs::Status sb = fresh.update(uv, z, uvd, zd, m, md, valid, b);
    check_same(sa, a, sb, b);
  }
}

// The split moments evaluation (the goal's side once, detail::moments_goal; then
// detail::moments_evaluate) against MomentsFeature::evaluate itself: refused alike, and e and L
// bit for bit.
void moments_split_matches_evaluate(std::mt19937& rng) {
  using MF = ibvs::MomentsFeature;
  const MF f(rng() % 2 ? MF::Source::region : MF::Source::points, rng() % 2 ? MF::Invariants::p : MF::Invariants::s,
             rng() % 2 ? MF::Alpha::third_order : MF::Alpha::second_order,
             rng() % 3 ? static_cast<unsigned>(MF::Row::all) : 1u + static_cast<unsigned>(rng() % 63));
  const Eigen::VectorXd md = moments_measurement(rng, f, rng() % 2 == 0, 0.3);
  Eigen::VectorXd m = moments_measurement(rng, f, false, 1.0), m2 = m;
  ibvs::detail::MomentsGoal goal;
  ibvs::detail::moments_goal(f, md.data(), goal);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(6), e2 = e;
  ibvs::MatrixX6 L = ibvs::MatrixX6::Zero(6, 6), L2 = L;
  const bool refused = f.evaluate(m.data(), md.data(), e.data(), L) != nullptr;
  const bool refused2 = ibvs::detail::moments_evaluate(f, m2.data(), goal, e2.data(), L2) != nullptr;
  CHECK(refused == refused2);
  CHECK(same_bits(m, m2));
  CHECK(same_bits(e, e2));
  CHECK(same_bits(L, L2));
}

}  // namespace

void run_tests() {
  std::mt19937 rng(ibvs_test::seed);
  for (int c = 0; c < ibvs_test::cases; ++c) random_episode(rng);
  for (int c = 0; c < ibvs_test::cases / 2; ++c) moments_episode(rng);
  for (int c = 0; c < ibvs_test::cases / 2; ++c) pose_episode(rng);
  for (int c = 0; c < 4 * ibvs_test::cases; ++c) moments_split_matches_evaluate(rng);
}
