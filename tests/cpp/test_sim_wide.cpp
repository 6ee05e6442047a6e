// The simulator with a wide lens (ibvs/sim/episode.hpp, wide_lens): a point is in
// the image when the lens's model maps it inside its image circle and onto the
// sensor, whatever the sign of its depth; a task of spherical features
// (SphericalSource) servoes from the lens's pixels to the goal with the target
// starting beyond 90 degrees off the axis, where a perspective camera cannot
// see it; the perspective models keep their depth rule.
#include "check.hpp"
#include "sim_cases.hpp"

#include "sim/stages/measure.hpp"

#include "ibvs/features/spherical.hpp"

#include <cmath>

using namespace ibvs;
using namespace ibvs::sim;
using namespace sim_cases;
namespace st = ibvs::sim::stages;

namespace {

constexpr double deg = 3.14159265358979323846 / 180.0;

Eigen::Matrix3d K_of(double f, double cx, double cy) {
  Eigen::Matrix3d K;
  K << f, 0, cx, 0, f, cy, 0, 0, 1;
  return K;
}

// An equidistant lens whose image circle is at `half` off the axis: theta_d = theta (1 + k1 theta^2)
// folds where its slope 1 + 3 k1 theta^2 vanishes, so k1 = -1 / (3 half^2); f puts the circle
// (f theta_d(half) = f 2 half / 3 px) inside the 1280 x 1024 sensor.
CameraModel circular_fisheye(double half, double f) {
  return CameraModel::from_opencv(K_of(f, 640, 512), Eigen::Vector4d(-1.0 / (3 * half * half), 0, 0, 0), 1280, 1024,
                                  true);
}

// The docs' full-frame fisheye (1280 x 1024, f = 300: the sensor sees 258 degrees across its diagonal).
CameraModel docs_fisheye() {
  return CameraModel::from_opencv(K_of(300, 640, 512), Eigen::Vector4d(-0.013, 0.02, -0.012, 0.002), 1280, 1024,
                                  true);
}

// A unit direction `angle` off the optical axis, at azimuth `azimuth`, times distance.
Eigen::Vector3d direction(double angle, double azimuth, double distance = 1.0) {
  return distance * Eigen::Vector3d(std::sin(angle) * std::cos(azimuth), std::sin(angle) * std::sin(azimuth),
                                    std::cos(angle));
}

// Measure's verdict at the identity pose on one point (world = camera frame): -1 in the image,
// 0 outside (Sighting::outside), 1 behind (Sighting::behind).
int verdict(const CameraModel& cam, const Eigen::Vector3d& p) {
  st::Measure m(cam, p, 0, 1e-3, true);
  ProjectionSensor sensor;
  const st::Sighting s = m.capture(0, Pose::Identity(), Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(),
                                   Twist::Zero(), sensor);
  return s.behind >= 0 ? 1 : (s.outside >= 0 ? 0 : -1);
}

void left_image_uses_the_image_circle() {
  const CameraModel lens200 = circular_fisheye(100 * deg, 400), lens150 = circular_fisheye(75 * deg, 500);
  CHECK_NEAR(lens200.max_angle(), 100 * deg, 1e-9);
  CHECK_NEAR(lens200.field_of_view(), 200 * deg, 1e-9);  // the circle lies inside the sensor
  CHECK_NEAR(lens150.field_of_view(), 150 * deg, 1e-9);
  CHECK(wide_lens(lens200) && !wide_lens(CameraModel::afma6()));
  for (double az : {0.0, 1.0, 2.5, -2.0}) {
    CHECK(verdict(lens200, direction(99.5 * deg, az)) == -1);  // behind the image plane, inside the circle
    CHECK(verdict(lens200, direction(100.5 * deg, az)) == 0);  // beyond it: left the image
    CHECK(verdict(lens150, direction(100 * deg, az)) == 0);
    CHECK(verdict(lens150, direction(74.5 * deg, az)) == -1);
    CHECK(verdict(lens200, direction(179 * deg, az)) == 0);
  }
  // The full-frame fisheye: 100 degrees along u is on its sensor; a full-frame 150-degree one (its
  // corners 75 degrees off the axis) images it off the sensor.
  const CameraModel full150 = CameraModel::from_opencv(K_of(std::hypot(640.0, 512.0) / (75 * deg), 640, 512),
                                                       Eigen::Vector4d::Zero(), 1280, 1024, true);
  CHECK_NEAR(full150.field_of_view(), 150 * deg, 1e-3);
  CHECK(verdict(docs_fisheye(), direction(100 * deg, 0.0)) == -1);
  CHECK(verdict(full150, direction(100 * deg, 0.0)) == 0);
  CHECK(verdict(full150, direction(70 * deg, std::atan2(512.0, 640.0))) == -1);  // towards a corner
  // behind_camera for a wide lens: closer than min_depth to its centre, whatever the direction
  CHECK(verdict(lens200, direction(30 * deg, 0.0, 1e-4)) == 1);
  CHECK(verdict(lens200, direction(95 * deg, 0.0, 0.5)) == -1);
  // a perspective model keeps z >= min_depth: 100 degrees is behind it
  CHECK(verdict(CameraModel::pinhole(300, 300, 640, 512, 1280, 1024), direction(100 * deg, 0.0)) == 1);
  CHECK(verdict(CameraModel::pinhole(300, 300, 640, 512, 1280, 1024), direction(30 * deg, 0.0)) == -1);
  // Mei's model: its circle is acos(-1/xi) for xi > 1 (the fold), the whole sphere's front and more
  const CameraModel omni =
      CameraModel::from_omnidir(K_of(350, 640, 512), 1.6, Eigen::Vector4d(-0.05, 0.01, 0, 0), 1280, 1024);
  CHECK(omni.max_angle() > 110 * deg);
  CHECK(verdict(omni, direction(105 * deg, 0.4)) == -1);
  CHECK(verdict(omni, direction(omni.max_angle() + 1e-3, 0.4)) == 0);
  // The controller's bearings (view): the measured pixel back to the sphere, beyond 90 degrees
  st::Measure m(lens200, direction(99 * deg, 0.7, 2.0), 0, 1e-3, true);
  ProjectionSensor sensor;
  m.capture(0, Pose::Identity(), Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), Twist::Zero(), sensor);
  CHECK(m.view(0) == -1);
  CHECK((m.bearings().col(0) - direction(99 * deg, 0.7)).norm() < 1e-9);
  CHECK(std::isnan(m.uv()(0, 0)));  // no normalised coordinates there
  // a task with image points needs them: the same pixel is lost to it (left_image)
  st::Measure mp(lens200, direction(99 * deg, 0.7, 2.0), 0, 1e-3, false);
  mp.capture(0, Pose::Identity(), Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), Twist::Zero(), sensor);
  CHECK(mp.view(0) == 0);
}

// The docs' 100-degree start (docs/wide.md): four spherical blocks, one SphericalSource each.
Target square_target() {
  Eigen::Matrix3Xd P(3, 4);
  P << -0.25, 0.25, 0.25, -0.25, -0.25, -0.25, 0.25, 0.25, 1.0, 1.0, 1.0, 1.0;
  Target t(P);
  for (int i = 0; i < 4; ++i) t.add(SphericalSource(i));
  return t;
}

template <class F>
Servo spherical_servo() {
  Task task;
  for (int i = 0; i < 4; ++i) task.add(F());
  ServoOptions o;
  o.gain = 1.0;
  return Servo(task, o);
}

// Mei's omnidirectional model with distortion (xi = 1.6) on the same sensor.
CameraModel omni_camera() {
  return CameraModel::from_omnidir(K_of(350, 640, 512), 1.6, Eigen::Vector4d(-0.05, 0.01, 2e-4, -1e-4), 1280, 1024);
}

// An episode of four spherical blocks of kind 0 (SphericalPolarFeature) or 1 (SphericalPointFeature) to the identity.
EpisodeResult run_spherical(int kind, const CameraModel& cam, const Target& tgt, const Pose& start,
                            const EpisodeOptions& o) {
  return kind == 0 ? run_episode(spherical_servo<SphericalPolarFeature>(), cam, tgt, start, Pose::Identity(), o)
                   : run_episode(spherical_servo<SphericalPointFeature>(), cam, tgt, start, Pose::Identity(), o);
}

Pose start_100() {
  Twist v;
  v << 0.05, -0.04, -0.2, 0.0, 107 * deg, 0.3;
  return se3_exp(v);
}

void spherical_episodes_converge_from_beyond_90_degrees() {
  const Pose start = start_100();
  const Target tgt = square_target();
  const Eigen::Vector3d c = se3_inverse(start).topLeftCorner<3, 3>() * Eigen::Vector3d(0, 0, 1) +
                            se3_inverse(start).topRightCorner<3, 1>();
  CHECK(std::acos(c.z() / c.norm()) > 100 * deg);  // the target's centre starts behind the image plane
  EpisodeOptions o;
  o.duration = 40;
  o.tolerance = 1e-9;
  const CameraModel omni = omni_camera();
  for (const CameraModel& cam : {docs_fisheye(), omni}) {
    for (int kind = 0; kind < 2; ++kind) {
      const EpisodeResult r = run_spherical(kind, cam, tgt, start, o);
      CHECK(r.status.outcome == Outcome::converged);
      CHECK(r.metrics.final_translation_error < 1e-8 && r.metrics.final_rotation_error < 1e-8);
      // the first frame's measurement is the sensor's pixel through to_bearing, and R the true distance
      const Eigen::Vector3d p = se3_inverse(start).topLeftCorner<3, 3>() * tgt.points.col(2) +
                                se3_inverse(start).topRightCorner<3, 1>();
      const Eigen::Vector4d m0 = r.history.measurements.row(0).segment<4>(8).transpose();
      CHECK((m0.head<3>() - p.normalized()).norm() < 1e-9);
      CHECK(std::abs(m0(3) - p.norm()) < 1e-12);
    }
  }
  // The same start with perspective points on the fisheye: the target is behind its image plane.
  ServoOptions so;
  const EpisodeResult rp = run_episode(Servo(Layout::cartesian(4), so), docs_fisheye(), Target(tgt.points), start,
                                       Pose::Identity(), o);
  CHECK(rp.status.outcome == Outcome::left_image && rp.status.frame == 0);
  // A wrong source for the block is refused; a point index beyond the target too.
  CHECK_THROWS(run_episode(spherical_servo<SphericalPolarFeature>(), docs_fisheye(),
                           Target(tgt.points).add(LineSource(0, 1)).add(SphericalSource(1)).add(SphericalSource(2))
                               .add(SphericalSource(3)),
                           start, Pose::Identity(), o));
  CHECK_THROWS(Target(tgt.points).add(SphericalSource(4)));
  CHECK_THROWS(SphericalSource(-1));
}

// depth = pose from the same 100-degree start: the depth stage estimates the target's pose from the
// bearings (PlanarPose::estimate_bearings; the normalised points do not exist beyond 90 degrees), so
// the spherical blocks' distances are the true ones and the episodes converge as with exact depths.
void pose_depth_from_bearings_beyond_90_degrees() {
  const Pose start = start_100();
  Eigen::Matrix3Xd P(3, 4);  // the square above, planar in its own frame, 1 m ahead of the goal
  P << -0.25, 0.25, 0.25, -0.25, -0.25, -0.25, 0.25, 0.25, 0.0, 0.0, 0.0, 0.0;
  Pose ahead = Pose::Identity();
  ahead(2, 3) = 1.0;
  Target tgt(P, ahead);
  for (int i = 0; i < 4; ++i) tgt.add(SphericalSource(i));
  EpisodeOptions o;
  o.duration = 40;
  o.tolerance = 1e-9;
  o.depth = DepthMode::pose;
  const CameraModel omni = omni_camera();
  for (const CameraModel& cam : {docs_fisheye(), omni}) {
    for (int kind = 0; kind < 2; ++kind) {
      const EpisodeResult r = run_spherical(kind, cam, tgt, start, o);
      CHECK(r.status.outcome == Outcome::converged);
      CHECK(r.metrics.final_translation_error < 1e-8 && r.metrics.final_rotation_error < 1e-8);
      // frame 0: the depths given are the points' true z (negative beyond 90 degrees) and each
      // block's distance R the true |P|, from the pose the bearings gave
      const Pose T0 = se3_inverse(start) * ahead;
      int behind = 0;
      for (int i = 0; i < 4; ++i) {
        const Eigen::Vector3d p = T0.topLeftCorner<3, 3>() * P.col(i) + T0.topRightCorner<3, 1>();
        behind += p.z() < 0;
        CHECK(std::abs(r.history.depth(0, i) - p.z()) < 1e-9);
        CHECK(std::abs(r.history.measurements(0, 4 * i + 3) - p.norm()) < 1e-9);
      }
      CHECK(behind >= 2);
    }
  }
}

}  // namespace

void run_tests() {
  left_image_uses_the_image_circle();
  spherical_episodes_converge_from_beyond_90_degrees();
  pose_depth_from_bearings_beyond_90_degrees();
}
