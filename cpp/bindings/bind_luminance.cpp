// ibvs.LuminanceServo and ibvs.photometric_moments: features/luminance.hpp.
#include "convert.hpp"

#include "ibvs/features/luminance.hpp"

#include <memory>
#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace {

using U8Array = py::array_t<std::uint8_t, py::array::c_style>;

/// A grey image: a 2-D numpy array, uint8 as is (no copy when C-ordered), any other real dtype as float64.
struct ImageArg {
  U8Array u8;
  CArray f64;
  bool is_u8 = false;
  Eigen::Map<const ImageU8> as_u8() const {
    return {u8.data(), static_cast<Eigen::Index>(u8.shape(0)), static_cast<Eigen::Index>(u8.shape(1))};
  }
  Eigen::Map<const ImageF64> as_f64() const {
    return {f64.data(), static_cast<Eigen::Index>(f64.shape(0)), static_cast<Eigen::Index>(f64.shape(1))};
  }
};

ImageArg image_arg(py::handle obj, const char* name) {
  ImageArg a;
  bool u8 = false;
  if (py::isinstance<py::array>(obj)) {
    const py::dtype d = py::reinterpret_borrow<py::array>(obj).dtype();
    u8 = d.kind() == 'u' && d.itemsize() == 1;
  }
  if (u8) {
    a.u8 = U8Array::ensure(obj);
    a.is_u8 = true;
    if (a.u8.ndim() != 2)
      throw py::value_error(std::string(name) + " must be a 2-D grey image (rows, columns), got shape " +
                            shape_of(a.u8));
  } else {
    a.f64 = as_array(obj, name);
    if (a.f64.ndim() != 2)
      throw py::value_error(std::string(name) + " must be a 2-D grey image (rows, columns), got shape " +
                            shape_of(a.f64));
  }
  return a;
}

InteractionMatrix jacobian_arg(const std::string& s) {
  if (s == "current") return InteractionMatrix::current;
  if (s == "desired") return InteractionMatrix::desired;
  if (s == "mean") return InteractionMatrix::mean;
  throw py::value_error("jacobian must be 'current', 'desired' or 'mean', got '" + s + "'");
}

LuminanceLaw law_arg(const std::string& s) {
  if (s == "levenberg_marquardt") return LuminanceLaw::levenberg_marquardt;
  if (s == "gauss_newton") return LuminanceLaw::gauss_newton;
  throw py::value_error("law must be 'levenberg_marquardt' or 'gauss_newton', got '" + s + "'");
}

const char* jacobian_name(InteractionMatrix j) {
  return j == InteractionMatrix::desired ? "desired" : j == InteractionMatrix::mean ? "mean" : "current";
}

}  // namespace

void bind_luminance(py::module_& m) {
  py::class_<LuminanceOutput, std::shared_ptr<LuminanceOutput>>(m, "LuminanceResult",
                                                                R"(Result of one LuminanceServo.update().)")
      .def_property_readonly(
          "twist", [](const LuminanceOutput& o) { return py::array_t<double>(6, o.twist.data()); },
          "Camera twist (vx, vy, vz, wx, wy, wz), (6,); zeros unless status is 'ok'.")
      .def_property_readonly(
          "status", [](const LuminanceOutput& o) { return std::string(to_string(o.status)); },
          "'ok', 'textureless' or 'saturated' (H singular: zero twist), 'invalid_input'.")
      .def_property_readonly(
          "ok", [](const LuminanceOutput& o) { return o.status == LuminanceStatus::ok; }, "status == 'ok'.")
      .def_property_readonly(
          "error_rms", [](const LuminanceOutput& o) { return o.error_rms; },
          "sqrt(|I - I*|^2 / N) over the grid, intensity units.")
      .def_property_readonly(
          "pixels", [](const LuminanceOutput& o) { return o.pixels; }, "N, the grid's pixels.")
      .def("__repr__", [](const LuminanceOutput& o) {
        return "LuminanceResult(status='" + std::string(to_string(o.status)) + "', error_rms=" +
               float_repr(o.error_rms) + ")";
      });

  py::class_<LuminanceServo>(m, "LuminanceServo", R"(Photometric visual servoing (Collewet & Marchand, IEEE T-RO 2011).

The feature is the image itself: the intensities of every pixel but a border. Its interaction
matrix per pixel is L_I = -(I_x L_x + I_y L_y) with the gradient (I_x, I_y) from ViSP's 7-tap
derivative filter, converted to normalised coordinates by the focal lengths, and the depth
1/Z = A x + B y + C (plane) of a planar scene. Law: v = -gain (H + mu diag H)^-1 L_I^T (I - I*),
H = L_I^T L_I ("levenberg_marquardt") or v = -gain H^-1 L_I^T (I - I*) ("gauss_newton"), with L_I
at the desired image (computed once by set_desired), the current one or their mean (jacobian).

Images: 2-D arrays (rows = height, columns = width), uint8 (no copy) or any real dtype (as float64,
finite, within +-1e6). camera: a pinhole CameraModel without distortion. See docs/photometric.md.)")
      .def(py::init([](const CameraModel& camera, py::handle width, py::handle height, py::handle border,
                       py::handle smoothing, const std::string& jacobian, const std::string& law, py::handle gain,
                       py::handle mu, py::handle plane, py::handle min_conditioning) {
             LuminanceOptions o;
             o.border = int_in(border, "border", 0, 100000);
             o.smoothing = real(smoothing, "smoothing");
             o.jacobian = jacobian_arg(jacobian);
             o.law = law_arg(law);
             o.gain = real(gain, "gain");
             o.mu = real(mu, "mu");
             const CArray p = as_array(plane, "plane");
             if (p.size() != 3) throw py::value_error("plane must be (A, B, C) of 1/Z = A x + B y + C");
             o.plane_a = p.data()[0], o.plane_b = p.data()[1], o.plane_c = p.data()[2];
             o.min_conditioning = real(min_conditioning, "min_conditioning");
             return LuminanceServo(camera, int_in(width, "width", 1, 100000), int_in(height, "height", 1, 100000), o);
           }),
           py::arg("camera"), py::arg("width"), py::arg("height"), py::arg("border") = 10,
           py::arg("smoothing") = 0.0, py::arg("jacobian") = "desired", py::arg("law") = "levenberg_marquardt",
           py::arg("gain") = 1.0, py::arg("mu") = 0.01, py::arg("plane") = std::vector<double>{0.0, 0.0, 1.0},
           py::arg("min_conditioning") = 1e-9)
      .def(
          "set_desired",
          [](LuminanceServo& s, py::handle image) {
            const ImageArg a = image_arg(image, "image");
            if (a.is_u8)
              s.set_desired(a.as_u8());
            else
              s.set_desired(a.as_f64());
          },
          py::arg("image"), "The goal image (ValueError for a wrong size, a non-finite pixel or too little texture).")
      .def(
          "update",
          [](LuminanceServo& s, py::handle image) {
            const ImageArg a = image_arg(image, "image");
            if (!s.has_desired()) throw py::value_error("LuminanceServo.update: set_desired(image) first");
            auto out = std::make_shared<LuminanceOutput>();
            if (a.is_u8) {
              const auto im = a.as_u8();
              s.validate(im, "image");
              py::gil_scoped_release release;
              s.update(im, *out);
            } else {
              const auto im = a.as_f64();
              s.validate(im, "image");
              py::gil_scoped_release release;
              s.update(im, *out);
            }
            return out;
          },
          py::arg("image"), "One control step on the current image: a LuminanceResult (ValueError for a bad image).")
      .def(
          "interaction",
          [](const LuminanceServo& s, py::handle image) {
            const ImageArg a = image_arg(image, "image");
            if (a.is_u8) return MatrixX6(s.interaction(a.as_u8().cast<double>()));
            return s.interaction(a.as_f64());
          },
          py::arg("image"), "L_I over the grid (N, 6) of an image, grid rows in order (double precision).")
      .def(
          "intensities",
          [](const LuminanceServo& s, py::handle image) {
            const ImageArg a = image_arg(image, "image");
            if (a.is_u8) return Eigen::VectorXd(s.intensities(a.as_u8().cast<double>()));
            return s.intensities(a.as_f64());
          },
          py::arg("image"), "The feature s (N,) of an image: its (smoothed) intensities over the grid.")
      .def_property_readonly("width", &LuminanceServo::width, "Image width, pixels (columns).")
      .def_property_readonly("height", &LuminanceServo::height, "Image height, pixels (rows).")
      .def_property_readonly("pixels", &LuminanceServo::pixels, "N, the grid's pixels.")
      .def(
          "set_mu", [](LuminanceServo& s, py::handle mu) { s.set_mu(real(mu, "mu")); }, py::arg("mu"),
          "Changes the Levenberg-Marquardt mu (in [0, 1e6]), e.g. to 0 (Gauss-Newton) once near the goal.")
      .def_property_readonly(
          "mu", [](const LuminanceServo& s) { return s.options().mu; }, "The Levenberg-Marquardt mu.")
      .def_property_readonly("has_desired", &LuminanceServo::has_desired, "Whether set_desired() was called.")
      .def_property_readonly(
          "border", [](const LuminanceServo& s) { return s.options().border; }, "Pixels left out on each side.")
      .def_property_readonly(
          "jacobian", [](const LuminanceServo& s) { return jacobian_name(s.options().jacobian); },
          "Where L_I is evaluated: \"desired\", \"current\" or \"mean\".")
      .def_property_readonly(
          "law",
          [](const LuminanceServo& s) {
            return s.options().law == LuminanceLaw::levenberg_marquardt ? "levenberg_marquardt" : "gauss_newton";
          },
          "\"levenberg_marquardt\" or \"gauss_newton\".")
      .def("__repr__", &LuminanceServo::describe);

  m.def(
      "photometric_moments",
      [](const CameraModel& camera, py::handle image) {
        const ImageArg a = image_arg(image, "image");
        const Moments mo = a.is_u8 ? photometric_moments(camera, a.as_u8()) : photometric_moments(camera, a.as_f64());
        return py::array_t<double>(15, mo.data());
      },
      py::arg("camera"), py::arg("image"),
      R"(Moments m00..m04 (15,) of an intensity image in normalised coordinates (Bakthavatchalam et al. 2018).

m_pq = sum of x^p y^q I(u, v) / (p_x p_y) over the pixels, x = (u - u0) / p_x, y = (v - v0) / p_y. For a
planar Lambertian object seen whole on a zero-intensity background, MomentsFeature(source="region")
gives their interaction matrix: use MomentsFeature.measure(photometric_moments(camera, image), plane).)");
}
