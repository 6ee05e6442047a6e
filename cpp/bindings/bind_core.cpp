// Bindings of the control-law core: Layout, features/jacobian/error, the
// pseudoinverse, Servo. Argument conversion only; the logic is in cpp/src.
#include "convert.hpp"
#include "ibvs/ibvs.hpp"
#include "py_servo.hpp"

#include <pybind11/operators.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>

#include <stdexcept>
#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;
using ibvs::py_servo::PyServo;

namespace {

// Python expression of a layout: Layout.stacked(4) or Layout([(0, 'polar'), ...], n_points=5).
std::string layout_repr(const Layout& l) {
  const std::string d = l.describe();
  return d[0] == '[' ? "Layout(" + d + ")" : "Layout." + d;
}

Representation representation(py::handle obj, const std::string& name) {
  if (py::isinstance<Representation>(obj)) return obj.cast<Representation>();
  if (!py::isinstance<py::str>(obj))
    throw py::type_error(name + " must be 'cartesian', 'polar' or 'cylindrical', got " +
                         std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  const auto s = obj.cast<std::string>();
  if (s == "cartesian") return Representation::cartesian;
  if (s == "polar") return Representation::polar;
  if (s == "cylindrical") return Representation::cylindrical;
  throw py::value_error(name + " must be 'cartesian', 'polar' or 'cylindrical', got '" + s + "'");
}

InteractionMatrix interaction(const std::string& s) {
  if (s == "current") return InteractionMatrix::current;
  if (s == "desired") return InteractionMatrix::desired;
  if (s == "mean") return InteractionMatrix::mean;
  throw py::value_error("jacobian must be 'current', 'desired' or 'mean', got '" + s + "'");
}

const char* interaction_name(InteractionMatrix j) {
  return j == InteractionMatrix::desired ? "desired" : j == InteractionMatrix::mean ? "mean" : "current";
}

AngleWrap angle_wrap_arg(py::handle obj) {
  if (!py::isinstance<py::str>(obj))
    throw py::type_error("angle_wrap must be 'consistent' or 'per_point', got " +
                         std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  const auto s = obj.cast<std::string>();
  if (s == "consistent") return AngleWrap::consistent;
  if (s == "per_point") return AngleWrap::per_point;
  throw py::value_error("angle_wrap must be 'consistent' or 'per_point', got '" + s + "'");
}

const char* angle_wrap_name(AngleWrap w) { return w == AngleWrap::per_point ? "per_point" : "consistent"; }


// One (point_index, representation) pair of Layout(blocks): a fast path for the usual (int, str) tuple
// (10^5 blocks in a few ms), the general checks, with their messages, for anything else.
Block block_of(py::handle item, std::size_t k) {
  PyObject* p = item.ptr();
  if (PyTuple_CheckExact(p) && PyTuple_GET_SIZE(p) == 2 && PyLong_CheckExact(PyTuple_GET_ITEM(p, 0)) &&
      PyUnicode_CheckExact(PyTuple_GET_ITEM(p, 1))) {
    int overflow = 0;
    const long long i = PyLong_AsLongLongAndOverflow(PyTuple_GET_ITEM(p, 0), &overflow);
    PyObject* r = PyTuple_GET_ITEM(p, 1);
    if (!overflow && i >= 0 && i < max_points) {
      if (PyUnicode_CompareWithASCIIString(r, "cartesian") == 0) return {static_cast<int>(i), Representation::cartesian};
      if (PyUnicode_CompareWithASCIIString(r, "polar") == 0) return {static_cast<int>(i), Representation::polar};
      if (PyUnicode_CompareWithASCIIString(r, "cylindrical") == 0)
        return {static_cast<int>(i), Representation::cylindrical};
    }
  }
  const std::string where = "blocks[" + std::to_string(k) + "]";
  if (!py::isinstance<py::sequence>(item) || py::isinstance<py::str>(item) || py::len(item) != 2)
    throw py::type_error(where + " must be a pair (point_index, 'cartesian' | 'polar' | 'cylindrical')");
  const auto pair = py::reinterpret_borrow<py::sequence>(item);
  return {int_in(pair[0], where + "[0] (point index)", 0, max_points - 1), representation(pair[1], where + "[1]")};
}

Layout make_layout(const py::iterable& blocks, const py::object& n_points) {
  if (py::isinstance<py::str>(blocks)) throw py::type_error("blocks must be a sequence of (point_index, representation)");
  std::vector<Block> out;
  if (PyList_Check(blocks.ptr())) out.reserve(static_cast<std::size_t>(PyList_GET_SIZE(blocks.ptr())));
  std::size_t k = 0;
  for (py::handle item : blocks) out.push_back(block_of(item, k++));
  return Layout(std::move(out), n_points.is_none() ? -1 : int_in(n_points, "n_points", 1, max_points));
}

int n_arg(py::handle n) { return int_in(n, "n", 1, max_points); }

// `gain` in Python: a positive number (constant gain) or an ibvs.AdaptiveGain.
void set_gain(ServoOptions& o, py::handle g) {
  if (py::isinstance<AdaptiveGain>(g)) {
    o.adaptive_gain = g.cast<AdaptiveGain>();
    o.gain = o.adaptive_gain.at_zero;  // kept valid; unused while adaptive_gain is enabled
    return;
  }
  try {
    o.gain = real(g, "gain");
  } catch (const py::type_error&) {
    throw py::type_error("gain must be a number or an ibvs.AdaptiveGain, got " + type_name(g));
  }
  o.adaptive_gain = AdaptiveGain{};
}

py::object gain_of(const ServoOptions& o) {
  if (o.adaptive_gain.enabled()) return py::cast(o.adaptive_gain);
  return py::float_(o.gain);
}

void check_switch_radius(double r) {
  if (!(r >= 0.0) || !std::isfinite(r)) throw py::value_error("switch_radius must be finite and >= 0");
}

std::string number(double x) { return py::str(py::float_(x)); }

}  // namespace

// Python's Servo.update: numpy arguments, validate() (raises), then the real-time update()
// into an output buffer no earlier result holds (py_servo.hpp: returned without a copy).
std::shared_ptr<ServoOutput> PyServo::update(py::handle uv_obj, py::handle depth_obj, py::handle uvd_obj,
                                             py::handle zd_obj, py::handle m_obj, py::handle md_obj,
                                             py::handle valid_obj) {
  if (!valid_obj.is_none()) {  // lost points: the masked path (smoothing.hpp's neighbour, servo.hpp)
    const Eigen::Index n = servo.layout().n_points();
    const py::array a = py::array::ensure(valid_obj);
    if (!a || a.dtype().kind() != 'b')
      throw py::type_error("valid must be an array of bools (True = the point is measured), got " +
                           type_name(valid_obj));
    if (a.ndim() != 1 || a.shape(0) != n)
      throw py::value_error("valid must have shape (" + std::to_string(n) + ",), got " + shape_of(a));
    const auto b = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(a);
    valid.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) valid(i) = b.data()[i];
    const CArray uv_a = as_array(uv_obj, "uv"), uvd_a = as_array(uvd_obj, "uv_desired");
    const auto uv = points(uv_a, "uv");
    const auto uvd = points(uvd_a, "uv_desired");
    depths(depth_obj, "depth", n, z);
    if (zd_obj.is_none()) {
      if (servo.options().jacobian != InteractionMatrix::current)
        throw py::value_error(std::string("depth_desired is required when jacobian='") +
                              interaction_name(servo.options().jacobian) + "'");
      zd = Eigen::VectorXd::Ones(n);
    } else {
      depths(zd_obj, "depth_desired", n, zd);
    }
    py_task::measurements(servo.task(), m_obj, "measurements", m);
    py_task::measurements(servo.task(), md_obj, "measurements_desired", md);
    servo.validate(uv, z, uvd, zd, m, md, valid);
    std::shared_ptr<ServoOutput> out = outputs.next();
    servo.update(uv, z, uvd, zd, m, md, valid, *out);
    return out;
  }
  const CArray uv_a = as_array(uv_obj, "uv"), uvd_a = as_array(uvd_obj, "uv_desired");
  const auto uv = points(uv_a, "uv");
  const auto uvd = points(uvd_a, "uv_desired");
  const Eigen::Index n = servo.layout().n_points();
  depths(depth_obj, "depth", n, z);
  if (zd_obj.is_none()) {
    if (servo.options().jacobian != InteractionMatrix::current && n > 0)  // a task of feature blocks has no depths
      throw py::value_error(std::string("depth_desired is required when jacobian='") +
                            interaction_name(servo.options().jacobian) + "'");
    zd = z;
  } else {
    depths(zd_obj, "depth_desired", n, zd);
  }
  if (servo.task().points_only()) {  // the point laws, exactly as before
    servo.validate(uv, z, uvd, zd);
    std::shared_ptr<ServoOutput> out = outputs.next();
    servo.update(uv, z, uvd, zd, *out);
    return out;
  }
  py_task::measurements(servo.task(), m_obj, "measurements", m);
  py_task::measurements(servo.task(), md_obj, "measurements_desired", md);
  servo.validate(uv, z, uvd, zd, m, md);
  std::shared_ptr<ServoOutput> out = outputs.next();
  servo.update(uv, z, uvd, zd, m, md, *out);
  return out;
}

void bind_core(py::module_& m) {
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const std::invalid_argument& e) {
      // Messages from the C++ validate path start with "ibvs: "; Python adds its own context.
      std::string s = e.what();
      if (s.rfind("ibvs: ", 0) == 0) s = s.substr(6);
      PyErr_SetString(PyExc_ValueError, s.c_str());
    }
  });

  py::enum_<Representation>(m, "Representation", "How an image point becomes two feature rows.")
      .value("cartesian", Representation::cartesian, "(u, v), Jacobian eq. (3)")
      .value("polar", Representation::polar, "(r, theta), Jacobian -(eq. 7)")
      .value("cylindrical", Representation::cylindrical,
             "(r, r theta) of Iwatsuki & Okiyama; error (r - r*, r wrap(theta - theta*))");

  py::enum_<Status>(m, "Status", "Outcome of Servo.update().")
      .value("ok", Status::ok)
      .value("singular", Status::singular, "J numerically rank-deficient; twist is the finite min-norm/damped solution")
      .value("invalid_input", Status::invalid_input, "non-finite input or depth <= 0 (never returned in Python: it raises)")
      .value("features_lost", Status::features_lost,
             "too few valid points for the task's DOF (update(valid=...)): the twist ramps to zero over stop_time");

  py::class_<Layout>(m, "Layout", R"(Which feature blocks are stacked, in which row order.

Layout(blocks, n_points=None): blocks is a sequence of (point_index, "cartesian" | "polar" | "cylindrical");
block k fills rows 2k and 2k+1 of the feature vector and the Jacobian.
n_points defaults to the largest point index + 1.)")
      .def(py::init(&make_layout), py::arg("blocks"), py::arg("n_points") = py::none())
      .def_static("cartesian", [](py::handle n) { return Layout::cartesian(n_arg(n)); }, py::arg("n"),
                  "Classic IBVS: (u_i, v_i) for each of n points, 2n x 6.")
      .def_static("polar", [](py::handle n) { return Layout::polar(n_arg(n)); }, py::arg("n"),
                  "IBVS-P: (r_i, theta_i) for each of n points, 2n x 6.")
      .def_static("stacked", [](py::handle n) { return Layout::stacked(n_arg(n)); }, py::arg("n"),
                  "Stacked hybrid: (u_i, v_i, r_i, theta_i) for each of n points, 4n x 6.")
      .def_static("cylindrical", [](py::handle n) { return Layout::cylindrical(n_arg(n)); }, py::arg("n"),
                  R"((r_i, r_i theta_i) for each of n points (Iwatsuki & Okiyama), 2n x 6. Servo error per point:
(r - r*, r wrap(theta - theta*)); rows bounded at r = 0, so no Cartesian fallback.)")
      .def_property_readonly("rows", &Layout::rows, "M, the number of feature rows (2 per block).")
      .def_property_readonly("n_points", &Layout::n_points, "N, the number of image points.")
      .def_property_readonly("blocks",
                             [](const Layout& l) {  // one str per representation, shared by the tuples
                               const py::str names[3] = {py::str("cartesian"), py::str("polar"),
                                                         py::str("cylindrical")};
                               py::list out(l.blocks().size());
                               std::size_t k = 0;
                               for (const Block& b : l.blocks()) {
                                 const int r = b.representation == Representation::polar         ? 1
                                               : b.representation == Representation::cylindrical ? 2
                                                                                                 : 0;
                                 out[k++] = py::make_tuple(b.point, names[r]);
                               }
                               return out;
                             },
                             "List of (point_index, representation) in row order.")
      .def(py::self == py::self)
      .def("__repr__", &layout_repr)
      .def("__hash__", [](const Layout& l) {  // of what == compares (n_points, blocks), without a string
        std::size_t h = static_cast<std::size_t>(l.n_points());
        for (const Block& b : l.blocks())
          h = (h * 1000003u) ^ (static_cast<std::size_t>(b.point) * 4u + static_cast<std::size_t>(b.representation));
        return static_cast<py::ssize_t>(h);
      });

  m.def(
      "features",
      [](py::handle uv, const Layout& layout) {
        const CArray a = as_array(uv, "uv");
        return features(layout, points(a, "uv"));
      },
      py::arg("uv"), py::arg("layout"),
      "Stacked feature vector f (M,) of the points uv (N, 2), normalised coordinates; theta in (-pi, pi].");

  m.def(
      "jacobian",
      [](py::handle uv, py::handle depth, const Layout& layout, py::handle polar_min_radius) {
        const CArray a = as_array(uv, "uv");
        const auto p = points(a, "uv");
        Eigen::VectorXd z;
        depths(depth, "depth", p.cols(), z);
        return jacobian(layout, p, z, real(polar_min_radius, "polar_min_radius"));
      },
      py::arg("uv"), py::arg("depth"), py::arg("layout"), py::arg("polar_min_radius") = default_polar_min_radius,
      R"(Stacked image Jacobian (M, 6): d f/dt = J @ v for the camera twist v = (Tx, Ty, Tz, wx, wy, wz).

uv (N, 2) normalised coordinates, |u|, |v| <= 10; depth (metres, in [1e-6, 1e6]) a scalar or (N,). A
polar block whose point lies within polar_min_radius (and always within 1e-12) of the principal point
gets its Cartesian rows (eq. 3) instead.)");

  m.def(
      "feature_error",
      [](py::handle f, py::handle fd, const Layout& layout, py::handle wrap) {
        const CArray a = as_array(f, "f"), b = as_array(fd, "f_desired");
        return feature_error(layout, vector(a, "f"), vector(b, "f_desired"), angle_wrap_arg(wrap));
      },
      py::arg("f"), py::arg("f_desired"), py::arg("layout"), py::arg("angle_wrap") = "consistent",
      R"(Feature error f (-) f* (M,): plain difference; theta rows wrapped (eq. 13); cylindrical rows
(r - r*, r wrap(theta - theta*)).

angle_wrap="consistent" (default): the angle differences of all polar and cylindrical blocks
are wrapped as one rotation, into (phi - pi, phi + pi] about their circular mean phi (in
(-pi, pi]; blocks with r or r* = 0 take no part; a difference exactly at phi - pi becomes
phi + pi); where the mean is undefined (resultant length below 1e-6) each keeps (-pi, pi].
angle_wrap="per_point": each difference into (-pi, pi] on its own (an exact half-turn is +pi).)");

  m.def(
      "damped_pinv",
      [](py::handle J, py::handle damping) {
        const CArray a = as_array(J, "J");
        return damped_pinv(matrix_x6(a, "J"), real(damping, "damping"));
      },
      py::arg("J"), py::arg("damping") = 0.0,
      R"(Pseudoinverse (6, M) of J (M, 6) by SVD, J = U S V^T: V diag(phi(s)) U^T with phi(s) = 1/s
(damping = 0, Moore-Penrose) or s / (s^2 + damping^2) (damped least squares, = (J^T J + damping^2 I)^-1 J^T),
singular values at or below max(M, 6) eps s_max dropped (rank-deficient J allowed). Entries of J and
damping at most 1e150 in magnitude; a nonzero J needs an entry of at least 1e-150.)");

  m.def(
      "singular_values",
      [](py::handle J) {
        const CArray a = as_array(J, "J");
        return singular_values(matrix_x6(a, "J"));
      },
      py::arg("J"), "Singular values of J (M, 6), decreasing (entries at most 1e150 in magnitude).");

  m.def(
      "wrap_angle",
      [](py::handle a) -> py::object {
        const CArray x = as_array(a, "angle");
        py::array_t<double> out(std::vector<py::ssize_t>(x.shape(), x.shape() + x.ndim()));
        const double* src = x.data();
        double* dst = out.mutable_data();
        for (py::ssize_t i = 0; i < x.size(); ++i) {
          if (!std::isfinite(src[i])) throw py::value_error("angle must be finite");
          dst[i] = wrap_angle(src[i]);
        }
        if (x.ndim() == 0) return py::float_(dst[0]);
        return std::move(out);
      },
      py::arg("angle"), "Wrap angles (radians, any finite value) into (-pi, pi]; exactly -pi maps to +pi.");

  m.def(
      "se3_exp",
      [](py::handle twist) {
        const CArray a = as_array(twist, "twist");
        const auto x = vector(a, "twist");
        if (x.size() != 6) throw py::value_error("twist must have shape (6,), got " + shape_of(a));
        if (!x.allFinite()) throw py::value_error("twist must be finite");
        if (!finite_within(x, max_twist_entry))
          throw py::value_error("twist entries must be at most 1e300 in magnitude");
        return Eigen::Matrix4d(se3_exp(x));
      },
      py::arg("twist"),
      R"(4x4 rigid motion exp(twist^) for a twist (Tx, Ty, Tz, wx, wy, wz) applied for unit time
(entries at most 1e300 in magnitude). A camera moving with twist v for dt goes from T_wc to
T_wc @ se3_exp(v * dt).)");

  py::class_<AdaptiveGain>(m, "AdaptiveGain", R"(Gain as a function of the error norm x (ViSP's vpAdaptiveGain):

  gain(x) = (at_zero - at_infinity) * exp(-(slope_at_zero / (at_zero - at_infinity)) * x) + at_infinity

at_zero in (0, 1e250] is the gain at x = 0, 0 < at_infinity <= at_zero the gain for large errors,
slope_at_zero >= 0 the rate at which the gain falls at x = 0. Pass it as Servo(..., gain=...).)")
      .def(py::init([](py::handle g0, py::handle ginf, py::handle slope) {
             AdaptiveGain a{real(g0, "at_zero"), real(ginf, "at_infinity"), real(slope, "slope_at_zero")};
             ServoOptions o;
             o.adaptive_gain = a;
             if (!a.enabled()) throw py::value_error("adaptive_gain.at_zero must be finite and > 0, got 0");
             Servo::validate(o);
             return a;
           }),
           py::arg("at_zero"), py::arg("at_infinity"), py::arg("slope_at_zero"))
      .def_readonly("at_zero", &AdaptiveGain::at_zero)
      .def_readonly("at_infinity", &AdaptiveGain::at_infinity)
      .def_readonly("slope_at_zero", &AdaptiveGain::slope_at_zero)
      .def(
          "__call__",
          [](const AdaptiveGain& a, py::handle x) -> py::object {
            const CArray arr = as_array(x, "x");
            py::array_t<double> out(std::vector<py::ssize_t>(arr.shape(), arr.shape() + arr.ndim()));
            const double* src = arr.data();
            double* dst = out.mutable_data();
            for (py::ssize_t i = 0; i < arr.size(); ++i) {
              if (!(src[i] >= 0.0) || !std::isfinite(src[i])) throw py::value_error("x must be finite and >= 0");
              dst[i] = a(src[i]);
            }
            if (arr.ndim() == 0) return py::float_(dst[0]);
            return std::move(out);
          },
          py::arg("x"), "gain(x) for an error norm (or array of them) x >= 0.")
      .def(py::self == py::self)
      .def("__repr__", [](const AdaptiveGain& a) {
        return "AdaptiveGain(at_zero=" + number(a.at_zero) + ", at_infinity=" + number(a.at_infinity) +
               ", slope_at_zero=" + number(a.slope_at_zero) + ")";
      });

  py::class_<ServoOutput, std::shared_ptr<ServoOutput>>(m, "ServoResult", R"(Result of one Servo.update().

A snapshot that owns its buffer: error, jacobian and velocity are read-only numpy views of it
(no copy is made, whether they are read or not), valid for as long as they or the result are
referenced; later updates never change them (they write into buffers no result holds).)")
      .def_readonly("status", &ServoOutput::status)
      .def_readonly("velocity", &ServoOutput::velocity,
                    "Camera twist (6,): Tx, Ty, Tz (m/s), wx, wy, wz (rad/s). Read-only view.")
      .def_readonly("error", &ServoOutput::error, "Feature error f (-) f* (M,). Read-only view.")
      .def_readonly("error_norm", &ServoOutput::error_norm, "Euclidean norm of error.")
      .def_readonly("jacobian", &ServoOutput::jacobian, "Interaction matrix used (M, 6). Read-only view.")
      .def_property_readonly("sigma_min", &ServoOutput::sigma_min,
                             "Smallest singular value of jacobian; NaN if not computed (diagnostics=False, or a refused\n"
                             "input). Computed when first read (exact eigenvalues of J^T J, ~0.5 us; relative error\n"
                             "~eps cond(J)^2) unless the step had it anyway (exact_diagnostics, QR + SVD route).")
      .def_property_readonly("sigma_max", &ServoOutput::sigma_max,
                             "Largest singular value of jacobian (to rounding); NaN if not computed. Computed when read.")
      .def_property_readonly("condition", &ServoOutput::condition,
                             "sigma_max / sigma_min (inf when sigma_min = 0; NaN if not computed).")
      .def_readonly("polar_fallbacks", &ServoOutput::polar_fallbacks,
                    "Polar blocks computed as Cartesian this step (point within polar_min_radius of the centre).")
      .def_readonly("gain", &ServoOutput::gain, "The gain applied this step (constant, or adaptive gain of error_norm).")
      .def_readonly("saturated", &ServoOutput::saturated, "True when the twist was scaled down to the speed limits.")
      .def_readonly("saturation_scale", &ServoOutput::saturation_scale,
                    "The uniform factor in (0, 1] applied to the twist (1 when not saturated).")
      .def_readonly("lost_points", &ServoOutput::lost_points, "Points marked invalid this step (update(valid=...)).")
      .def_readonly("law_switched", &ServoOutput::law_switched,
                    "The continuous law (decay_rate > 0) started a transition this step: start, reset, a change of\n"
                    "law, of the Cartesian / polar choices or of the valid points.")
      .def_readonly("acceleration_limited", &ServoOutput::acceleration_limited,
                    "The change of twist was scaled down to the acceleration limits this step.")
      .def_readonly("pixel_error", &ServoOutput::pixel_error,
                    "update_pixels: largest distance (pixels) between a point and its desired point; NaN after update.")
      .def("__repr__", [](const ServoOutput& o) {
        return "ServoResult(status=" + std::string(py::str(py::cast(o.status))) +
               ", error_norm=" + number(o.error_norm) + ", sigma_min=" + number(o.sigma_min()) + ")";
      });

  py::implicitly_convertible<Layout, Task>();  // a Layout is a Task of points (bind_task.cpp)

  py::class_<PyServo>(m, "Servo", R"(The IBVS control law v = -gain * J+ (f (-) f*) for a Layout or a Task.

Servo(layout, gain, damping=0.0, jacobian="current", polar_min_radius=1e-3, diagnostics=True,
      max_linear_speed=inf, max_angular_speed=inf, camera=None, angle_wrap="consistent",
      exact_diagnostics=False)
  gain      gamma in (0, 1e250] (1/s), or an AdaptiveGain (gain as a function of the error norm)
  damping   lambda >= 0: 0 = Moore-Penrose, > 0 = damped least squares; the twist equals
            -gain * damped_pinv(jacobian, damping) @ error (to ~1e-10 relative) either way
  jacobian  "current" J(f, z), "desired" J(f*, z*) or "mean" of the two
  diagnostics  Status.singular every step (exact, from the full-rank test of the solve,
            nearly free) and ServoResult.sigma_min / sigma_max / condition, computed when
            read; False: NaN, never singular
  exact_diagnostics  compute sigma_min / sigma_max every step by QR + SVD (~4 us)
  max_linear_speed, max_angular_speed  > 0 (m/s, rad/s): the whole twist is scaled by one
            factor so that |T| and |w| stay within them (direction kept); inf = no limit
  camera    an ibvs.CameraModel for update_pixels (pixels in, twist out), or None
  angle_wrap  "consistent" (default): the theta differences of one frame (and the feature blocks'
            angles about the axis, Feature.axis_angle_rows) are wrapped as one
            rotation about their circular mean (see feature_error), the mean kept on the
            previous frame's side of the half-turn while within pi + pi/4 of 0 (reset()
            forgets it); "per_point": eq. (13) point by point, no memory
  decay_rate  mu >= 0 (1/s): the continuous law of Mansard & Chaumette 2007 (eq. 17),
            v = v_law(t) + (v(t_s-) - v_law(t_s)) exp(-mu (t - t_s)), from the first update
            (from rest), reset(twist) and every change of law, of the Cartesian / polar choices
            or of the valid points; 0 = off (docs/control-law.md)
  max_linear_acceleration, max_angular_acceleration  > 0 (m/s^2, rad/s^2): the change of twist
            per period scaled by one factor (its direction kept); inf = no limit
  period    the control period (s, > 0) the above and stop_time need; ibvs.sim.run uses 1/fps
  cartesian_near_goal  > 0 (normalised units): every polar block is Cartesian while every
            valid point lies within this distance of its goal (polar again beyond 1.5 times it)
  stop_time  >= 0 (s): with too few valid points the twist ramps to zero over this time)")
      .def(py::init([](const Task& layout, py::handle gain, py::handle damping, const std::string& jac,
                       py::handle polar_min_radius, py::handle diagnostics, py::handle max_linear_speed,
                       py::handle max_angular_speed, py::handle camera, py::handle angle_wrap,
                       py::handle exact_diagnostics, py::handle decay_rate, py::handle max_linear_acceleration,
                       py::handle max_angular_acceleration, py::handle period, py::handle cartesian_near_goal,
                       py::handle stop_time) {
             ServoOptions o;
             o.angle_wrap = angle_wrap_arg(angle_wrap);
             set_gain(o, gain);
             o.damping = real(damping, "damping");
             o.jacobian = interaction(jac);
             o.polar_min_radius = real(polar_min_radius, "polar_min_radius");
             o.diagnostics = boolean(diagnostics, "diagnostics");
             o.exact_diagnostics = boolean(exact_diagnostics, "exact_diagnostics");
             o.max_linear_speed = real(max_linear_speed, "max_linear_speed");
             o.max_angular_speed = real(max_angular_speed, "max_angular_speed");
             o.smoothing.decay_rate = real(decay_rate, "decay_rate");
             o.smoothing.max_linear_acceleration = real(max_linear_acceleration, "max_linear_acceleration");
             o.smoothing.max_angular_acceleration = real(max_angular_acceleration, "max_angular_acceleration");
             o.smoothing.period = real(period, "period");
             o.cartesian_near_goal = real(cartesian_near_goal, "cartesian_near_goal");
             o.stop_time = real(stop_time, "stop_time");
             PyServo s(layout, o);
             py_servo::set_camera(s.servo, camera);
             return s;
           }),
           py::arg("layout"), py::arg("gain"), py::arg("damping") = 0.0, py::arg("jacobian") = "current",
           py::arg("polar_min_radius") = default_polar_min_radius, py::arg("diagnostics") = true,
           py::arg("max_linear_speed") = no_limit, py::arg("max_angular_speed") = no_limit,
           py::arg("camera") = py::none(), py::arg("angle_wrap") = "consistent", py::arg("exact_diagnostics") = false,
           py::arg("decay_rate") = 0.0, py::arg("max_linear_acceleration") = no_limit,
           py::arg("max_angular_acceleration") = no_limit, py::arg("period") = 0.0,
           py::arg("cartesian_near_goal") = 0.0, py::arg("stop_time") = 0.0)
      .def_static(
          "automatic_hybrid",
          [](py::handle n, py::handle gain, py::handle switch_radius, py::handle damping, const std::string& jac,
             py::handle diagnostics, py::handle max_linear_speed, py::handle max_angular_speed, py::handle camera,
             py::handle angle_wrap) {
            ServoOptions o;
            o.angle_wrap = angle_wrap_arg(angle_wrap);
            set_gain(o, gain);
            o.damping = real(damping, "damping");
            o.jacobian = interaction(jac);
            o.diagnostics = boolean(diagnostics, "diagnostics");
            o.max_linear_speed = real(max_linear_speed, "max_linear_speed");
            o.max_angular_speed = real(max_angular_speed, "max_angular_speed");
            const double r = real(switch_radius, "switch_radius");
            check_switch_radius(r);
            o.polar_min_radius = r;
            const int n_points = int_in(n, "n_points", 1, max_points);
            PyServo s(Layout::polar(n_points), o);
            py_servo::set_camera(s.servo, camera);
            return s;
          },
          py::arg("n_points"), py::arg("gain"), py::arg("switch_radius") = default_switch_radius,
          py::arg("damping") = 0.0, py::arg("jacobian") = "current", py::arg("diagnostics") = true,
          py::arg("max_linear_speed") = no_limit, py::arg("max_angular_speed") = no_limit,
          py::arg("camera") = py::none(), py::arg("angle_wrap") = "consistent",
          R"(Automatic hybrid: each point polar while it and its desired point lie at least switch_radius
(normalised units) from the principal point, Cartesian otherwise, re-decided every step. It is
Servo(Layout.polar(n_points), gain, polar_min_radius=switch_radius, ...); ServoResult.polar_fallbacks
counts the points computed as Cartesian.)")
      .def("update", &PyServo::update, py::arg("uv"), py::arg("depth"), py::arg("uv_desired"),
           py::arg("depth_desired") = py::none(), py::arg("measurements") = py::none(),
           py::arg("measurements_desired") = py::none(), py::arg("valid") = py::none(),
           R"(One control step.

uv, uv_desired (N, 2): current and desired points, normalised coordinates, |u|, |v| <= 10
(larger values look like pixels: ibvs.CameraModel.normalize converts them).
depth, depth_desired: metres, in [1e-6, 1e6], scalar or (N,); depth_desired is needed for
jacobian="desired" or "mean" (and must hold N depths whenever given).
measurements, measurements_desired: a Task's feature blocks (None for points only): one array per
block (its kind's measurement) or all of them concatenated (Task.measurement_size values).
valid: None (every point measured) or N bools, False for a point a tracker lost: its uv and depth
are not read (NaN allowed), its rows are left out; with too few valid points (2 x valid < the
task's DOF) the status is Status.features_lost and the twist ramps to zero over stop_time.
Returns a ServoResult (a snapshot: see its docstring). Bad input raises ValueError/TypeError.)")
      .def("update_pixels", &PyServo::update_pixels, py::arg("pixels"), py::arg("depth"), py::arg("pixels_desired"),
           py::arg("depth_desired") = py::none(),
           R"(One control step from pixels, with the servo's camera model (Servo(..., camera=...)).

pixels, pixels_desired: (N, 2) or OpenCV's (N, 1, 2), as the sensor measures them (distorted);
normalised by camera.normalize, then as update(). The result's pixel_error is the largest distance
(pixels) between a point and its desired point: compare a tolerance in pixels with it.)")
      .def_property_readonly(
          "camera", [](const PyServo& s) -> py::object { return s.servo.camera() ? py::cast(*s.servo.camera()) : py::none(); },
          "The CameraModel used by update_pixels (None if not given).")
      .def_property_readonly("layout", [](const PyServo& s) { return s.servo.layout(); })
      .def_property_readonly("task", [](const PyServo& s) { return s.servo.task(); })
      .def_property(
          "gain", [](const PyServo& s) { return gain_of(s.servo.options()); },
          [](PyServo& s, py::handle g) {
            ServoOptions o = s.servo.options();
            set_gain(o, g);
            s.servo.set_options(o);
          },
          "The constant gain (float) or the AdaptiveGain.")
      .def_property(
          "max_linear_speed", [](const PyServo& s) { return s.servo.options().max_linear_speed; },
          [](PyServo& s, py::handle x) {
            ServoOptions o = s.servo.options();
            o.max_linear_speed = real(x, "max_linear_speed");
            s.servo.set_options(o);
          },
          "Limit on |T| (m/s), inf = none.")
      .def_property(
          "max_angular_speed", [](const PyServo& s) { return s.servo.options().max_angular_speed; },
          [](PyServo& s, py::handle x) {
            ServoOptions o = s.servo.options();
            o.max_angular_speed = real(x, "max_angular_speed");
            s.servo.set_options(o);
          },
          "Limit on |w| (rad/s), inf = none.")
      .def_property(
          "damping", [](const PyServo& s) { return s.servo.options().damping; },
          [](PyServo& s, py::handle d) {
            ServoOptions o = s.servo.options();
            o.damping = real(d, "damping");
            s.servo.set_options(o);
          })
      .def_property(
          "angle_wrap", [](const PyServo& s) { return angle_wrap_name(s.servo.options().angle_wrap); },
          [](PyServo& s, py::handle w) {
            ServoOptions o = s.servo.options();
            o.angle_wrap = angle_wrap_arg(w);
            s.servo.set_options(o);
          },
          "'consistent' or 'per_point' (see the class doc); setting it also forgets the previous frame.")
      .def(
          "reset",
          [](PyServo& s, py::handle twist) {
            Twist v = Twist::Zero();
            if (!twist.is_none()) {
              const CArray a = as_array(twist, "twist");
              const auto x = vector(a, "twist");
              if (x.size() != 6 || !x.allFinite()) throw py::value_error("twist must be 6 finite numbers");
              v = x;
            }
            s.servo.reset(v);
          },
          py::arg("twist") = py::none(),
          "Forget the previous frame's angle-wrap branch (call it when a new servoing task starts); with\n"
          "decay_rate > 0 the next update starts from `twist` (the camera's current twist; None: at rest).")
      .def(
          "continue_turn", [](PyServo& s, double centre) { s.servo.continue_turn(centre); }, py::arg("centre"),
          "Choose the consistent angle wrap's branch for the next frame, as if the previous frame's mean polar\n"
          "angle error (theta - theta*, radians) had been `centre`: at a half-turn about the optical axis,\n"
          "+pi or -pi chooses the way the camera turns instead of the image noise. NaN forgets it (as reset()\n"
          "and a change of angle_wrap do; ibvs.sim.run resets the servo: use its turn). ValueError unless NaN or\n"
          "|centre| <= pi + pi/4.")
      .def_property_readonly("decay_rate", [](const PyServo& s) { return s.servo.options().smoothing.decay_rate; })
      .def_property_readonly("max_linear_acceleration",
                             [](const PyServo& s) { return s.servo.options().smoothing.max_linear_acceleration; })
      .def_property_readonly("max_angular_acceleration",
                             [](const PyServo& s) { return s.servo.options().smoothing.max_angular_acceleration; })
      .def_property_readonly("period", [](const PyServo& s) { return s.servo.options().smoothing.period; })
      .def_property_readonly("cartesian_near_goal", [](const PyServo& s) { return s.servo.options().cartesian_near_goal; })
      .def_property_readonly("stop_time", [](const PyServo& s) { return s.servo.options().stop_time; })
      .def_property_readonly("jacobian_mode", [](const PyServo& s) { return interaction_name(s.servo.options().jacobian); })
      .def_property_readonly("polar_min_radius", [](const PyServo& s) { return s.servo.options().polar_min_radius; })
      .def("__repr__", [](const PyServo& s) {
        const auto& o = s.servo.options();
        const std::string what = s.servo.task().points_only() ? layout_repr(s.servo.layout())
                                                               : "Task(" + s.servo.task().describe() + ")";
        return "Servo(" + what + ", gain=" + std::string(py::repr(gain_of(o))) +
               ", damping=" + float_repr(o.damping) + ", jacobian='" + interaction_name(o.jacobian) +
               "', angle_wrap='" + angle_wrap_name(o.angle_wrap) + "')";
      });
}
