// Bindings of ibvs::CameraModel (ibvs.CameraModel, also ibvs.sim.Camera).
// Argument conversion only; the model is cpp/src/camera_model.cpp, the
// calibration-file reader python/ibvs/camera_files.py.
#include "convert.hpp"
#include "ibvs/camera_model.hpp"
#include "py_servo.hpp"

#include <pybind11/operators.h>
#include <pybind11/stl.h>

#include <cmath>
#include <string>
#include <type_traits>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace {

// (N, 2), OpenCV's (N, 1, 2) or one point (2,): the 2 x N view and the shape to give back.
struct PointArgs {
  CArray a;
  Eigen::Map<const Points> p;
};

PointArgs point_args(py::handle obj, const char* name) {
  CArray a = as_array(obj, name);
  const bool one = a.ndim() == 1 && a.shape(0) == 2;
  if (!one && !((a.ndim() == 2 && a.shape(1) == 2) || (a.ndim() == 3 && a.shape(1) == 1 && a.shape(2) == 2)))
    throw py::value_error(std::string(name) + " must have shape (N, 2), (N, 1, 2) or (2,), got " + shape_of(a));
  const Eigen::Index n = one ? 1 : static_cast<Eigen::Index>(a.shape(0));
  return {a, Eigen::Map<const Points>(a.data(), 2, n)};
}

// (N, 3) or one bearing (3,): the 3 x N view.
struct BearingArgs {
  CArray a;
  Eigen::Map<const Bearings> b;
};

BearingArgs bearing_args(py::handle obj, const char* name) {
  CArray a = as_array(obj, name);
  const bool one = a.ndim() == 1 && a.shape(0) == 3;
  if (!one && !(a.ndim() == 2 && a.shape(1) == 3))
    throw py::value_error(std::string(name) + " must have shape (N, 3) or (3,), got " + shape_of(a));
  const Eigen::Index n = one ? 1 : static_cast<Eigen::Index>(a.shape(0));
  return {a, Eigen::Map<const Bearings>(a.data(), 3, n)};
}

void check_invalid(const std::string& invalid) {
  if (invalid != "raise" && invalid != "nan")
    throw py::value_error("invalid must be 'raise' or 'nan', got '" + invalid + "'");
}

// Pixels -> bearings: (N, 2) / (N, 1, 2) -> (N, 3), (2,) -> (3,); the throwing path names the first refused pixel.
py::array_t<double> to_bearings(const CameraModel& c, py::handle obj, const std::string& invalid) {
  check_invalid(invalid);
  const PointArgs in = point_args(obj, "pixels");
  py::array_t<double> out = in.a.ndim() == 1 ? py::array_t<double>(3) : py::array_t<double>({in.p.cols(), Eigen::Index(3)});
  Eigen::Map<Bearings> o(out.mutable_data(), 3, in.p.cols());
  if (c.to_bearing(in.p, o) > 0 && invalid == "raise") {
    try {  // the throwing path names the first refused pixel
      c.validate_pixels(in.p, "pixels");
    } catch (const std::invalid_argument& e) {
      throw py::value_error(std::string(e.what()).substr(6));  // without the "ibvs: " prefix, as the other messages
    }
  }
  return out;
}

py::array_t<double> from_bearings(const CameraModel& c, py::handle obj, const std::string& invalid) {
  check_invalid(invalid);
  const BearingArgs in = bearing_args(obj, "bearings");
  py::array_t<double> out = in.a.ndim() == 1 ? py::array_t<double>(2) : py::array_t<double>({in.b.cols(), Eigen::Index(2)});
  Eigen::Map<Points> o(out.mutable_data(), 2, in.b.cols());
  if (c.from_bearing(in.b, o) > 0 && invalid == "raise") {
    try {
      c.validate_bearings(in.b, "bearings");
    } catch (const std::invalid_argument& e) {
      throw py::value_error(std::string(e.what()).substr(6));
    }
  }
  return out;
}

std::string pair(double a, double b) {
  return "(" + float_repr(a) + ", " + float_repr(b) + ")";
}

// Maps every point with the batched f (project or normalize); a point f refuses (NaN) raises a
// ValueError naming it, or stays NaN with invalid="nan".
template <class F>
py::array_t<double> map_points(py::handle obj, const char* name, const std::string& invalid, F f,
                               const std::string& why) {
  if (invalid != "raise" && invalid != "nan")
    throw py::value_error("invalid must be 'raise' or 'nan', got '" + invalid + "'");
  const PointArgs in = point_args(obj, name);
  py::array_t<double> out(std::vector<py::ssize_t>(in.a.shape(), in.a.shape() + in.a.ndim()));
  Eigen::Map<Points> o(out.mutable_data(), 2, in.p.cols());
  if (f(in.p, o) == 0 || invalid == "nan") return out;
  for (Eigen::Index i = 0; i < in.p.cols(); ++i) {
    if (!std::isnan(o(0, i))) continue;
    const double x = in.p(0, i), y = in.p(1, i);
    const std::string which = in.a.ndim() == 1 ? std::string(name) : std::string(name) + "[" + std::to_string(i) + "]";
    if (!std::isfinite(x) || !std::isfinite(y)) throw py::value_error(which + " is not finite");
    throw py::value_error(which + " = " + pair(x, y) + why);
  }
  return out;
}

py::object mask(const CameraModel& c, py::handle obj) {
  const PointArgs in = point_args(obj, "pixels");
  py::array_t<bool> out(in.p.cols());
  for (Eigen::Index i = 0; i < in.p.cols(); ++i) out.mutable_at(i) = c.contains(in.p(0, i), in.p(1, i));
  if (in.a.ndim() == 1) return py::bool_(out.at(0));
  return std::move(out);
}

std::string radius_note(const CameraModel& c) {
  if (!std::isfinite(c.max_radius())) return "";
  return " (the " + std::string(to_string(c.distortion())) + " model is one-to-one only within a normalised radius of " +
         std::to_string(c.max_radius()) + ", " + std::to_string(std::atan(c.max_radius()) * 180.0 / pi) +
         " degrees off-axis)";
}

Eigen::Matrix3d k_arg(py::handle obj) {
  const CArray a = as_array(obj, "K");
  if (a.ndim() != 2 || a.shape(0) != 3 || a.shape(1) != 3)
    throw py::value_error("K must have shape (3, 3), got " + shape_of(a));
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(a.data());
}

Eigen::VectorXd dist_arg(py::handle obj) {
  if (obj.is_none()) return Eigen::VectorXd(0);
  const CArray a = as_array(obj, "dist");
  // OpenCV hands out (n,), (1, n) or (n, 1): any vector shape.
  py::ssize_t big = 0;
  for (py::ssize_t i = 0; i < a.ndim(); ++i)
    if (a.shape(i) != 1) ++big;
  if (big > 1) throw py::value_error("dist must be a vector of coefficients, got shape " + shape_of(a));
  return Eigen::Map<const Eigen::VectorXd>(a.data(), a.size());
}

// Pixel arrays of update_pixels: (N, 2) or (N, 1, 2), validated by the servo's validate_pixels.
template <class PyLaw>
std::shared_ptr<ServoOutput> pixel_update(PyLaw& s, py::handle px_obj, py::handle depth_obj, py::handle pxd_obj, py::handle zd_obj) {
  const CArray a = as_array(px_obj, "pixels"), b = as_array(pxd_obj, "pixels_desired");
  const auto px = points(a, "pixels");
  const auto pxd = points(b, "pixels_desired");
  const Eigen::Index n = s.servo.layout().n_points();
  depths(depth_obj, "depth", n, s.z);
  if (zd_obj.is_none()) {
    s.zd = s.z;
  } else {
    depths(zd_obj, "depth_desired", n, s.zd);
  }
  if constexpr (std::is_same_v<PyLaw, py_servo::PyServo>) {
    if (zd_obj.is_none() && s.servo.options().jacobian != InteractionMatrix::current)
      throw py::value_error("depth_desired is required when jacobian is 'desired' or 'mean'");
    s.servo.validate_pixels(px, s.z, pxd, s.zd);
  } else {
    s.servo.validate_pixels(px, s.z, pxd);
  }
  std::shared_ptr<ServoOutput> out = s.outputs.next();  // a buffer no earlier result holds (py_servo.hpp)
  s.servo.update_pixels(px, s.z, pxd, s.zd, *out);
  return out;
}

}  // namespace

std::shared_ptr<ServoOutput> py_servo::PyServo::update_pixels(py::handle px, py::handle depth, py::handle pxd, py::handle zd) {
  return pixel_update(*this, px, depth, pxd, zd);
}

std::shared_ptr<ServoOutput> py_servo::PyPartitioned::update_pixels(py::handle px, py::handle depth, py::handle pxd, py::handle zd) {
  return pixel_update(*this, px, depth, pxd, zd);
}

namespace {
template <class Law>
void set_camera_of(Law& s, py::handle camera) {
  if (camera.is_none()) return;
  if (!py::isinstance<CameraModel>(camera))
    throw py::type_error("camera must be an ibvs.CameraModel or None, got " +
                         std::string(py::str(py::type::handle_of(camera).attr("__name__"))));
  s.set_camera(camera.cast<const CameraModel&>());
}
}  // namespace

void py_servo::set_camera(Servo& s, py::handle camera) { set_camera_of(s, camera); }
void py_servo::set_camera(PartitionedServo& s, py::handle camera) { set_camera_of(s, camera); }

namespace {
// ViSP's form with every number checked as a real (bool, complex and str refused, by name).
CameraModel from_visp_arg(py::handle px, py::handle py, py::handle u0, py::handle v0, py::handle kud, py::handle kdu,
                          py::handle width, py::handle height, py::handle fps) {
  return CameraModel::from_visp(real(px, "px"), real(py, "py"), real(u0, "u0"), real(v0, "v0"), real(kud, "kud"),
                                real(kdu, "kdu"), real(width, "width"), real(height, "height"), real(fps, "fps"));
}
}  // namespace

void bind_camera(py::module_& m) {
  py::class_<CameraModel>(m, "CameraModel", R"(Pinhole camera with lens distortion: normalised image coordinates <-> pixels.

Normalised coordinates (x, y) = (X/Z, Y/Z) of a point (X, Y, Z) in the camera frame (x right,
y down, z forward); pixels u = u0 + px xd, v = v0 + py yd with (xd, yd) the distorted normalised
coordinates. Distortion models: "none"; "visp" (ViSP's kud for project, kdu for normalize);
"plumb_bob" (OpenCV / ROS k1, k2, p1, p2, k3); "equidistant" (OpenCV fisheye / ROS, k1..k4).
normalize() inverts plumb_bob and equidistant by Newton's method to < 1e-9 px. Points beyond
max_radius (where the distortion stops being one-to-one) are refused.

CameraModel(px, py, u0, v0, kud=0, kdu=0, width=640, height=480, fps=60) is ViSP's form (the
simulator's camera, ibvs.sim.Camera); see also from_opencv, from_yaml, from_visp, normalized.
The sensor spans [0, width] x [0, height] pixels; fps is the frame rate (the simulator's control
period is 1 / fps).)")
      .def(py::init(&from_visp_arg), py::arg("px"), py::arg("py"), py::arg("u0"), py::arg("v0"),
           py::arg("kud") = 0.0, py::arg("kdu") = 0.0, py::arg("width") = 640.0, py::arg("height") = 480.0,
           py::arg("fps") = 60.0)
      .def_static("from_visp", &from_visp_arg, py::arg("px"), py::arg("py"), py::arg("u0"), py::arg("v0"),
                  py::arg("kud"), py::arg("kdu"), py::arg("width"), py::arg("height"), py::arg("fps") = 60.0,
                  R"(ViSP's vpCameraParameters with distortion: focal lengths px, py and principal point u0, v0
(pixels); project with kud, normalize with kdu (separate calibrations: the round trip is close,
not exact). kud = kdu = 0 gives distortion "none".)")
      .def_static(
          "from_opencv",
          [](py::handle K, py::handle dist, py::handle width, py::handle height, py::handle fisheye, py::handle fps) {
            return CameraModel::from_opencv(k_arg(K), dist_arg(dist), real(width, "width"), real(height, "height"),
                                            boolean(fisheye, "fisheye"), real(fps, "fps"));
          },
          py::arg("K"), py::arg("dist"), py::arg("width"), py::arg("height"), py::arg("fisheye") = false,
          py::arg("fps") = 60.0,
          R"(From OpenCV's camera matrix K (3, 3) = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (pixels) and
distortion coefficients dist: (k1, k2, p1, p2[, k3]) as cv2.calibrateCamera gives them
("plumb_bob"; longer OpenCV vectors are accepted when their extra terms are 0), or with
fisheye=True the 4 of cv2.fisheye (k1, k2, k3, k4, "equidistant"). None or all zeros: no
distortion. width, height: image size in pixels.)")
      .def_static(
          "from_omnidir",
          [](py::handle K, py::handle xi, py::handle D, py::handle width, py::handle height, py::handle fps) {
            const CArray d = as_array(D, "D");
            if (d.size() != 4) throw py::value_error("D must hold 4 coefficients (k1, k2, p1, p2), got " + std::to_string(d.size()));
            double x = 0.0;
            if (py::isinstance<py::array>(xi)) {  // cv2.omnidir.calibrate's (1, 1) array
              const CArray a = as_array(xi, "xi");
              if (a.size() != 1) throw py::value_error("xi must be one number, got shape " + shape_of(a));
              x = a.data()[0];
            } else {
              x = real(xi, "xi");
            }
            return CameraModel::from_omnidir(k_arg(K), x, dist_arg(D), real(width, "width"),
                                             real(height, "height"), real(fps, "fps"));
          },
          py::arg("K"), py::arg("xi"), py::arg("D"), py::arg("width"), py::arg("height"), py::arg("fps") = 60.0,
          R"(Mei's unified omnidirectional model ("omnidir"), as cv2.omnidir.calibrate returns it: K (3, 3)
without skew (K[0][1] = 0), xi >= 0 (a float or OpenCV's (1, 1) array) and D = (k1, k2, p1, p2).
A bearing b maps to (bx, by) / (bz + xi), then the radial-tangential distortion, then K (Mei &
Rives, ICRA 2007). It sees up to max_angle off the axis: acos(-xi) for xi <= 1, acos(-1/xi) for
xi > 1 (where the model folds), less where its distortion folds first.)")
      .def_static(
          "from_yaml",
          [](py::handle path, py::handle fps) {
            if (!fps.is_none()) real(fps, "fps");  // a bad type is refused before the file is read
            const py::dict d = py::module_::import("ibvs.camera_files").attr("read")(path, fps);
            if (!d["xi"].is_none())
              return CameraModel::from_omnidir(k_arg(d["K"]), real(d["xi"], "xi"), dist_arg(d["dist"]),
                                               real(d["width"], "image_width"), real(d["height"], "image_height"),
                                               real(d["fps"], "fps"));
            return CameraModel::from_opencv(k_arg(d["K"]), dist_arg(d["dist"]), real(d["width"], "image_width"),
                                            real(d["height"], "image_height"), boolean(d["fisheye"], "fisheye_model"),
                                            real(d["fps"], "fps"));
          },
          py::arg("path"), py::arg("fps") = py::none(),
          R"(From a calibration file: a ROS camera_info YAML (camera_matrix, distortion_model,
distortion_coefficients, image_width, image_height) or an OpenCV calibration file written by
cv::FileStorage (YAML, XML or JSON; camera_matrix, distortion_coefficients, image_width,
image_height, optional fisheye_model), or Mei's omnidirectional model: distortion_model "omnidir"
(or "mei", "omni") with its xi key and distortion_coefficients (k1, k2, p1, p2). Read with OpenCV's cv2.FileStorage: needs
pip install ".[vision]" from the ibvs repository root.

fps, the frame rate (the simulator's control period is 1 / fps): the fps= given, else the file's
own fps or frame_rate, else 60 with a UserWarning saying so (calibration files rarely state one).)")
      .def_static(
          "normalized", [](py::handle bounds, py::handle fps) {
            return CameraModel::normalized(real(bounds, "bounds"), real(fps, "fps"));
          },
          py::arg("bounds") = 0.3, py::arg("fps") = 60.0,
                  "Paper Table I: unit focal length (pixels = normalised coordinates), sensor +-bounds, no distortion.")
      .def_static("afma6", &CameraModel::afma6,
                  "Paper Section III-B / ViSP's Afma6 camera: 640x480, px 1090.6, py 1090.0, u0 310.1, v0 260.8, "
                  "kud -0.2114, kdu 0.2217, 60 fps.")
      .def_property_readonly("px", &CameraModel::px, "Focal length along u, pixels (OpenCV fx).")
      .def_property_readonly("py", &CameraModel::py, "Focal length along v, pixels (OpenCV fy).")
      .def_property_readonly("u0", &CameraModel::u0, "Principal point u, pixels (OpenCV cx).")
      .def_property_readonly("v0", &CameraModel::v0, "Principal point v, pixels (OpenCV cy).")
      .def_property_readonly("distortion", [](const CameraModel& c) { return to_string(c.distortion()); },
                             "'none', 'visp', 'plumb_bob', 'equidistant' or 'omnidir'.")
      .def_property_readonly(
          "coefficients",
          [](const CameraModel& c) {
            const Eigen::VectorXd k = c.coefficients();
            return py::tuple(py::cast(std::vector<double>(k.data(), k.data() + k.size())));
          },
          "The distortion coefficients: () none, (kud, kdu) visp, (k1, k2, p1, p2, k3) plumb_bob, "
          "(k1, k2, k3, k4) equidistant, (xi, k1, k2, p1, p2) omnidir.")
      .def_property_readonly("xi", &CameraModel::xi, "Mei's xi (omnidir; 0 for the other models).")
      .def_property_readonly("max_angle", &CameraModel::max_angle,
                             "Angle off the optical axis (radians, <= pi) below which to_bearing / from_bearing are "
                             "one-to-one: the lens's field of view is 2 max_angle.")
      .def_property_readonly("fold_radius", &CameraModel::fold_radius,
                             "Distorted normalised radius that max_angle images to: the image circle (px * fold_radius "
                             "pixels along u); inf when there is none.")
      .def_property_readonly("field_of_view", &CameraModel::field_of_view,
                             "Full angle (radians) the sensor sees: twice the largest angle off the axis of its border's "
                             "pixels, or 2 max_angle when the image circle lies inside the sensor.")
      .def_property_readonly("K", &CameraModel::K, "OpenCV's camera matrix (3, 3) [[px, 0, u0], [0, py, v0], [0, 0, 1]].")
      .def_property_readonly("width", &CameraModel::width, "u_max - u_min, pixels.")
      .def_property_readonly("height", &CameraModel::height, "v_max - v_min, pixels.")
      .def_property_readonly(
          "bounds", [](const CameraModel& c) { return py::make_tuple(c.u_min(), c.u_max(), c.v_min(), c.v_max()); },
          "(u_min, u_max, v_min, v_max), pixels (normalised units for CameraModel.normalized).")
      .def_property_readonly("fps", &CameraModel::fps, "Frames per second.")
      .def_property_readonly("max_radius", &CameraModel::max_radius,
                             "Normalised radius |(x, y)| up to which the distortion is one-to-one (inf: everywhere).")
      .def(
          "project",
          [](const CameraModel& c, py::handle uv, const std::string& invalid) {
            return map_points(
                uv, "uv", invalid, [&](const Eigen::Ref<const Points>& a, Eigen::Ref<Points> b) { return c.project(a, b); },
                " lies beyond the radius where the distortion stops being one-to-one" + radius_note(c));
          },
          py::arg("uv"), py::arg("invalid") = "raise",
          R"(Normalised points -> pixels (distorted). uv: (N, 2), (N, 1, 2) or (2,); the result has its shape.
A point at or beyond max_radius raises ValueError naming it, or becomes NaN with invalid="nan".)")
      .def(
          "normalize",
          [](const CameraModel& c, py::handle pixels, const std::string& invalid) {
            return map_points(
                pixels, "pixels", invalid,
                [&](const Eigen::Ref<const Points>& a, Eigen::Ref<Points> b) { return c.normalize(a, b); },
                " has no inverse in this camera model" + radius_note(c));
          },
          py::arg("pixels"), py::arg("invalid") = "raise",
          R"(Pixels -> normalised points (undistorted): (N, 2), (N, 1, 2) or (2,); the result has its shape.
A pixel without an inverse (beyond the image of max_radius) raises ValueError naming it, or becomes
NaN with invalid="nan".)")
      .def("to_bearing", &to_bearings, py::arg("pixels"), py::arg("invalid") = "raise",
           R"(Pixels -> unit bearing vectors b = P / |P| of the rays imaged there: (N, 2) or (N, 1, 2) -> (N, 3),
(2,) -> (3,). The whole field of view (beyond 90 degrees off the axis for the equidistant and
omnidir models). A pixel beyond the image circle (fold_radius) raises ValueError naming it, or
becomes NaN with invalid="nan".)")
      .def("from_bearing", &from_bearings, py::arg("bearings"), py::arg("invalid") = "raise",
           R"(Directions (any finite, non-zero length) -> pixels: (N, 3) -> (N, 2), (3,) -> (2,). A zero or
non-finite vector, or one at or beyond max_angle off the axis, raises ValueError naming it, or
becomes NaN with invalid="nan".)")
      .def("contains", &mask, py::arg("pixels"),
           "Whether each pixel lies inside the sensor bounds (inclusive): bool (N,), or a bool for one point (2,).")
      .def(
          "to_opencv",
          [](const CameraModel& c) -> py::tuple {
            if (c.distortion() == Distortion::omnidir) return py::make_tuple(c.K(), c.xi(), c.opencv_coefficients());
            return py::make_tuple(c.K(), c.opencv_coefficients());
          },
          R"((K, dist) for OpenCV (omnidir: (K, xi, D) for cv2.omnidir): plumb_bob its 5 coefficients, equidistant its 4 (use cv2.fisheye),
none 5 zeros; visp (kud, 0, 0, 0, 0), which is exact for project() (OpenCV's undistortion then
inverts kud exactly, where normalize() applies ViSP's separately calibrated kdu).)")
      .def(py::self == py::self)
      .def("__repr__", &CameraModel::describe)
      // Pickling (process pools, Dask): every field, re-validated on load.
      .def(py::pickle(
          [](const CameraModel& c) {
            const Eigen::VectorXd k = c.coefficients();
            return py::make_tuple(c.px(), c.py(), c.u0(), c.v0(), to_string(c.distortion()),
                                  std::vector<double>(k.data(), k.data() + k.size()), c.u_min(), c.u_max(), c.v_min(),
                                  c.v_max(), c.fps());
          },
          [](const py::tuple& t) {
            if (t.size() != 11) throw py::value_error("CameraModel: bad pickle state");
            const std::string d = t[4].cast<std::string>();
            const Distortion dist = d == "visp"          ? Distortion::visp
                                    : d == "plumb_bob"   ? Distortion::plumb_bob
                                    : d == "equidistant" ? Distortion::equidistant
                                    : d == "omnidir"     ? Distortion::omnidir
                                                         : Distortion::none;
            const std::vector<double> k = t[5].cast<std::vector<double>>();
            return CameraModel::make(t[0].cast<double>(), t[1].cast<double>(), t[2].cast<double>(), t[3].cast<double>(),
                                     dist, Eigen::Map<const Eigen::VectorXd>(k.data(), static_cast<Eigen::Index>(k.size())),
                                     t[6].cast<double>(), t[7].cast<double>(), t[8].cast<double>(), t[9].cast<double>(),
                                     t[10].cast<double>());
          }));
}
