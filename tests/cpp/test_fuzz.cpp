// Fuzz target over Layout, Task (feature blocks, weights, DOF), Servo (options,
// validate, update), PartitionedServo, damped_pinv / singular_values and se3_exp,
// the simulator's feature sources (LineSource on a target, measure from any pose;
// short episodes of a line task), the wide-angle camera path (fisheye / omnidir bearings,
// PlanarPose::estimate_bearings), LuminanceServo and photometric_moments (images of any values):
// arbitrary bytes become a layout,
// options and inputs (every double bit pattern possible: NaN, inf, subnormals,
// 1e300), and the contract is checked:
//  * every function either throws std::invalid_argument or answers with finite numbers;
//  * Servo::validate throws exactly when Servo::update returns invalid_input, and
//    then update leaves a zero twist and NaN diagnostics (nothing of an earlier frame);
//  * an accepted update gives a finite twist, error and Jacobian, and finite
//    diagnostics (NaN only with diagnostics off).
// LLVMFuzzerTestOneInput is libFuzzer's entry point (clang -fsanitize=fuzzer;
// tests/CMakeLists.txt builds fuzz_ibvs with it when the compiler can). Here it
// is also a ctest: a seeded random driver feeds it [cases] inputs (default 500,
// x 20 below) of random bytes, and CI runs it under ASan + UBSan as well.
#include "check.hpp"

#include "ibvs/ibvs.hpp"
#include "ibvs/partitioned.hpp"
#include "ibvs/robot_mapping.hpp"
#include "ibvs/secondary_task.hpp"
#include "ibvs/sim/sim.hpp"
#include "ibvs/task.hpp"
#include "ibvs/features/ellipse.hpp"
#include "ibvs/features/line.hpp"
#include "ibvs/features/luminance.hpp"
#include "ibvs/features/moments.hpp"
#include "ibvs/features/segment.hpp"
#include "ibvs/features/spherical.hpp"
#include "ibvs/features/function.hpp"
#include "ibvs/features/pose.hpp"

#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <vector>

using namespace ibvs;

namespace {

/// Reads typed values from the bytes (zeros once they run out).
struct Bytes {
  const std::uint8_t* p;
  std::size_t n;
  std::uint8_t byte() noexcept { return n ? (--n, *p++) : 0; }
  int small(int lo, int hi) noexcept { return lo + byte() % (hi - lo + 1); }
  /// A double: half the time any bit pattern, else an "interesting" value
  /// (signed zero, powers of ten from 1e-320 to 1e300, specials, values near the limits).
  double real() noexcept {
    const std::uint8_t mode = byte();
    if (mode < 96) {
      std::uint64_t bits = 0;
      for (int i = 0; i < 8; ++i) bits = bits << 8 | byte();
      double x;
      std::memcpy(&x, &bits, sizeof x);
      return x;
    }
    const double sign = mode & 1 ? -1.0 : 1.0;
    switch (mode % 8) {
      case 0: return sign * 0.0;
      case 1: return std::numeric_limits<double>::quiet_NaN();
      case 2: return sign * std::numeric_limits<double>::infinity();
      case 3: return sign * std::numeric_limits<double>::denorm_min() * (1 + byte());
      default: {
        const int e = static_cast<int>(byte()) * 620 / 255 - 320;  // 1e-320 .. 1e300
        const double mant = 1.0 + byte() / 64.0;
        return sign * mant * std::pow(10.0, e);
      }
    }
  }
  /// Mostly plausible values (normalised coordinates, depths) with occasional hostile ones.
  double coordinate() noexcept { return byte() < 200 ? (byte() - 127.5) / 300.0 : real(); }
  double depth() noexcept { return byte() < 200 ? 0.1 + byte() / 25.0 : real(); }
  /// NaN, +-inf or a huge magnitude (beyond every limit of limits.hpp).
  double hostile() noexcept {
    const double sign = byte() & 1 ? -1.0 : 1.0;
    switch (byte() % 3) {
      case 0: return std::numeric_limits<double>::quiet_NaN();
      case 1: return sign * std::numeric_limits<double>::infinity();
      default: return sign * 1e300 * (1.0 + byte());
    }
  }
  /// Now and then, hostile values at random positions of x (any entry, not only the first): every
  /// array input goes through this, so a check that looks at some entries only is found.
  void poison(double* x, Eigen::Index n) noexcept {
    if (n <= 0) return;
    while (byte() >= 216) x[byte() % n] = hostile();
  }
  template <class M>
  void poison(M& x) noexcept {
    poison(x.data(), x.size());
  }
};

bool finite(double x) { return std::isfinite(x); }

void check_output(const ServoOutput& out, Status st, bool diagnostics, const char* what) {
  if (st == Status::invalid_input) {
    ibvs_test::report(out.velocity.isZero(0.0) && std::isnan(out.sigma_min()) && std::isnan(out.sigma_max()),
                      "refusal: zero twist, NaN diagnostics", __FILE__, __LINE__, what);
    return;
  }
  ibvs_test::report(out.velocity.allFinite() && out.error.allFinite() && out.jacobian.allFinite() &&
                        finite(out.error_norm) && finite(out.gain) && finite(out.saturation_scale),
                    "accepted: finite outputs", __FILE__, __LINE__, what);
  ibvs_test::report(diagnostics ? finite(out.sigma_min()) && finite(out.sigma_max()) && out.sigma_min() >= 0 &&
                                      out.sigma_min() <= out.sigma_max() * (1 + 1e-9)
                                : std::isnan(out.sigma_min()) && std::isnan(out.sigma_max()),
                    "diagnostics finite (NaN when off)", __FILE__, __LINE__, what);
}

void fuzz_servo(Bytes& b) {
  // Layout: a uniform one or random blocks (indices and representations may be invalid).
  std::optional<Layout> layout;
  try {
    const int kind = b.small(0, 4);
    const int n = b.small(-1, 9);
    if (kind == 0) layout = Layout::cartesian(n);
    else if (kind == 1) layout = Layout::polar(n);
    else if (kind == 2) layout = Layout::stacked(n);
    else if (kind == 3) layout = Layout::cylindrical(n);
    else {
      std::vector<Block> blocks(static_cast<std::size_t>(b.small(0, 8)));
      for (Block& k : blocks) {
        const std::uint8_t x = b.byte();
        k.point = x < 250 ? x % 8 : x == 250 ? -1 : x == 251 ? std::numeric_limits<int>::max() : max_points;
        k.representation = static_cast<Representation>(b.small(0, 3));
      }
      layout.emplace(std::move(blocks), b.byte() < 200 ? -1 : b.small(0, 10));
    }
  } catch (const std::invalid_argument&) {
    return;
  }
  CHECK(!layout->describe().empty() && *layout == *layout && layout->n_points() >= 1 && layout->rows() >= 2);

  ServoOptions o;
  o.gain = b.byte() < 200 ? 0.1 + b.byte() / 50.0 : b.real();
  o.damping = b.byte() < 128 ? 0.0 : b.byte() < 200 ? b.byte() / 1000.0 : std::abs(b.real());
  o.jacobian = static_cast<InteractionMatrix>(b.small(0, 3));
  o.polar_min_radius = b.byte() < 200 ? 1e-3 : b.real();
  o.diagnostics = b.byte() < 200;
  o.exact_diagnostics = b.byte() < 40;
  if (b.byte() > 220) o.adaptive_gain = {b.real(), b.real(), b.real()};
  if (b.byte() > 200) o.max_linear_speed = b.real();
  if (b.byte() > 200) o.max_angular_speed = b.real();
  bool options_ok = true;
  try {
    Servo::validate(o);
  } catch (const std::invalid_argument&) {
    options_ok = false;
  }
  std::optional<Servo> servo;
  try {
    servo.emplace(*layout, o);
  } catch (const std::invalid_argument&) {
  }
  ibvs_test::report(options_ok == servo.has_value(), "Servo(options) throws iff validate(options) does", __FILE__,
                    __LINE__);
  if (!servo) return;

  const int n = layout->n_points();
  ServoOutput out(*layout);
  for (int frame = 0; frame < 3; ++frame) {
    // Sizes mostly right; sometimes one off (every argument can be the wrong one).
    const int wrong = b.byte() < 230 ? -1 : b.small(0, 3);
    Points uv(2, wrong == 0 ? n + 1 : n), uvd(2, wrong == 1 ? n + 1 : n);
    Eigen::VectorXd z(wrong == 2 ? n + 1 : n), zd(wrong == 3 ? n + 1 : n);
    for (Eigen::Index i = 0; i < uv.size(); ++i) uv.data()[i] = b.coordinate();
    for (Eigen::Index i = 0; i < uvd.size(); ++i) uvd.data()[i] = b.coordinate();
    for (Eigen::Index i = 0; i < z.size(); ++i) z(i) = b.depth();
    for (Eigen::Index i = 0; i < zd.size(); ++i) zd(i) = b.depth();
    b.poison(uv), b.poison(uvd), b.poison(z), b.poison(zd);
    bool valid = true;
    try {
      servo->validate(uv, z, uvd, zd);
    } catch (const std::invalid_argument&) {
      valid = false;
    }
    const Status st = servo->update(uv, z, uvd, zd, out);
    ibvs_test::report(valid == (st != Status::invalid_input), "validate() throws iff update() refuses", __FILE__,
                      __LINE__, layout->describe());
    check_output(out, st, o.diagnostics, "Servo::update");
  }
}

void fuzz_partitioned(Bytes& b) {
  PartitionedOptions o;
  o.gain = b.byte() < 200 ? 0.5 : b.real();
  o.damping = b.byte() < 200 ? 0.0 : b.real();
  o.segment_first = b.small(-1, 4);
  o.segment_second = b.small(-1, 4);
  std::optional<PartitionedServo> servo;
  try {
    servo.emplace(b.small(2, 5), o);
  } catch (const std::invalid_argument&) {
    return;
  }
  const int n = servo->layout().n_points();
  ServoOutput out(servo->layout());
  Points uv(2, n), uvd(2, n);
  Eigen::VectorXd z(n);
  for (Eigen::Index i = 0; i < uv.size(); ++i) uv.data()[i] = b.coordinate();
  for (Eigen::Index i = 0; i < uvd.size(); ++i) uvd.data()[i] = b.coordinate();
  for (Eigen::Index i = 0; i < n; ++i) z(i) = b.depth();
  b.poison(uv), b.poison(uvd), b.poison(z);
  bool valid = true;
  try {
    servo->validate(uv, z, uvd);
  } catch (const std::invalid_argument&) {
    valid = false;
  }
  const Status st = servo->update(uv, z, uvd, z, out);
  ibvs_test::report(valid == (st != Status::invalid_input), "partitioned: validate() throws iff update() refuses",
                    __FILE__, __LINE__);
  check_output(out, st, true, "PartitionedServo::update");
}

void fuzz_pinv_exp(Bytes& b) {
  MatrixX6 J(b.small(0, 9), 6);
  const bool hostile = b.byte() < 128;
  const double scale = b.real();
  for (Eigen::Index i = 0; i < J.size(); ++i) J.data()[i] = hostile ? b.real() : scale * (b.byte() - 127.5);
  b.poison(J);
  const double lambda = b.byte() < 100 ? 0.0 : b.real();
  try {
    const Eigen::Matrix<double, 6, Eigen::Dynamic> P = damped_pinv(J, lambda);
    CHECK(P.allFinite() && P.cols() == J.rows());
  } catch (const std::invalid_argument&) {
  }
  try {
    CHECK(singular_values(J).allFinite());
  } catch (const std::invalid_argument&) {
  }
  Twist xi;
  for (int i = 0; i < 6; ++i) xi(i) = b.real();
  b.poison(xi);
  if (xi.allFinite() && xi.cwiseAbs().maxCoeff() <= max_twist_entry) {  // se3_exp's documented domain
    const Pose T = se3_exp(xi);
    CHECK(T.allFinite());
    const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
    CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-12);
  }
}

// Eye-to-hand JointMapping and SecondaryTask: options (refused by the constructor or accepted) and
// inputs from the bytes; validate() throwing implies update() refuses (the latter may also refuse
// finite input whose result overflows), a refusal leaves qdot = 0, an accepted update is finite.
void fuzz_mounting_secondary(Bytes& b) {
  const int n = b.small(1, 9);
  const bool hostile = b.byte() < 80;
  const auto value = [&] { return hostile ? b.real() : b.coordinate(); };
  Pose bMc = Pose::Identity();
  if (b.byte() < 40) bMc(b.small(0, 3), b.small(0, 3)) = b.real();
  b.poison(bMc);
  JointMappingOptions mo;
  mo.mounting = b.byte() < 128 ? Mounting::eye_to_hand : Mounting::eye_in_hand;
  mo.frame = b.byte() < 128 ? JacobianFrame::base : JacobianFrame::end_effector;
  std::optional<JointMapping> map;
  try {
    map.emplace(n, bMc, mo);
  } catch (const std::invalid_argument&) {
  }
  JointMappingInput in(n);
  JointMappingOutput out(n);
  for (Eigen::Index i = 0; i < in.jacobian.size(); ++i) in.jacobian.data()[i] = value();
  for (int i = 0; i < 6; ++i) in.twist(i) = value();
  in.base_pose.topRightCorner<3, 1>() << value(), value(), value();
  if (b.byte() < 30) in.base_pose(b.small(0, 3), b.small(0, 2)) = b.real();
  b.poison(in.jacobian), b.poison(in.twist), b.poison(in.base_pose);
  if (map) {
    bool valid = true;
    try {
      map->validate(in);
    } catch (const std::invalid_argument&) {
      valid = false;
    }
    const Status st = map->update(in, out);
    ibvs_test::report(valid || st == Status::invalid_input, "mapping: validate() throws => update() refuses",
                      __FILE__, __LINE__);
    CHECK(st == Status::invalid_input ? out.qdot.isZero(0.0) : out.qdot.allFinite());
  }
  SecondaryTaskOptions so;
  so.projector = b.byte() < 128 ? Projector::large : Projector::classical;
  if (b.byte() < 160) {
    so.q_min = JointVector::Constant(n, b.byte() < 30 ? b.real() : -1.0);
    so.q_max = JointVector::Constant(n, b.byte() < 30 ? b.real() : 1.0);
  }
  if (b.byte() < 30) so.rho = b.real();
  if (b.byte() < 30) so.switch_high = b.real();
  if (b.byte() < 100) so.max_joint_speed = JointVector::Constant(n, b.byte() < 30 ? b.real() : 0.5);
  if (b.byte() < 100) {
    so.max_joint_acceleration = JointVector::Constant(n, b.byte() < 30 ? b.real() : 2.0);
    so.period = b.byte() < 30 ? b.real() : 0.01;
  }
  b.poison(so.q_min), b.poison(so.q_max), b.poison(so.max_joint_speed), b.poison(so.max_joint_acceleration);
  std::optional<SecondaryTask> task;
  try {
    task.emplace(n, so);
  } catch (const std::invalid_argument&) {
    return;
  }
  SecondaryTaskInput sin(n);
  SecondaryTaskOutput sout(n);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j <= i; ++j) sin.task_gram(i, j) = sin.task_gram(j, i) = value();
  if (b.byte() < 20) sin.task_gram(0, 1) = b.real();  // perhaps not symmetric
  for (int i = 0; i < 6; ++i) sin.task_gradient(i) = value(), sin.twist(i) = value();
  sin.error_norm = b.byte() < 30 ? b.real() : std::abs(value());
  sin.camera_jacobian = in.jacobian;
  for (int i = 0; i < n; ++i) {
    sin.qdot(i) = value();
    sin.q(i) = value();
    sin.qdot_previous(i) = value();
    sin.joints(i) = value();
  }
  b.poison(sin.task_gram), b.poison(sin.task_gradient), b.poison(sin.twist), b.poison(sin.camera_jacobian);
  b.poison(sin.qdot), b.poison(sin.q), b.poison(sin.qdot_previous), b.poison(sin.joints);
  bool valid = true;
  try {
    task->validate(sin);
  } catch (const std::invalid_argument&) {
    valid = false;
  }
  const Status st = task->update(sin, sout);
  ibvs_test::report(valid || st == Status::invalid_input, "secondary: validate() throws => update() refuses", __FILE__,
                    __LINE__);
  CHECK(st == Status::invalid_input ? sout.qdot.isZero(0.0) : sout.qdot.allFinite());
}

// The smooth law and lost points (smoothing.hpp, ServoInput::valid): options with any values,
// a random validity mask (NaN where a point is lost), several frames so that transitions, the
// near-goal switch and the stop ramp happen. validate() throws iff update() refuses; accepted
// steps (ok, singular, features_lost) give a finite twist and error.
void fuzz_smooth(Bytes& b) {
  const int n = b.small(1, 6), kind = b.small(0, 2);
  const Layout layout = kind == 0 ? Layout::cartesian(n) : kind == 1 ? Layout::polar(n) : Layout::stacked(n);
  ServoOptions o;
  o.gain = b.byte() < 220 ? 0.1 + b.byte() / 50.0 : b.real();
  o.damping = b.byte() < 128 ? 0.0 : b.byte() / 1000.0;
  Smoothing& sm = o.smoothing;
  sm.decay_rate = b.byte() < 200 ? b.byte() / 10.0 : b.real();
  if (b.byte() > 100) sm.max_linear_acceleration = b.byte() < 200 ? 0.01 + b.byte() / 20.0 : b.real();
  if (b.byte() > 100) sm.max_angular_acceleration = b.byte() < 200 ? 0.01 + b.byte() / 20.0 : b.real();
  sm.period = b.byte() < 200 ? 0.001 + b.byte() / 1000.0 : b.real();
  o.cartesian_near_goal = b.byte() < 150 ? 0.0 : b.byte() < 230 ? b.byte() / 500.0 : b.real();
  o.stop_time = b.byte() < 150 ? 0.0 : b.byte() < 230 ? b.byte() / 100.0 : b.real();
  if (b.byte() > 200) o.max_linear_speed = b.byte() < 128 ? 0.05 : b.real();
  bool options_ok = true;
  try {
    Servo::validate(o);
  } catch (const std::invalid_argument&) {
    options_ok = false;
  }
  std::optional<Servo> servo;
  try {
    servo.emplace(layout, o);
  } catch (const std::invalid_argument&) {
  }
  ibvs_test::report(options_ok == servo.has_value(), "Servo(smooth options) throws iff validate(options) does",
                    __FILE__, __LINE__);
  if (!servo) return;
  ServoInput in(layout);
  ServoOutput out(layout);
  for (int i = 0; i < n; ++i) {
    in.uv_desired.col(i) << b.coordinate(), b.coordinate();
    in.depth_desired(i) = b.depth();
  }
  b.poison(in.uv_desired), b.poison(in.depth_desired);
  for (int frame = 0; frame < 6; ++frame) {
    for (int i = 0; i < n; ++i) {
      in.valid(i) = b.byte() < 200;
      const bool hostile = !in.valid(i) && b.byte() < 128;  // a lost point's values are not read
      in.uv.col(i) << (hostile ? b.real() : b.coordinate()), (hostile ? b.real() : b.coordinate());
      in.depth(i) = hostile ? b.real() : b.depth();
    }
    b.poison(in.uv), b.poison(in.depth);
    if (b.byte() > 250) in.valid.resize(n + 1), in.valid.setConstant(true);  // a wrong size
    bool accepted = true;
    try {
      servo->validate(in);
    } catch (const std::invalid_argument&) {
      accepted = false;
    }
    const Status st = servo->update(in, out);
    ibvs_test::report(accepted == (st != Status::invalid_input), "validate(valid) throws iff update refuses",
                      __FILE__, __LINE__, layout.describe());
    if (st == Status::invalid_input) {
      CHECK(out.velocity.isZero(0.0));
      in.valid = PointMask::Constant(n, true);
    } else {
      ibvs_test::report(out.velocity.allFinite() && out.error.allFinite() && out.jacobian.allFinite() &&
                            finite(out.error_norm),
                        "smooth / masked step: finite outputs", __FILE__, __LINE__, layout.describe());
    }
    if (b.byte() > 240) servo->reset();
    if (b.byte() > 240) {  // a hand-chosen wrap branch: refused beyond pi + pi/4 (NaN included: accepted)
      const double centre = b.real();
      bool threw = false;
      try {
        servo->continue_turn(centre);
      } catch (const std::invalid_argument&) {
        threw = true;
      }
      ibvs_test::report(threw == !(std::isnan(centre) || std::abs(centre) <= pi + wrap_hysteresis),
                        "continue_turn refuses exactly what is out of range", __FILE__, __LINE__, layout.describe());
    }
  }
}

// Wide field of view: a fisheye or omnidirectional CameraModel built from fuzzed parameters (or
// refused), to_bearing / from_bearing on fuzzed pixels and directions (accepted: finite, unit
// bearings; validate_* throws exactly for what they refuse). The spherical feature blocks are
// kinds of the task fuzzer below (fuzz_kinds).
void fuzz_wide_wrap(Bytes& b);
void fuzz_planar_bearings(Bytes& b);
void spherical_measurement(Bytes& b, double* m);

void fuzz_wide(Bytes& b) {
  std::optional<CameraModel> cam;
  try {
    Eigen::Matrix3d K;
    K << (b.byte() < 200 ? 100.0 + b.byte() : b.real()), 0, 640, 0, (b.byte() < 200 ? 100.0 + b.byte() : b.real()), 512,
        0, 0, 1;
    Eigen::Vector4d d;
    for (int i = 0; i < 4; ++i) d(i) = b.byte() < 200 ? (b.byte() - 127.5) / 2000.0 : b.real();
    b.poison(K), b.poison(d);
    if (b.byte() % 2) cam.emplace(CameraModel::from_opencv(K, d, 1280, 1024, true));
    else cam.emplace(CameraModel::from_omnidir(K, b.byte() < 200 ? b.byte() / 80.0 : b.real(), d, 1280, 1024));
  } catch (const std::invalid_argument&) {
    return;
  }
  CHECK(cam->max_angle() > 0.0 && cam->max_angle() <= pi && !(cam->fold_radius() <= 0.0));
  for (int k = 0; k < 4; ++k) {
    Points px(2, 1);
    px << (b.byte() < 200 ? b.byte() * 6.0 : b.real()), (b.byte() < 200 ? b.byte() * 5.0 : b.real());
    b.poison(px);
    Eigen::Vector3d v;
    const bool ok = cam->to_bearing(px(0, 0), px(1, 0), v);
    CHECK(ok ? v.allFinite() && std::abs(v.norm() - 1.0) < 1e-12 : std::isnan(v.x()));
    bool threw = false;
    try {
      cam->validate_pixels(px, "pixels");
    } catch (const std::invalid_argument&) {
      threw = true;
    }
    CHECK(threw == !ok);
    Bearings d(3, 1);
    d << b.coordinate(), b.coordinate(), b.coordinate();
    b.poison(d);
    Eigen::Vector2d q;
    const bool okb = cam->from_bearing(d(0), d(1), d(2), q);
    CHECK(okb ? q.allFinite() : std::isnan(q.x()));
    threw = false;
    try {
      cam->validate_bearings(d, "bearings");
    } catch (const std::invalid_argument&) {
      threw = true;
    }
    CHECK(threw == !okb);
  }
  fuzz_wide_wrap(b);
  fuzz_planar_bearings(b);
}

// PlanarPose::estimate_bearings on fuzzed bearings of 4 to 6 target points: those of a pose at any
// angle off the axis (some perturbed, reversed or replaced) or any doubles. Accepted: a finite rigid
// pose and finite positive ranges; refused: T and the ranges untouched; validate_bearings throws
// only for a refused input (a degenerate one is refused without throwing).
void fuzz_planar_bearings(Bytes& b) {
  const int n = b.small(4, 6);
  Eigen::Matrix3Xd P = Eigen::Matrix3Xd::Zero(3, n);
  P.leftCols(4) << -0.2, 0.2, 0.2, -0.2, -0.2, -0.2, 0.2, 0.2, 0.0, 0.0, 0.0, 0.0;
  for (int i = 4; i < n; ++i) P.block<2, 1>(0, i) << b.coordinate(), b.coordinate();
  b.poison(P);
  std::optional<PlanarPose> est;
  try {
    est.emplace(P, b.small(0, 8));
  } catch (const std::invalid_argument&) {
    return;
  }
  Twist xi;
  for (int k = 0; k < 6; ++k) xi(k) = b.byte() < 220 ? (b.byte() - 127.5) / 40.0 : b.real();
  xi(2) += 1.0;
  const Pose T0 = xi.allFinite() && xi.cwiseAbs().maxCoeff() < 1e3 ? se3_exp(xi) : Pose(Pose::Identity());
  Eigen::Matrix3Xd bear = T0.topLeftCorner<3, 3>() * P;
  bear.colwise() += T0.topRightCorner<3, 1>();
  for (int i = 0; i < n; ++i) {
    const std::uint8_t how = b.byte();
    if (how < 40) bear.col(i) << b.real(), b.real(), b.real();
    else if (how < 60) bear.col(i) *= -1.0;
    else if (how < 100) bear.col(i) += 1e-3 * Eigen::Vector3d(b.coordinate(), b.coordinate(), b.coordinate());
  }
  b.poison(bear);
  const Pose keep = Pose::Constant(3.0);
  Pose T = keep;
  Eigen::VectorXd range = Eigen::VectorXd::Constant(n, 3.0);
  const bool ok = est->estimate_bearings(bear, T, range);
  bool threw = false;
  try {
    est->validate_bearings(bear);
  } catch (const std::invalid_argument&) {
    threw = true;
  }
  CHECK(!(threw && ok));
  if (ok) {
    const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
    CHECK(T.allFinite() && range.allFinite() && (range.array() > 0.0).all());
    CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-9 && R.determinant() > 0.0);
  } else {
    CHECK(T == keep && range == Eigen::VectorXd::Constant(n, 3.0));
  }
}

// The consistent wrap of spherical-polar azimuths (Feature::axis_angle_rows): polar points and
// spherical-polar blocks on fuzzed bearings (near a common turn about the axis, near the axis, or
// any), one Servo consistent and one per point on the same frames: both refuse alike; accepted, each
// angle row of the consistent one is the per-point row or it -/+ 2 pi exactly, every other row equal.
void fuzz_wide_wrap(Bytes& b) {
  const int n = b.small(0, 2), blocks = b.small(1, 4);
  Task task = n > 0 ? Task(Layout::polar(n)) : Task();
  for (int k = 0; k < blocks; ++k) task.add(SphericalPolarFeature(b.byte() < 200 ? 1e-3 : 0.2));
  ServoOptions o;
  o.polar_min_radius = b.byte() < 128 ? 0.0 : 1e-3;
  Servo consistent(task, o);
  o.angle_wrap = AngleWrap::per_point;
  Servo per_point(task, o);
  ServoInput in(task);
  ServoOutput oc(task), op(task);
  for (int frame = 0; frame < 3; ++frame) {
    const double turn = b.byte() < 128 ? pi + (b.byte() - 127.5) / 1e4 : b.coordinate() * 10.0;
    const double c = std::cos(turn), s = std::sin(turn);
    for (int i = 0; i < n; ++i) {
      in.uv_desired.col(i) << b.coordinate(), b.coordinate();
      in.uv.col(i) << c * in.uv_desired(0, i) - s * in.uv_desired(1, i) + b.coordinate() / 100.0,
          s * in.uv_desired(0, i) + c * in.uv_desired(1, i);
      in.depth(i) = b.depth();
      in.depth_desired(i) = b.depth();
    }
    for (int k = 0; k < blocks; ++k) {
      double* md = in.measurements_desired.data() + 4 * k;
      double* m = in.measurements.data() + 4 * k;
      spherical_measurement(b, md);
      m[0] = c * md[0] - s * md[1] + (b.byte() < 128 ? 0.0 : b.coordinate());
      m[1] = s * md[0] + c * md[1];
      m[2] = md[2];
      m[3] = b.byte() < 200 ? md[3] : b.depth();
    }
    const Status sc = consistent.update(in, oc), sp = per_point.update(in, op);
    CHECK((sc == Status::invalid_input) == (sp == Status::invalid_input));
    check_output(oc, sc, o.diagnostics, "Servo(spherical polar, consistent)::update");
    if (sc == Status::invalid_input) continue;
    for (Eigen::Index r = 0; r < oc.error.size(); ++r) {
      const double d = oc.error(r) - op.error(r);
      ibvs_test::report(d == 0.0 || (r % 2 == 1 && std::abs(std::abs(d) - 2.0 * pi) < 1e-12), "consistent wrap: the same angle",
                        __FILE__, __LINE__, task.describe() + " row " + std::to_string(r));
    }
  }
}

// ---- Tasks of feature blocks --------------------------------------------------
// Each kind the task fuzzer draws from: a block and a measurement of it, mostly
// plausible (so that the accepted path is reached), sometimes hostile (every
// entry can be any double). A new feature kind adds one entry to fuzz_kinds.
struct FuzzKind {
  std::unique_ptr<Feature> (*make)(Bytes&);
  void (*measure)(Bytes&, double* m);  // Feature::size() doubles
};

void line_measurement(Bytes& b, double* m) {
  m[0] = b.coordinate();
  m[1] = b.byte() < 200 ? (b.byte() - 127.5) / 20.0 : b.real();
  for (int i = 2; i < 4; ++i) m[i] = b.byte() < 200 ? b.coordinate() : b.real();
  m[4] = 1.0 / b.depth();
}


// The segment and the ellipse (features/segment.hpp, ellipse.hpp): measurements from their own
// measurement functions, on geometry in view or on any input (what they return must then pass
// check(); what they cannot measure they refuse with std::invalid_argument), then entries
// sometimes overwritten with hostile doubles.
Eigen::Vector3d in_view(Bytes& b) {
  const double z = 0.2 + b.byte() / 40.0;
  return {(b.byte() - 127.5) / 400.0 * z, (b.byte() - 127.5) / 400.0 * z, z};
}

template <std::size_t N>
void measured(Bytes& b, const Feature& f, std::array<double, N> (*from)(Bytes&), double* m) {
  std::array<double, N> v;
  try {
    v = from(b);
    int entry = 0;
    ibvs_test::report(f.check(v.data(), entry) == nullptr, "a measurement function's result is accepted", __FILE__,
                      __LINE__, f.describe());
  } catch (const std::invalid_argument&) {
    for (double& x : v) x = b.real();
  }
  std::copy(v.begin(), v.end(), m);
  while (b.byte() > 230) m[b.small(0, static_cast<int>(N) - 1)] = b.byte() < 128 ? b.real() : b.coordinate();
  b.poison(m, static_cast<Eigen::Index>(N));
}

void segment_measurement(Bytes& b, double* m) {
  measured<6>(b, SegmentFeature(), [](Bytes& b) {
    if (b.byte() < 200) return SegmentFeature::project(in_view(b), in_view(b));
    return SegmentFeature::measure(b.coordinate(), b.coordinate(), b.depth(), b.coordinate(), b.coordinate(),
                                   b.depth());
  }, m);
}

void ellipse_measurement(Bytes& b, double* m) {
  measured<8>(b, EllipseFeature(), [](Bytes& b) {
    const int how = b.small(0, 3);
    if (how <= 1) {  // a circle in view, facing the camera
      const Eigen::Vector3d c = in_view(b), n((b.byte() - 127.5) / 200.0, (b.byte() - 127.5) / 200.0, -1.0);
      return EllipseFeature::project_circle(c, n, c.z() * (0.005 + b.byte() / 1000.0));
    }
    if (how == 2)
      return EllipseFeature::project_circle({b.coordinate(), b.coordinate(), b.depth()},
                                            {b.coordinate(), b.coordinate(), b.real()}, b.byte() < 128 ? b.real() : 0.1);
    std::array<double, 6> mo;
    for (double& x : mo) x = b.byte() < 200 ? b.coordinate() : b.real();
    return EllipseFeature::measure_moments(mo, b.coordinate(), b.coordinate(), 1.0 / b.depth());
  }, m);
}

// Image moments (features/moments.hpp): the projection of a random planar object (a polygon or a
// point set, mostly in view; project() refuses what it cannot measure) or any 20 doubles, then
// entries sometimes overwritten with hostile ones. A projection need not be accepted (a flat or
// symmetric object is refused by check()), so its result is only fed to the servo.
void moments_measurement(Bytes& b, double* m) {
  std::array<double, 20> v;
  bool made = false;
  if (b.byte() < 200) {
    Eigen::Matrix3Xd P(3, b.small(3, 7));
    const Eigen::Vector3d c = in_view(b), n((b.byte() - 127.5) / 200.0, (b.byte() - 127.5) / 200.0, -1.0);
    const Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u).normalized();
    for (Eigen::Index k = 0; k < P.cols(); ++k)  // on the plane through c with normal n
      P.col(k) = c + 0.1 * c.z() * ((b.byte() - 127.5) / 128.0 * u + (b.byte() - 127.5) / 128.0 * w);
    try {
      v = MomentsFeature::project(P, b.byte() & 1 ? MomentsFeature::Source::points : MomentsFeature::Source::region,
                                  b.byte() < 200 ? 0.0 : b.real(), b.depth());
      made = true;
    } catch (const std::invalid_argument&) {
    }
  }
  if (!made)
    for (double& x : v) x = b.real();
  std::copy(v.begin(), v.end(), m);
  while (b.byte() > 230) m[b.small(0, 19)] = b.byte() < 128 ? b.real() : b.coordinate();
  b.poison(m, 20);
}

MomentsFeature moments_kind(Bytes& b) {
  using MF = MomentsFeature;
  const MF::Source source = b.byte() & 1 ? MF::Source::points : MF::Source::region;
  const MF::Invariants invariants = b.byte() & 1 ? MF::Invariants::s : MF::Invariants::p;
  return MF(source, invariants, b.byte() & 1 ? MF::Alpha::second_order : MF::Alpha::third_order, 1u + b.byte() % 63u);
}

// A bearing (unit most of the time, else any three doubles) and a distance.
void spherical_measurement(Bytes& b, double* m) {
  Eigen::Vector3d d(b.coordinate(), b.coordinate(), b.byte() < 200 ? (b.byte() - 100.0) / 50.0 : b.real());
  const double n = d.norm();
  if (b.byte() < 220 && std::isfinite(n) && n > 0.0) d /= n;
  for (int i = 0; i < 3; ++i) m[i] = d(i);
  m[3] = b.depth();
}
// A camera <- object pose: mostly a rigid motion (any angle, exactly pi about z at times), sometimes
// not one (measure() must then throw).
Pose fuzz_rigid_pose(Bytes& b) {
  Twist xi;
  for (int i = 0; i < 6; ++i) xi(i) = b.byte() < 200 ? (b.byte() - 127.5) / 30.0 : b.real();
  Pose T = xi.allFinite() && xi.cwiseAbs().maxCoeff() <= max_twist_entry ? se3_exp(xi) : Pose::Identity();
  if (b.byte() > 240) T.topLeftCorner<3, 3>() = rotation_of(pi * Eigen::Vector3d::UnitZ());  // theta u at pi
  if (b.byte() > 240) T(b.small(0, 2), b.small(0, 3)) = b.real();
  b.poison(T);
  return T;
}

// PBVS (Target 0: desired camera, 1: object) and 2.5-D (2) measurements: measure() of two random poses, or
// hostile entries; theta_u's invariants on the way (angle <= pi, L_tu finite up to 2 pi).
template <int Target>
void pose_measurement(Bytes& b, double* m) {
  const Pose cMo = fuzz_rigid_pose(b), cdMo = fuzz_rigid_pose(b);
  try {
    if (b.byte() < 60) throw std::invalid_argument("hostile");
    const Eigen::Vector3d P(b.coordinate(), b.coordinate(), b.coordinate());
    const std::array<double, 6> v =
        Target == 2 ? Point25DFeature::measure(cMo, cdMo, P)
                    : PbvsFeature::measure(cMo, cdMo, Target == 0 ? PbvsTarget::desired_camera : PbvsTarget::object);
    std::copy(v.begin(), v.end(), m);
    CHECK(Eigen::Map<const Eigen::Vector3d>(m + 3).norm() <= pi + 1e-12);
  } catch (const std::invalid_argument&) {
    for (int i = 0; i < 6; ++i) m[i] = b.byte() < 128 ? b.coordinate() : b.real();
  }
  const Eigen::Map<const Eigen::Vector3d> tu(m + 3);
  if (tu.allFinite() && tu.norm() <= 2 * pi) CHECK(theta_u_interaction(tu).allFinite());
}

// A user's block: s = 1 / m (infinite at 0, huge near it: refused by check()), and 1 itself refused.
constexpr auto fuzz_inverse = [](const double* m, double* s, Eigen::Ref<MatrixX6> L) noexcept {
  s[0] = 1.0 / m[0];
  L.setZero();
  L(0, 2) = -s[0] * s[0];
  return m[0] != 1.0;
};

// A user's block of 2 rows whose s and L are its 14 measurement entries, decoded: the codes 7, 8 and 9
// give NaN, +-inf and -1e200, so any entry of s or L (not only the first) may be non-finite or huge,
// and check() must then refuse the block (validate() throws, update() returns invalid_input).
constexpr auto fuzz_passthrough = [](const double* m, double* s, Eigen::Ref<MatrixX6> L) noexcept {
  const auto decode = [](double x) {
    return x == 7.0 ? std::numeric_limits<double>::quiet_NaN()
                    : x == 8.0 ? std::numeric_limits<double>::infinity() : x == 9.0 ? -1e200 : x;
  };
  for (int i = 0; i < 2; ++i) s[i] = decode(m[i]);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 6; ++j) L(i, j) = decode(m[2 + 6 * i + j]);
  return true;
};

void passthrough_measurement(Bytes& b, double* m) {
  for (int i = 0; i < 14; ++i) m[i] = b.byte() < 232 ? b.coordinate() : 7.0 + b.byte() % 3;  // NaN, inf, huge
  b.poison(m, 14);
}

const FuzzKind fuzz_kinds[] = {
    {[](Bytes&) -> std::unique_ptr<Feature> { return std::make_unique<LineFeature>(); }, line_measurement},
    {[](Bytes&) -> std::unique_ptr<Feature> { return std::make_unique<SphericalPointFeature>(); }, spherical_measurement},
    {[](Bytes& b) -> std::unique_ptr<Feature> {
       return std::make_unique<SphericalPolarFeature>(b.byte() < 200 ? 1e-3 : 0.2);
     },
     spherical_measurement},
    {[](Bytes& b) -> std::unique_ptr<Feature> { return std::make_unique<SegmentFeature>(b.byte() < 160); },
     segment_measurement},
    {[](Bytes&) -> std::unique_ptr<Feature> { return std::make_unique<EllipseFeature>(); }, ellipse_measurement},
    {[](Bytes& b) -> std::unique_ptr<Feature> { return std::make_unique<MomentsFeature>(moments_kind(b)); },
     moments_measurement},
    {[](Bytes&) -> std::unique_ptr<Feature> { return std::make_unique<PbvsFeature>(PbvsTarget::desired_camera); },
     pose_measurement<0>},
    {[](Bytes&) -> std::unique_ptr<Feature> { return std::make_unique<PbvsFeature>(PbvsTarget::object); },
     pose_measurement<1>},
    {[](Bytes&) -> std::unique_ptr<Feature> { return std::make_unique<Point25DFeature>(); }, pose_measurement<2>},
    {[](Bytes&) -> std::unique_ptr<Feature> {
       return std::make_unique<FunctionFeature<decltype(fuzz_inverse)>>(1, 1, fuzz_inverse);
     },
     [](Bytes& b, double* m) { m[0] = b.byte() < 200 ? b.coordinate() : b.real(); }},
    {[](Bytes&) -> std::unique_ptr<Feature> {
       return std::make_unique<FunctionFeature<decltype(fuzz_passthrough)>>(2, 14, fuzz_passthrough);
     },
     passthrough_measurement},
};

void fuzz_task(Bytes& b) {
  std::optional<Task> task;
  std::vector<const FuzzKind*> kind_of;  // the kind of each block, to draw its measurements
  try {
    const int n = b.small(0, 4);
    task.emplace(n == 0 ? Task() : Task(b.byte() < 128 ? Layout::cartesian(n) : Layout::polar(n)));
    const int blocks = b.small(0, 3);
    constexpr int kinds = static_cast<int>(sizeof fuzz_kinds / sizeof fuzz_kinds[0]);
    for (int k = 0; k < blocks; ++k) {
      const FuzzKind& kind = fuzz_kinds[b.small(0, kinds - 1)];
      task->add(*kind.make(b), b.byte() < 200 ? 1.0 + b.byte() / 64.0 : b.real());
      kind_of.push_back(&kind);
    }
    if (n > 0 && b.byte() > 200) {
      std::vector<double> w(static_cast<std::size_t>(n));
      for (double& x : w) x = b.byte() < 200 ? 0.5 + b.byte() / 100.0 : b.real();
      task->set_point_weights(w);
    }
    if (b.byte() > 180) {
      Dof dof{};
      for (bool& d : dof) d = b.byte() < 160;
      task->set_dof(dof);
    }
  } catch (const std::invalid_argument&) {
    return;
  }
  ServoOptions o;
  o.damping = b.byte() < 128 ? 0.0 : b.byte() / 1000.0;
  o.diagnostics = b.byte() < 200;
  if (b.byte() > 200) o.max_linear_speed = b.real();
  std::optional<Servo> servo;
  try {
    servo.emplace(*task, o);
  } catch (const std::invalid_argument&) {
    return;  // no block (an empty Task) or bad options: refused at construction
  }
  ServoInput in(*task);
  ServoOutput out(*task);
  for (int frame = 0; frame < 3; ++frame) {
    for (Eigen::Index i = 0; i < in.uv.size(); ++i) in.uv.data()[i] = b.coordinate();
    for (Eigen::Index i = 0; i < in.uv_desired.size(); ++i) in.uv_desired.data()[i] = b.coordinate();
    for (Eigen::Index i = 0; i < in.depth.size(); ++i) in.depth(i) = b.depth();
    for (Eigen::Index i = 0; i < in.depth_desired.size(); ++i) in.depth_desired(i) = b.depth();
    b.poison(in.uv), b.poison(in.uv_desired), b.poison(in.depth), b.poison(in.depth_desired);
    for (int k = 0; k < task->n_features(); ++k) {
      kind_of[static_cast<std::size_t>(k)]->measure(b, in.measurements.data() + task->offset(k));
      kind_of[static_cast<std::size_t>(k)]->measure(b, in.measurements_desired.data() + task->offset(k));
    }
    bool valid = true;
    try {
      servo->validate(in);
    } catch (const std::invalid_argument&) {
      valid = false;
    }
    const Status st = servo->update(in, out);
    ibvs_test::report(valid == (st != Status::invalid_input), "task: validate() throws iff update() refuses",
                      __FILE__, __LINE__, task->describe());
    check_output(out, st, o.diagnostics, "Servo(Task)::update");
  }
}

// Feature sources: a LineSource (SegmentSource, EllipseSource) of any indices (centre, normal,
// radius) on a target of any points is accepted or refused (std::invalid_argument); from any poses
// and points (and bearings), measure() answers false or finite values (every source); a short
// episode of a line task (or a PBVS + 2.5-D task, any depth mode, depth_scale and goal_pose: the goal
// estimated from its image or given) from any start either throws std::invalid_argument or ends with finite recorded
// errors.
void fuzz_sources(Bytes& b) {
  using namespace ibvs::sim;
  const int n = b.small(1, 5);
  Eigen::Matrix3Xd P(3, n);
  const bool plate = b.byte() < 160;
  for (Eigen::Index i = 0; i < P.size(); ++i) P.data()[i] = plate && i % 3 == 2 ? 0.0 : b.coordinate();
  b.poison(P);
  Target t;
  try {
    t = Target(P);
    t.validate();
    t.add(LineSource(b.small(-1, 5), b.small(-1, 5), b.small(-2, 5)));
  } catch (const std::invalid_argument&) {
    return;
  }
  Twist xi, xd;
  for (int i = 0; i < 6; ++i) xi(i) = b.byte() < 200 ? (b.byte() - 127.5) / 40.0 : b.real();
  for (int i = 0; i < 6; ++i) xd(i) = b.byte() < 200 ? (b.byte() - 127.5) / 40.0 : b.real();
  b.poison(xi), b.poison(xd);
  const auto pose = [](const Twist& x) {
    return x.allFinite() && x.cwiseAbs().maxCoeff() <= max_twist_entry ? se3_exp(x) : Pose(Pose::Constant(x(0)));
  };
  SourceFrame f;
  f.cMo = pose(xi);
  f.depth_pose = pose(xd);
  Points uv(2, n);
  Eigen::VectorXd z(n);
  for (Eigen::Index i = 0; i < uv.size(); ++i) uv.data()[i] = b.coordinate();
  for (Eigen::Index i = 0; i < n; ++i) z(i) = b.depth();
  Bearings bearings(3, n);  // any values, also not unit (the spherical source passes them on)
  for (Eigen::Index i = 0; i < bearings.size(); ++i) bearings.data()[i] = b.byte() < 16 ? b.real() : b.coordinate();
  b.poison(uv), b.poison(z), b.poison(bearings);
  f.points = &t.points;
  f.uv = &uv;
  f.depth = &z;
  f.bearings = &bearings;
  double m[5];
  if (t.sources[0]->measure(f, m))
    CHECK(std::isfinite(m[0]) && std::isfinite(m[1]) && std::isfinite(m[2]) && std::isfinite(m[3]) &&
          std::isfinite(m[4]));
  // The moments, PBVS and 2.5-D sources on the same frame, the goal from any pose: false or finite.
  f.goal = pose(b.byte() < 128 ? xd : xi);
  const MomentsSource moments_region(MomentsFeature::Source::region), moments_points(MomentsFeature::Source::points);
  const PbvsSource to_camera(PbvsTarget::desired_camera), to_object(PbvsTarget::object);
  const Point25DSource reference(0);
  const SphericalSource sphere(0);
  for (const FeatureSource* src : std::initializer_list<const FeatureSource*>{
           &moments_region, &moments_points, &to_camera, &to_object, &reference, &sphere}) {
    try {
      src->validate(t.points, "fuzz");
    } catch (const std::invalid_argument&) {
      continue;
    }
    double ms[20];
    if (src->measure(f, ms))
      for (int i = 0; i < src->size(); ++i) CHECK(std::isfinite(ms[i]));
  }
  // Segment and circle sources of any arguments (a zero or negative radius, a zero normal, coincident
  // points...): refused with std::invalid_argument, or measure() false or finite values its block checks.
  try {
    const SegmentSource segment(b.small(-1, 5), b.small(-1, 5));
    segment.validate(t.points, "fuzz");
    double ms[6];
    int entry = -1;
    if (segment.measure(f, ms)) {
      for (double v : ms) CHECK(std::isfinite(v));
      SegmentFeature().check(ms, entry);
    }
  } catch (const std::invalid_argument&) {
  }
  try {
    const Eigen::Vector3d centre(b.coordinate(), b.coordinate(), b.byte() < 200 ? 0.0 : b.real());
    const Eigen::Vector3d normal(b.byte() < 128 ? 0.0 : b.real(), b.byte() < 128 ? 0.0 : b.real(),
                                 b.byte() < 64 ? 0.0 : b.real());
    const EllipseSource circle(centre, normal, b.byte() < 40 ? b.real() : b.byte() / 128.0);
    circle.validate(t.points, "fuzz");
    double ms[8];
    int entry = -1;
    if (circle.measure(f, ms)) {
      for (double v : ms) CHECK(std::isfinite(v));
      EllipseFeature().check(ms, entry);
    }
  } catch (const std::invalid_argument&) {
  }
  if (b.byte() < 224) return;  // an episode now and then (a few frames)
  Task task;
  task.add(LineFeature());
  EpisodeOptions o;
  o.duration = 0.05;
  o.depth = static_cast<DepthMode>(b.small(0, 3));
  o.depth_scale = b.byte() < 192 ? 1.0 : 0.5 + b.byte() / 128.0;
  o.goal_pose = static_cast<GoalPose>(b.small(0, 2));  // taught, given, or an invalid value (refused)
  if (b.byte() > 230) o.turn = b.real();  // a half-turn's way: NaN or within pi + pi/4, else refused
  t.pose = Pose::Identity();
  t.pose(2, 3) = 1.0 + b.byte() / 64.0;
  if (b.byte() < 96) {  // PBVS and 2.5-D instead: their goal as the depth mode knows it (teach by showing)
    const PbvsTarget to = b.byte() < 128 ? PbvsTarget::desired_camera : PbvsTarget::object;
    Target tp(t.points, t.pose);
    tp.add(PbvsSource(to)).add(Point25DSource(0));
    task = Task();
    task.add(PbvsFeature(to)).add(Point25DFeature());
    t = tp;
  }
  try {
    Episode e(Servo(task), CameraModel::normalized(0.5), t, o);
    const EpisodeResult& r = e.run(pose(xi), Pose::Identity());
    for (int k = 0; k < r.history.frames; ++k)
      if (!std::isnan(r.history.error_norm(k))) CHECK(std::isfinite(r.history.error_norm(k)));
    CHECK(r.status.outcome != Outcome::lost_feature || r.status.feature == 0 || r.status.point >= 0);
  } catch (const std::invalid_argument&) {
  }
}

}  // namespace

// LuminanceServo (features/luminance.hpp) and photometric_moments: any camera, size, options and
// images (double images with any bit patterns; 8-bit ones): the constructor and set_desired throw
// std::invalid_argument or accept; validate throws exactly when update returns invalid_input; every
// other update gives a finite twist (zero unless ok) and moments are finite or refused.
void fuzz_luminance(Bytes& b) {
  const int w = b.small(1, 40), h = b.small(1, 40);
  std::optional<LuminanceServo> servo;
  try {
    const double f = b.byte() < 220 ? 5.0 + b.byte() : b.real();
    const CameraModel cam = CameraModel::pinhole(f, f, b.byte() < 220 ? 0.5 * w : b.real(),
                                                 b.byte() < 220 ? 0.5 * h : b.real(), w, h);
    LuminanceOptions o;
    o.border = b.small(0, 8);
    o.smoothing = b.byte() < 200 ? b.small(0, 3) * 0.4 : b.real();
    o.jacobian = static_cast<InteractionMatrix>(b.small(0, 3));
    o.law = static_cast<LuminanceLaw>(b.small(0, 2));
    if (b.byte() > 200) o.gain = b.real();
    if (b.byte() > 200) o.mu = b.real();
    if (b.byte() > 200) o.min_conditioning = b.real();
    if (b.byte() > 150) o.plane_a = b.coordinate(), o.plane_b = b.coordinate(), o.plane_c = b.depth();
    servo.emplace(cam, w, h, o);
    try {
      (void)photometric_moments(cam, ImageF64::Zero(h, w));
    } catch (const std::invalid_argument&) {
    }
  } catch (const std::invalid_argument&) {
    return;
  }
  const auto image = [&](ImageF64& im) {
    const int kind = b.small(0, 3);
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c)
        im(r, c) = kind == 0 ? 100.0 + 60.0 * std::sin(0.7 * c + 0.3 * r) * std::cos(0.4 * r - 0.2 * c)
                   : kind == 1 ? double(b.byte())
                   : kind == 2 ? 77.0
                               : (b.byte() < 230 ? double(b.byte()) : b.real());
  };
  ImageF64 goal(h, w), cur(h, w);
  image(goal);
  try {
    servo->set_desired(goal);
  } catch (const std::invalid_argument&) {
    return;
  }
  LuminanceOutput out;
  for (int k = 0; k < 3; ++k) {
    image(cur);
    bool refused = false;
    try {
      servo->validate(cur, "image");
    } catch (const std::invalid_argument&) {
      refused = true;
    }
    const LuminanceStatus s = servo->update(cur, out);
    CHECK(refused == (s == LuminanceStatus::invalid_input));
    CHECK(out.twist.allFinite());
    if (s != LuminanceStatus::ok) CHECK(out.twist.isZero(0.0));
    if (!refused) CHECK(std::isfinite(out.error_rms));
    try {
      const Moments m = photometric_moments(servo->camera(), cur);
      for (double x : m) CHECK(std::isfinite(x));
      CHECK(!refused);
    } catch (const std::invalid_argument&) {
      CHECK(refused);
    }
    const ImageU8 u8 = cur.array().max(0.0).min(255.0).unaryExpr([](double x) { return x == x ? x : 0.0; })
                           .cast<std::uint8_t>();
    const LuminanceStatus s8 = servo->update(u8, out);
    CHECK(s8 != LuminanceStatus::invalid_input && out.twist.allFinite());
  }
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes b{data, size};
  switch (b.byte() % 9) {
    case 0: fuzz_servo(b); break;
    case 1: fuzz_partitioned(b); break;
    case 2: fuzz_task(b); break;
    case 3: fuzz_mounting_secondary(b); break;
    case 4: fuzz_smooth(b); break;
    case 5: fuzz_sources(b); break;
    case 6: fuzz_wide(b); break;
    case 7: fuzz_luminance(b); break;
    default: fuzz_pinv_exp(b); break;
  }
  return 0;
}

#if !defined(IBVS_LIBFUZZER)
// The seeded random driver (ctest): [cases] x 20 inputs of 0..400 random bytes.
void run_tests() {
  std::mt19937_64 rng(ibvs_test::seed);
  std::vector<std::uint8_t> buf;
  const long runs = 20L * ibvs_test::cases;
  for (long k = 0; k < runs; ++k) {
    buf.resize(rng() % 401);
    for (auto& x : buf) x = static_cast<std::uint8_t>(rng());
    LLVMFuzzerTestOneInput(buf.data(), buf.size());
  }
  std::printf("fuzz: %ld inputs\n", runs);
}
#endif
