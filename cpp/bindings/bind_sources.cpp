// Bindings of the simulator's pose and moments feature sources (ibvs._core.sim): MomentsSource,
// PbvsSource, Point25DSource, SphericalSource beside LineSource (bind_sim.cpp). Argument conversion only.
#include "convert.hpp"
#include "ibvs/ibvs.hpp"
#include "ibvs/sim/sim.hpp"

#include <pybind11/pybind11.h>

#include <memory>
#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace ibvs::py_sources {

MomentsFeature::Source moments_source_arg(py::handle obj) {
  if (py::isinstance<py::str>(obj)) {
    const std::string s = obj.cast<std::string>();
    if (s == "region") return MomentsFeature::Source::region;
    if (s == "points") return MomentsFeature::Source::points;
    throw py::value_error("source must be 'region' or 'points', got '" + s + "'");
  }
  throw py::type_error("source must be 'region' or 'points', got " + type_name(obj));
}

const char* moments_source_name(MomentsFeature::Source s) {
  return s == MomentsFeature::Source::region ? "region" : "points";
}

}  // namespace ibvs::py_sources

void bind_sources(py::module_& m) {
  using namespace ibvs::py_sources;
  py::module_ s = m.attr("sim").cast<py::module_>();

  py::class_<sim::MomentsSource, sim::FeatureSource, std::shared_ptr<sim::MomentsSource>>(s, "MomentsSource", R"(Image moments (ibvs.MomentsFeature) of the target's points as one planar object.

MomentsSource(source="region"): the moments of the controller's points (source "region": the polygon
whose vertices they are, in order; "points": the point set), the plane (A, B, C) of the target's
z = 0 plane from the pose the depth mode gives, and the goal's area a* and depth Z* (at its image's
centre of gravity). Feeds an ibvs.MomentsFeature of the same source; the target's points must be in
its z = 0 plane.)")
      .def(py::init([](py::handle source) { return std::make_shared<sim::MomentsSource>(moments_source_arg(source)); }),
           py::arg("source") = "region")
      .def_property_readonly("source", [](const sim::MomentsSource& x) { return moments_source_name(x.source()); },
                             "'region' or 'points'.")
      .def("__repr__",
           [](const sim::MomentsSource& x) { return std::string("MomentsSource('") + moments_source_name(x.source()) + "')"; })
      .def(py::pickle([](const sim::MomentsSource& x) { return py::make_tuple(moments_source_name(x.source())); },
                      [](const py::tuple& t) {
                        if (t.size() != 1) throw py::value_error("MomentsSource: bad pickle state");
                        return std::make_shared<sim::MomentsSource>(moments_source_arg(t[0]));
                      }));

  py::class_<sim::PbvsSource, sim::FeatureSource, std::shared_ptr<sim::PbvsSource>>(s, "PbvsSource", R"(PBVS (ibvs.PbvsFeature) on the pose the depth mode gives.

PbvsSource(target="desired_camera"): PbvsFeature.measure(pose, goal pose, target) with the camera <-
target pose of the depth mode (depth="exact": the true pose; "pose": ibvs.PlanarPose's estimate from
the image) and the goal's true pose. Feeds an ibvs.PbvsFeature of the same target.)")
      .def(py::init([](py::handle target) { return std::make_shared<sim::PbvsSource>(ibvs::py_pose::target_arg(target)); }),
           py::arg("target") = "desired_camera")
      .def_property_readonly("target", [](const sim::PbvsSource& x) { return ibvs::py_pose::target_name(x.target()); },
                             "'desired_camera' or 'object'.")
      .def("__repr__",
           [](const sim::PbvsSource& x) { return std::string("PbvsSource('") + ibvs::py_pose::target_name(x.target()) + "')"; })
      .def(py::pickle([](const sim::PbvsSource& x) { return py::make_tuple(ibvs::py_pose::target_name(x.target())); },
                      [](const py::tuple& t) {
                        if (t.size() != 1) throw py::value_error("PbvsSource: bad pickle state");
                        return std::make_shared<sim::PbvsSource>(ibvs::py_pose::target_arg(t[0]));
                      }));

  py::class_<sim::Point25DSource, sim::FeatureSource, std::shared_ptr<sim::Point25DSource>>(s, "Point25DSource", R"(2.5-D (ibvs.Point25DFeature) with target point i as the reference point.

Point25DSource(i=0): (x, y) the controller's point i, Z the depth the depth mode gives it, theta u of
c*Rc from the depth mode's pose against the goal's true pose.)")
      .def(py::init([](py::handle i) { return std::make_shared<sim::Point25DSource>(int_in(i, "i", 0, max_points)); }),
           py::arg("i") = 0)
      .def_property_readonly("i", &sim::Point25DSource::i, "The reference point (a target point's index).")
      .def("__repr__", [](const sim::Point25DSource& x) { return "Point25DSource(" + std::to_string(x.i()) + ")"; })
      .def(py::pickle([](const sim::Point25DSource& x) { return py::make_tuple(x.i()); },
                      [](const py::tuple& t) {
                        if (t.size() != 1) throw py::value_error("Point25DSource: bad pickle state");
                        return std::make_shared<sim::Point25DSource>(t[0].cast<int>());
                      }));

  py::class_<sim::SphericalSource, sim::FeatureSource, std::shared_ptr<sim::SphericalSource>>(s, "SphericalSource", R"(A point on the sphere (ibvs.SphericalPointFeature or SphericalPolarFeature) of target point i.

SphericalSource(i=0): the bearing the controller has of point i (the sensor's pixel through
CameraModel.to_bearing: over a fisheye's or omnidirectional lens's whole field of view, beyond 90
degrees off the axis too) and its distance from the camera centre under the pose the depth mode gives
(depth="exact": the true distance; "desired": the goal's). Lost when the pixel has no bearing.)")
      .def(py::init([](py::handle i) { return std::make_shared<sim::SphericalSource>(int_in(i, "i", 0, max_points)); }),
           py::arg("i") = 0)
      .def_property_readonly("i", &sim::SphericalSource::i, "The target point's index.")
      .def("__repr__", [](const sim::SphericalSource& x) { return "SphericalSource(" + std::to_string(x.i()) + ")"; })
      .def(py::pickle([](const sim::SphericalSource& x) { return py::make_tuple(x.i()); },
                      [](const py::tuple& t) {
                        if (t.size() != 1) throw py::value_error("SphericalSource: bad pickle state");
                        return std::make_shared<sim::SphericalSource>(t[0].cast<int>());
                      }));
}
