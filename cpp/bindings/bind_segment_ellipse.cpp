// ibvs.SegmentFeature and ibvs.EllipseFeature: features/segment.hpp, features/ellipse.hpp.
// Bound after bind_task (their base, ibvs.Feature, is bound there).
#include "convert.hpp"

#include "ibvs/features/ellipse.hpp"
#include "ibvs/features/segment.hpp"

#include <array>
#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace ibvs::py_segell {

template <std::size_t N>
py::array_t<double> to_numpy(const std::array<double, N>& a) {
  return py::array_t<double>(static_cast<py::ssize_t>(N), a.data());
}

/// A 3-vector (array-like of 3 reals).
Eigen::Vector3d vector3(py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 1 || a.shape(0) != 3) throw py::value_error(std::string(name) + " must hold 3 values (x, y, z)");
  return {a.data()[0], a.data()[1], a.data()[2]};
}

/// An image point (array-like of 2 reals).
std::array<double, 2> point2(py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 1 || a.shape(0) != 2) throw py::value_error(std::string(name) + " must be an image point (x, y)");
  return {a.data()[0], a.data()[1]};
}

/// (m00, m10, m01, mu20, mu11, mu02) from cv2.moments' dict (or any mapping with those keys) or a sequence of 6.
std::array<double, 6> moments_arg(py::handle obj) {
  static const char* keys[6] = {"m00", "m10", "m01", "mu20", "mu11", "mu02"};
  std::array<double, 6> m{};
  if (py::isinstance<py::dict>(obj) || py::hasattr(obj, "keys")) {
    for (std::size_t i = 0; i < 6; ++i) {
      const std::string item = std::string("moments['") + keys[i] + "']";
      if (!obj.attr("__contains__")(keys[i]).cast<bool>())
        throw py::value_error("moments must have the keys m00, m10, m01, mu20, mu11, mu02 (cv2.moments' names); " +
                              item + " is missing");
      m[i] = real(obj[py::str(keys[i])], item.c_str());
    }
    return m;
  }
  const CArray a = as_array(obj, "moments");
  if (a.ndim() != 1 || a.shape(0) != 6)
    throw py::value_error(
        "moments must be cv2.moments' dict or 6 values (m00, m10, m01, mu20, mu11, mu02), got shape " + shape_of(a));
  for (std::size_t i = 0; i < 6; ++i) m[i] = a.data()[i];
  return m;
}

}  // namespace ibvs::py_segell

void bind_segment_ellipse(py::module_& m) {
  using namespace ibvs::py_segell;

  py::class_<SegmentFeature, Feature, std::shared_ptr<SegmentFeature>>(m, "SegmentFeature",
                                                                       R"(An image segment (ViSP's vpFeatureSegment).

The segment from image point p1 (depth Z1) to p2 (depth Z2): centre (xc, yc), length l and
orientation alpha = atan2(y2 - y1, x2 - x1). Features: (xc/l, yc/l, 1/l, alpha) when normalized
(default; 1/l is proportional to the depth of a fronto-parallel segment), else (xc, yc, l, alpha).
Measurement (6): xc, yc, l, alpha, Z1, Z2, from SegmentFeature.measure(p1, p2, Z1, Z2) or from two
3-D points by SegmentFeature.project(P1, P2). The segment is unoriented: it is also its reverse
(alpha + pi, Z1 and Z2 exchanged), and the error uses the form whose alpha is nearest the goal's
(alpha's difference wrapped into (-pi, pi], at most pi/2). Interaction matrix: the end points' point
rows composed (equal to ViSP's closed form). Refused: a segment shorter than 1e-9 (zero length),
depths outside [1e-6, 1e6] m, a centre beyond 10 (normalised), non-finite values.)")
      .def(py::init([](py::handle normalized) { return SegmentFeature(boolean(normalized, "normalized")); }),
           py::arg("normalized") = true)
      .def("__reduce__",
           [](const SegmentFeature& f) {
             return py::make_tuple(py::type::of<SegmentFeature>(), py::make_tuple(f.normalized()));
           },
           "Pickles as SegmentFeature(normalized).")
      .def_property_readonly("normalized", &SegmentFeature::normalized,
                             "True: features (xc/l, yc/l, 1/l, alpha); False: (xc, yc, l, alpha).")
      .def_static(
          "measure",
          [](py::handle p1, py::handle p2, py::handle Z1, py::handle Z2) {
            const auto a = point2(p1, "p1"), b = point2(p2, "p2");
            return to_numpy(SegmentFeature::measure(a[0], a[1], real(Z1, "Z1"), b[0], b[1], real(Z2, "Z2")));
          },
          py::arg("p1"), py::arg("p2"), py::arg("Z1"), py::arg("Z2"),
          "The measurement (xc, yc, l, alpha, Z1, Z2) of the segment from image point p1 at depth Z1 to p2 at "
          "depth Z2 (normalised coordinates, metres).")
      .def_static(
          "project",
          [](py::handle P1, py::handle P2) {
            return to_numpy(SegmentFeature::project(vector3(P1, "P1"), vector3(P2, "P2")));
          },
          py::arg("P1"), py::arg("P2"),
          "The measurement of the segment between two 3-D points of the camera frame (in front of the camera).");

  py::class_<EllipseFeature, Feature, std::shared_ptr<EllipseFeature>>(m, "EllipseFeature", R"(An image ellipse or planar blob by its moments (ViSP's vpFeatureEllipse).

Features (xg, yg, n20, n11, n02): the centroid and the centred second-order moments divided by the
area (normalised coordinates; a disc of radius R has n20 = n02 = R^2 / 4). Measurement (8): xg, yg,
n20, n11, n02 and the plane A, B, C (1/Z = A x + B y + C) of the 3-D circle or planar blob; from a
3-D circle by EllipseFeature.project_circle(centre, normal, radius), from an image blob by
EllipseFeature.measure_moments(cv2.moments(mask), plane, camera). Interaction matrix: Chaumette
2004 (IEEE T-RO), eqs. (14) and (26). Refused: zero or negative area (n20 n02 - n11^2 <= 0), a
plane seen edge-on or behind the camera over the ellipse, a centroid beyond 10 (normalised),
non-finite values. A circle seen fronto-parallel and centred is a singular configuration (the
five rows have rank 3).)")
      .def(py::init<>())
      .def("__reduce__", [](py::handle self) { return py::make_tuple(py::type::handle_of(self), py::tuple()); },
           "Pickles as the class called with no arguments.")
      .def_static(
          "project_circle",
          [](py::handle centre, py::handle normal, py::handle radius) {
            return to_numpy(EllipseFeature::project_circle(vector3(centre, "centre"), vector3(normal, "normal"),
                                                           real(radius, "radius")));
          },
          py::arg("centre"), py::arg("normal"), py::arg("radius"),
          "The measurement of the image of a 3-D circle (camera frame, metres): its centre, the normal of its "
          "plane (any length, either sign) and its radius.")
      .def_static(
          "measure_moments",
          [](py::handle moments, py::handle plane, py::handle camera) {
            const CArray p = as_array(plane, "plane");
            if (p.ndim() != 1 || p.shape(0) != 3)
              throw py::value_error("plane must be (A, B, C) of 1/Z = A x + B y + C");
            if (!camera.is_none() && !py::isinstance<CameraModel>(camera))
              throw py::type_error("camera must be an ibvs.CameraModel or None, got " + type_name(camera));
            const CameraModel cam = camera.is_none() ? CameraModel() : camera.cast<CameraModel>();
            return to_numpy(
                EllipseFeature::measure_moments(moments_arg(moments), p.data()[0], p.data()[1], p.data()[2], cam));
          },
          py::arg("moments"), py::arg("plane"), py::arg("camera") = py::none(),
          "The measurement of a planar blob from its image moments: cv2.moments' dict (or the 6 values m00, m10, "
          "m01, mu20, mu11, mu02), in pixels of `camera` (without lens distortion: undistort first) or, camera "
          "None, in normalised coordinates; plane (A, B, C) of 1/Z = A x + B y + C.");
}
