// Prototype, not shipped: variants of the Python binding of Servo.update, to
// measure where the time of a Python call goes (docs/benchmarks.md). The
// argument conversion is the one of cpp/bindings/convert.hpp.
#include "../../cpp/bindings/convert.hpp"
#include "ibvs/ibvs.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace {

struct P {
  P(const Layout& l, double gain, double damping, bool diag) : servo(l, opts(gain, damping, diag)), out(servo.layout()) {}
  static ServoOptions opts(double g, double d, bool diag) {
    ServoOptions o;
    o.gain = g;
    o.damping = d;
    o.diagnostics = diag;
    return o;
  }
  Servo servo;
  ServoOutput out;
  Eigen::VectorXd z, zd;
  Points uv0, uvd0;  // for step_only

  // As cpp/bindings/bind_core.cpp (jacobian = current).
  void convert_and_step(py::handle uv_obj, py::handle depth_obj, py::handle uvd_obj) {
    const CArray uv_a = as_array(uv_obj, "uv"), uvd_a = as_array(uvd_obj, "uv_desired");
    const auto uv = points(uv_a, "uv");
    const auto uvd = points(uvd_a, "uv_desired");
    const Eigen::Index n = servo.layout().n_points();
    depths(depth_obj, "depth", n, z);
    zd = z;
    servo.validate(uv, z, uvd, zd);
    servo.update(uv, z, uvd, zd, out);
  }
};

// Variant E: a result whose arrays are numpy arrays made once per update.
struct Result {
  py::array_t<double> velocity, error, jacobian;
  double sigma_min, sigma_max, error_norm;
};

}  // namespace

PYBIND11_MODULE(ibvs_py_proto, m) {
  py::class_<ServoOutput>(m, "ServoResult", py::module_local())
      .def_readonly("velocity", &ServoOutput::velocity)
      .def_readonly("error", &ServoOutput::error)
      .def_readonly("jacobian", &ServoOutput::jacobian)
      .def_property_readonly("sigma_min", &ServoOutput::sigma_min);
  py::class_<Result>(m, "EagerResult", py::module_local())
      .def_readonly("velocity", &Result::velocity)
      .def_readonly("error", &Result::error)
      .def_readonly("jacobian", &Result::jacobian)
      .def_readonly("sigma_min", &Result::sigma_min);
  py::class_<P>(m, "Servo", py::module_local())
      .def(py::init<const Layout&, double, double, bool>())
      // A: as today: convert, validate, step, return a copy of ServoOutput.
      .def("update", [](P& p, py::handle uv, py::handle z, py::handle uvd, py::handle) -> ServoOutput {
             p.convert_and_step(uv, z, uvd);
             return p.out;
           }, py::arg("uv"), py::arg("depth"), py::arg("uv_desired"), py::arg("depth_desired") = py::none())
      // B: convert + step only, return None: the floor of any binding with these conversions.
      .def("step_none", [](P& p, py::handle uv, py::handle z, py::handle uvd) { p.convert_and_step(uv, z, uvd); })
      // C: no argument conversion at all: the pybind11 call + C++ step.
      .def("step_only", [](P& p) { p.servo.update(p.uv0, p.z, p.uvd0, p.zd, p.out); })
      .def("keep_inputs", [](P& p, py::handle uv, py::handle z, py::handle uvd) {
        p.convert_and_step(uv, z, uvd);
        p.uv0 = points(as_array(uv, "uv"), "uv");
        p.uvd0 = points(as_array(uvd, "uv_desired"), "uv_desired");
      })
      // D: return the twist as a new (6,) array (copy of 6 doubles).
      .def("update_velocity", [](P& p, py::handle uv, py::handle z, py::handle uvd) {
        p.convert_and_step(uv, z, uvd);
        py::array_t<double> v(6);
        std::copy(p.out.velocity.data(), p.out.velocity.data() + 6, v.mutable_data());
        return v;
      })
      // E: an eager result object holding fresh numpy arrays (attribute access is then free).
      .def("update_eager", [](P& p, py::handle uv, py::handle z, py::handle uvd) {
        p.convert_and_step(uv, z, uvd);
        Result r;
        const auto m = p.out.error.size();
        r.velocity = py::array_t<double>(6);
        std::copy(p.out.velocity.data(), p.out.velocity.data() + 6, r.velocity.mutable_data());
        r.error = py::array_t<double>(m);
        std::copy(p.out.error.data(), p.out.error.data() + m, r.error.mutable_data());
        r.jacobian = py::array_t<double>({m, Eigen::Index(6)});
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>>(r.jacobian.mutable_data(), m, 6) = p.out.jacobian;
        r.sigma_min = p.out.sigma_min();
        r.sigma_max = p.out.sigma_max();
        r.error_norm = p.out.error_norm;
        return r;
      });
}
