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

// Python's PartitionedServo.update: numpy arguments, validate() (raises), then update() into a free
// output buffer (returned without a copy, as Servo.update).
std::shared_ptr<ServoOutput> PyPartitioned::update(py::handle uv_obj, py::handle depth_obj, py::handle uvd_obj,
                                                   py::handle zd_obj) {
  const CArray uv_a = as_array(uv_obj, "uv"), uvd_a = as_array(uvd_obj, "uv_desired");
  const auto uv = points(uv_a, "uv");
  const auto uvd = points(uvd_a, "uv_desired");
  const Eigen::Index n = servo.layout().n_points();
  depths(depth_obj, "depth", n, z);
  if (zd_obj.is_none()) zd = z;
  else depths(zd_obj, "depth_desired", n, zd);
  servo.validate(uv, z, uvd);
  if (zd.size() != n)  // accepted and unused, but update() refuses a wrong size: raise as it would
    throw py::value_error("depth_desired must hold " + std::to_string(n) + " depths, got " + std::to_string(zd.size()));
  std::shared_ptr<ServoOutput> out = outputs.next();
  servo.update(uv, z, uvd, zd, *out);
  return out;
}

namespace {

// uv (N, 2) checked as the core's validate path checks points (finite, within the coordinate bound).
Eigen::Map<const Points> checked_points(const CArray& a) {
  const auto p = points(a, "uv");
  validate_points(p, "uv");
  return p;
}

// Segment indices: distinct ints in [0, N).
// Points i and j of uv, two distinct indices of two distinct points (segment_angle and its Jacobian
// refuse the same inputs: in C++ both give NaN for coincident points).
std::pair<int, int> segment_indices(py::handle i, py::handle j, const Eigen::Ref<const Points>& uv) {
  const Eigen::Index n = uv.cols();
  const int a = int_in(i, "i", 0, n - 1), b = int_in(j, "j", 0, n - 1);
  if (a == b) throw py::value_error("i and j must be distinct point indices");
  if ((uv.col(a) - uv.col(b)).squaredNorm() == 0.0)
    throw py::value_error("uv: points i and j coincide (theta_z undefined)");
  return {a, b};
}

std::pair<int, int> segment_arg(py::handle s) {
  if (!py::isinstance<py::sequence>(s) || py::isinstance<py::str>(s) || py::len(s) != 2)
    throw py::type_error("segment must be a pair of point indices (i, j)");
  const auto q = py::reinterpret_borrow<py::sequence>(s);
  return {int_in(q[0], "segment[0]", 0, max_points), int_in(q[1], "segment[1]", 0, max_points)};
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
      .def(py::init([](py::handle n, py::handle gain, py::handle damping, py::handle segment, py::handle vmax,
                       py::handle wmax, py::handle camera) {
             const int n_points = int_in(n, "n_points", 3, max_realtime_rows / 2);
             PartitionedOptions o;
             o.gain = real(gain, "gain");
             o.damping = real(damping, "damping");
             std::tie(o.segment_first, o.segment_second) = segment_arg(segment);
             o.max_linear_speed = real(vmax, "max_linear_speed");
             o.max_angular_speed = real(wmax, "max_angular_speed");
             PyPartitioned s(n_points, o);
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
          [](PyPartitioned& s, py::handle g) {
            PartitionedOptions o = s.servo.options();
            o.gain = real(g, "gain");
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
      [](py::handle uv, py::handle i, py::handle j) {
        const CArray a = as_array(uv, "uv");
        const auto p = checked_points(a);
        const auto [k, l] = segment_indices(i, j, p);
        return segment_angle(p, k, l);
      },
      py::arg("uv"), py::arg("i"), py::arg("j"), "theta_z: angle of the image segment from point i to point j.");
  m.def(
      "segment_angle_jacobian",
      [](py::handle uv, py::handle depth, py::handle i, py::handle j) {
        const CArray a = as_array(uv, "uv");
        const auto p = checked_points(a);
        Eigen::VectorXd z;
        depths(depth, "depth", p.cols(), z);
        validate_depths(z, "depth", p.cols());
        const auto [k, l] = segment_indices(i, j, p);
        const Eigen::Matrix<double, 1, 6> J = segment_angle_jacobian(p, z, k, l);
        return py::array_t<double>(6, J.data());  // (6,), as the stub says (an Eigen row would read [1, 6])
      },
      py::arg("uv"), py::arg("depth"), py::arg("i"), py::arg("j"), "(6,) d theta_z/dt = J @ v.");
  m.def(
      "area_scale",
      [](py::handle uv) {
        const CArray a = as_array(uv, "uv");
        return area_scale(checked_points(a));
      },
      py::arg("uv"), "sigma = sqrt(|area|) of the polygon of the points in order.");
  m.def(
      "area_scale_jacobian",
      [](py::handle uv, py::handle depth) {
        const CArray a = as_array(uv, "uv");
        const auto p = checked_points(a);
        Eigen::VectorXd z;
        depths(depth, "depth", p.cols(), z);
        validate_depths(z, "depth", p.cols());
        if (area_scale(p) == 0.0) throw py::value_error("uv: the points enclose no area (sigma = 0)");
        const Eigen::Matrix<double, 1, 6> J = area_scale_jacobian(p, z);
        return py::array_t<double>(6, J.data());
      },
      py::arg("uv"), py::arg("depth"), "(6,) d sigma/dt = J @ v.");
}
