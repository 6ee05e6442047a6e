// Bindings of the estimators (ibvs.DepthEstimator, ibvs.PlanarPose). Argument
// conversion only; the algorithms are in cpp/src.
#include "convert.hpp"
#include "ibvs/depth_estimator.hpp"
#include "ibvs/planar_pose.hpp"

#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace {

constexpr double not_a_number = std::numeric_limits<double>::quiet_NaN();

Eigen::VectorXd prior_arg(py::handle obj) {
  const CArray a = as_array(obj, "prior");
  if (a.ndim() != 1) throw py::value_error("prior must have shape (N,) (one depth per point, metres), got " + shape_of(a));
  return vector(a, "prior");
}

// The motion since the previous frame: a 4x4 rigid transform (previous <- current) or a 6-vector twist * dt.
Pose motion_arg(py::handle obj) {
  const CArray a = as_array(obj, "motion");
  if (a.ndim() == 2 && a.shape(0) == 4 && a.shape(1) == 4)
    return Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(a.data());
  if (a.ndim() == 1 && a.shape(0) == 6) {
    const Twist x = Eigen::Map<const Twist>(a.data());
    if (!x.allFinite()) throw py::value_error("motion (twist * dt) must be finite");
    return Pose(se3_exp(x));
  }
  throw py::value_error("motion must be a 4x4 pose (previous <- current camera) or a (6,) twist * dt, got shape " +
                        shape_of(a));
}

struct PyDepthEstimator {
  DepthEstimator est;
  py::tuple update(py::handle uv_obj, py::handle motion_obj) {
    const CArray a = as_array(uv_obj, "uv");
    const auto uv = points(a, "uv");
    const Pose M = motion_arg(motion_obj);
    est.validate(uv, M);
    est.update(uv, M);
    return py::make_tuple(Eigen::VectorXd(est.depth()), Eigen::VectorXd(est.variance()));
  }
};

}  // namespace

void bind_estimators(py::module_& m) {
  py::class_<PyDepthEstimator>(m, "DepthEstimator", R"(Online depth of tracked points from successive frames and the camera's motion.

DepthEstimator(prior, point_noise=0, prior_uncertainty=1, process_noise=1e-4, position_noise=1e-6,
               min_depth=1e-3, max_depth_ratio=100)
One extended Kalman filter per point on (x, y, 1/z): predicted exactly through the camera's motion
between frames (odometry), corrected with the measured point.
  prior              initial depth per point (N,), metres (e.g. the desired depths)
  point_noise        std of a measured point in normalised units (pixel noise / focal length in px)
  prior_uncertainty  std of the prior inverse depth, relative (1 = 100 %)
  process_noise      std added to 1/z per update, relative; position_noise: to x, y, normalised
  min_depth, max_depth_ratio  depths are kept within [min_depth, max_depth_ratio * prior] (metres)
update(uv, motion) -> (depth, variance), each (N,), metres and m^2.)")
      .def(py::init([](py::handle prior, py::handle point_noise, py::handle prior_uncertainty,
                       py::handle process_noise, py::handle position_noise, py::handle min_depth,
                       py::handle max_depth_ratio) {
             DepthEstimatorOptions o;
             o.point_noise = real(point_noise, "point_noise");
             o.prior_uncertainty = real(prior_uncertainty, "prior_uncertainty");
             o.process_noise = real(process_noise, "process_noise");
             o.position_noise = real(position_noise, "position_noise");
             o.min_depth = real(min_depth, "min_depth");
             o.max_depth_ratio = real(max_depth_ratio, "max_depth_ratio");
             return PyDepthEstimator{DepthEstimator(prior_arg(prior), o)};
           }),
           py::arg("prior"), py::arg("point_noise") = 0.0, py::arg("prior_uncertainty") = 1.0,
           py::arg("process_noise") = 1e-4, py::arg("position_noise") = 1e-6, py::arg("min_depth") = 1e-3,
           py::arg("max_depth_ratio") = 100.0)
      .def("update", &PyDepthEstimator::update, py::arg("uv"), py::arg("motion"),
           R"(One frame: measured points uv (N, 2) or (N, 1, 2), normalised coordinates, and the camera's
motion since the previous frame: the current camera's pose in the previous camera frame
(previous <- current, 4x4, metres), or the camera twist times the frame period, (6,) =
(Tx, Ty, Tz) dt in m and (wx, wy, wz) dt in rad (motion = se3_exp(twist * dt)). The first
call after construction or reset() starts from the prior and ignores motion.
Returns (depth, variance): metres and m^2, each (N,).)")
      .def("reset", [](PyDepthEstimator& s, py::handle prior) {
             if (prior.is_none()) s.est.reset();
             else s.est.reset(prior_arg(prior));
           }, py::arg("prior") = py::none(),
           "Forget the state (and take a new prior (N,) if given): the next update() starts from the prior.")
      .def_property_readonly("depth", [](const PyDepthEstimator& s) { return Eigen::VectorXd(s.est.depth()); },
                             "Current depth estimate (N,), metres (the prior before the first update).")
      .def_property_readonly("variance", [](const PyDepthEstimator& s) { return Eigen::VectorXd(s.est.variance()); },
                             "Its variance (N,), m^2 (first order in 1/z).")
      .def_property_readonly("prior", [](const PyDepthEstimator& s) { return Eigen::VectorXd(s.est.prior()); },
                             "The prior depths (N,), metres.")
      .def_property_readonly("initialized", [](const PyDepthEstimator& s) { return s.est.initialized(); },
                             "False until the first update() after construction or reset().")
      .def_property_readonly("restarts", [](const PyDepthEstimator& s) { return s.est.restarts(); },
                             "Points restarted from the prior by the last update() (a prediction behind the camera).")
      .def_property_readonly("n_points", [](const PyDepthEstimator& s) { return s.est.n_points(); })
      .def("__repr__", [](const PyDepthEstimator& s) {
        return "DepthEstimator(" + std::to_string(s.est.n_points()) + " points, point_noise=" +
               float_repr(s.est.options().point_noise) + (s.est.initialized() ? ", running)" : ", at the prior)");
      });

  py::class_<PlanarPose>(m, "PlanarPose", R"(Pose of a planar target from its image points.

PlanarPose(points, iterations=5): points (N, 3) in the target's frame (metres), all with z = 0,
N >= 4, not all on one line. estimate(uv) -> (pose, depth, degenerate): the camera <- target pose
(4x4, metres) and the points' depths in the camera frame (N,), from normalised image points uv;
a homography (DLT) refined by Gauss-Newton on the reprojection error. degenerate is True (pose and
depth NaN) when the image does not determine a pose (collinear points, a point behind the camera).
estimate_bearings(bearings) -> (pose, range, degenerate): the same from the points' bearings (N, 3),
e.g. CameraModel.to_bearing of a fisheye's pixels, at any angle off the optical axis (beyond 90
degrees too); range is each point's distance |P| from the camera centre.)")
      .def(py::init([](py::handle pts, py::handle iterations) {
             const CArray a = as_array(pts, "points");
             if (a.ndim() != 2 || a.shape(1) != 3)
               throw py::value_error("points must have shape (N, 3), got " + shape_of(a));
             return PlanarPose(Eigen::Map<const Eigen::Matrix3Xd>(a.data(), 3, a.shape(0)),
                               int_in(iterations, "iterations", 0, 1000));
           }),
           py::arg("points"), py::arg("iterations") = 5)
      .def(
          "estimate",
          [](const PlanarPose& p, py::handle uv_obj) {
            const CArray a = as_array(uv_obj, "uv");
            const auto uv = points(a, "uv");
            p.validate(uv);
            Pose T = Pose::Constant(not_a_number);
            Eigen::VectorXd z = Eigen::VectorXd::Constant(p.n_points(), not_a_number);
            const bool ok = p.estimate(uv, T, z);
            return py::make_tuple(Eigen::Matrix4d(T), z, !ok);
          },
          py::arg("uv"),
          R"(uv (N, 2) or (N, 1, 2), normalised -> (pose, depth, degenerate): camera <- target 4x4 (metres),
depths (N,) in the camera frame, and True when no pose could be determined (pose and depth NaN).)")
      .def(
          "estimate_bearings",
          [](const PlanarPose& p, py::handle b_obj) {
            const CArray a = as_array(b_obj, "bearings");
            if (a.ndim() != 2 || a.shape(1) != 3)
              throw py::value_error("bearings must have shape (N, 3), got " + shape_of(a));
            const Eigen::Map<const Eigen::Matrix3Xd> b(a.data(), 3, a.shape(0));
            p.validate_bearings(b);
            Pose T = Pose::Constant(not_a_number);
            Eigen::VectorXd range = Eigen::VectorXd::Constant(p.n_points(), not_a_number);
            const bool ok = p.estimate_bearings(b, T, range);
            return py::make_tuple(Eigen::Matrix4d(T), range, !ok);
          },
          py::arg("bearings"),
          R"(bearings (N, 3), directions in the camera frame (any non-zero length; CameraModel.to_bearing of
the pixels) -> (pose, range, degenerate): camera <- target 4x4 (metres), each point's distance |P|
from the camera centre (N,), and True when no pose could be determined (four points whose bearings
lie in one plane, i.e. the camera centre in the target's plane, or repeat; a point not in front
along its bearing; pose and range NaN).
Works at any angle off the optical axis, beyond 90 degrees too, where normalised points do not exist.)")
      .def_property_readonly("points", [](const PlanarPose& p) { return Eigen::MatrixX3d(p.points().transpose()); },
                             "(N, 3), target frame, metres.")
      .def_property_readonly("iterations", &PlanarPose::iterations)
      .def("__repr__", [](const PlanarPose& p) {
        return "PlanarPose(" + std::to_string(p.n_points()) + " points, iterations=" + std::to_string(p.iterations()) + ")";
      });
}
