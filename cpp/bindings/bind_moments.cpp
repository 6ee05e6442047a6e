// ibvs.MomentsFeature: features/moments.hpp.
#include "convert.hpp"

#include "ibvs/features/moments.hpp"

#include <pybind11/stl.h>

#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace {

using Src = MomentsFeature::Source;

Src source_arg(const std::string& s) {
  if (s == "region") return Src::region;
  if (s == "points") return Src::points;
  throw py::value_error("source must be 'region' or 'points', got '" + s + "'");
}

const char* row_names[6] = {"xn", "yn", "an", "r1", "r2", "alpha"};

unsigned rows_arg(py::handle rows) {
  if (rows.is_none()) return MomentsFeature::Row::all;
  if (py::isinstance<py::str>(rows) || !py::isinstance<py::sequence>(rows))
    throw py::type_error("rows must be None or a sequence of names among xn, yn, an, r1, r2, alpha");
  unsigned bits = 0;
  for (const py::handle item : py::reinterpret_borrow<py::sequence>(rows)) {
    if (!py::isinstance<py::str>(item)) throw py::type_error("rows: names among xn, yn, an, r1, r2, alpha");
    const std::string s = item.cast<std::string>();
    unsigned b = 0;
    while (b < 6 && s != row_names[b]) ++b;
    if (b == 6) throw py::value_error("rows: unknown row '" + s + "' (xn, yn, an, r1, r2, alpha)");
    bits |= 1u << b;
  }
  if (bits == 0) throw py::value_error("rows: select at least one of xn, yn, an, r1, r2, alpha");
  return bits;
}

Points points_arg(py::handle obj, const char* name, int min_points) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 2 || a.shape(1) != 2 || a.shape(0) < min_points)
    throw py::value_error(std::string(name) + " must be an array (N, 2) of image points with N >= " +
                          std::to_string(min_points));
  Points p(2, a.shape(0));
  for (py::ssize_t k = 0; k < a.shape(0); ++k) {
    p(0, k) = a.at(k, 0);
    p(1, k) = a.at(k, 1);
    if (!std::isfinite(p(0, k)) || !std::isfinite(p(1, k)))
      throw py::value_error(std::string(name) + "[" + std::to_string(k) + "] is not finite");
  }
  return p;
}

py::array_t<double> to_array(const double* v, int n) { return py::array_t<double>(n, v); }

}  // namespace

void bind_moments(py::module_& m) {
  py::class_<MomentsFeature, Feature, std::shared_ptr<MomentsFeature>>(m, "MomentsFeature",
                                                                         R"(Image moments of a planar object.

Tahri & Chaumette (IEEE T-RO 2005): rows xn, yn (normalised centre of gravity), an = Z* sqrt(a*/a)
(normalised area), r1, r2 (invariants for wx, wy: invariants="p" gives px = I1/I3^2,
py = a I2/I3^3, rotation invariant, for non-symmetric objects; "s" gives sx, sy, which turn with
the object, ViSP's choice for symmetric ones) and alpha (orientation, for wz). alpha="second_order":
atan2(2 mu11, mu20 - mu02)/2, defined modulo pi (error wrapped into (-pi/2, pi/2]); "third_order":
the same axis oriented by the third-order moments, over the full turn (error wrapped into
(-pi, pi]) - use it for non-symmetric objects, so that a turn beyond pi/2 is not taken for its
complement. Undefined: alpha for mu20 = mu02, mu11 = 0 (a square, a disc), the third-order alpha for
centrally symmetric objects (refused; leave the row out with rows=[...]).

source="region": moments are integrals over the object (a polygon, a binary image); "points":
sums over discrete points. Their interaction matrices differ (Chaumette 2004; Tahri & Chaumette
2005). Measurement (20): m00, m10, m01, m20, m11, m02, m30, m21, m12, m03, m40, m31, m22, m13, m04
(normalised coordinates), a* (the goal's area), Z* (the goal's depth) and the plane A, B, C with
1/Z = A x + B y + C. Build it with measure(), project(), of_points(), of_polygon() or, from a
binary image, ibvs.vision.image_moments().)")
      .def(py::init([](const std::string& source, const std::string& invariants, const std::string& alpha,
                       py::handle rows) {
             if (invariants != "p" && invariants != "s")
               throw py::value_error("invariants must be 'p' or 's', got '" + invariants + "'");
             if (alpha != "second_order" && alpha != "third_order")
               throw py::value_error("alpha must be 'second_order' or 'third_order', got '" + alpha + "'");
             return MomentsFeature(source_arg(source),
                                   invariants == "p" ? MomentsFeature::Invariants::p : MomentsFeature::Invariants::s,
                                   alpha == "second_order" ? MomentsFeature::Alpha::second_order
                                                           : MomentsFeature::Alpha::third_order,
                                   rows_arg(rows));
           }),
           py::arg("source") = "region", py::arg("invariants") = "p", py::arg("alpha") = "third_order",
           py::arg("rows") = py::none())
      .def_property_readonly("source",
                             [](const MomentsFeature& f) { return f.source() == Src::region ? "region" : "points"; },
                             "\"region\" (moments are integrals over the object) or \"points\" (sums over "
                             "discrete points).")
      .def_property_readonly("invariants",
                             [](const MomentsFeature& f) {
                               return f.invariants() == MomentsFeature::Invariants::p ? "p" : "s";
                             },
                             "The pair of invariants for wx, wy: \"p\" (px, py) or \"s\" (sx, sy).")
      .def_property_readonly("alpha",
                             [](const MomentsFeature& f) {
                               return f.alpha_kind() == MomentsFeature::Alpha::third_order ? "third_order"
                                                                                           : "second_order";
                             },
                             "The orientation: \"second_order\" (modulo pi) or \"third_order\" (over the full turn).")
      .def_property_readonly("row_names",
                             [](const MomentsFeature& f) {
                               std::vector<std::string> names;
                               for (unsigned b = 0; b < 6; ++b)
                                 if ((f.selected() >> b) & 1u) names.emplace_back(row_names[b]);
                               return names;
                             },
                             "The selected rows, in order.")
      .def("__reduce__",
           [](const MomentsFeature& f) {
             py::list rows;
             for (unsigned b = 0; b < 6; ++b)
               if ((f.selected() >> b) & 1u) rows.append(row_names[b]);
             return py::make_tuple(
                 py::type::of<MomentsFeature>(),
                 py::make_tuple(f.source() == Src::region ? "region" : "points",
                                f.invariants() == MomentsFeature::Invariants::p ? "p" : "s",
                                f.alpha_kind() == MomentsFeature::Alpha::third_order ? "third_order" : "second_order",
                                rows));
           },
           "Pickles as MomentsFeature(source, invariants, alpha, rows).")
      .def_static(
          "of_points",
          [](py::handle xy) {
            const Moments mo = MomentsFeature::of_points(points_arg(xy, "xy", 1));
            return to_array(mo.data(), 15);
          },
          py::arg("xy"), "Moments m00..m04 (15,) of discrete image points (N, 2): sums of x^i y^j.")
      .def_static(
          "of_polygon",
          [](py::handle xy) {
            const Moments mo = MomentsFeature::of_polygon(points_arg(xy, "xy", 3));
            return to_array(mo.data(), 15);
          },
          py::arg("xy"),
          "Moments m00..m04 (15,) of the region inside a simple polygon (N, 2), either orientation (Green's theorem).")
      .def_static(
          "measure",
          [](py::handle moments, py::handle plane, const std::string& source, py::handle area_desired,
             py::handle depth_desired) {
            const CArray mo = as_array(moments, "moments"), pl = as_array(plane, "plane");
            if (mo.size() != 15) throw py::value_error("moments must hold the 15 moments m00..m04");
            if (pl.size() != 3) throw py::value_error("plane must be (A, B, C) of 1/Z = A x + B y + C");
            Moments mm;
            std::copy(mo.data(), mo.data() + 15, mm.begin());
            const auto r = MomentsFeature::measure(mm, source_arg(source), real(area_desired, "area_desired"),
                                                   real(depth_desired, "depth_desired"), pl.data()[0], pl.data()[1],
                                                   pl.data()[2]);
            return to_array(r.data(), 20);
          },
          py::arg("moments"), py::arg("plane"), py::arg("source") = "region", py::arg("area_desired") = 0.0,
          py::arg("depth_desired") = 1.0,
          "The measurement (20,): moments, a*, Z*, plane. area_desired=0: the object's own area (for the goal).")
      .def_static(
          "project",
          [](py::handle P, const std::string& source, py::handle area_desired, py::handle depth_desired) {
            const CArray a = as_array(P, "points");
            if (a.ndim() != 2 || a.shape(1) != 3)
              throw py::value_error("points must be an array (N, 3) in the camera frame");
            Eigen::Matrix3Xd Q(3, a.shape(0));
            for (py::ssize_t k = 0; k < a.shape(0); ++k)
              for (int i = 0; i < 3; ++i) Q(i, k) = a.at(k, i);
            const auto r = MomentsFeature::project(Q, source_arg(source), real(area_desired, "area_desired"),
                                                   real(depth_desired, "depth_desired"));
            return to_array(r.data(), 20);
          },
          py::arg("points"), py::arg("source") = "region", py::arg("area_desired") = 0.0,
          py::arg("depth_desired") = 1.0,
          "The measurement (20,) of a 3-D planar polygon (source 'region') or point set ('points'), (N, 3) in "
          "the camera frame: its image moments and its plane.")
      .def_static(
          "area",
          [](py::handle measurement, const std::string& source) {
            const CArray a = as_array(measurement, "measurement");
            if (a.size() < 15) throw py::value_error("measurement must hold at least the 15 moments");
            return MomentsFeature::area(a.data(), source_arg(source));
          },
          py::arg("measurement"), py::arg("source") = "region",
          "The object's area a: m00 (region) or mu20 + mu02 (points).");
}
