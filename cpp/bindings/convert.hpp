// numpy <-> Eigen argument conversion for the bindings. Each helper names the
// argument in its error: TypeError for what is not an array of numbers,
// ValueError for a wrong shape. Values are checked by the C++ validate path.
#pragma once

#include "ibvs/layout.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

namespace ibvs::py_convert {

namespace py = pybind11;
using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

inline std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

/// Any array-like of real numbers as a C-ordered float64 array (no copy when it already is one).
inline CArray as_array(py::handle obj, const char* name) {
  if (!obj.is_none() && !py::isinstance<py::str>(obj) && !py::isinstance<py::bytes>(obj)) {
    if (CArray a = CArray::ensure(obj)) return a;
  }
  throw py::type_error(std::string(name) + " must be an array of real numbers, got " +
                       std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
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

/// Depth: a scalar for every point, or an (n,) vector; written into `out` (size n).
inline void depths(py::handle obj, const char* name, Eigen::Index n, Eigen::VectorXd& out) {
  if (py::isinstance<py::float_>(obj) || py::isinstance<py::int_>(obj)) {
    out.setConstant(n, obj.cast<double>());
    return;
  }
  const CArray a = as_array(obj, name);
  if (a.ndim() == 0) {
    out.setConstant(n, *a.data());
    return;
  }
  out = vector(a, name);
}

}  // namespace ibvs::py_convert
