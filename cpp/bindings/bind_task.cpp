// ibvs.Task and the feature blocks (ibvs.Feature and its kinds): task.hpp, feature.hpp.
#include "convert.hpp"

#include "ibvs/features/line.hpp"
#include "ibvs/features/spherical.hpp"
#include "ibvs/task.hpp"

#include <pybind11/stl.h>

#include <array>
#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace ibvs::py_task {

/// One measurement of `f` (size() doubles) from an array-like, checked by the feature (ValueError).
Eigen::VectorXd measurement(const Feature& f, py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  const Eigen::Map<const Eigen::VectorXd> v = vector(a, name);
  if (v.size() != f.size())
    throw py::value_error(std::string(name) + " must hold " + std::to_string(f.size()) + " values for a " +
                          f.describe() + " block, got " + std::to_string(v.size()));
  f.validate(v.data(), name);
  return v;
}

/// The measurements of every block of `task`: None (a task without feature blocks), a flat
/// array of measurement_size() values, or a sequence of one array per block.
void measurements(const Task& task, py::handle obj, const char* name, Eigen::VectorXd& out) {
  out.resize(task.measurement_size());
  if (obj.is_none()) {
    if (task.n_features() > 0)
      throw py::value_error(std::string(name) + " is required: the task has " + std::to_string(task.n_features()) +
                            " feature block(s)");
    return;
  }
  if (py::isinstance<py::list>(obj) || py::isinstance<py::tuple>(obj)) {
    const py::sequence seq = py::reinterpret_borrow<py::sequence>(obj);
    if (static_cast<int>(seq.size()) != task.n_features())
      throw py::value_error(std::string(name) + " must hold one measurement per feature block (" +
                            std::to_string(task.n_features()) + "), got " + std::to_string(seq.size()));
    for (int k = 0; k < task.n_features(); ++k) {
      const std::string item = std::string(name) + "[" + std::to_string(k) + "]";
      out.segment(task.offset(k), task.feature(k).size()) =
          measurement(task.feature(k), seq[static_cast<std::size_t>(k)], item.c_str());
    }
    return;
  }
  const CArray a = as_array(obj, name);
  const auto v = vector(a, name);
  if (v.size() != task.measurement_size())
    throw py::value_error(std::string(name) + " must hold " + std::to_string(task.measurement_size()) +
                          " values (the task's feature blocks, concatenated), got " + std::to_string(v.size()));
  out = v;
}

}  // namespace ibvs::py_task

namespace {

Dof dof_arg(py::handle obj) {
  static const char* names[6] = {"Tx", "Ty", "Tz", "wx", "wy", "wz"};
  Dof d{};
  if (py::isinstance<py::str>(obj) || !py::isinstance<py::sequence>(obj))
    throw py::type_error("dof must be a sequence of 6 bools or of names among Tx, Ty, Tz, wx, wy, wz");
  const py::sequence seq = py::reinterpret_borrow<py::sequence>(obj);
  bool names_given = false;
  for (const py::handle item : seq) names_given = names_given || py::isinstance<py::str>(item);
  if (names_given) {
    for (const py::handle item : seq) {
      if (!py::isinstance<py::str>(item)) throw py::type_error("dof: mix of names and bools");
      const std::string s = item.cast<std::string>();
      int i = 0;
      while (i < 6 && s != names[i]) ++i;
      if (i == 6) throw py::value_error("dof: unknown component '" + s + "' (Tx, Ty, Tz, wx, wy, wz)");
      d[static_cast<std::size_t>(i)] = true;
    }
    return d;
  }
  if (seq.size() != 6) throw py::value_error("dof must hold 6 bools (Tx, Ty, Tz, wx, wy, wz), got " + std::to_string(seq.size()));
  for (std::size_t i = 0; i < 6; ++i) d[i] = boolean(seq[i], "dof");
  return d;
}

py::array_t<double> to_array(const Eigen::VectorXd& v) { return py::array_t<double>(v.size(), v.data()); }

}  // namespace

void bind_task(py::module_& m) {
  using ibvs::py_task::measurement;

  py::class_<Feature, std::shared_ptr<Feature>>(m, "Feature", R"(A block of feature rows of a Task beside its points.

Each kind documents its measurement: the values a frame gives it (e.g. a line: rho, theta and the
plane A, B, C with 1/Z = A x + B y + C), in normalised coordinates and metres. value(), error() and
interaction() evaluate it (they check the measurement first: ValueError naming the entry).)")
      .def_property_readonly("rows", &Feature::rows, "Rows of the block (size of its value).")
      .def_property_readonly("size", &Feature::size, "Values in one measurement.")
      .def("value",
           [](const Feature& f, py::handle m) {
             const Eigen::VectorXd v = measurement(f, m, "measurement");
             Eigen::VectorXd s(f.rows());
             f.value(v.data(), s.data());
             return to_array(s);
           },
           py::arg("measurement"), "The block's feature values s (rows,).")
      .def("error",
           [](const Feature& f, py::handle m, py::handle md) {
             Eigen::VectorXd v = measurement(f, m, "measurement");
             const Eigen::VectorXd vd = measurement(f, md, "measurement_desired");
             Eigen::VectorXd e(f.rows());
             f.align(v.data(), vd.data());
             f.error(v.data(), vd.data(), e.data());
             return to_array(e);
           },
           py::arg("measurement"), py::arg("measurement_desired"),
           "s (-) s*: the measurement aligned to the goal's, angles wrapped (rows,).")
      .def("axis_angle_rows",
           [](const Feature& f, py::handle m, py::handle md) {
             Eigen::VectorXd v = measurement(f, m, "measurement");
             const Eigen::VectorXd vd = measurement(f, md, "measurement_desired");
             f.align(v.data(), vd.data());
             const std::uint64_t bits = f.axis_angle_rows(v.data(), vd.data());
             std::vector<int> rows;
             for (int i = 0; i < std::min(f.rows(), 64); ++i)
               if (bits >> i & 1U) rows.push_back(i);
             return rows;
           },
           py::arg("measurement"), py::arg("measurement_desired"),
           "The error rows that are angles about the optical axis at these measurements: they join a Servo's "
           "consistent angle wrap (angle_wrap=\"consistent\") with the polar points' theta rows. [] for most kinds; "
           "[1] (the azimuth) for a SphericalPolarFeature off the axis.")
      .def("interaction",
           [](const Feature& f, py::handle m) {
             const Eigen::VectorXd v = measurement(f, m, "measurement");
             MatrixX6 L(f.rows(), 6);
             f.interaction(v.data(), L);
             return Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>(L);
           },
           py::arg("measurement"), "The interaction matrix L (rows, 6): ds/dt = L v for the camera twist v.")
      .def("__repr__", [](const Feature& f) { return "<ibvs feature " + f.describe() + ">"; });

  py::class_<LineFeature, Feature, std::shared_ptr<LineFeature>>(m, "LineFeature", R"(An image line (rho, theta).

The line x cos(theta) + y sin(theta) = rho (normalised coordinates), projection of a 3-D line in
the plane 1/Z = A x + B y + C (one through the line, not through the camera centre). Measurement
(5): rho, theta, A, B, C; LineFeature.measure(p1, p2, plane) builds it from two image points.
Interaction matrix: Espiau, Chaumette & Rives 1992 (ViSP's vpFeatureLine with A = -A'/D',
B = -B'/D', C = -C'/D'). The line is also (-rho, theta + pi): the error uses the form nearest the
goal's, theta's difference wrapped into (-pi, pi].)")
      .def(py::init<>())
      .def("__reduce__", [](py::handle self) { return py::make_tuple(py::type::handle_of(self), py::tuple()); },
           "Pickles as the class called with no arguments.")
      .def_static(
          "measure",
          [](py::handle p1, py::handle p2, py::handle plane) {
            const CArray a = as_array(p1, "p1"), b = as_array(p2, "p2"), c = as_array(plane, "plane");
            if (a.size() != 2 || b.size() != 2) throw py::value_error("p1 and p2 must be image points (x, y)");
            if (c.size() != 3) throw py::value_error("plane must be (A, B, C) of 1/Z = A x + B y + C");
            const auto m = LineFeature::measure(a.data()[0], a.data()[1], b.data()[0], b.data()[1], c.data()[0],
                                                c.data()[1], c.data()[2]);
            return py::array_t<double>(5, m.data());
          },
          py::arg("p1"), py::arg("p2"), py::arg("plane"),
          "The measurement (rho >= 0, theta, A, B, C) of the line through two distinct image points.");

  py::class_<SphericalPointFeature, Feature, std::shared_ptr<SphericalPointFeature>>(
      m, "SphericalPointFeature", R"(A point on the unit sphere: its bearing b = P / |P| (3 rows).

Measurement (4): bx, by, bz (a unit vector, e.g. from CameraModel.to_bearing) and the distance
R = |P| in metres; SphericalPointFeature.measure(P) builds it from a camera-frame point. Any angle
off the optical axis, behind the camera too. Interaction matrix [-(I - b b^T) / R, [b]_x] (Hamel &
Mahony, IEEE T-RA 2002, eq. 9), rank 2.)")
      .def(py::init<>())
      .def("__reduce__", [](py::handle self) { return py::make_tuple(py::type::handle_of(self), py::tuple()); },
           "Pickles as the class called with no arguments.")
      .def_static(
          "measure",
          [](py::handle P) {
            const CArray a = as_array(P, "P");
            if (a.size() != 3) throw py::value_error("P must be a camera-frame point (X, Y, Z)");
            const auto m = SphericalPointFeature::measure(a.data()[0], a.data()[1], a.data()[2]);
            return py::array_t<double>(4, m.data());
          },
          py::arg("P"), "The measurement (bx, by, bz, R) of the camera-frame point P (finite, non-zero).");

  py::class_<SphericalPolarFeature, Feature, std::shared_ptr<SphericalPolarFeature>>(
      m, "SphericalPolarFeature", R"(A point on the unit sphere as (colatitude, azimuth) (2 rows).

The paper's polar coordinates lifted to the sphere: colatitude beta = angle from the optical axis
in [0, pi], azimuth phi = atan2(by, bx) about it (a rotation about the axis moves phi alone).
Measurement (4): bx, by, bz, R as SphericalPointFeature. Interaction matrix: Corke, ICRA 2010
(MVTB's SphericalCamera.visjac_p), camera-twist convention; the azimuth error is wrapped into
(-pi, pi]. Near the axis (sin beta < min_sin) the current point uses its (bx, by) rows and a goal
there has no azimuth (its error is 0).)")
      .def(py::init([](py::handle min_sin) { return SphericalPolarFeature(real(min_sin, "min_sin")); }),
           py::arg("min_sin") = default_polar_min_radius)
      .def("__reduce__",
           [](const SphericalPolarFeature& f) {
             return py::make_tuple(py::type::of<SphericalPolarFeature>(), py::make_tuple(f.min_sin()));
           },
           "Pickles as SphericalPolarFeature(min_sin).")
      .def_property_readonly("min_sin", &SphericalPolarFeature::min_sin,
                             "sin(colatitude) below which the current point uses its (bx, by) rows.");

  m.def(
      "spherical_measurements",
      [](const CameraModel& camera, py::handle pixels, py::handle distance, const std::string& invalid) {
        if (invalid != "raise" && invalid != "nan")
          throw py::value_error("invalid must be 'raise' or 'nan', got '" + invalid + "'");
        const CArray a = as_array(pixels, "pixels");
        const auto px = points(a, "pixels");
        const CArray d = as_array(distance, "distance");
        const auto R = vector(d, "distance");
        if (R.size() != px.cols())
          throw py::value_error("distance must hold one value per pixel (" + std::to_string(px.cols()) + "), got " +
                                std::to_string(R.size()));
        if (invalid == "raise") {
          try {
            camera.validate_pixels(px, "pixels");
          } catch (const std::invalid_argument& e) {
            throw py::value_error(std::string(e.what()).substr(6));
          }
          for (Eigen::Index i = 0; i < R.size(); ++i)
            if (!(R(i) >= min_depth && R(i) <= max_depth))
              throw py::value_error("distance[" + std::to_string(i) + "] must be within [" + float_repr(min_depth) +
                                    ", " + float_repr(max_depth) + "] m, got " + float_repr(R(i)));
        }
        py::array_t<double> out({px.cols(), Eigen::Index(4)});
        Eigen::Map<Eigen::VectorXd> o(out.mutable_data(), 4 * px.cols());
        spherical_measurements(camera, px, R, o);
        return out;
      },
      py::arg("camera"), py::arg("pixels"), py::arg("distance"), py::arg("invalid") = "raise",
      R"(Measurements of spherical feature blocks from pixels, through the lens model.

camera: an ibvs.CameraModel; pixels (N, 2) or (N, 1, 2); distance (N,): |P| of each point, metres.
Returns (N, 4): one (bx, by, bz, R) row per point, the measurement of a SphericalPointFeature or
SphericalPolarFeature (pass it to Servo.update as measurements, one row per block, e.g.
list(rows)). The bearing comes from camera.to_bearing: no normalised coordinates, any angle the
lens sees (beyond 90 degrees off the axis with a fisheye or omnidir model). A pixel beyond the
image circle or a distance outside [1e-6, 1e6] m raises ValueError naming it, or gives a row of NaN
with invalid="nan".)");

  py::class_<Task>(m, "Task", R"(What a Servo drives to zero: the points of a Layout, then feature blocks.

Task(layout=None): the image points of `layout` (a Servo of a Task of points only is the Servo of
the Layout, bit for bit), then add(feature, weight) appends blocks of other kinds. Each block's
rows (of J and of the error) are multiplied by its weight; point_weights gives one weight per
block of the Layout. dof: the camera twist components the law may use (ViSP's setCameraDoF):
six bools, or names among "Tx", "Ty", "Tz", "wx", "wy", "wz"; the others are 0 and the law is
solved on the remaining columns of J.)")
      .def(py::init([](py::handle layout) {
             if (layout.is_none()) return Task();
             if (!py::isinstance<Layout>(layout))
               throw py::type_error("layout must be an ibvs.Layout or None, got " + type_name(layout));
             return Task(layout.cast<Layout>());
           }),
           py::arg("layout") = py::none())
      .def(
          "add",
          [](Task& t, const Feature& f, py::handle weight) -> Task& {
            t.add(f, real(weight, "weight"));
            return t;
          },
          py::arg("feature"), py::arg("weight") = 1.0, py::return_value_policy::reference_internal,
          "Append a copy of a feature block (rows multiplied by weight > 0); returns the task.")
      .def_property(
          "point_weights", [](const Task& t) { return t.point_weights(); },
          [](Task& t, py::handle w) {
            const CArray a = as_array(w, "point_weights");
            const auto v = vector(a, "point_weights");
            t.set_point_weights(std::vector<double>(v.data(), v.data() + v.size()));
          },
          "One weight per Layout block ([] = all 1).")
      .def_property(
          "dof", [](const Task& t) { return std::vector<bool>(t.dof().begin(), t.dof().end()); },
          [](Task& t, py::handle d) { t.set_dof(dof_arg(d)); }, "The controlled twist components (6 bools).")
      .def_property_readonly("layout", [](const Task& t) -> py::object {
        return t.has_points() ? py::cast(t.points()) : py::none();
      }, "The task's point Layout, or None.")
      .def_property_readonly("rows", &Task::rows)
      .def_property_readonly("measurement_size", &Task::measurement_size,
                             "Values in one measurement of all feature blocks, concatenated.")
      .def_property_readonly("features",
                             [](const Task& t) {
                               py::list l;
                               for (int k = 0; k < t.n_features(); ++k) l.append(py::cast(std::shared_ptr<Feature>(t.feature(k).clone())));
                               return l;
                             },
                             "Copies of the feature blocks, in row order.")
      .def_property_readonly("weights", [](const Task& t) {
        std::vector<double> w;
        for (int k = 0; k < t.n_features(); ++k) w.push_back(t.weight(k));
        return w;
      }, "The feature blocks' weights.")
      .def("__repr__", [](const Task& t) { return "Task(" + t.describe() + ")"; });
}
