// ibvs.PbvsFeature, ibvs.Point25DFeature, ibvs.theta_u (features/pose.hpp) and
// ibvs.FunctionFeature: a feature block of a Python callable fn(measurement) -> (s, L).
#include "convert.hpp"

#include "ibvs/features/function.hpp"
#include "ibvs/features/pose.hpp"
#include "ibvs/task.hpp"

#include <array>
#include <memory>
#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace ibvs::py_pose {

Pose pose_arg(py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
    throw py::value_error(std::string(name) + " must be a 4x4 rigid transform (camera <- object), got shape " +
                          shape_of(a));
  return Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(a.data());
}

Eigen::Vector3d vector3_arg(py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  if (a.size() != 3) throw py::value_error(std::string(name) + " must hold 3 values, got shape " + shape_of(a));
  return Eigen::Map<const Eigen::Vector3d>(a.data());
}

PbvsTarget target_arg(py::handle obj) {
  if (py::isinstance<py::str>(obj)) {
    const std::string s = obj.cast<std::string>();
    if (s == "desired_camera") return PbvsTarget::desired_camera;
    if (s == "object") return PbvsTarget::object;
    throw py::value_error("target must be 'desired_camera' or 'object', got '" + s + "'");
  }
  throw py::type_error("target must be 'desired_camera' or 'object', got " + type_name(obj));
}

const char* target_name(PbvsTarget t) { return t == PbvsTarget::desired_camera ? "desired_camera" : "object"; }

py::array_t<double> array6(const std::array<double, 6>& m) { return py::array_t<double>(6, m.data()); }

// The callable's Python object, released under the GIL wherever the last copy of the block goes.
std::shared_ptr<py::object> hold(py::object fn) {
  return std::shared_ptr<py::object>(new py::object(std::move(fn)), [](py::object* o) {
    py::gil_scoped_acquire gil;
    delete o;
  });
}

/// A feature block of a Python callable fn(measurement) -> (s, L): s of shape (rows,), L of
/// shape (rows, 6). check() calls it (under the GIL) and refuses what it raises and any
/// non-finite or huge output, with the exception's text; the outputs of the last two accepted
/// measurements (the current one and the goal's) are kept, so value() and interaction() of the
/// same frame do not call it again.
class PyFunctionFeature final : public Feature {
 public:
  PyFunctionFeature(int rows, int size, py::object fn, std::string name)
      : rows_(rows), size_(size), fn_(hold(std::move(fn))), name_(std::move(name)) {
    for (Entry& e : cache_) {
      e.m.resize(size);
      e.s.resize(rows);
      e.L.resize(rows, 6);
    }
  }
  std::unique_ptr<Feature> clone() const override { return std::make_unique<PyFunctionFeature>(*this); }
  std::string describe() const override { return name_ + "(rows=" + std::to_string(rows_) + ")"; }
  int rows() const noexcept override { return rows_; }
  int size() const noexcept override { return size_; }
  const py::object& function() const { return *fn_; }
  const std::string& name() const { return name_; }

  const char* check(const double* m, int& entry) const noexcept override {
    for (entry = 0; entry < size_; ++entry)
      if (!std::isfinite(m[entry])) return "is not finite";
    entry = -1;
    py::gil_scoped_acquire gil;
    const Entry* e = find(m);
    if (e) return nullptr;
    Entry& slot = cache_[static_cast<std::size_t>(next_)];
    if (const char* why = evaluate(m, slot)) return why;
    next_ = 1 - next_;
    return nullptr;
  }
  void value(const double* m, double* s) const noexcept override {
    py::gil_scoped_acquire gil;
    const Entry* e = lookup(m);
    for (int i = 0; i < rows_; ++i) s[i] = e ? e->s(i) : 0.0;
  }
  void interaction(const double* m, Eigen::Ref<MatrixX6> L) const noexcept override {
    py::gil_scoped_acquire gil;
    const Entry* e = lookup(m);
    if (e)
      L.topRows(rows_) = e->L;
    else
      L.topRows(rows_).setZero();
  }

 private:
  struct Entry {
    bool valid = false;
    Eigen::VectorXd m, s;
    MatrixX6 L;
  };
  const Entry* find(const double* m) const noexcept {
    for (const Entry& e : cache_)
      if (e.valid && std::equal(m, m + size_, e.m.data())) return &e;
    return nullptr;
  }
  // The cached outputs of m, evaluated now if m was not checked (a function that refuses it
  // then gives zero rows: the Servo always checks first).
  const Entry* lookup(const double* m) const noexcept {
    if (const Entry* e = find(m)) return e;
    Entry& slot = cache_[static_cast<std::size_t>(next_)];
    if (evaluate(m, slot)) return nullptr;
    next_ = 1 - next_;
    return &slot;
  }
  const char* evaluate(const double* m, Entry& e) const noexcept {
    e.valid = false;
    try {
      py::array_t<double> arg(size_);
      std::copy(m, m + size_, arg.mutable_data());
      const py::object r = (*fn_)(arg);
      if (!py::isinstance<py::tuple>(r) && !py::isinstance<py::list>(r))
        return fail("fn must return a pair (s, L), got " + type_name(r));
      const py::sequence seq = py::reinterpret_borrow<py::sequence>(r);
      if (seq.size() != 2) return fail("fn must return a pair (s, L), got " + std::to_string(seq.size()) + " items");
      const CArray s = as_array(seq[0], "s"), L = as_array(seq[1], "L");
      if (s.size() != rows_)
        return fail("fn's s must hold rows = " + std::to_string(rows_) + " values, got shape " + shape_of(s));
      if (L.size() != 6 * rows_ || !(L.ndim() == 2 || (L.ndim() == 1 && rows_ == 1)))
        return fail("fn's L must have shape (" + std::to_string(rows_) + ", 6), got " + shape_of(L));
      e.s = Eigen::Map<const Eigen::VectorXd>(s.data(), rows_);
      e.L = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>>(L.data(), rows_, 6);
    } catch (py::error_already_set& err) {
      // The exception's type and text (what() would add the traceback).
      std::string text;
      try {
        text = py::str(err.type().attr("__name__")).cast<std::string>() + ": " +
               py::str(err.value()).cast<std::string>();
      } catch (...) {
        text = err.what();
      }
      return fail("fn raised " + text);
    } catch (const std::exception& err) {
      return fail(std::string("fn: ") + err.what());
    }
    if (!finite_within(e.s, max_matrix_entry)) return fail("fn's s is not finite (or beyond 1e150)");
    if (!finite_within(e.L, max_matrix_entry)) return fail("fn's L is not finite (or beyond 1e150)");
    std::copy(m, m + size_, e.m.data());
    e.valid = true;
    return nullptr;
  }
  // The message lives in a per-thread string: copies of a Task share this block, and a message held
  // in the block could be overwritten by another thread's refusal while this thread still reads it.
  static const char* fail(std::string why) noexcept {
    thread_local std::string message;
    try {
      message = std::move(why);
    } catch (...) {
      return "fn failed";
    }
    return message.c_str();
  }

  int rows_, size_;
  std::shared_ptr<py::object> fn_;
  std::string name_;
  // Touched only under the GIL (copies of a Task share their blocks).
  mutable std::array<Entry, 2> cache_;
  mutable int next_ = 0;
};

}  // namespace ibvs::py_pose

void bind_pose(py::module_& m) {
  using namespace ibvs::py_pose;

  m.def(
      "theta_u",
      [](py::handle R) {
        const CArray a = as_array(R, "R");
        if (a.ndim() != 2 || a.shape(0) != 3 || a.shape(1) != 3)
          throw py::value_error("R must be a 3x3 rotation matrix, got shape " + shape_of(a));
        Pose T = Pose::Identity();
        T.topLeftCorner<3, 3>() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(a.data());
        PbvsFeature::measure(T, T, PbvsTarget::object);  // refuses what is not a rotation (to 1e-6), naming "pose"
        const Eigen::Vector3d tu = theta_u(T.topLeftCorner<3, 3>());
        return py::array_t<double>(3, tu.data());
      },
      py::arg("R"),
      R"(The rotation vector theta u (3,) of a rotation matrix, theta in [0, pi] (at pi, the axis' sign
with its largest component positive).)");

  m.def(
      "theta_u_interaction",
      [](py::handle tu) {
        const Eigen::Vector3d v = vector3_arg(tu, "tu");
        if (!v.allFinite() || !(v.norm() <= 2 * pi)) throw py::value_error("tu must be finite with |tu| <= 2 pi");
        return Eigen::Matrix<double, 3, 3, Eigen::RowMajor>(theta_u_interaction(v));
      },
      py::arg("tu"),
      R"(L_tu (3, 3): d(theta u)/dt = L_tu w for theta u of c*Rc and the camera's angular velocity w:
I + (theta/2)[u]x + (1 - sinc(theta)/sinc^2(theta/2))[u]x^2 (Malis et al. 1999; ViSP cdRc).)");

  py::class_<PbvsFeature, Feature, std::shared_ptr<PbvsFeature>>(m, "PbvsFeature", R"(Position-based visual servoing: (translation, theta u), 6 rows.

target="desired_camera": s = (c*t_c, theta u), the current camera's centre in the desired camera's
frame (goal 0), L = [c*Rc 0; 0 L_tu]: the camera centre moves on a straight line.
target="object": s = (c t_o, theta u), the object origin in the camera frame (goal c*t_o),
L = [-I [c t_o]x; 0 L_tu]: the object origin's image moves on a straight line.
theta u is that of c*Rc (the current camera's orientation in the desired one), goal 0
(Chaumette & Hutchinson, IEEE RAM 2006, Sec. IV; ViSP's vpFeatureTranslation cdMc / cMo and
vpFeatureThetaU cdRc). Measurement (6): t (3, metres), theta u (3, radians); measure(pose,
pose_desired) builds it from camera <- object poses (e.g. ibvs.PlanarPose's). theta u of angle in
(pi, 2 pi] is used in its principal form; beyond 2 pi, refused.)")
      .def(py::init([](py::handle target) { return PbvsFeature(target_arg(target)); }),
           py::arg("target") = "desired_camera")
      .def("__reduce__",
           [](const PbvsFeature& f) {
             return py::make_tuple(py::type::of<PbvsFeature>(), py::make_tuple(target_name(f.target())));
           },
           "Pickles as PbvsFeature(target).")
      .def_property_readonly("target", [](const PbvsFeature& f) { return target_name(f.target()); },
                             "'desired_camera' or 'object'.")
      .def_static(
          "measure",
          [](py::handle pose, py::handle pose_desired, py::handle target) {
            return array6(PbvsFeature::measure(pose_arg(pose, "pose"), pose_arg(pose_desired, "pose_desired"),
                                               target_arg(target)));
          },
          py::arg("pose"), py::arg("pose_desired"), py::arg("target") = "desired_camera",
          "The measurement (6,) from the current and desired camera <- object poses (4x4).");

  py::class_<Point25DFeature, Feature, std::shared_ptr<Point25DFeature>>(m, "Point25DFeature", R"(2.5-D visual servoing (Malis, Chaumette & Boudet, IEEE T-RA 1999): 6 rows.

s = (x, y, log Z, theta u) of a reference point: its normalised image point, its depth and theta
u of c*Rc; the error is (x - x*, y - y*, log(Z/Z*), theta u). L: the point's rows (paper eq. 3),
[0, 0, -1/Z, -y, x, 0] for log Z, [0 L_tu] for theta u; the reference point's image moves on a
straight line. Measurement (6): x, y, Z (> 0, metres), theta u (3); measure(pose, pose_desired,
point) builds it from camera <- object poses and the point in the object frame.)")
      .def(py::init<>())
      .def("__reduce__", [](py::handle self) { return py::make_tuple(py::type::handle_of(self), py::tuple()); },
           "Pickles as the class called with no arguments.")
      .def_static(
          "measure",
          [](py::handle pose, py::handle pose_desired, py::handle point) {
            return array6(Point25DFeature::measure(pose_arg(pose, "pose"), pose_arg(pose_desired, "pose_desired"),
                                                   vector3_arg(point, "point")));
          },
          py::arg("pose"), py::arg("pose_desired"), py::arg("point") = std::array<double, 3>{0.0, 0.0, 0.0},
          "The measurement (6,) of `point` (object frame) from the current and desired camera <- object poses.");

  py::class_<PyFunctionFeature, Feature, std::shared_ptr<PyFunctionFeature>>(m, "FunctionFeature", R"(A feature block of your own: fn(measurement) -> (s, L).

rows: the block's rows (1 to 64); size: values in one measurement; fn receives the measurement
(a (size,) array) and returns s (rows,) and L (rows, 6), the interaction matrix (ds/dt = L v for
the camera twist v). It must be a pure function of the measurement. A measurement for which fn
raises or returns a non-finite value is refused (ValueError with fn's message, from validate() and
update() alike). Stack it with any other block in a Task.)")
      .def(py::init([](py::handle rows, py::handle size, py::object fn, std::string name) {
             const int r = int_in(rows, "rows", 1, max_function_rows), n = int_in(size, "size", 1, 1 << 20);
             if (!PyCallable_Check(fn.ptr())) throw py::type_error("fn must be callable, got " + type_name(fn));
             return PyFunctionFeature(r, n, std::move(fn), std::move(name));
           }),
           py::arg("rows"), py::arg("size"), py::arg("fn"), py::arg("name") = "function")
      .def(
          "__reduce__",
          [](const PyFunctionFeature& f) {
            const py::object& fn = f.function();
            require_pickles(fn, "FunctionFeature's fn");
            return py::make_tuple(py::type::of<PyFunctionFeature>(), py::make_tuple(f.rows(), f.size(), fn, f.name()));
          },
          "Pickles as FunctionFeature(rows, size, fn, name) when fn pickles; TypeError naming it otherwise.")
      .def_property_readonly("fn", &PyFunctionFeature::function, "The callable.")
      .def_property_readonly("name", &PyFunctionFeature::name,
                             "The block's name in describe() and repr (default \"function\").");
}
