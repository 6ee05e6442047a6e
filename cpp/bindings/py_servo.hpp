// The Python faces of the two control laws (ibvs.Servo, ibvs.PartitionedServo):
// the C++ object plus its output and depth buffers. Shared by the binding files
// so that bind_sim.cpp can read the C++ servo a Python object holds (pybind11
// matches the type by its typeid, hence a named namespace, not an anonymous one).
#pragma once

#include "ibvs/partitioned.hpp"
#include "ibvs/servo.hpp"

#include <pybind11/pybind11.h>

namespace ibvs::py_servo {

namespace py = pybind11;

struct PyServo {
  PyServo(Layout layout, ServoOptions o) : servo(std::move(layout), o), out(servo.layout()) {}
  Servo servo;
  ServoOutput out;
  Eigen::VectorXd z, zd;

  /// validate() then update() on numpy arguments (bind_core.cpp).
  ServoOutput update(py::handle uv_obj, py::handle depth_obj, py::handle uvd_obj, py::handle zd_obj);
  /// validate_pixels() then update_pixels() (bind_camera.cpp).
  ServoOutput update_pixels(py::handle px_obj, py::handle depth_obj, py::handle pxd_obj, py::handle zd_obj);
};

struct PyPartitioned {
  PyPartitioned(int n, PartitionedOptions o) : servo(n, o), out(servo.layout()) {}
  PartitionedServo servo;
  ServoOutput out;
  Eigen::VectorXd z, zd;

  /// validate() then update() on numpy arguments (bind_partitioned.cpp).
  ServoOutput update(py::handle uv_obj, py::handle depth_obj, py::handle uvd_obj, py::handle zd_obj);
  /// validate_pixels() then update_pixels() (bind_camera.cpp).
  ServoOutput update_pixels(py::handle px_obj, py::handle depth_obj, py::handle pxd_obj, py::handle zd_obj);
};

/// `camera` in Python: None or an ibvs.CameraModel (TypeError naming camera otherwise).
void set_camera(Servo& s, py::handle camera);
void set_camera(PartitionedServo& s, py::handle camera);

}  // namespace ibvs::py_servo
