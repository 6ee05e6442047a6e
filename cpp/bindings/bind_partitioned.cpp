// Bindings of PartitionedServo (Corke & Hutchinson 2001) and its two feature
// functions. Argument conversion only; the logic is in cpp/src/partitioned.cpp.
#include "convert.hpp"
#include "ibvs/partitioned.hpp"
#include "py_servo.hpp"

#include <pybind11/stl.h>

#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;
using ibvs::py_servo::PyPartitioned;

// Python's PartitionedServo.update: numpy arguments, validate() (raises), then update().
ServoOutput PyPartitioned::update(py::handle uv_obj, py::handle depth_obj, py::handle uvd_obj, py::handle zd_obj) {
  const CArray uv_a = as_array(uv_obj, "uv"), uvd_a = as_array(uvd_obj, "uv_desired");
  const auto uv = points(uv_a, "uv");
  const auto uvd = points(uvd_a, "uv_desired");
  const Eigen::Index n = servo.layout().n_points();
  depths(depth_obj, "depth", n, z);
  if (zd_obj.is_none()) zd = z;
  else depths(zd_obj, "depth_desired", n, zd);
  servo.validate(uv, z, uvd);
  servo.update(uv, z, uvd, zd, out);
  return out;
}

namespace {

void check_depths(const Eigen::Ref<const Points>& p, const Eigen::VectorXd& z) {
  if (z.size() != p.cols()) throw py::value_error("depth must hold one depth per point");
  for (Eigen::Index k = 0; k < z.size(); ++k)
    if (!(z(k) > 0.0) || !std::isfinite(z(k))) throw py::value_error("depth must be finite and > 0");
}

std::pair<int, int> segment_arg(py::handle s) {
  if (!py::isinstance<py::sequence>(s) || py::isinstance<py::str>(s) || py::len(s) != 2)
    throw py::type_error("segment must be a pair of point indices (i, j)");
  const auto q = py::reinterpret_borrow<py::sequence>(s);
  return {q[0].cast<int>(), q[1].cast<int>()};
}

}  // namespace

void bind_partitioned(py::module_& m) {
  py::class_<PyPartitioned>(m, "PartitionedServo", R"(Partitioned IBVS (Corke & Hutchinson, IEEE T-RA 2001).

PartitionedServo(n_points, gain, damping=0.0, segment=(0, 1), max_linear_speed=inf, max_angular_speed=inf,
                 camera=None)
  wz   = gain * wrap(theta_z - theta_z*), theta_z the angle of the image segment from point i to j
  Tz   = gain * ln(sigma* / sigma),       sigma = sqrt(area of the point polygon, points in order)
  v_xy = -J_xy^+ (gain e + J_z v_z)       the Cartesian law for (Tx, Ty, wx, wy)
n_points >= 3. update() has Servo's signature and returns a ServoResult (Cartesian error and Jacobian).)")
      .def(py::init([](py::handle n, double gain, double damping, py::handle segment, double vmax, double wmax,
                       py::handle camera) {
             if (py::isinstance<py::bool_>(n) || !py::hasattr(n, "__index__"))
               throw py::type_error("n_points must be an int");
             PartitionedOptions o;
             o.gain = gain;
             o.damping = damping;
             std::tie(o.segment_first, o.segment_second) = segment_arg(segment);
             o.max_linear_speed = vmax;
             o.max_angular_speed = wmax;
             PyPartitioned s(n.cast<int>(), o);
             py_servo::set_camera(s.servo, camera);
             return s;
           }),
           py::arg("n_points"), py::arg("gain"), py::arg("damping") = 0.0, py::arg("segment") = py::make_tuple(0, 1),
           py::arg("max_linear_speed") = no_limit, py::arg("max_angular_speed") = no_limit,
           py::arg("camera") = py::none())
      .def("update", &PyPartitioned::update, py::arg("uv"), py::arg("depth"), py::arg("uv_desired"),
           py::arg("depth_desired") = py::none(), "One control step (depth_desired is accepted and unused).")
      .def("update_pixels", &PyPartitioned::update_pixels, py::arg("pixels"), py::arg("depth"),
           py::arg("pixels_desired"), py::arg("depth_desired") = py::none(),
           "One control step from pixels (N, 2) or (N, 1, 2) with the servo's camera model, as Servo.update_pixels.")
      .def_property_readonly(
          "camera",
          [](const PyPartitioned& s) -> py::object { return s.servo.camera() ? py::cast(*s.servo.camera()) : py::none(); },
          "The CameraModel used by update_pixels (None if not given).")
      .def_property_readonly("layout", [](const PyPartitioned& s) { return s.servo.layout(); })
      .def_property_readonly("n_points", [](const PyPartitioned& s) { return s.servo.layout().n_points(); })
      .def_property(
          "gain", [](const PyPartitioned& s) { return s.servo.options().gain; },
          [](PyPartitioned& s, double g) {
            PartitionedOptions o = s.servo.options();
            o.gain = g;
            s.servo.set_options(o);
          })
      .def_property_readonly("damping", [](const PyPartitioned& s) { return s.servo.options().damping; })
      .def_property_readonly(
          "max_linear_speed", [](const PyPartitioned& s) { return s.servo.options().max_linear_speed; },
          "Limit on |(Tx, Ty, Tz)| (m/s); inf = none.")
      .def_property_readonly(
          "max_angular_speed", [](const PyPartitioned& s) { return s.servo.options().max_angular_speed; },
          "Limit on |(wx, wy, wz)| (rad/s); inf = none.")
      .def_property_readonly("segment", [](const PyPartitioned& s) {
        return py::make_tuple(s.servo.options().segment_first, s.servo.options().segment_second);
      })
      .def("__repr__", [](const PyPartitioned& s) {
        return "PartitionedServo(" + std::to_string(s.servo.layout().n_points()) +
               ", gain=" + std::string(py::repr(py::float_(s.servo.options().gain))) + ")";
      });

  m.def(
      "segment_angle",
      [](py::handle uv, int i, int j) {
        const CArray a = as_array(uv, "uv");
        const auto p = points(a, "uv");
        if (i < 0 || j < 0 || i >= p.cols() || j >= p.cols() || i == j)
          throw py::value_error("segment indices must be distinct and in range");
        return segment_angle(p, i, j);
      },
      py::arg("uv"), py::arg("i"), py::arg("j"), "theta_z: angle of the image segment from point i to point j.");
  m.def(
      "segment_angle_jacobian",
      [](py::handle uv, py::handle depth, int i, int j) {
        const CArray a = as_array(uv, "uv");
        const auto p = points(a, "uv");
        Eigen::VectorXd z;
        depths(depth, "depth", p.cols(), z);
        check_depths(p, z);
        if (i < 0 || j < 0 || i >= p.cols() || j >= p.cols() || i == j)
          throw py::value_error("segment indices must be distinct and in range");
        return Eigen::Matrix<double, 1, 6>(segment_angle_jacobian(p, z, i, j));
      },
      py::arg("uv"), py::arg("depth"), py::arg("i"), py::arg("j"), "(6,) d theta_z/dt = J @ v.");
  m.def(
      "area_scale",
      [](py::handle uv) {
        const CArray a = as_array(uv, "uv");
        return area_scale(points(a, "uv"));
      },
      py::arg("uv"), "sigma = sqrt(|area|) of the polygon of the points in order.");
  m.def(
      "area_scale_jacobian",
      [](py::handle uv, py::handle depth) {
        const CArray a = as_array(uv, "uv");
        const auto p = points(a, "uv");
        Eigen::VectorXd z;
        depths(depth, "depth", p.cols(), z);
        check_depths(p, z);
        return Eigen::Matrix<double, 1, 6>(area_scale_jacobian(p, z));
      },
      py::arg("uv"), py::arg("depth"), "(6,) d sigma/dt = J @ v.");
}
