// Proof that Servo::update allocates nothing: malloc, calloc, realloc, the
// aligned allocators and operator new are interposed and counted (glibc), so
// every heap allocation of the process is seen, Eigen's included (its
// aligned_malloc ends in malloc). The test links the library as users do
// (compiling it a second time with Eigen's EIGEN_RUNTIME_NO_MALLOC assertion,
// as before, doubled the C++ build for a witness that sees less than this one).
#include "check.hpp"

#include "ibvs/ibvs.hpp"
#include "ibvs/features/function.hpp"
#include "ibvs/features/pose.hpp"
#include "ibvs/partitioned.hpp"
#include "ibvs/robot_mapping.hpp"
#include "ibvs/secondary_task.hpp"
#include "sim_cases.hpp"

#include <atomic>
#include <limits>
#include <new>
#include <vector>

namespace {
std::atomic<long> news{0};
}

// AddressSanitizer owns malloc in its builds: there only operator new is counted.
#if !defined(__SANITIZE_ADDRESS__)
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* malloc(std::size_t n) {
  ++news;
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t size) {
  ++news;
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t n) {
  ++news;
  return __libc_realloc(p, n);
}
void* __libc_memalign(std::size_t, std::size_t);
void* memalign(std::size_t alignment, std::size_t n) {
  ++news;
  return __libc_memalign(alignment, n);
}
void* aligned_alloc(std::size_t alignment, std::size_t n) {
  ++news;
  return __libc_memalign(alignment, n);
}
int posix_memalign(void** p, std::size_t alignment, std::size_t n) {
  ++news;
  *p = __libc_memalign(alignment, n);
  return *p ? 0 : 12;  // ENOMEM
}
}
#endif

void* operator new(std::size_t n) {
  ++news;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

using namespace ibvs;

// A whole simulated episode (the per-frame loop: camera model, noise, latency,
// pose estimate, depth estimate, depth error, image-boundary potential, Servo
// or PartitionedServo, gantry) allocates nothing once the Episode is built.
void episode_allocates_nothing() {
  using namespace sim_cases;
  for (bool partitioned : {false, true}) {
    for (bool gantry : {false, true}) {
      for (DepthMode depth : {DepthMode::exact, DepthMode::pose, DepthMode::desired, DepthMode::estimated}) {
        EpisodeOptions o;
        o.duration = 5.0;
        o.noise = gantry ? 0.3 : 1e-4;
        o.latency = 2;
        o.depth = depth;
        o.depth_scale = 1.1;                          // depth error
        o.boundary_margin = gantry ? 150.0 : 0.1;    // image-boundary potential active
        o.boundary_gain = 0.1;
        ServoOptions so;
        so.gain = 1.0;
        PartitionedOptions po;
        po.gain = 1.0;
        AnyServo servo = partitioned ? AnyServo(PartitionedServo(4, po)) : AnyServo(Servo(Layout::stacked(4), so));
        const Gantry g = Gantry::afma6();
        std::optional<Episode> e;
        if (gantry)
          e.emplace(std::move(servo), CameraModel::afma6(), gantry_target(g), g, o);
        else
          e.emplace(std::move(servo), CameraModel::normalized(0.3), Target::paper(), o);
        const long before = news.load();
        const EpisodeResult& r =
            gantry ? e->run(gantry_start(), gantry_goal()) : e->run(general_motion(), Pose::Identity());
        const long during = news.load() - before;
        ibvs_test::report(during == 0, "no allocation in Episode::run", __FILE__, __LINE__,
                          std::string(partitioned ? "partitioned " : "stacked ") + (gantry ? "gantry " : "free ") +
                              to_string(depth) + ": " + std::to_string(during));
        CHECK(r.history.frames > 10);
      }
    }
  }
}

// The episode on a generic robot with n = 7 joints (JointMapping with a
// redundant Jacobian, joint history of 7 columns).
void robot_episode_allocates_nothing() {
  using namespace sim_cases;
  EpisodeOptions o;
  o.duration = 5.0;
  o.depth = DepthMode::estimated;
  ServoOptions so;
  so.gain = 2.0;
  Episode e(Servo(Layout::stacked(4), so), CameraModel::afma6(), gantry_target(Gantry::afma6()),
            std::make_shared<StackedGantry>(), o);
  const JointVector qs = stacked_start(), qg = stacked_goal();
  const Pose goal = e.robot()->camera(qg);
  const long before = news.load();
  const EpisodeResult& r = e.run(qs, goal);
  const long during = news.load() - before;
  ibvs_test::report(during == 0, "no allocation in Episode::run on a 7-joint robot", __FILE__, __LINE__,
                    std::to_string(during));
  CHECK(r.history.frames > 10 && r.history.q.cols() == 7);
}

// Episodes of tasks with feature blocks (lines between target points, with and without the
// points; every depth mode, so every depth pose: the true one, the goal's, the planar pose
// estimate and the fit to the estimated points), free and on the gantry: the sources stage
// and the servo's feature blocks allocate nothing per frame.
void feature_episode_allocates_nothing() {
  using namespace sim_cases;
  for (bool points : {false, true}) {
    for (bool gantry : {false, true}) {
      for (DepthMode depth : {DepthMode::exact, DepthMode::pose, DepthMode::desired, DepthMode::estimated}) {
        EpisodeOptions o;
        o.duration = 5.0;
        o.noise = gantry ? 0.3 : 1e-4;
        o.latency = 2;
        o.depth = depth;
        o.depth_scale = 1.1;
        ServoOptions so;
        so.gain = gantry ? 2.0 : 1.0;
        Task task(points ? Layout::stacked(4) : Layout::none());
        for (int k = 0; k < 4; ++k) task.add(LineFeature());
        const Gantry g = Gantry::afma6();
        Target t = gantry ? gantry_target(g) : Target::paper();
        for (int k = 0; k < 4; ++k) t.add(sim::LineSource(k, (k + 1) % 4));
        std::optional<Episode> e;
        if (gantry)
          e.emplace(Servo(task, so), CameraModel::afma6(), t, g, o);
        else
          e.emplace(Servo(task, so), CameraModel::normalized(0.3), t, o);
        const long before = news.load();
        const EpisodeResult& r =
            gantry ? e->run(gantry_start(), gantry_goal()) : e->run(general_motion(), Pose::Identity());
        const long during = news.load() - before;
        ibvs_test::report(during == 0, "no allocation in Episode::run of a task with lines", __FILE__, __LINE__,
                          std::string(points ? "points+lines " : "lines ") + (gantry ? "gantry " : "free ") +
                              to_string(depth) + ": " + std::to_string(during));
        CHECK(r.history.frames > 10 && r.history.measurements.cols() == 20);
      }
    }
  }
}

// Episodes of moments, PBVS and 2.5-D tasks (their simulator sources, every depth mode that moves
// them; in the pose and estimated modes their goal is estimated from the goal's image when run()
// teaches it, or given) on an asymmetric planar quadrilateral: nothing allocated in run().
void pose_moments_episode_allocates_nothing() {
  using namespace sim_cases;
  Eigen::Matrix3Xd quad(3, 4);
  quad << 0.30, -0.22, -0.27, 0.16, 0.18, 0.26, -0.20, -0.24, 0.0, 0.0, 0.0, 0.0;
  Pose at = Pose::Identity();
  at(2, 3) = 3.0;
  for (int kind = 0; kind < 4; ++kind) {
    for (DepthMode depth : {DepthMode::exact, DepthMode::pose, DepthMode::estimated}) {
      EpisodeOptions o;
      o.duration = 3.0;
      o.noise = 1e-4;
      o.latency = 1;
      o.depth = depth;
      o.depth_scale = 1.1;
      Task task;
      Target t(quad, at);
      if (kind == 0) {
        task.add(MomentsFeature());
        t.add(sim::MomentsSource());
      } else if (kind == 3) {
        task.add(Point25DFeature());
        t.add(sim::Point25DSource(0));
      } else {
        const PbvsTarget pt = kind == 1 ? PbvsTarget::desired_camera : PbvsTarget::object;
        task.add(PbvsFeature(pt));
        t.add(sim::PbvsSource(pt));
      }
      for (GoalPose goal_pose : {GoalPose::taught, GoalPose::given}) {  // the goal taught or given
        o.goal_pose = goal_pose;
        Episode e(Servo(task, ServoOptions{}), CameraModel::normalized(0.3), t, o);
        const long before = news.load();
        const EpisodeResult& r = e.run(general_motion(), Pose::Identity());
        const long during = news.load() - before;
        ibvs_test::report(during == 0, "no allocation in Episode::run of a moments / PBVS / 2.5-D task", __FILE__,
                          __LINE__, task.feature(0).describe() + " " + to_string(depth) + " " + to_string(goal_pose) +
                                        ": " + std::to_string(during));
        CHECK(r.history.frames > 10);
      }
    }
  }
}

// An episode of spherical blocks on a fisheye from 100 degrees off the axis (SphericalSource, the wide
// lens's in-image test and bearings): nothing allocated per frame.
void spherical_episode_allocates_nothing() {
  using namespace sim_cases;
  Eigen::Matrix3d K;
  K << 300, 0, 640, 0, 300, 512, 0, 0, 1;
  const CameraModel fish = CameraModel::from_opencv(K, Eigen::Vector4d(-0.013, 0.02, -0.012, 0.002), 1280, 1024, true);
  Eigen::Matrix3Xd P(3, 4);
  P << -0.25, 0.25, 0.25, -0.25, -0.25, -0.25, 0.25, 0.25, 0.0, 0.0, 0.0, 0.0;
  Pose ahead = Pose::Identity();
  ahead(2, 3) = 1.0;
  Target t(P, ahead);
  Task task;
  for (int i = 0; i < 4; ++i) {
    task.add(SphericalPolarFeature());
    t.add(sim::SphericalSource(i));
  }
  // exact depths, and the pose depth mode (PlanarPose::estimate_bearings each frame)
  for (const DepthMode mode : {DepthMode::exact, DepthMode::pose}) {
    EpisodeOptions o;
    o.duration = 3.0;
    o.noise = 0.1;
    o.latency = 1;
    o.depth = mode;
    Twist v;
    v << 0.05, -0.04, -0.2, 0.0, 1.87, 0.3;
    Episode e(Servo(task, ServoOptions{}), fish, t, o);
    const long before = news.load();
    const EpisodeResult& r = e.run(se3_exp(v), Pose::Identity());
    const long during = news.load() - before;
    ibvs_test::report(during == 0, "no allocation in Episode::run of a spherical task on a fisheye", __FILE__, __LINE__,
                      std::to_string(during));
    CHECK(r.history.frames > 100);
  }
}

// An episode with a C++ sensor in place of the default (the measurement hook costs no allocation).
class ShiftSensor final : public ibvs::sim::Sensor {
 public:
  void reset(std::uint64_t) noexcept override {}
  bool measure(const ibvs::sim::SensorFrame& f, Eigen::Ref<Points> m) noexcept override {
    m = *f.projected;
    m.array() += 0.5;
    return true;
  }
};

void sensor_episode_allocates_nothing() {
  using namespace sim_cases;
  using ibvs::sim::Episode;
  EpisodeOptions o;
  o.duration = 5.0;
  o.latency = 2;
  o.depth = DepthMode::pose;
  ServoOptions so;
  so.gain = 1.0;
  const Gantry g = Gantry::afma6();
  Episode e(Servo(Layout::stacked(4), so), CameraModel::afma6(), gantry_target(g), g, o);
  e.set_sensor(std::make_shared<ShiftSensor>());
  const long before = news.load();
  const EpisodeResult& r = e.run(gantry_start(), gantry_goal());
  const long during = news.load() - before;
  ibvs_test::report(during == 0, "no allocation in Episode::run with a sensor", __FILE__, __LINE__,
                    std::to_string(during));
  CHECK(r.history.frames > 10);
}

// PartitionedServo::update: fixed 8 rows and the bounded dynamic workspace (256 rows).
void partitioned_allocates_nothing() {
  for (int n : {4, 3, 128}) {
    for (double lambda : {0.0, 0.01}) {
      PartitionedOptions o;
      o.damping = lambda;
      o.max_linear_speed = 0.01;
      PartitionedServo servo(n, o);
      ServoOutput out(servo.layout());
      Points uv(2, n), uvd(2, n);
      for (int i = 0; i < n; ++i) {
        const double a = 2 * pi * i / n;
        uv.col(i) << 0.1 * std::cos(a), 0.1 * std::sin(a);
        uvd.col(i) << 0.12 * std::cos(a + 2.5), 0.12 * std::sin(a + 2.5);
      }
      Eigen::VectorXd z = Eigen::VectorXd::Ones(n);
      const long before = news.load();
      Status st = Status::ok;
      for (int k = 0; k < 3; ++k) st = servo.update(uv, z, uvd, z, out);
      z(0) = -1.0;
      const Status bad = servo.update(uv, z, uvd, z, out);
      const long during = news.load() - before;
      ibvs_test::report(during == 0, "no allocation in PartitionedServo::update", __FILE__, __LINE__,
                        std::to_string(n) + ": " + std::to_string(during));
      CHECK(st != Status::invalid_input && bad == Status::invalid_input && out.velocity.allFinite());
    }
  }
}

// JointMapping::update: SVD of the 6 x n camera Jacobian (n up to max_joints,
// workspace sized by the constructor), damping, variable damping, null-space task, speed limits,
// both Jacobian frames, and the invalid-input path.
void joint_mapping_allocates_nothing() {
  for (int n : {1, 3, 6, 7, max_joints}) {
    for (JacobianFrame frame : {JacobianFrame::end_effector, JacobianFrame::base}) {
      for (double damping : {0.0, 0.05}) {
        JointMappingOptions o;
        o.frame = frame;
        o.damping = damping;
        o.singular_region = damping > 0.0 ? 10.0 : 0.0;  // inside the region: variable damping active
        o.max_joint_speed = JointVector::Constant(n, 0.01);
        Pose eMc = Pose::Identity();
        eMc.topRightCorner<3, 1>() << 0.05, -0.02, 0.1;
        JointMapping map(n, eMc, o);
        JointMappingInput in(n);
        JointMappingOutput out(n);
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < 6; ++i) in.jacobian(i, j) = std::sin(1.0 + i + 7.0 * j);
        in.twist << 0.1, -0.2, 0.05, 0.3, -0.1, 0.2;
        in.base_rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
        in.secondary.setConstant(0.3);
        const long before = news.load();
        Status st = Status::ok;
        for (int k = 0; k < 3; ++k) st = map.update(in, out);
        in.twist(0) = std::nan("");  // the invalid-input path must not allocate either
        const Status bad = map.update(in, out);
        const long during = news.load() - before;
        ibvs_test::report(during == 0, "no allocation in JointMapping::update", __FILE__, __LINE__,
                          std::to_string(n) + " joints: " + std::to_string(during));
        CHECK(st != Status::invalid_input && bad == Status::invalid_input);
      }
    }
  }
}

// CameraModel::project / normalize (every distortion, Newton included) and the
// pixel API of both servos, refused pixels included.
void pixels_allocate_nothing() {
  Eigen::Matrix3d K;
  K << 600, 0, 320, 0, 601, 240, 0, 0, 1;
  Eigen::VectorXd pb(5), fe(4);
  pb << -0.4, 0.05, 0.001, -0.0005, 0.0;
  fe << -0.013, 0.021, -0.012, 0.003;
  const CameraModel cams[4] = {CameraModel::normalized(0.3), CameraModel::afma6(),
                               CameraModel::from_opencv(K, pb, 640, 480),
                               CameraModel::from_opencv(K, fe, 640, 480, true)};
  for (const CameraModel& cam : cams) {
    Points uv(2, 4), uvd(2, 4), px(2, 4), pxd(2, 4), back(2, 4);
    uvd << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
    uv << 0.16, -0.05, -0.16, 0.05, 0.05, 0.16, -0.05, -0.16;
    Servo servo(Layout::stacked(4), {});
    PartitionedServo part(4, {});
    servo.set_camera(cam);
    part.set_camera(cam);
    ServoOutput out(servo.layout()), pout(part.layout());
    const Eigen::VectorXd z = Eigen::VectorXd::Constant(4, 0.6);
    const long before = news.load();
    int failed = cam.project(uv, px) + cam.project(uvd, pxd) + cam.normalize(px, back);
    const Status a = servo.update_pixels(px, z, pxd, z, out);
    const Status b = part.update_pixels(px, z, pxd, z, pout);
    px(0, 1) = std::numeric_limits<double>::quiet_NaN();  // refused pixel: no allocation either
    const Status c = servo.update_pixels(px, z, pxd, z, out);
    failed += cam.normalize(px, back);
    const long during = news.load() - before;
    ibvs_test::report(during == 0, "no allocation in CameraModel / update_pixels", __FILE__, __LINE__,
                      cam.describe() + ": " + std::to_string(during));
    CHECK(failed == 1 && a != Status::invalid_input && b != Status::invalid_input && c == Status::invalid_input);
  }
}

// The wide-angle path: to_bearing / from_bearing of every model (Newton included, refused points
// too), spherical_measurements and a Servo of spherical point and spherical-polar blocks.
void bearings_allocate_nothing() {
  Eigen::Matrix3d K;
  K << 300, 0, 640, 0, 300.5, 512, 0, 0, 1;
  Eigen::VectorXd pb(5);
  pb << -0.4, 0.05, 0.001, -0.0005, 0.0;
  const CameraModel cams[4] = {CameraModel::afma6(), CameraModel::from_opencv(K, pb, 1280, 1024),
                               CameraModel::from_opencv(K, Eigen::Vector4d(-0.013, 0.02, -0.012, 0.002), 1280, 1024, true),
                               CameraModel::from_omnidir(K, 1.2, Eigen::Vector4d(-0.1, 0.02, 1e-4, 2e-4), 1280, 1024)};
  Task task;
  task.add(SphericalPointFeature()).add(SphericalPolarFeature()).add(SphericalPolarFeature()).add(SphericalPointFeature());
  Servo servo(task);
  ServoInput in(task);
  ServoOutput out(task);
  for (const CameraModel& cam : cams) {
    Points px(2, 4), back(2, 4);
    px << 640, 700, 300, 1000, 512, 400, 900, 100;
    Bearings b(3, 4);
    const Eigen::VectorXd R = Eigen::VectorXd::Constant(4, 0.8);
    const long before = news.load();
    const int refused = cam.to_bearing(px, b);
    cam.from_bearing(b, back);
    spherical_measurements(cam, px, R, in.measurements);
    in.measurements_desired = in.measurements;  // same size: no allocation
    in.measurements_desired(0) += 0.0;
    const Status st = servo.update(in, out);
    px(0, 0) = std::numeric_limits<double>::quiet_NaN();  // refused by every model
    const int bad = cam.to_bearing(px, b);
    const long during = news.load() - before;
    ibvs_test::report(during == 0, "no allocation in to_bearing / from_bearing / spherical servo", __FILE__, __LINE__,
                      cam.describe() + ": " + std::to_string(during));
    CHECK(bad == refused + 1 && (refused > 0 || st != Status::invalid_input));
  }
}

// DepthEstimator::update (both motion forms, a restart, refused input) and
// PlanarPose::estimate (a pose and a degenerate image).
void estimators_allocate_nothing() {
  Points uv(2, 4), line(2, 4);
  uv << 0.1, -0.1, -0.1, 0.1, 0.1, 0.1, -0.1, -0.1;
  line << 0.0, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 0.0;
  DepthEstimatorOptions eo;
  eo.point_noise = 1e-3;
  DepthEstimator est(Eigen::VectorXd::Constant(4, 0.8), eo);
  const PlanarPose pp(sim::Target::square(0.2).points);
  Twist d;
  d << 0.004, -0.002, 0.003, 0.001, -0.002, 0.004;
  const Pose M = se3_exp(d);
  Pose through = Pose::Identity(), T;
  through(2, 3) = 5.0;
  Eigen::VectorXd z(4);
  const Eigen::VectorXd prior = Eigen::VectorXd::Constant(4, 0.7);
  const long before = news.load();
  bool ok = est.update(uv, M) && est.update(uv, d, 1.0 / 60.0) && est.update(uv, M) && est.update(uv, through);
  const int restarts = est.restarts();
  ok = ok && !est.update(uv.leftCols(3), M);
  est.reset(prior);
  ok = ok && est.update(uv, M) && pp.estimate(uv, T, z) && !pp.estimate(line, T, z);
  const long during = news.load() - before;
  ibvs_test::report(during == 0, "no allocation in DepthEstimator::update / PlanarPose::estimate", __FILE__, __LINE__,
                    std::to_string(during));
  CHECK(ok && restarts == 4 && est.depth().allFinite() && z.allFinite());
  // PlanarPose::estimate_bearings: the target 110 degrees off the axis (z < 0), a reversed bearing.
  Pose Tb = se3_exp((Twist() << 0, 0, 0, 0, 1.92, 0).finished());
  Tb.topRightCorner<3, 1>() << 0.94, 0.0, -0.34;
  Eigen::Matrix3Xd bearings = Tb.topLeftCorner<3, 3>() * pp.points();
  bearings.colwise() += Tb.topRightCorner<3, 1>();
  Eigen::Matrix3Xd away = bearings;
  away.col(1) *= -1.0;
  const long before_b = news.load();
  const bool ok_b = pp.estimate_bearings(bearings, T, z) && !pp.estimate_bearings(away, T, z) && pp.estimate_bearings(bearings, T);
  const long during_b = news.load() - before_b;
  ibvs_test::report(during_b == 0, "no allocation in PlanarPose::estimate_bearings", __FILE__, __LINE__,
                    std::to_string(during_b));
  CHECK(ok_b && (T - Tb).cwiseAbs().maxCoeff() < 1e-9 && z.allFinite());
}

// A Task of PBVS (both targets), 2.5-D and a user's FunctionFeature blocks beside a point:
// Servo::update (the blocks' check, value, error, interaction) allocates nothing, with every
// interaction-matrix mode, damped or not, and on the invalid-input path.
void pose_blocks_allocate_nothing() {
  const auto point = [](const double* m, double* s, Eigen::Ref<MatrixX6> L) noexcept {
    s[0] = m[0];
    s[1] = m[1];
    L = cartesian_jacobian(m[0], m[1], m[2]);
    return m[2] > 0.0;
  };
  Task task(Layout::cartesian(1));
  task.add(PbvsFeature(PbvsTarget::desired_camera)).add(PbvsFeature(PbvsTarget::object), 0.5);
  task.add(Point25DFeature()).add(FunctionFeature(2, 3, point));
  for (double lambda : {0.0, 0.01}) {
    for (auto mode : {InteractionMatrix::current, InteractionMatrix::desired, InteractionMatrix::mean}) {
      ServoOptions o;
      o.damping = lambda;
      o.jacobian = mode;
      Servo servo(task, o);
      ServoInput in(task);
      ServoOutput out(task);
      in.uv << 0.1, -0.05;
      in.uv_desired << 0.0, 0.02;
      in.measurements << 0.1, 0.2, 0.3, 0.5, -1.0, 2.5, 0.1, 0.2, 1.5, 0.1, 0.2, 3.0, 0.1, -0.1, 1.2, 0.3, 0.2, 1e-9,
          0.1, 0.1, 1.0;
      in.measurements_desired << 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 1;
      const long before = news.load();
      Status st = Status::ok;
      for (int k = 0; k < 3; ++k) st = servo.update(in, out);
      in.measurements(20) = -1.0;  // the function refuses it: the invalid-input path
      const Status bad = servo.update(in, out);
      const long during = news.load() - before;
      ibvs_test::report(during == 0, "no allocation in update (pose blocks)", __FILE__, __LINE__,
                        task.describe() + ": " + std::to_string(during));
      CHECK(st != Status::invalid_input && bad == Status::invalid_input);
    }
  }
}

// Task blocks of the segment and the ellipse (with a point, weights, a DOF left out): every
// route of update() (damping 0 and 0.01, the current, desired and mean Jacobians), the
// unoriented segment's align() taking the reverse, and a refused measurement.
void segment_ellipse_allocate_nothing() {
  Task task(Layout::cartesian(1));
  task.add(SegmentFeature()).add(SegmentFeature(false), 2.0).add(EllipseFeature(), 10.0);
  for (bool all : {true, false}) {
    if (!all) task.set_dof({true, true, true, true, true, false});
    for (double lambda : {0.0, 0.01}) {
      for (auto mode : {InteractionMatrix::current, InteractionMatrix::desired, InteractionMatrix::mean}) {
        ServoOptions o;
        o.damping = lambda;
        o.jacobian = mode;
        Servo servo(task, o);
        ServoInput in(task);
        ServoOutput out(task);
        in.uv << 0.05, -0.02;
        in.uv_desired << 0.0, 0.0;
        const auto s1 = SegmentFeature::measure(0.1, 0.1, 1.0, -0.1, 0.12, 1.2);
        const auto s2 = SegmentFeature::measure(0.1, -0.1, 1.0, 0.12, 0.1, 1.1);
        const auto s1d = SegmentFeature::measure(-0.1, 0.12, 1.2, 0.1, 0.1, 1.0);  // the reverse: align() turns it
        const auto e = EllipseFeature::project_circle({0.05, 0.0, 1.0}, {0.2, 0.1, -1.0}, 0.1),
                   ed = EllipseFeature::project_circle({0.0, 0.0, 1.0}, {0.0, 0.0, -1.0}, 0.12);
        std::copy(s1.begin(), s1.end(), in.measurements.data());
        std::copy(s2.begin(), s2.end(), in.measurements.data() + 6);
        std::copy(e.begin(), e.end(), in.measurements.data() + 12);
        std::copy(s1d.begin(), s1d.end(), in.measurements_desired.data());
        std::copy(s1.begin(), s1.end(), in.measurements_desired.data() + 6);
        std::copy(ed.begin(), ed.end(), in.measurements_desired.data() + 12);
        const long before = news.load();
        Status st = servo.update(in, out);
        const double sigma = out.sigma_min() + out.sigma_max();
        in.measurements(12 + 3) = 1.0;  // n11^2 > n20 n02: refused
        const Status bad = servo.update(in, out);
        const long during = news.load() - before;
        ibvs_test::report(during == 0, "no allocation in update with segment / ellipse blocks", __FILE__, __LINE__,
                          task.describe() + ": " + std::to_string(during));
        CHECK(st != Status::invalid_input && bad == Status::invalid_input && std::isfinite(sigma));
      }
    }
  }
}

// The witness itself: an Eigen heap matrix and a std::vector are counted, so a
// zero elsewhere means no allocation, not a counter that sees nothing.
void counter_sees_allocations() {
  long before = news.load();
  Eigen::MatrixXd big = Eigen::MatrixXd::Random(40, 40);  // Eigen's aligned_malloc
  ibvs_test::report(news.load() - before >= 1, "Eigen heap allocation counted", __FILE__, __LINE__, "");
  before = news.load();
  std::vector<double> v(static_cast<std::size_t>(big.rows()));
  ibvs_test::report(news.load() - before >= 1, "operator new counted", __FILE__, __LINE__, std::to_string(v.size()));
}

// Eye-to-hand JointMapping (eq. 5), SecondaryTask::update with every option (large projector,
// joint-limit avoidance, both caps, task- and joint-space motions), the refused paths, and episodes
// with the robot's secondary task on and with the camera eye-to-hand.
void mounting_and_secondary_allocate_nothing() {
  using namespace sim_cases;
  for (int n : {1, 6, 7, max_joints}) {
    JointMappingOptions mo;
    mo.mounting = Mounting::eye_to_hand;
    Pose bMc = Pose::Identity();
    bMc.topRightCorner<3, 1>() << 0.5, -0.2, 1.0;
    JointMapping map(n, bMc, mo);
    JointMappingInput in(n);
    JointMappingOutput out(n);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < 6; ++i) in.jacobian(i, j) = std::sin(1.0 + i + 7.0 * j);
    in.twist << 0.1, -0.2, 0.05, 0.3, -0.1, 0.2;
    in.base_pose.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    SecondaryTaskOptions so;
    so.projector = Projector::large;
    so.q_min = JointVector::Constant(n, -1.0);
    so.q_max = JointVector::Constant(n, 1.0);
    so.max_joint_speed = JointVector::Constant(n, 0.05);
    so.max_joint_acceleration = JointVector::Constant(n, 1.0);
    so.period = 0.01;
    SecondaryTask task(n, so);
    SecondaryTaskInput sin(n);
    SecondaryTaskOutput sout(n);
    for (int i = 0; i < n; ++i) sin.q(i) = -1.0 + 2.0 * i / std::max(1, n - 1);  // some joints in the zones
    sin.twist << 0.01, 0.0, 0.02, 0.0, 0.1, 0.0;
    sin.joints.setConstant(0.2);
    sin.task_gram.diagonal() << 1, 2, 3, 0, 0, 1;  // rank 4: the classical part has room
    sin.task_gradient << 0.1, 0.2, -0.3, 0, 0, 0.1;
    sin.error_norm = 0.4;  // the sigmoid between the projectors
    const long before = news.load();
    Status st = Status::ok, st2 = Status::ok;
    for (int k = 0; k < 3; ++k) {
      st = map.update(in, out);
      sin.camera_jacobian = out.camera_jacobian;
      sin.qdot = out.qdot;
      st2 = task.update(sin, sout);
      sin.qdot_previous = sout.qdot;
    }
    in.base_pose(0, 0) = 3.0;  // refused paths
    const Status bad = map.update(in, out);
    sin.q(0) = std::nan("");
    const Status bad2 = task.update(sin, sout);
    const long during = news.load() - before;
    ibvs_test::report(during == 0, "no allocation in eye-to-hand JointMapping::update and SecondaryTask::update",
                      __FILE__, __LINE__, std::to_string(n) + " joints: " + std::to_string(during));
    ibvs_test::report(st != Status::invalid_input && st2 == Status::ok && bad == Status::invalid_input &&
                          bad2 == Status::invalid_input,
                      "statuses", __FILE__, __LINE__,
                      std::to_string(static_cast<int>(st)) + " " + std::to_string(static_cast<int>(st2)));
  }
  for (bool eye_to_hand : {false, true}) {
    EpisodeOptions o;
    o.duration = 3.0;
    ServoOptions so;
    so.gain = 2.0;
    auto robot = std::make_shared<StackedGantry>();
    robot->secondary_task = true;
    robot->avoid_joint_limits = true;
    robot->secondary.projector = Projector::large;
    robot->qddot_max = JointVector::Constant(7, 5.0);
    JointVector qs = stacked_start();
    const JointVector qg = stacked_goal();
    Target target = gantry_target(robot->g);
    if (eye_to_hand) {  // the camera fixed where the goal put it, the target on the flange
      const Pose T_we = robot->g.end_effector(gantry_goal());
      robot->mount = T_we * robot->mount;
      robot->mapping.mounting = Mounting::eye_to_hand;
      target.pose = se3_inverse(T_we) * target.pose;
      qs = qg;  // a start the fixed camera sees: the goal moved a little
      qs.head<6>() += (Joints() << 0.02, -0.02, 0.01, 0.05, -0.05, 0.05).finished();
    }
    Episode e(Servo(Layout::stacked(4), so), CameraModel::afma6(), target, robot, o);
    const Pose goal = e.robot()->camera(qg);
    const long before = news.load();
    const EpisodeResult& r = e.run(qs, goal);
    const long during = news.load() - before;
    ibvs_test::report(during == 0, "no allocation in Episode::run with a secondary task (eye-in-hand, eye-to-hand)",
                      __FILE__, __LINE__, std::to_string(during));
    ibvs_test::report(r.history.frames > 10, "the episode runs", __FILE__, __LINE__,
                      std::string(to_string(r.status.outcome)) + " at " + std::to_string(r.status.frame));
  }
}

// The smooth law, the near-goal switch, lost points (masked step and stop ramp) and an episode
// keeping its lost points: Servo::update and Episode::run allocate nothing with them either.
class Hiding final : public sim::Sensor {
 public:
  void reset(std::uint64_t) noexcept override {}
  bool measure(const sim::SensorFrame& f, Eigen::Ref<Points> m) noexcept override {
    m = *f.projected;
    if (f.frame >= 5 && f.frame < 15) m.col(1).setConstant(std::numeric_limits<double>::quiet_NaN());
    return true;
  }
};

void smooth_and_lost_allocate_nothing() {
  for (const Layout& L : {Layout::cartesian(4), Layout::stacked(4), Layout::polar(5), Layout::stacked(64)}) {
    ServoOptions o;
    o.smoothing.decay_rate = 4.0;
    o.smoothing.max_linear_acceleration = 0.5;
    o.smoothing.max_angular_acceleration = 1.0;
    o.smoothing.period = 0.01;
    o.cartesian_near_goal = 0.5;
    o.stop_time = 0.05;
    Servo servo(L, o);
    ServoInput in(L);
    ServoOutput out(L);
    for (int i = 0; i < L.n_points(); ++i) {
      const double a = 2 * pi * i / L.n_points();
      in.uv.col(i) << 0.1 * std::cos(a), 0.1 * std::sin(a);
      in.uv_desired.col(i) << 0.12 * std::cos(a + 0.3), 0.12 * std::sin(a + 0.3);
    }
    const long before = news.load();
    Status st = servo.update(in, out);
    in.valid(1) = false;  // degraded
    in.uv.col(1).setConstant(std::numeric_limits<double>::quiet_NaN());
    const Status degraded = servo.update(in, out);
    in.valid.setConstant(false);  // too few: the stop ramp
    const Status lost = servo.update(in, out);
    in.valid.setConstant(true);
    in.uv.col(1) << 0.1, 0.0;
    servo.continue_turn(-pi);  // a hand-chosen wrap branch (set up between frames): no allocation either
    st = servo.update(in, out);
    const long during = news.load() - before;
    ibvs_test::report(during == 0, "no allocation in the smooth / masked update", __FILE__, __LINE__, L.describe());
    CHECK(st == Status::ok && degraded == Status::ok && lost == Status::features_lost);
  }
  sim::EpisodeOptions eo;
  eo.keep_lost = true;
  eo.duration = 2.0;
  ServoOptions o;
  o.smoothing.decay_rate = 4.0;
  o.smoothing.period = 1.0;
  o.stop_time = 0.2;
  sim::Episode e(Servo(Layout::cartesian(4), o), CameraModel::normalized(0.3), sim::Target::paper(), eo);
  e.set_sensor(std::make_shared<Hiding>());
  Pose start = Pose::Identity();
  start(0, 3) = 0.1;
  e.run(start, Pose::Identity());  // warm
  const long before = news.load();
  e.run(start, Pose::Identity());
  const long during = news.load() - before;
  ibvs_test::report(during == 0, "no allocation in a keep_lost episode", __FILE__, __LINE__, std::to_string(during));
}

// A Servo of a moments task (features/moments.hpp): update() of accepted and refused measurements,
// and MomentsFeature::project (the simulator's per-frame measurement).
void moments_allocate_nothing() {
  Eigen::Matrix3Xd P(3, 5);
  P << 0.1, 0.02, -0.09, -0.05, 0.08, 0.0, 0.1, 0.04, -0.08, -0.06, 0, 0, 0, 0, 0;
  P.row(2) = (1.0 + 0.3 * P.row(0).array() + 0.2 * P.row(1).array()).matrix();  // a tilted plane
  for (auto src : {MomentsFeature::Source::region, MomentsFeature::Source::points}) {
    Task task;
    task.add(MomentsFeature(src));
    Servo servo(task);
    ServoInput in(task);
    ServoOutput out(task);
    const auto md = MomentsFeature::project(P, src, 0.0, 1.0);
    in.measurements_desired = Eigen::Map<const Eigen::VectorXd>(md.data(), 20);
    in.measurements = in.measurements_desired;
    const Eigen::Matrix3Xd P2 = 1.1 * P;  // farther away
    const long before = news.load();
    const auto m = MomentsFeature::project(P2, src, md[15], 1.0);
    std::copy(m.begin(), m.end(), in.measurements.data());
    const Status a = servo.update(in, out);
    in.measurements(0) = -1.0;  // refused: no allocation either
    const Status c = servo.update(in, out);
    const long during = news.load() - before;
    ibvs_test::report(during == 0, "no allocation in Servo::update of a moments task / project", __FILE__, __LINE__,
                      std::to_string(during));
    CHECK(a != Status::invalid_input && c == Status::invalid_input);
  }
}

// Episodes of segment and circle tasks (SegmentSource, EllipseSource), every depth mode: nothing
// allocated per frame.
void shape_sources_episode_allocates_nothing() {
  using namespace sim_cases;
  Eigen::Matrix3Xd rim(3, 8);
  for (int k = 0; k < 8; ++k) rim.col(k) << 0.3 * std::cos(pi * k / 4), 0.3 * std::sin(pi * k / 4), 0.0;
  for (int kind = 0; kind < 2; ++kind) {
    for (DepthMode depth : {DepthMode::exact, DepthMode::desired, DepthMode::pose, DepthMode::estimated}) {
      EpisodeOptions o;
      o.duration = 3.0;
      o.noise = 1e-4;
      o.latency = 1;
      o.depth = depth;
      Task task;
      Target t = kind == 0 ? Target::paper() : Target(rim, Target::paper().pose);
      if (kind == 0) {
        for (int i = 0; i < 4; ++i) {
          task.add(SegmentFeature());
          t.add(sim::SegmentSource(i, (i + 1) % 4));
        }
      } else {
        task.add(EllipseFeature());
        task.set_dof(Dof{true, true, true, true, true, false});  // blind to the turn about the circle's axis
        t.add(sim::EllipseSource(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0.3));
      }
      const Pose goal = kind == 0 ? Pose(Pose::Identity()) : make_pose(0.08, -0.05, 0.0, 0.08, -0.06, 0.0);
      Episode e(Servo(task, ServoOptions{}), CameraModel::normalized(0.3), t, o);
      const long before = news.load();
      const Pose start = goal * make_pose(0.1, 0.05, -0.3, 0.03, 0.04, 0.3);
      const EpisodeResult& r = e.run(start, goal);
      const long during = news.load() - before;
      ibvs_test::report(during == 0, "no allocation in Episode::run of a segment / circle task", __FILE__, __LINE__,
                        task.feature(0).describe() + " " + to_string(depth) + ": " + std::to_string(during));
      CHECK(r.history.frames > 10);
    }
  }
}

// LuminanceServo::update (features/luminance.hpp), every J and law, with and without smoothing, on
// 8-bit and double images, accepted, textureless and refused: nothing allocated after set_desired.
void luminance_allocates_nothing() {
  const int w = 64, h = 48;
  const CameraModel cam = CameraModel::pinhole(60.0, 60.0, 31.5, 23.5, w, h);
  ImageF64 goal(h, w), cur(h, w), flat = ImageF64::Constant(h, w, 90.0), bad(h, w);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) {
      goal(r, c) = 120.0 + 50.0 * std::sin(0.3 * c + 0.1 * r) + 40.0 * std::cos(0.25 * r - 0.15 * c);
      cur(r, c) = 120.0 + 50.0 * std::sin(0.3 * (c + 0.4) + 0.1 * r) + 40.0 * std::cos(0.25 * r - 0.15 * c);
    }
  bad = cur;
  bad(7, 9) = std::numeric_limits<double>::quiet_NaN();
  const ImageU8 cur8 = cur.cast<std::uint8_t>();
  for (const auto jac : {InteractionMatrix::desired, InteractionMatrix::current, InteractionMatrix::mean})
    for (const auto law : {LuminanceLaw::levenberg_marquardt, LuminanceLaw::gauss_newton})
      for (const double sigma : {0.0, 1.0}) {
        LuminanceOptions o;
        o.jacobian = jac;
        o.law = law;
        o.smoothing = sigma;
        LuminanceServo servo(cam, w, h, o);
        servo.set_desired(goal);
        LuminanceOutput out;
        const long before = news.load();
        const LuminanceStatus a = servo.update(cur, out);
        const LuminanceStatus b = servo.update(cur8, out);
        const LuminanceStatus c = servo.update(flat, out);
        const LuminanceStatus d = servo.update(bad, out);
        const long during = news.load() - before;
        ibvs_test::report(during == 0, "no allocation in LuminanceServo::update", __FILE__, __LINE__,
                          servo.describe() + ": " + std::to_string(during));
        CHECK(a == LuminanceStatus::ok && b == LuminanceStatus::ok && d == LuminanceStatus::invalid_input);
        CHECK(c == (jac == InteractionMatrix::current ? LuminanceStatus::textureless : LuminanceStatus::ok));
      }
}

void run_tests() {
  luminance_allocates_nothing();
  mounting_and_secondary_allocate_nothing();
  smooth_and_lost_allocate_nothing();
  counter_sees_allocations();
  segment_ellipse_allocate_nothing();
  estimators_allocate_nothing();
  episode_allocates_nothing();
  partitioned_allocates_nothing();
  joint_mapping_allocates_nothing();
  robot_episode_allocates_nothing();
  sensor_episode_allocates_nothing();
  feature_episode_allocates_nothing();
  pose_moments_episode_allocates_nothing();
  spherical_episode_allocates_nothing();
  pixels_allocate_nothing();
  moments_allocate_nothing();
  bearings_allocate_nothing();
  pose_blocks_allocate_nothing();
  shape_sources_episode_allocates_nothing();
  const Layout hybrid({{0, Representation::cartesian}, {1, Representation::cartesian}, {2, Representation::polar},
                       {3, Representation::polar}});
  const Layout cyl_mixed({{0, Representation::cylindrical}, {0, Representation::polar}, {1, Representation::cartesian},
                          {2, Representation::cylindrical}, {3, Representation::cylindrical}});
  // 8 and 16 rows (fixed kernels), 2, 6, 10, 12 and 256 rows (dynamic kernel).
  for (const Layout& L : {Layout::cartesian(4), Layout::stacked(4), hybrid, Layout::polar(1), Layout::cartesian(3),
                          Layout::stacked(3), Layout::polar(5), Layout::stacked(8), Layout::cartesian(16),
                          Layout::stacked(32), Layout::stacked(64), Layout::cylindrical(4), Layout::cylindrical(1),
                          cyl_mixed, Layout::cylindrical(128)}) {
    // Every route of solve.hpp: normal (0, 0.01), robust (rank-deficient layouts and the half-turn
    // mean below; 1e-9: a tiny damping that the normal route cannot carry on them), diagnostics
    // estimated (and their exact fallback), exact, off.
    for (double lambda : {0.0, 0.01, 1e-9}) {
      for (auto mode : {InteractionMatrix::current, InteractionMatrix::desired, InteractionMatrix::mean}) {
        for (int diag : {0, 1, 2}) {
          ServoOptions o;
          o.damping = lambda;
          o.jacobian = mode;
          o.diagnostics = diag > 0;
          o.exact_diagnostics = diag == 2;
          // Both angle wraps: the consistent one (default; its circular mean and the
          // frame-to-frame centre) and eq. (13) point by point.
          o.angle_wrap = diag ? AngleWrap::consistent : AngleWrap::per_point;
          if (diag) {  // adaptive gain and saturation on the hot path as well
            o.adaptive_gain = {2.0, 0.5, 10.0};
            o.max_linear_speed = 0.01;
            o.max_angular_speed = 0.02;
          }
          Servo servo(L, o);
          ServoInput in(L);
          ServoOutput out(L);
          for (int i = 0; i < L.n_points(); ++i) {
            const double a = 2 * pi * i / L.n_points();
            in.uv.col(i) << 0.1 * std::cos(a), 0.1 * std::sin(a);
            in.uv_desired.col(i) << 0.12 * std::cos(a + 2.5), 0.12 * std::sin(a + 2.5);
          }
          in.uv.col(0).setZero();  // exercise the r -> 0 fallback as well
          ServoInput half_turn = in;  // the mean Jacobian at the half-turn: rank-deficient
          half_turn.uv = -half_turn.uv_desired;
          half_turn.depth = half_turn.depth_desired;
          const long before = news.load();
          Status st = Status::ok;
          double sigma = 0.0;
          for (int k = 0; k < 3; ++k) {
            st = servo.update(in, out);
            sigma += out.sigma_min() + out.sigma_max() + out.condition();  // computed on read: allocation-free too
          }
          const Status st_half = servo.update(half_turn, out);
          sigma += out.sigma_min();
          servo.reset();
          st = servo.update(in, out);
          in.depth(0) = -1.0;  // the invalid-input path must not allocate either
          const Status bad = servo.update(in, out);
          const long during = news.load() - before;
          ibvs_test::report(during == 0, "no operator new in update", __FILE__, __LINE__, L.describe());
          CHECK(st != Status::invalid_input && st_half != Status::invalid_input && bad == Status::invalid_input);
          CHECK(diag == 0 ? std::isnan(sigma) : !std::isnan(sigma));
          CHECK(out.velocity.isZero(0.0) && std::isnan(out.sigma_min()));  // the refusal: zero twist, NaN diagnostics
        }
      }
    }
  }
}
