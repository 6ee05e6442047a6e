// numpy <-> Eigen argument conversion for the bindings. Each helper names the
// argument in its error: TypeError for what is not an array of real numbers
// (complex, bool, strings, datetimes, objects), ValueError for a wrong shape or
// an integer out of range. Values are checked by the C++ validate path.
#pragma once

#include "ibvs/layout.hpp"
#include "ibvs/robot_mapping.hpp"
#include "ibvs/secondary_task.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <climits>
#include <string>

namespace ibvs::py_convert {

namespace py = pybind11;
using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

inline std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

inline std::string type_name(py::handle obj) { return py::str(py::type::handle_of(obj).attr("__name__")); }

[[noreturn]] inline void not_real(const char* name, const std::string& what) {
  throw py::type_error(std::string(name) + " must be an array of real numbers, got " + what);
}

/// Any array-like of real numbers (numpy dtype kind i, u or f: not bool,
/// complex, string, datetime or object) as a C-ordered float64 array. No copy
/// when it already is one; other real dtypes are converted exactly (float32,
/// integers up to 2^53), so equivalent inputs give bit-identical results.
inline CArray as_array(py::handle obj, const char* name) {
  if (obj.is_none() || py::isinstance<py::str>(obj) || py::isinstance<py::bytes>(obj) ||
      py::isinstance<py::bool_>(obj))
    not_real(name, type_name(obj));
  if (CArray::check_(obj)) return py::reinterpret_borrow<CArray>(obj);  // float64, C-ordered: as is
  py::array a;
  if (py::isinstance<py::array>(obj)) {
    a = py::reinterpret_borrow<py::array>(obj);
  } else {
    a = py::array::ensure(obj);  // dtype inferred; empty (error cleared) for what numpy cannot read
    if (!a) not_real(name, type_name(obj));
  }
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    not_real(name, "an array of dtype " + std::string(py::str(a.dtype())));
  CArray c = CArray::ensure(a);
  if (!c) {
    PyErr_Clear();
    not_real(name, type_name(obj));
  }
  return c;
}

/// (N, 2) points, or OpenCV's (N, 1, 2), as the 2 x N column-major matrix sharing the same memory.
inline Eigen::Map<const Points> points(const CArray& a, const char* name) {
  const bool opencv = a.ndim() == 3 && a.shape(1) == 1 && a.shape(2) == 2;
  if (!opencv && (a.ndim() != 2 || a.shape(1) != 2))
    throw py::value_error(std::string(name) + " must have shape (N, 2) or (N, 1, 2), got " + shape_of(a));
  return {a.data(), 2, static_cast<Eigen::Index>(a.shape(0))};
}

/// (n,) vector.
inline Eigen::Map<const Eigen::VectorXd> vector(const CArray& a, const char* name) {
  if (a.ndim() != 1) throw py::value_error(std::string(name) + " must be one-dimensional, got shape " + shape_of(a));
  return {a.data(), static_cast<Eigen::Index>(a.shape(0))};
}

/// (M, 6) matrix, copied into column-major storage.
inline MatrixX6 matrix_x6(const CArray& a, const char* name) {
  if (a.ndim() != 2 || a.shape(1) != 6)
    throw py::value_error(std::string(name) + " must have shape (M, 6), got " + shape_of(a));
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>>(a.data(), a.shape(0), 6);
}

/// A double as Python prints it (repr of a float: 1e-08, not to_string's 0.000000).
inline std::string float_repr(double x) { return py::repr(py::float_(x)); }

/// A real scalar (Python int or float, numpy real scalar or 0-d array); not
/// bool, complex or str. TypeError / ValueError naming the argument.
inline double real(py::handle obj, const char* name) {
  if (PyFloat_CheckExact(obj.ptr())) return PyFloat_AS_DOUBLE(obj.ptr());
  const CArray a = as_array(obj, name);
  if (a.ndim() != 0) throw py::type_error(std::string(name) + " must be a real number, got shape " + shape_of(a));
  return *a.data();
}

/// A bool (Python's or numpy's), nothing else: "no", 0 or None are refused rather than read as
/// true or false. TypeError naming the argument.
inline bool boolean(py::handle obj, const char* name) {
  if (obj.ptr() == Py_True || obj.ptr() == Py_False) return obj.ptr() == Py_True;
  if (type_name(obj) == "bool" || type_name(obj) == "bool_") return PyObject_IsTrue(obj.ptr()) == 1;
  throw py::type_error(std::string(name) + " must be a bool, got " + type_name(obj));
}

/// Depth: a scalar for every point, or an (n,) vector; written into `out` (size n).
inline void depths(py::handle obj, const char* name, Eigen::Index n, Eigen::VectorXd& out) {
  if (PyFloat_CheckExact(obj.ptr())) {
    out.setConstant(n, PyFloat_AS_DOUBLE(obj.ptr()));
    return;
  }
  const CArray a = as_array(obj, name);
  if (a.ndim() == 0) {
    out.setConstant(n, *a.data());
    return;
  }
  out = vector(a, name);
}

/// A Python integer (anything with __index__, not bool) within [lo, hi]:
/// TypeError / ValueError naming the argument, also for integers too large for C.
inline int int_in(py::handle obj, const std::string& name, long long lo, long long hi) {
  if (py::isinstance<py::bool_>(obj) || !py::hasattr(obj, "__index__"))
    throw py::type_error(name + " must be an int, got " + type_name(obj));
  auto i = py::reinterpret_steal<py::object>(PyNumber_Index(obj.ptr()));
  if (!i) throw py::error_already_set();
  int overflow = 0;
  const long long v = PyLong_AsLongLongAndOverflow(i.ptr(), &overflow);
  if (overflow || v < lo || v > hi)
    throw py::value_error(name + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                          std::string(py::str(i)));
  return static_cast<int>(v);
}

/// The frame of an end-effector Jacobian: "end_effector" or "base".
inline JacobianFrame frame_arg(py::handle obj) {
  if (!py::isinstance<py::str>(obj))
    throw py::type_error("frame must be 'end_effector' or 'base', got " + type_name(obj));
  const auto s = obj.cast<std::string>();
  if (s == "end_effector") return JacobianFrame::end_effector;
  if (s == "base") return JacobianFrame::base;
  throw py::value_error("frame must be 'end_effector' or 'base', got '" + s + "'");
}

inline Mounting mounting_arg(py::handle obj) {
  if (!py::isinstance<py::str>(obj))
    throw py::type_error("mounting must be 'eye_in_hand' or 'eye_to_hand', got " + type_name(obj));
  const auto s = obj.cast<std::string>();
  if (s == "eye_in_hand") return Mounting::eye_in_hand;
  if (s == "eye_to_hand") return Mounting::eye_to_hand;
  throw py::value_error("mounting must be 'eye_in_hand' or 'eye_to_hand', got '" + s + "'");
}

inline Projector projector_arg(py::handle obj) {
  if (!py::isinstance<py::str>(obj))
    throw py::type_error("projector must be 'classical' or 'large', got " + type_name(obj));
  const auto s = obj.cast<std::string>();
  if (s == "classical") return Projector::classical;
  if (s == "large") return Projector::large;
  throw py::value_error("projector must be 'classical' or 'large', got '" + s + "'");
}

/// Throws TypeError "<what> <repr of fn> does not pickle (...)", pickle's own error chained, unless fn pickles
/// (pickle's error names only the type of what it could not pickle): for the __reduce__ of objects holding
/// a Python callable (FunctionSource, FunctionFeature).
inline void require_pickles(const py::object& fn, const std::string& what, const std::string& example = "") {
  try {
    py::module_::import("pickle").attr("dumps")(fn);
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_Exception)) throw;
    py::raise_from(e, PyExc_TypeError,
                   (what + " " + py::repr(fn).cast<std::string>() +
                    " does not pickle (a lambda or a local function does not; give a module-level function or an "
                    "instance of a module-level class with __call__" + example + ")")
                       .c_str());
    throw py::error_already_set();
  }
}

}  // namespace ibvs::py_convert
