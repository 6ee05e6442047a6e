// The native module ibvs._core; each part of the library binds itself.
#include "ibvs/version.hpp"

#include <pybind11/pybind11.h>

namespace py = pybind11;

void bind_core(py::module_& m);  // bind_core.cpp
void bind_camera(py::module_& m);  // bind_camera.cpp
void bind_estimators(py::module_& m);  // bind_estimators.cpp
void bind_sim(py::module_& m);   // bind_sim.cpp
void bind_partitioned(py::module_& m);  // bind_partitioned.cpp
void bind_robot(py::module_& m);        // bind_robot.cpp
void bind_task(py::module_& m);         // bind_task.cpp
void bind_segment_ellipse(py::module_& m);  // bind_segment_ellipse.cpp
void bind_pose(py::module_& m);         // bind_pose.cpp
void bind_moments(py::module_& m);      // bind_moments.cpp
void bind_sources(py::module_& m);      // bind_sources.cpp
void bind_shape_sources(py::module_& m);  // bind_sources.cpp
void bind_luminance(py::module_& m);     // bind_luminance.cpp

PYBIND11_MODULE(_core, m) {
  m.doc() = "ibvs native core (C++/Eigen). Use the ibvs package, not this module.";
  m.attr("__version__") = IBVS_VERSION;
  bind_task(m);  // first: Servo(task) names ibvs.Task in its signature
  bind_moments(m);  // a Feature: after bind_task
  bind_segment_ellipse(m);  // after bind_task: ibvs.Feature, their base
  bind_core(m);
  bind_camera(m);
  bind_estimators(m);
  bind_sim(m);
  bind_partitioned(m);
  bind_robot(m);
  bind_pose(m);
  bind_sources(m);  // after bind_sim (FeatureSource) and bind_pose
  bind_shape_sources(m);  // after bind_sources
  bind_luminance(m);  // after bind_camera (CameraModel)
}
