// Bindings of the simulator's pose and moments feature sources (ibvs._core.sim): MomentsSource,
// PbvsSource, Point25DSource, SphericalSource beside LineSource (bind_sim.cpp). Argument conversion only.
#include "convert.hpp"
#include "ibvs/ibvs.hpp"
#include "ibvs/sim/sim.hpp"

#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <exception>
#include <memory>
#include <string>
#include <typeinfo>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace ibvs::py_pose {  // bind_pose.cpp
PbvsTarget target_arg(py::handle obj);
const char* target_name(PbvsTarget t);
Pose pose_arg(py::handle obj, const char* name);
}  // namespace ibvs::py_pose
namespace ibvs::py_segell {  // bind_segment_ellipse.cpp
Eigen::Vector3d vector3(py::handle obj, const char* name);
}  // namespace ibvs::py_segell

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
the image) against the goal's pose as the same depth mode knew it at the goal (exact: the true one;
"pose": the estimate from the goal's image, teach by showing). Feeds an ibvs.PbvsFeature of the same
target.)")
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
c*Rc from the depth mode's pose against the goal's as the same mode knew it (exact: the true one;
"pose": the estimate from the goal's image), and Z* the depth it gave point i at the goal.)")
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
(depth="exact": the true distance; "desired": the goal's; "pose": from ibvs.PlanarPose.estimate_bearings
of the measured bearings, for a task of feature blocks only through a wide lens). Lost when the pixel
has no bearing.)")
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

// ---------------------------------------------------------------- segments, circles, Python sources

namespace ibvs::py_sources {

// A feature source whose measurement a Python callable writes (sim.FunctionSource): the image-in-the-loop
// blob sources of ibvs.vision are ones. The episode calls measure() every frame with the GIL released;
// it takes the GIL, calls measure(frame, cMo, depth_pose, goal, uv, depth) and copies its answer (None:
// lost). An exception is kept (the episode ends, the run raises it: py_sources::raise_kept).
class FunctionSource final : public sim::FeatureSource {
 public:
  FunctionSource(std::shared_ptr<const Feature> feature, py::object fn)
      : feature_(std::move(feature)), fn_(std::make_shared<Held>(std::move(fn))) {}
  std::unique_ptr<sim::FeatureSource> clone() const override { return std::make_unique<FunctionSource>(*this); }
  std::string describe() const override { return "function(" + feature_->describe() + ")"; }
  int size() const noexcept override { return feature_->size(); }
  bool fits(const Feature& f) const noexcept override {
    return f.size() == feature_->size() && typeid(f) == typeid(*feature_);  // the same measurement
  }
  bool measure(const sim::SourceFrame& f, double* m) const noexcept override {
    if (fn_->error) return false;
    try {
      py::gil_scoped_acquire gil;
      Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> uv = f.uv->transpose();
      const py::object r = fn_->fn(f.frame, Eigen::Matrix4d(f.cMo), Eigen::Matrix4d(f.depth_pose),
                                   Eigen::Matrix4d(f.goal), uv, Eigen::VectorXd(*f.depth));
      if (r.is_none()) return false;
      const CArray a = as_array(r, "measure(...) (the block's measurement)");
      if (a.ndim() != 1 || a.shape(0) != size())
        throw py::value_error("measure(...) must return " + std::to_string(size()) + " values (a " +
                              feature_->describe() + " measurement) or None, got shape " + shape_of(a));
      std::copy_n(a.data(), size(), m);
      return true;
    } catch (...) {
      if (!fn_->error) fn_->error = std::current_exception();
      return false;
    }
  }
  const Feature& feature() const noexcept { return *feature_; }
  py::object function() const { return fn_->fn; }
  /// Raises (and forgets) the callable's kept exception, if any.
  void raise_kept() const {
    if (!fn_->error) return;
    std::exception_ptr e = fn_->error;
    fn_->error = nullptr;
    std::rethrow_exception(e);
  }

 private:
  // The callable (released with the GIL held: the episode may drop the last copy without it) and its
  // kept exception, shared by the copies the target and the episode hold.
  struct Held {
    explicit Held(py::object f) : fn(std::move(f)) {}
    ~Held() {
      py::gil_scoped_acquire gil;
      fn = py::object();
    }
    py::object fn;
    std::exception_ptr error;
  };
  std::shared_ptr<const Feature> feature_;
  std::shared_ptr<Held> fn_;
};

/// FunctionSource(feature, measure) from Python arguments, checked (the constructor and the unpickling).
std::shared_ptr<FunctionSource> make_function_source(py::handle feature, py::handle measure) {
  if (!py::isinstance<Feature>(feature))
    throw py::type_error("feature must be an ibvs.Feature (e.g. ibvs.EllipseFeature()), got " + type_name(feature));
  if (!PyCallable_Check(measure.ptr())) throw py::type_error("measure must be callable, got " + type_name(measure));
  return std::make_shared<FunctionSource>(std::shared_ptr<const Feature>(feature.cast<const Feature&>().clone()),
                                          py::reinterpret_borrow<py::object>(measure));
}

/// What a FunctionSource pickles as: FunctionSource(feature, measure). The callable is pickled once first
/// (the standard pickle module), so that one which does not pickle (a lambda, a local function) is named
/// in a TypeError rather than in pickle's message about a function nobody sees here.
py::tuple reduce_function_source(const FunctionSource& x) {
  const py::object fn = x.function();
  require_pickles(fn, "FunctionSource's callable", ", as ibvs.vision.BlobMeasure");
  return py::make_tuple(py::type::of<FunctionSource>(),
                        py::make_tuple(py::cast(std::shared_ptr<Feature>(x.feature().clone())), fn));
}

/// Raises the first exception a FunctionSource of the target kept during a run.
void raise_kept(const sim::Target& t) {
  for (const auto& s : t.sources)
    if (const auto* f = dynamic_cast<const FunctionSource*>(s.get())) f->raise_kept();
}

}  // namespace ibvs::py_sources

void bind_shape_sources(py::module_& m) {
  using namespace ibvs::py_sources;
  py::module_ s = m.attr("sim").cast<py::module_>();

  py::class_<sim::SegmentSource, sim::FeatureSource, std::shared_ptr<sim::SegmentSource>>(s, "SegmentSource", R"(An image segment (ibvs.SegmentFeature) between target points i and j.

SegmentSource(i, j): (xc, yc, l, alpha) of the segment from the controller's point i to its point j
(with the sensor's noise, distortion and latency, as SegmentFeature.measure of them) and the end
points' depths Z1, Z2 as the depth mode gives them. Feeds an ibvs.SegmentFeature of either set
(normalised or plain). Refused: i == j, an index beyond the target's points, coincident points;
lost (the episode's lost_feature) when the two image points coincide (the segment seen end-on).)")
      .def(py::init([](py::handle i, py::handle j) {
             return std::make_shared<sim::SegmentSource>(int_in(i, "i", 0, max_points), int_in(j, "j", 0, max_points));
           }),
           py::arg("i"), py::arg("j"))
      .def_property_readonly("i", &sim::SegmentSource::i, "The segment's first target point (p1).")
      .def_property_readonly("j", &sim::SegmentSource::j, "The segment's second target point (p2).")
      .def("__repr__",
           [](const sim::SegmentSource& x) {
             return "SegmentSource(" + std::to_string(x.i()) + ", " + std::to_string(x.j()) + ")";
           })
      .def(py::pickle([](const sim::SegmentSource& x) { return py::make_tuple(x.i(), x.j()); },
                      [](const py::tuple& t) {
                        if (t.size() != 2) throw py::value_error("SegmentSource: bad pickle state");
                        return std::make_shared<sim::SegmentSource>(t[0].cast<int>(), t[1].cast<int>());
                      }));

  py::class_<sim::EllipseSource, sim::FeatureSource, std::shared_ptr<sim::EllipseSource>>(s, "EllipseSource", R"(The image ellipse (ibvs.EllipseFeature) of a 3-D circle fixed to the target.

EllipseSource(centre, normal, radius): the circle in the target frame (metres; the normal of its
plane, any length > 0). Each frame: (xg, yg, n20, n11, n02) of the circle's exact image from the true
pose (EllipseFeature.project_circle, without the sensor's noise), and the circle's plane (A, B, C)
from the pose the depth mode gives ("exact", "desired", "pose", "estimated"). Give the target points
on the circle's rim: the episode judges visibility on them. Refused: a
non-finite centre, a normal of zero length, a radius <= 0; lost (lost_feature) when the circle's
image is not an ellipse (its plane seen edge-on, part of it behind the camera).)")
      .def(py::init([](py::handle centre, py::handle normal, py::handle radius) {
             return std::make_shared<sim::EllipseSource>(ibvs::py_segell::vector3(centre, "centre"),
                                                         ibvs::py_segell::vector3(normal, "normal"),
                                                         real(radius, "radius"));
           }),
           py::arg("centre"), py::arg("normal"), py::arg("radius"))
      .def_property_readonly("centre", [](const sim::EllipseSource& x) { return Eigen::Vector3d(x.centre()); },
                             "The circle's centre (3,), target frame, metres.")
      .def_property_readonly("normal", [](const sim::EllipseSource& x) { return Eigen::Vector3d(x.normal()); },
                             "The unit normal of the circle's plane (3,), target frame.")
      .def_property_readonly("radius", &sim::EllipseSource::radius, "The circle's radius, metres.")
      .def("__repr__",
           [](const sim::EllipseSource& x) {
             const auto v = [](const Eigen::Vector3d& p) {
               return "(" + py::repr(py::float_(p.x())).cast<std::string>() + ", " +
                      py::repr(py::float_(p.y())).cast<std::string>() + ", " +
                      py::repr(py::float_(p.z())).cast<std::string>() + ")";
             };
             return "EllipseSource(" + v(x.centre()) + ", " + v(x.normal()) + ", " +
                    py::repr(py::float_(x.radius())).cast<std::string>() + ")";
           })
      .def(py::pickle(
          [](const sim::EllipseSource& x) {
            return py::make_tuple(Eigen::Vector3d(x.centre()), Eigen::Vector3d(x.normal()), x.radius());
          },
          [](const py::tuple& t) {
            if (t.size() != 3) throw py::value_error("EllipseSource: bad pickle state");
            return std::make_shared<sim::EllipseSource>(t[0].cast<Eigen::Vector3d>(), t[1].cast<Eigen::Vector3d>(),
                                                        t[2].cast<double>());
          }));

  py::class_<FunctionSource, sim::FeatureSource, std::shared_ptr<FunctionSource>>(s, "FunctionSource", R"(A feature source whose measurement a Python callable gives (e.g. from a rendered image).

FunctionSource(feature, measure): feeds Task blocks of the kind of `feature` (an ibvs.Feature: the
same class and size). Each frame the episode calls measure(frame, cMo, depth_pose, goal, uv, depth)
with frame (-1: the goal, then 0, 1, ...), cMo the true camera <- target pose (4, 4) of the frame the
controller sees, depth_pose the pose the depth mode gives (NaN: unknown), goal the goal's
camera <- target pose as the depth mode knew it at the goal (exact, desired: the true one; "pose":
the estimate from the goal's image), uv (N, 2) the controller's points (normalised) and depth (N,)
their depths;
it returns the block's measurement (feature.size values) or None (cannot measure: the episode ends
as lost_feature). An exception it raises ends the episode and is raised by ibvs.sim.run.
ibvs.vision.blob_source is one (blob moments and ellipses from rendered images). It pickles (and
so does a Target holding it: sweeps on worker processes or Dask) when measure pickles with the
standard pickle module (a module-level function or class instance); otherwise pickling raises a
TypeError naming the callable.)")
      .def(py::init(&make_function_source), py::arg("feature"), py::arg("measure"))
      .def_property_readonly("measure", &FunctionSource::function, "The callable.")
      .def("__repr__", [](const FunctionSource& x) { return "FunctionSource(" + x.feature().describe() + ")"; })
      .def("__reduce__", &reduce_function_source,
           "Pickles as FunctionSource(feature, measure) when measure pickles; TypeError naming it otherwise.");

  s.def(
      "plane_in_camera",
      [](py::handle pose, py::handle normal, py::handle d) {
        double plane[3];
        if (!sim::plane_in_camera(ibvs::py_pose::pose_arg(pose, "pose"), ibvs::py_segell::vector3(normal, "normal"), real(d, "d"),
                                  plane))
          throw py::value_error("plane_in_camera: the plane passes through the camera centre (or is not finite)");
        return Eigen::Vector3d(plane[0], plane[1], plane[2]);
      },
      py::arg("pose"), py::arg("normal") = Eigen::Vector3d(0.0, 0.0, 1.0), py::arg("d") = 0.0,
      "(A, B, C) of 1/Z = A x + B y + C for the plane {X : normal . X = d} of the target frame seen with pose "
      "(camera <- target, 4x4); default the target's z = 0 plane. ValueError when it passes through the camera "
      "centre.");
}
