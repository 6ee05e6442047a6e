// Servo: the real-time IBVS control law v = -gain * J+ (f (-) f*) (paper
// eqs. 11-13) for any Layout: Cartesian, polar, per-point hybrid or stacked.
//
// Two error channels, as in ruckig:
//  * validate(...) throws std::invalid_argument with a message naming the bad
//    argument (the Python bindings call it before every update);
//  * update(...) is noexcept, allocates nothing and returns a Status.
#pragma once

#include "ibvs/camera_model.hpp"
#include "ibvs/gain.hpp"
#include "ibvs/layout.hpp"
#include "ibvs/pixel_front_end.hpp"
#include "ibvs/limits.hpp"
#include "ibvs/smoothing.hpp"
#include "ibvs/task.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <memory>

namespace ibvs {

/// Where the interaction matrix is evaluated (the choices ViSP users know).
enum class InteractionMatrix : std::uint8_t {
  current = 0,  ///< J(f, z): current features and depths
  desired = 1,  ///< J(f*, z*): desired features and desired depths
  mean = 2,     ///< (J(f, z) + J(f*, z*)) / 2
};

/// Outcome of one update().
enum class Status : std::int8_t {
  ok = 0,
  singular = 1,        ///< sigma_min <= singular_tolerance(M) sigma_max (J rank-deficient to what
                       ///< J^T J resolves); the twist is still the finite minimum-norm (or damped)
                       ///< solution. Reported only with diagnostics on.
  /// Too few valid points for the task's degrees of freedom (ServoInput::valid: 2 x valid points +
  /// feature rows < Task::n_dof()): the twist ramps linearly from the last commanded one to zero
  /// over ServoOptions::stop_time, then stays 0, until enough points are valid again.
  features_lost = 2,
  invalid_input = -1,  ///< an input validate() refuses (non-finite, outside limits.hpp, wrong size):
                       ///< twist 0, error, Jacobian and diagnostics NaN
};

struct ServoOptions {
  double gain = 0.5;                                    ///< gamma in (0, max_gain], 1/s
  double damping = 0.0;                                 ///< lambda in [0, max_matrix_entry] (units of J's singular values)
  InteractionMatrix jacobian = InteractionMatrix::current;
  double polar_min_radius = default_polar_min_radius;  ///< r -> 0 policy, >= 0 (polar_radius_floor applies below it)
  /// Diagnostics: Status::singular every step, decided exactly and nearly free
  /// by the full-rank test of the solve (cpp/src/solve.hpp), and
  /// ServoOutput::sigma_min() / sigma_max() / condition(), computed when read.
  /// Off: they are NaN and Status::singular is never reported.
  bool diagnostics = true;
  /// With diagnostics: compute sigma_min / sigma_max every step, exactly (QR of
  /// J and the SVD of its R factor, ~4 us: sigma_min to eps sigma_max).
  bool exact_diagnostics = false;
  /// gain(|e|) instead of the constant `gain` when enabled (at_zero > 0); off by default.
  AdaptiveGain adaptive_gain{};
  /// Twist limits, > 0: the whole twist is scaled by one factor so that |T| <= max_linear_speed
  /// (m/s) and |w| <= max_angular_speed (rad/s). Infinite (off) by default.
  double max_linear_speed = no_limit;
  double max_angular_speed = no_limit;
  /// Angle errors (polar theta, cylindrical r theta, feature blocks' angles about the axis:
  /// Feature::axis_angle_rows, e.g. spherical-polar azimuths) wrapped as one rotation about their
  /// circular mean, with frame-to-frame continuity (default), or point by point (eq. 13).
  /// See angle_wrap.hpp for the exact rules.
  AngleWrap angle_wrap = AngleWrap::consistent;
  /// Smooth starts and switches (smoothing.hpp): the continuous law with decay rate mu and
  /// acceleration limits, applied at the first update, after reset(), after set_options()
  /// changes the law (jacobian, polar_min_radius, angle_wrap, cartesian_near_goal), when the
  /// Cartesian / polar choice of a block changes, and when the set of valid points changes.
  /// Off by default (the instantaneous law, bit for bit).
  Smoothing smoothing{};
  /// > 0, normalised units: automatic law switch. Every polar block is computed as Cartesian
  /// while every valid point lies within this distance of its desired point, and polar again
  /// once one is farther than near_goal_hysteresis times it (polar far from the goal for its
  /// straight r-theta paths, Cartesian near it for its straight image paths). 0 = off.
  double cartesian_near_goal = 0.0;
  /// >= 0, s: with too few valid points (Status::features_lost), the time over which the twist
  /// ramps to zero (0: at once). Needs smoothing.period > 0 when > 0.
  double stop_time = 0.0;
};

/// The automatic law switch returns to polar beyond this multiple of cartesian_near_goal.
inline constexpr double near_goal_hysteresis = 1.5;

/// Which points a tracker still has (ServoInput::valid): true = measured.
using PointMask = Eigen::Array<bool, Eigen::Dynamic, 1>;

/// Per-frame input, sized once for a task (N points, its feature blocks'
/// measurements). The library allocates its buffers and frees them (special
/// members defined in the library, so a consumer built with other flags,
/// sanitizers included, never frees them with another allocator): fill them, do
/// not resize them.
struct ServoInput {
  explicit ServoInput(const Task& task);
  ServoInput(const ServoInput&);
  ServoInput(ServoInput&&) noexcept;
  ServoInput& operator=(const ServoInput&);
  ServoInput& operator=(ServoInput&&) noexcept;
  ~ServoInput();
  Points uv;                     ///< current points, 2 x N, normalised coordinates, |u|, |v| <= max_normalized_coordinate
  Eigen::VectorXd depth;         ///< current depths, metres, N, in [min_depth, max_depth]
  Points uv_desired;             ///< desired points, 2 x N
  Eigen::VectorXd depth_desired; ///< desired depths, N (values used by desired / mean)
  /// The feature blocks' measurements (Task::measurement_size(), block k from Task::offset(k)),
  /// current and at the goal; empty for a task of points only.
  Eigen::VectorXd measurements;
  Eigen::VectorXd measurements_desired;
  /// N, true where the point is measured (default all). A point marked false (a tracker lost it)
  /// is left out of the law: its uv and depth are not read (NaN allowed) and its rows of J and of
  /// the error are 0 (ServoOutput::lost_points counts them). uv_desired must still be valid.
  PointMask valid;
};

/// Per-frame output, sized once for a layout (M rows); buffers owned by the
/// library as ServoInput's.
struct ServoOutput {
  explicit ServoOutput(const Task& task);
  ServoOutput(const ServoOutput&);
  ServoOutput(ServoOutput&&) noexcept;
  ServoOutput& operator=(const ServoOutput&);
  ServoOutput& operator=(ServoOutput&&) noexcept;
  ~ServoOutput();
  Status status = Status::ok;
  Twist velocity = Twist::Zero();  ///< camera twist (Tx, Ty, Tz, wx, wy, wz), m/s and rad/s
  Eigen::VectorXd error;           ///< f (-) f*, M
  double error_norm = 0.0;         ///< |error|_2
  MatrixX6 jacobian;               ///< the interaction matrix used, M x 6

  int polar_fallbacks = 0;         ///< polar blocks computed as Cartesian (r < polar_min_radius)
  double gain = 0.0;               ///< the gain applied this step (constant or adaptive_gain(error_norm))
  bool saturated = false;          ///< the twist was scaled down to the speed limits
  double saturation_scale = 1.0;   ///< that factor, in (0, 1]; 1 when not saturated
  int lost_points = 0;                ///< points marked invalid (ServoInput::valid) this step
  bool law_switched = false;          ///< the smooth law started a transition this step (smoothing.hpp)
  bool acceleration_limited = false;  ///< the twist change was scaled to the acceleration limits
  /// update_pixels(): the largest distance, in pixels, between a measured point and its
  /// desired point (a tolerance in pixels compares with this); NaN after update().
  double pixel_error = std::numeric_limits<double>::quiet_NaN();

  /// Smallest and largest singular value of `jacobian` (of its 6 columns), and
  /// sigma_max / sigma_min (inf when sigma_min = 0). NaN with diagnostics off
  /// and after a refused update. Known after update() where the step computed
  /// them anyway (the robust route, exact_diagnostics, PartitionedServo);
  /// otherwise computed on the first call from the J^T J the update kept (its
  /// exact eigenvalues, ~0.5 us: sigma_max to rounding, sigma_min to relative
  /// ~eps cond(J)^2) and cached until the next update. Noexcept, allocation-free;
  /// the first call writes the cache, so do not make it from two threads at once.
  double sigma_min() const noexcept;
  double sigma_max() const noexcept;
  double condition() const noexcept;

  // For the update functions of the library: record the singular values, or
  // J^T J to compute them from on demand, or neither (NaN).
  void set_singular_values(double smin, double smax) noexcept;
  void set_gram(const Eigen::Matrix<double, 6, 6>& gram) noexcept;
  void clear_singular_values() noexcept;

 private:
  void resolve() const noexcept;
  Eigen::Matrix<double, 6, 6> gram_ = Eigen::Matrix<double, 6, 6>::Zero();
  mutable double sigma_min_ = std::numeric_limits<double>::quiet_NaN();
  mutable double sigma_max_ = std::numeric_limits<double>::quiet_NaN();
  mutable bool pending_ = false;  ///< gram_ holds a J^T J whose eigenvalues are not computed yet
};

namespace detail {
struct ServoCaches;  // cpp/src/servo_caches.hpp: the goal caches, for the library's white-box tests
}

/// The control law. Build once per layout; call update() every frame.
///
/// velocity = -s * g * J+ e with g = options.gain, or options.adaptive_gain(|e|)
/// when enabled, and s = saturation_scale(...) <= 1 the uniform factor that
/// brings the twist within max_linear_speed / max_angular_speed (1 by default).
///
/// Pseudoinverse: velocity = -gain * damped_pinv(J, damping) * e (pinv.hpp) to
/// ~1e-10 relative, for every damping >= 0. Two routes (cpp/src/solve.hpp):
/// the normal equations (J^T J + lambda^2 I) x = J^T e by Cholesky plus one
/// refinement step (~0.3 us at 16 rows), taken when a cheap bound on their
/// condition number, tr(N) tr(N^-1), is below 1e10 (damping 0) or 1e7
/// (damping > 0); otherwise a QR of J and an SVD of its 6x6 R factor (~5 us;
/// rank-deficient J: fewer than 3 points, the mean Jacobian at the half-turn,
/// a tiny damping on a rank-deficient J).
///
/// Angle wrap (options.angle_wrap, angle_wrap.hpp): consistent (default) wraps
/// the theta differences of every polar and cylindrical block that is not a
/// fallback, and the feature blocks' angle rows about the axis
/// (Feature::axis_angle_rows), into (phi - pi, phi + pi] about their circular mean phi; phi is
/// unwrapped against the previous update's while within pi + wrap_hysteresis
/// of 0, so near the half-turn the branch does not alternate from frame to
/// frame with the noise. reset() forgets the previous frame (call it when a
/// new servoing task starts); per_point is eq. (13) point by point, stateless.
///
/// r -> 0 policy: a polar block whose current or desired radius is below
/// polar_min_radius uses its Cartesian rows and Cartesian error for that step
/// (theta is undefined at the principal point and its rows grow as 1/r);
/// counted in ServoOutput::polar_fallbacks. Cylindrical blocks (r, r theta)
/// have bounded rows and never fall back: their error is
/// (r - r*, r wrap(theta - theta*)) and their rows the derivative of it (see
/// cylindrical_jacobian); a point at r = 0 borrows the other point's direction.
///
/// Smooth starts and switches (options.smoothing, smoothing.hpp): the twist above is the law's;
/// with a decay rate mu the commanded one is the continuous law of Mansard & Chaumette 2007
/// (eq. 17), then scaled to the acceleration limits. Transitions: the first update, reset(),
/// switch_law(), a set_options() that changes the law, a change of the Cartesian / polar choice
/// of a block (polar_min_radius, cartesian_near_goal) or of the valid points. Turning smoothing
/// on mid-run starts from the last twist it saw (give the current one with reset(twist)).
///
/// Lost points (ServoInput::valid): their blocks' rows are zeroed (weighted least squares with
/// weight 0: exactly the law of the other points); below 2 x valid points + feature rows =
/// Task::n_dof() the step is Status::features_lost and the twist ramps to zero over stop_time.
class Servo {
 public:
  /// A task: the points of a Layout (a Layout converts to one), feature blocks, weights, DOF.
  explicit Servo(Task task, ServoOptions options = {});  // throws std::invalid_argument
  ~Servo();
  Servo(Servo&&) noexcept;
  Servo& operator=(Servo&&) noexcept;

  const Layout& layout() const noexcept { return task_.points(); }  ///< the task's points
  const Task& task() const noexcept { return task_; }
  const ServoOptions& options() const noexcept { return options_; }
  /// Replace the options (gain scheduling etc.). Throws on invalid values; never allocates.
  void set_options(const ServoOptions& options);
  static void validate(const ServoOptions& options);
  /// Forget the previous frame's angle-wrap branch (see angle_wrap.hpp) and, with smoothing,
  /// start the next update from `current`, the twist the camera has (rest by default). noexcept.
  void reset(const Twist& current = Twist::Zero()) noexcept;
  /// The consistent angle wrap's branch for the next frame (angle_wrap.hpp), chosen by hand: as if the
  /// previous frame's circular mean of the polar angle errors (theta - theta*, radians) had been `centre`.
  /// At a half-turn about the optical axis, whose direction the image noise would otherwise decide,
  /// centre = +pi or -pi chooses which way the camera turns (e.g. the way a wrist joint's limits allow);
  /// the frames after it continue from there as usual. NaN forgets the branch, as do reset() and a change
  /// of angle_wrap; the per-point wrap and a task without polar angles ignore it. Throws
  /// std::invalid_argument unless centre is NaN or |centre| <= pi + wrap_hysteresis; allocates only
  /// when it throws. (sim::EpisodeOptions::turn applies it after an episode's reset.)
  void continue_turn(double centre);
  /// Smoothing: the law changes now (e.g. a gain switched by hand, or another servo handing
  /// over): the next update blends from `from`, the twist last commanded. noexcept.
  void switch_law(const Twist& from) noexcept;

  /// Throws std::invalid_argument naming the first bad argument.
  void validate(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                const Eigen::Ref<const Points>& uv_desired,
                const Eigen::Ref<const Eigen::VectorXd>& depth_desired) const;

  /// validate() above, then the feature blocks' measurements (Task::measurement_size() each):
  /// throws naming the block and entry, e.g. "ibvs: measurements[block 1, line][4]: ...".
  void validate(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                const Eigen::Ref<const Eigen::VectorXd>& measurements,
                const Eigen::Ref<const Eigen::VectorXd>& measurements_desired) const;
  /// validate() above for the points marked valid only (valid: N entries; the others are not read).
  void validate(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                const Eigen::Ref<const Eigen::VectorXd>& measurements,
                const Eigen::Ref<const Eigen::VectorXd>& measurements_desired, const PointMask& valid) const;
  void validate(const ServoInput& in) const {
    validate(in.uv, in.depth, in.uv_desired, in.depth_desired, in.measurements, in.measurements_desired, in.valid);
  }

  /// One control step of a task of points only (a task with feature blocks needs their
  /// measurements: Status::invalid_input here). Real-time safe: noexcept, no heap allocation.
  Status update(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                ServoOutput& out) noexcept;
  /// One control step of any task. Real-time safe: noexcept, no heap allocation.
  Status update(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                const Eigen::Ref<const Eigen::VectorXd>& measurements,
                const Eigen::Ref<const Eigen::VectorXd>& measurements_desired, ServoOutput& out) noexcept;
  /// One control step with some points possibly lost (valid: N entries, see ServoInput::valid):
  /// the law on the valid points while 2 x valid points + feature rows >= Task::n_dof() (>= 3
  /// points for 6 DOF), else Status::features_lost and the twist ramped to zero over stop_time.
  Status update(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
                const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
                const Eigen::Ref<const Eigen::VectorXd>& measurements,
                const Eigen::Ref<const Eigen::VectorXd>& measurements_desired, const PointMask& valid,
                ServoOutput& out) noexcept;
  Status update(const ServoInput& in, ServoOutput& out) noexcept {
    return update(in.uv, in.depth, in.uv_desired, in.depth_desired, in.measurements, in.measurements_desired, in.valid,
                  out);
  }

  /// Pixels in, twist out (cpp/src/pixels.cpp): the camera model that update_pixels() uses.
  /// Allocates its buffers; throws std::invalid_argument for an invalid model.
  void set_camera(const CameraModel& camera);
  const CameraModel* camera() const noexcept { return pixels_.camera(); }  ///< nullptr until set_camera()
  /// Throws std::invalid_argument naming the first bad argument: no camera, a pixel (2 x N, as
  /// the sensor delivers it) that the camera model cannot normalise, then validate()'s checks.
  void validate_pixels(const Eigen::Ref<const Points>& pixels, const Eigen::Ref<const Eigen::VectorXd>& depth,
                       const Eigen::Ref<const Points>& pixels_desired,
                       const Eigen::Ref<const Eigen::VectorXd>& depth_desired) const;
  /// One control step from pixels: CameraModel::normalize of pixels and pixels_desired, then
  /// update(); out.pixel_error is the largest point-to-goal distance in pixels. No camera, or a
  /// pixel without an inverse: Status::invalid_input, zero twist. Noexcept, allocation-free.
  Status update_pixels(const Eigen::Ref<const Points>& pixels, const Eigen::Ref<const Eigen::VectorXd>& depth,
                       const Eigen::Ref<const Points>& pixels_desired,
                       const Eigen::Ref<const Eigen::VectorXd>& depth_desired, ServoOutput& out) noexcept;

 private:
  friend struct detail::ServoCaches;
  struct Kernel;  // sized workspace: fixed 8 or 16 rows, or dynamic
  Status step(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Eigen::VectorXd>& depth,
              const Eigen::Ref<const Points>& uv_desired, const Eigen::Ref<const Eigen::VectorXd>& depth_desired,
              const Eigen::Ref<const Eigen::VectorXd>& measurements,
              const Eigen::Ref<const Eigen::VectorXd>& measurements_desired, const PointMask* valid, int lost,
              ServoOutput& out) noexcept;
  Status stop(ServoOutput& out) noexcept;
  void switch_near_goal(const Eigen::Ref<const Points>& uv, const Eigen::Ref<const Points>& uv_desired,
                        const PointMask* valid) noexcept;
  void smooth(std::uint64_t key, ServoOutput& out) noexcept;
  Task task_;
  ServoOptions options_;
  ServoOptions near_options_;  // options_ with every polar block Cartesian (cartesian_near_goal)
  TwistSmoother smoother_;     // smoothing.hpp: the last twist and the continuous law's offset
  std::uint64_t pattern_ = 0;  // the last step's Cartesian / polar choices and valid points (a hash)
  bool extras_ = false;        // smoothing, cartesian_near_goal or stop_time on (else the plain law)
  bool near_goal_ = false;     // cartesian_near_goal: within the switch distance
  bool stopping_ = false;      // Status::features_lost: ramping the twist to zero
  double stop_elapsed_ = 0.0;
  Twist stop_from_ = Twist::Zero();
  std::unique_ptr<Kernel> kernel_;
  detail::PixelFrontEnd pixels_;  // camera and normalised points of update_pixels()
  // The previous frame's angle-wrap centre; NaN: none (after construction / reset()). A frame whose
  // centre is its circular mean and moves no angle row (Servo::step) keeps its resultant instead, and
  // the centre (one atan2) is computed if a later frame reads it: the same value, when it is needed.
  class WrapCentre {
   public:
    double get() noexcept {
      if (pending_) {
        value_ = sum_.mean();
        pending_ = false;
      }
      return value_;
    }
    void set(double centre) noexcept {
      value_ = centre;
      pending_ = false;
    }
    void defer(const AngleResultant& sum) noexcept {
      sum_ = sum;
      pending_ = true;
    }

   private:
    double value_ = std::numeric_limits<double>::quiet_NaN();
    AngleResultant sum_;
    bool pending_ = false;
  } wrap_centre_;
};

/// Default switching radius of the automatic hybrid (normalised units: 50 px
/// at a focal length of 1000 px).
inline constexpr double default_switch_radius = 0.05;

/// Automatic hybrid: each point is polar (IBVS-P) while it and its desired
/// point lie at least switch_radius from the principal point, and Cartesian
/// (eq. 3) otherwise, re-decided every step. This is the r -> 0 policy above
/// with a larger radius: Layout::polar(n) and polar_min_radius = switch_radius
/// (options.polar_min_radius is replaced). Near the centre the polar rows grow
/// as 1/r and a small image distance becomes a large theta error; the
/// Cartesian block has neither problem, while far from it the polar block
/// keeps the straight r-theta paths that avoid the camera retreat.
/// ServoOutput::polar_fallbacks counts the points computed as Cartesian.
Servo automatic_hybrid(int n_points, ServoOptions options = {}, double switch_radius = default_switch_radius);

}  // namespace ibvs
