// The Python faces of the two control laws (ibvs.Servo, ibvs.PartitionedServo):
// the C++ object plus its output buffers and depth buffers. Shared by the
// binding files so that bind_sim.cpp can read the C++ servo a Python object
// holds (pybind11 matches the type by its typeid, hence a named namespace, not
// an anonymous one).
#pragma once

#include "ibvs/partitioned.hpp"
#include "ibvs/servo.hpp"

#include <pybind11/pybind11.h>

#include <array>
#include <memory>

namespace ibvs::py_servo {

namespace py = pybind11;

/// The ServoOutputs that update() writes and returns as ServoResult, without a
/// copy: each result is an immutable snapshot owning its buffer (its error and
/// jacobian arrays are read-only views of it). update() writes into a buffer
/// that no result holds any more, so the usual loop (`res = servo.update(...)`)
/// alternates between two buffers and allocates nothing; a buffer still held
/// (results kept in a list) is left to its holders and replaced by a new one.
class OutputPool {
 public:
  explicit OutputPool(const Task& task) : task_(task) {
    for (auto& p : slots_) p = std::make_shared<ServoOutput>(task_);
  }
  /// A buffer only the pool holds.
  std::shared_ptr<ServoOutput> next() {
    for (auto& p : slots_)
      if (p.use_count() == 1) return p;
    auto& p = slots_[turn_++ % slots_.size()];
    p = std::make_shared<ServoOutput>(task_);
    return p;
  }

 private:
  Task task_;
  std::array<std::shared_ptr<ServoOutput>, 3> slots_;
  std::size_t turn_ = 0;
};

struct PyServo {
  PyServo(Task task, ServoOptions o) : servo(std::move(task), o), outputs(servo.task()) {}
  Servo servo;
  OutputPool outputs;
  Eigen::VectorXd z, zd, m, md;

  /// validate() then update() on numpy arguments (bind_core.cpp); m_obj, md_obj: the feature
  /// blocks' measurements (bind_task.cpp: None, a flat array or one array per block).
  std::shared_ptr<ServoOutput> update(py::handle uv_obj, py::handle depth_obj, py::handle uvd_obj, py::handle zd_obj,
                                      py::handle m_obj = py::none(), py::handle md_obj = py::none(),
                                      py::handle valid_obj = py::none());
  PointMask valid;  // update(valid=...)
  /// validate_pixels() then update_pixels() (bind_camera.cpp).
  std::shared_ptr<ServoOutput> update_pixels(py::handle px_obj, py::handle depth_obj, py::handle pxd_obj,
                                             py::handle zd_obj);
};

struct PyPartitioned {
  PyPartitioned(int n, PartitionedOptions o) : servo(n, o), outputs(servo.layout()) {}
  PartitionedServo servo;
  OutputPool outputs;
  Eigen::VectorXd z, zd;

  /// validate() then update() on numpy arguments (bind_partitioned.cpp).
  std::shared_ptr<ServoOutput> update(py::handle uv_obj, py::handle depth_obj, py::handle uvd_obj, py::handle zd_obj);
  /// validate_pixels() then update_pixels() (bind_camera.cpp).
  std::shared_ptr<ServoOutput> update_pixels(py::handle px_obj, py::handle depth_obj, py::handle pxd_obj,
                                             py::handle zd_obj);
};

}  // namespace ibvs::py_servo

namespace ibvs::py_task {
/// The measurements of a task's feature blocks from Python (bind_task.cpp).
void measurements(const Task& task, pybind11::handle obj, const char* name, Eigen::VectorXd& out);
}  // namespace ibvs::py_task

namespace ibvs::py_servo {

/// `camera` in Python: None or an ibvs.CameraModel (TypeError naming camera otherwise).
void set_camera(Servo& s, py::handle camera);
void set_camera(PartitionedServo& s, py::handle camera);

}  // namespace ibvs::py_servo
