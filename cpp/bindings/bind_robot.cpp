// Bindings of the robot mapping (robot_mapping.hpp): JointMapping,
// JointMappingResult and joint_velocities(). Argument conversion only.
#include "convert.hpp"
#include "ibvs/robot_mapping.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::py_convert;

namespace {

Pose pose4(py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
    throw py::value_error(std::string(name) + " must be a 4x4 transform, got shape " + shape_of(a));
  return Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(a.data());
}

double real_arg(py::handle obj, const char* name) {
  if (py::isinstance<py::bool_>(obj) || py::isinstance<py::str>(obj) || !py::hasattr(obj, "__float__"))
    throw py::type_error(std::string(name) + " must be a real number, got " + type_name(obj));
  return py::float_(py::reinterpret_borrow<py::object>(obj)).cast<double>();
}

/// (n,) vector of at most max_joints entries; a scalar is repeated n times when `n` > 0.
JointVector joint_vector(py::handle obj, const char* name, Eigen::Index n, bool scalar_ok) {
  const CArray a = as_array(obj, name);
  if (scalar_ok && a.ndim() == 0) return JointVector::Constant(n, *a.data());
  if (a.ndim() != 1 || a.shape(0) != n)
    throw py::value_error(std::string(name) + " must have shape (" + std::to_string(n) + ",), got " + shape_of(a));
  return Eigen::Map<const Eigen::VectorXd>(a.data(), n);
}

RobotJacobian jacobian_arg(py::handle obj) {
  const CArray a = as_array(obj, "jacobian");
  if (a.ndim() != 2 || a.shape(0) != 6 || a.shape(1) < 1 || a.shape(1) > max_joints)
    throw py::value_error("jacobian must have shape (6, n) with 1 <= n <= " + std::to_string(max_joints) + ", got " +
                          shape_of(a));
  return Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>>(a.data(), 6, a.shape(1));
}

Twist twist6(py::handle obj) {
  const CArray a = as_array(obj, "twist");
  if (a.ndim() != 1 || a.shape(0) != 6) throw py::value_error("twist must have shape (6,), got " + shape_of(a));
  return Eigen::Map<const Twist>(a.data());
}

JointMappingOptions options(int n, py::handle frame, py::handle damping, py::handle singular_region,
                            py::handle max_joint_speed) {
  JointMappingOptions o;
  o.frame = frame_arg(frame);
  o.damping = real_arg(damping, "damping");
  o.singular_region = real_arg(singular_region, "singular_region");
  if (!max_joint_speed.is_none()) o.max_joint_speed = joint_vector(max_joint_speed, "max_joint_speed", n, true);
  return o;
}

/// The Python object: the mapping with its input and output, sized once.
struct PyJointMapping {
  PyJointMapping(int n, const Pose& eMc, JointMappingOptions o) : map(n, eMc, std::move(o)), in(n), out(n) {}
  JointMapping map;
  JointMappingInput in;
  JointMappingOutput out;

  const JointMappingOutput& update(py::handle twist, py::handle jacobian, py::handle bRe, py::handle secondary) {
    const int n = map.joints();
    in.twist = twist6(twist);
    in.jacobian = jacobian_arg(jacobian);
    if (in.jacobian.cols() != n)
      throw py::value_error("jacobian must have shape (6, " + std::to_string(n) + ") for " + std::to_string(n) +
                            " joints, got (6, " + std::to_string(in.jacobian.cols()) + ")");
    const bool base = map.options().frame == JacobianFrame::base;
    if (base && bRe.is_none()) throw py::value_error("bRe (base <- end-effector rotation) is required when frame='base'");
    if (!base && !bRe.is_none()) throw py::value_error("bRe is only used with frame='base' (the Jacobian is in the end effector's frame)");
    if (base) {
      const CArray a = as_array(bRe, "bRe");
      if (a.ndim() != 2 || a.shape(0) != 3 || a.shape(1) != 3)
        throw py::value_error("bRe must be a 3x3 rotation, got shape " + shape_of(a));
      in.base_rotation = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(a.data());
    }
    in.secondary = secondary.is_none() ? JointVector::Zero(n) : joint_vector(secondary, "secondary", n, false);
    map.validate(in);
    if (map.update(in, out) == Status::invalid_input)  // valid but out of range: Jc or qdot overflows
      throw py::value_error("twist, jacobian, eMc or secondary too large: the joint velocities overflow");
    return out;
  }
};

}  // namespace

void bind_robot(py::module_& m) {
  py::class_<JointMappingOutput>(m, "JointMappingResult", "Result of one JointMapping.update().")
      .def_readonly("status", &JointMappingOutput::status,
                    "ok, or singular when the camera Jacobian has rank < min(6, n) (qdot is then the damped / "
                    "minimum-norm least-squares solution).")
      .def_property_readonly("qdot", [](const JointMappingOutput& o) { return Eigen::VectorXd(o.qdot); },
                             "Joint velocities (n,), m/s or rad/s per joint.")
      .def_property_readonly("camera_jacobian",
                             [](const JointMappingOutput& o) { return Eigen::MatrixXd(o.camera_jacobian); },
                             "(6, n): camera twist (camera frame) = camera_jacobian @ qdot.")
      .def_readonly("sigma_min", &JointMappingOutput::sigma_min,
                    "Smallest of the min(6, n) singular values of camera_jacobian.")
      .def_readonly("sigma_max", &JointMappingOutput::sigma_max, "Largest singular value of camera_jacobian.")
      .def_readonly("manipulability", &JointMappingOutput::manipulability,
                    "sqrt(det(Jc Jc^T)), the product of the 6 singular values (|det Jc| for 6 joints); 0 for n < 6.")
      .def_readonly("damping", &JointMappingOutput::damping, "The damping lambda applied this step.")
      .def_readonly("rank", &JointMappingOutput::rank, "Numerical rank of camera_jacobian.")
      .def_readonly("saturated", &JointMappingOutput::saturated,
                    "True when qdot was scaled down to max_joint_speed.")
      .def_readonly("saturation_scale", &JointMappingOutput::saturation_scale,
                    "The uniform factor in (0, 1] applied to qdot (1 when not saturated).")
      .def("__repr__", [](const JointMappingOutput& o) {
        return "JointMappingResult(status=" + std::string(py::str(py::cast(o.status))) +
               ", rank=" + std::to_string(o.rank) + ", sigma_min=" + float_repr(o.sigma_min) +
               ", saturation_scale=" + float_repr(o.saturation_scale) + ")";
      });

  py::class_<PyJointMapping>(m, "JointMapping", R"(Camera twist -> joint velocities of the arm carrying the camera.

JointMapping(n_joints, eMc, frame="end_effector", damping=0.0, singular_region=0.0, max_joint_speed=None)
  eMc        (4, 4) end-effector <- camera (hand-eye calibration, metres)
  frame      the frame of the robot's end-effector Jacobian (6, n): "end_effector" (ViSP's eJe,
             Pinocchio's LOCAL) or "base" (Pinocchio's LOCAL_WORLD_ALIGNED; update() then needs bRe)
  damping    lambda >= 0 of the damped least-squares solve (0 = Moore-Penrose)
  singular_region  eps >= 0: damping only while the smallest singular value s of the camera
             Jacobian is below eps, lambda^2 = (1 - (s / eps)^2) damping^2; 0 = constant damping
  max_joint_speed  None, a number or (n,) limits > 0 (inf = none): qdot is scaled by one factor
             so that every |qdot_i| stays within its limit (direction kept)
Sized once; update() runs the allocation-free C++ step.)")
      .def(py::init([](py::handle n, py::handle eMc, py::handle frame, py::handle damping, py::handle region,
                       py::handle max_joint_speed) {
             if (py::isinstance<py::bool_>(n) || !py::hasattr(n, "__index__"))
               throw py::type_error("n_joints must be an int, got " + type_name(n));
             const int joints = py::int_(py::reinterpret_borrow<py::object>(n)).cast<int>();
             if (joints < 1 || joints > max_joints)
               throw py::value_error("n_joints must be in [1, " + std::to_string(max_joints) + "], got " +
                                     std::to_string(joints));
             return PyJointMapping(joints, pose4(eMc, "eMc"), options(joints, frame, damping, region, max_joint_speed));
           }),
           py::arg("n_joints"), py::arg("eMc"), py::arg("frame") = "end_effector", py::arg("damping") = 0.0,
           py::arg("singular_region") = 0.0, py::arg("max_joint_speed") = py::none())
      .def("update", &PyJointMapping::update, py::arg("twist"), py::arg("jacobian"), py::arg("bRe") = py::none(),
           py::arg("secondary") = py::none(), py::return_value_policy::copy,
           R"(One step: twist (6,) the camera twist (camera frame, m/s and rad/s); jacobian (6, n) the
end-effector Jacobian in the mapping's frame; bRe (3, 3) base <- end-effector rotation (frame="base"
only); secondary (n,) joint velocities added in the null space of the camera Jacobian (redundant
arms; they do not move the camera). Returns a JointMappingResult.)")
      .def_property_readonly("n_joints", [](const PyJointMapping& p) { return p.map.joints(); })
      .def_property_readonly("eMc", [](const PyJointMapping& p) { return Eigen::Matrix4d(p.map.eMc()); },
                             "end-effector <- camera, 4x4.")
      .def_property_readonly("frame", [](const PyJointMapping& p) { return to_string(p.map.options().frame); })
      .def_property_readonly("damping", [](const PyJointMapping& p) { return p.map.options().damping; })
      .def_property_readonly("singular_region", [](const PyJointMapping& p) { return p.map.options().singular_region; })
      .def_property_readonly(
          "max_joint_speed",
          [](const PyJointMapping& p) -> py::object {
            if (p.map.options().max_joint_speed.size() == 0) return py::none();
            return py::cast(Eigen::VectorXd(p.map.options().max_joint_speed));
          },
          "(n,) joint-speed limits, or None.")
      .def("__repr__", [](const PyJointMapping& p) {
        return "JointMapping(n_joints=" + std::to_string(p.map.joints()) + ", frame='" +
               to_string(p.map.options().frame) + "', damping=" + float_repr(p.map.options().damping) + ")";
      });

  m.def(
      "joint_velocities",
      [](py::handle twist, py::handle eMc, py::handle jacobian, py::handle frame, py::handle bRe, py::handle damping,
         py::handle region, py::handle max_joint_speed, py::handle secondary) {
        const int n = static_cast<int>(jacobian_arg(jacobian).cols());
        PyJointMapping p(n, pose4(eMc, "eMc"), options(n, frame, damping, region, max_joint_speed));
        return Eigen::VectorXd(p.update(twist, jacobian, bRe, secondary).qdot);
      },
      py::arg("twist"), py::arg("eMc"), py::arg("jacobian"), py::arg("frame") = "end_effector",
      py::arg("bRe") = py::none(), py::arg("damping") = 0.0, py::arg("singular_region") = 0.0,
      py::arg("max_joint_speed") = py::none(), py::arg("secondary") = py::none(),
      R"(Joint velocities (n,) that move the camera with `twist`: one JointMapping(...).update(...) (see
JointMapping for the arguments). twist (6,) camera twist in the camera frame; eMc (4, 4) end-effector
<- camera; jacobian (6, n) the robot's end-effector Jacobian in `frame` ("end_effector" or "base",
the latter with bRe, the base <- end-effector rotation).)");
}
