// Bindings of the robot mapping (robot_mapping.hpp): JointMapping,
// JointMappingResult and joint_velocities(). Argument conversion only.
#include "convert.hpp"
#include "ibvs/robot_mapping.hpp"
#include "ibvs/secondary_task.hpp"

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
                            py::handle max_joint_speed, py::handle mounting) {
  JointMappingOptions o;
  o.frame = frame_arg(frame);
  o.mounting = mounting_arg(mounting);
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

  const JointMappingOutput& update(py::handle twist, py::handle jacobian, py::handle bRe, py::handle secondary,
                                   py::handle bMe) {
    const int n = map.joints();
    in.twist = twist6(twist);
    in.jacobian = jacobian_arg(jacobian);
    if (in.jacobian.cols() != n)
      throw py::value_error("jacobian must have shape (6, " + std::to_string(n) + ") for " + std::to_string(n) +
                            " joints, got (6, " + std::to_string(in.jacobian.cols()) + ")");
    const bool eye_to_hand = map.options().mounting == Mounting::eye_to_hand;
    if (eye_to_hand) {
      if (bMe.is_none()) throw py::value_error("bMe (base <- end-effector pose, 4x4) is required when mounting='eye_to_hand'");
      if (!bRe.is_none()) throw py::value_error("bRe is not used with mounting='eye_to_hand' (bMe holds the rotation)");
      in.base_pose = pose4(bMe, "bMe");
    } else if (!bMe.is_none()) {
      throw py::value_error("bMe is only used with mounting='eye_to_hand'");
    }
    const bool base = !eye_to_hand && map.options().frame == JacobianFrame::base;
    if (base && bRe.is_none()) throw py::value_error("bRe (base <- end-effector rotation) is required when frame='base'");
    if (!eye_to_hand && !base && !bRe.is_none()) throw py::value_error("bRe is only used with frame='base' (the Jacobian is in the end effector's frame)");
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

/// The Python SecondaryTask: the task with its input and output, sized once.
struct PySecondaryTask {
  PySecondaryTask(int n, SecondaryTaskOptions o) : task(n, std::move(o)), in(n), out(n) {}
  SecondaryTask task;
  SecondaryTaskInput in;
  SecondaryTaskOutput out;

  const SecondaryTaskOutput& update(py::handle qdot, py::handle camera_jacobian, py::handle interaction,
                                    py::handle error, py::handle q, py::handle qdot_previous, py::handle twist,
                                    py::handle joints) {
    const int n = task.joints();
    in.qdot = joint_vector(qdot, "qdot", n, false);
    const CArray jc = as_array(camera_jacobian, "camera_jacobian");
    if (jc.ndim() != 2 || jc.shape(0) != 6 || jc.shape(1) != n)
      throw py::value_error("camera_jacobian must have shape (6, " + std::to_string(n) + "), got " + shape_of(jc));
    in.camera_jacobian = Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>>(jc.data(), 6, n);
    if (interaction.is_none() != error.is_none())
      throw py::value_error("interaction and error go together (the primary task's L (M, 6) and e (M,)), or neither");
    in.task_gram.setIdentity();
    in.task_gradient.setZero();
    in.error_norm = 0.0;
    if (!interaction.is_none()) {
      const CArray L = as_array(interaction, "interaction");
      if (L.ndim() != 2 || L.shape(1) != 6 || L.shape(0) < 1)
        throw py::value_error("interaction must have shape (M, 6), M >= 1, got " + shape_of(L));
      const CArray e = as_array(error, "error");
      if (e.ndim() != 1 || e.shape(0) != L.shape(0))
        throw py::value_error("error must have shape (" + std::to_string(L.shape(0)) + ",), got " + shape_of(e));
      const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>> Lm(L.data(), L.shape(0), 6);
      const Eigen::Map<const Eigen::VectorXd> em(e.data(), e.shape(0));
      if (!Lm.allFinite()) throw py::value_error("interaction must be finite");
      if (!em.allFinite()) throw py::value_error("error must be finite");
      in.task_gram = Lm.transpose() * Lm;
      in.task_gradient = Lm.transpose() * em;
      in.error_norm = em.stableNorm();
      if (!in.task_gram.allFinite() || !in.task_gradient.allFinite() || !std::isfinite(in.error_norm))
        throw py::value_error("interaction and error too large: L^T L or L^T e overflows");
    }
    if (q.is_none() && task.avoids_joint_limits())
      throw py::value_error("q (the joint positions) is required when avoiding joint limits (q_min, q_max given)");
    in.q = q.is_none() ? JointVector::Zero(n) : joint_vector(q, "q", n, false);
    if (qdot_previous.is_none() && task.options().max_joint_acceleration.size() != 0)
      throw py::value_error("qdot_previous (the last command) is required with max_joint_acceleration");
    in.qdot_previous = qdot_previous.is_none() ? JointVector::Zero(n) : joint_vector(qdot_previous, "qdot_previous", n, false);
    in.twist = twist.is_none() ? Twist::Zero() : twist6(twist);
    in.joints = joints.is_none() ? JointVector::Zero(n) : joint_vector(joints, "joints", n, false);
    task.validate(in);
    if (task.update(in, out) == Status::invalid_input)
      throw py::value_error("qdot, camera_jacobian, interaction, error, twist or joints too large: the result overflows");
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

  py::class_<PyJointMapping>(m, "JointMapping", R"(Camera twist -> joint velocities of the arm carrying the camera (or the target).

JointMapping(n_joints, eMc, frame="end_effector", damping=0.0, singular_region=0.0, max_joint_speed=None,
             mounting="eye_in_hand")
  eMc        (4, 4) end-effector <- camera (hand-eye calibration, metres); with mounting="eye_to_hand"
             the fixed camera's base <- camera pose bMc (the target rides on the end effector, and
             update() needs the end effector's pose bMe: Jc = -cVe(q) eJe, cMe = bMc^-1 bMe)
  frame      the frame of the robot's end-effector Jacobian (6, n): "end_effector" (ViSP's eJe,
             Pinocchio's LOCAL) or "base" (Pinocchio's LOCAL_WORLD_ALIGNED; update() then needs bRe)
  damping    lambda >= 0 of the damped least-squares solve (0 = Moore-Penrose)
  singular_region  eps >= 0: damping only while the smallest singular value s of the camera
             Jacobian is below eps, lambda^2 = (1 - (s / eps)^2) damping^2; 0 = constant damping
  max_joint_speed  None, a number or (n,) limits > 0 (inf = none): qdot is scaled by one factor
             so that every |qdot_i| stays within its limit (direction kept)
Sized once; update() runs the allocation-free C++ step.)")
      .def(py::init([](py::handle n, py::handle eMc, py::handle frame, py::handle damping, py::handle region,
                       py::handle max_joint_speed, py::handle mounting) {
             if (py::isinstance<py::bool_>(n) || !py::hasattr(n, "__index__"))
               throw py::type_error("n_joints must be an int, got " + type_name(n));
             const int joints = py::int_(py::reinterpret_borrow<py::object>(n)).cast<int>();
             if (joints < 1 || joints > max_joints)
               throw py::value_error("n_joints must be in [1, " + std::to_string(max_joints) + "], got " +
                                     std::to_string(joints));
             return PyJointMapping(joints, pose4(eMc, "eMc"),
                                   options(joints, frame, damping, region, max_joint_speed, mounting));
           }),
           py::arg("n_joints"), py::arg("eMc"), py::arg("frame") = "end_effector", py::arg("damping") = 0.0,
           py::arg("singular_region") = 0.0, py::arg("max_joint_speed") = py::none(),
           py::arg("mounting") = "eye_in_hand")
      .def("update", &PyJointMapping::update, py::arg("twist"), py::arg("jacobian"), py::arg("bRe") = py::none(),
           py::arg("secondary") = py::none(), py::arg("bMe") = py::none(), py::return_value_policy::copy,
           R"(One step: twist (6,) the camera twist (camera frame, m/s and rad/s); jacobian (6, n) the
end-effector Jacobian in the mapping's frame; bRe (3, 3) base <- end-effector rotation (frame="base"
only); secondary (n,) joint velocities added in the null space of the camera Jacobian (redundant
arms; they do not move the camera); bMe (4, 4) base <- end-effector pose (mounting="eye_to_hand"
only, required there). Returns a JointMappingResult.)")
      .def_property_readonly("n_joints", [](const PyJointMapping& p) { return p.map.joints(); })
      .def_property_readonly("eMc", [](const PyJointMapping& p) { return Eigen::Matrix4d(p.map.eMc()); },
                             "end-effector <- camera, 4x4.")
      .def_property_readonly("frame", [](const PyJointMapping& p) { return to_string(p.map.options().frame); })
      .def_property_readonly("mounting", [](const PyJointMapping& p) { return to_string(p.map.options().mounting); },
                             "'eye_in_hand' or 'eye_to_hand'.")
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
               to_string(p.map.options().frame) + "', damping=" + float_repr(p.map.options().damping) +
               (p.map.options().mounting == Mounting::eye_to_hand ? ", mounting='eye_to_hand')" : ")");
      });

  m.def(
      "joint_velocities",
      [](py::handle twist, py::handle eMc, py::handle jacobian, py::handle frame, py::handle bRe, py::handle damping,
         py::handle region, py::handle max_joint_speed, py::handle secondary, py::handle mounting, py::handle bMe) {
        const int n = static_cast<int>(jacobian_arg(jacobian).cols());
        PyJointMapping p(n, pose4(eMc, "eMc"), options(n, frame, damping, region, max_joint_speed, mounting));
        return Eigen::VectorXd(p.update(twist, jacobian, bRe, secondary, bMe).qdot);
      },
      py::arg("twist"), py::arg("eMc"), py::arg("jacobian"), py::arg("frame") = "end_effector",
      py::arg("bRe") = py::none(), py::arg("damping") = 0.0, py::arg("singular_region") = 0.0,
      py::arg("max_joint_speed") = py::none(), py::arg("secondary") = py::none(),
      py::arg("mounting") = "eye_in_hand", py::arg("bMe") = py::none(),
      R"(Joint velocities (n,) that move the camera with `twist`: one JointMapping(...).update(...) (see
JointMapping for the arguments). twist (6,) camera twist in the camera frame; eMc (4, 4) end-effector
<- camera; jacobian (6, n) the robot's end-effector Jacobian in `frame` ("end_effector" or "base",
the latter with bRe, the base <- end-effector rotation); mounting="eye_to_hand": eMc is the fixed
camera's bMc and bMe (4, 4) the end effector's pose (which carries the target).)");

  // ---- SecondaryTask (secondary_task.hpp)
  py::class_<SecondaryTaskOutput>(m, "SecondaryTaskResult", "Result of one SecondaryTask.update().")
      .def_readonly("status", &SecondaryTaskOutput::status, "ok (a refused input raises ValueError).")
      .def_property_readonly("qdot", [](const SecondaryTaskOutput& o) { return Eigen::VectorXd(o.qdot); },
                             "The joint velocities to command (n,): primary + projected secondary + avoidance, capped.")
      .def_property_readonly("secondary", [](const SecondaryTaskOutput& o) { return Eigen::VectorXd(o.secondary); },
                             "P (joints + Jc^+ twist), (n,): the projected secondary motion.")
      .def_property_readonly("avoidance", [](const SecondaryTaskOutput& o) { return Eigen::VectorXd(o.avoidance); },
                             "The joint-limit avoidance term (n,) (zero when no joint is near a limit).")
      .def_readonly("weight", &SecondaryTaskOutput::weight,
                    "s of the large projector's switch (1: P_|e|, 0: classical), 0 with the classical projector.")
      .def_readonly("rank", &SecondaryTaskOutput::rank, "Rank of the primary task's joint Jacobian L Jc.")
      .def_readonly("active", &SecondaryTaskOutput::active, "Joints beyond their activation threshold.")
      .def_readonly("saturation_scale", &SecondaryTaskOutput::saturation_scale, "Speed-cap factor in (0, 1].")
      .def_readonly("acceleration_scale", &SecondaryTaskOutput::acceleration_scale,
                    "Acceleration-cap factor in (0, 1].")
      .def("__repr__", [](const SecondaryTaskOutput& o) {
        return "SecondaryTaskResult(rank=" + std::to_string(o.rank) + ", weight=" + float_repr(o.weight) +
               ", active=" + std::to_string(o.active) + ", saturation_scale=" + float_repr(o.saturation_scale) +
               ", acceleration_scale=" + float_repr(o.acceleration_scale) + ")";
      });

  py::class_<PySecondaryTask>(m, "SecondaryTask", R"(Secondary motions in the null space of a visual servo's task, joint-limit avoidance and caps.

SecondaryTask(n_joints, projector="classical", q_min=None, q_max=None, rho=0.1, rho1=0.3, lambda_tune=0.7,
              max_joint_speed=None, max_joint_acceleration=None, period=0.0, switch_low=0.1, switch_high=0.7)
  projector   "classical": I - J1^+ J1 with J1 = L Jc (the feature velocity is kept exactly), or "large":
              Marey & Chaumette's (ICRA 2010, eq. 24) I - h h^T / h^T h, h = J1^T e (only d|e|/dt is kept;
              n - 1 free directions), switched to the classical one as |e| falls from switch_high to
              switch_low (ViSP's sigmoid, e0 = 0.1, e1 = 0.7)
  q_min, q_max  (n,) joint limits: joint-limit avoidance (Marey & Chaumette, IROS 2010; ViSP's
              vpServo::secondaryTaskJointLimitAvoidance) with thresholds rho, rho1 and gain lambda_tune
  max_joint_speed, max_joint_acceleration  None, a number or (n,) caps > 0 (inf = none); the latter with
              period (s) > 0, the control period
Sized once; update() runs the allocation-free C++ step (cpp/include/ibvs/secondary_task.hpp).)")
      .def(py::init([](py::handle n, py::handle projector, py::handle q_min, py::handle q_max, py::handle rho,
                       py::handle rho1, py::handle lambda_tune, py::handle max_joint_speed,
                       py::handle max_joint_acceleration, py::handle period, py::handle switch_low,
                       py::handle switch_high) {
             if (py::isinstance<py::bool_>(n) || !py::hasattr(n, "__index__"))
               throw py::type_error("n_joints must be an int, got " + type_name(n));
             const int joints = py::int_(py::reinterpret_borrow<py::object>(n)).cast<int>();
             if (joints < 1 || joints > max_joints)
               throw py::value_error("n_joints must be in [1, " + std::to_string(max_joints) + "], got " +
                                     std::to_string(joints));
             SecondaryTaskOptions o;
             o.projector = projector_arg(projector);
             if (q_min.is_none() != q_max.is_none()) throw py::value_error("q_min and q_max go together, or neither");
             if (!q_min.is_none()) {
               o.q_min = joint_vector(q_min, "q_min", joints, false);
               o.q_max = joint_vector(q_max, "q_max", joints, false);
             }
             o.rho = real_arg(rho, "rho");
             o.rho1 = real_arg(rho1, "rho1");
             o.lambda_tune = real_arg(lambda_tune, "lambda_tune");
             if (!max_joint_speed.is_none()) o.max_joint_speed = joint_vector(max_joint_speed, "max_joint_speed", joints, true);
             if (!max_joint_acceleration.is_none())
               o.max_joint_acceleration = joint_vector(max_joint_acceleration, "max_joint_acceleration", joints, true);
             o.period = real_arg(period, "period");
             o.switch_low = real_arg(switch_low, "switch_low");
             o.switch_high = real_arg(switch_high, "switch_high");
             return PySecondaryTask(joints, std::move(o));
           }),
           py::arg("n_joints"), py::arg("projector") = "classical", py::arg("q_min") = py::none(),
           py::arg("q_max") = py::none(), py::arg("rho") = 0.1, py::arg("rho1") = 0.3, py::arg("lambda_tune") = 0.7,
           py::arg("max_joint_speed") = py::none(), py::arg("max_joint_acceleration") = py::none(),
           py::arg("period") = 0.0, py::arg("switch_low") = 0.1, py::arg("switch_high") = 0.7)
      .def("update", &PySecondaryTask::update, py::arg("qdot"), py::arg("camera_jacobian"),
           py::arg("interaction") = py::none(), py::arg("error") = py::none(), py::arg("q") = py::none(),
           py::arg("qdot_previous") = py::none(), py::arg("twist") = py::none(), py::arg("joints") = py::none(),
           py::return_value_policy::copy,
           R"(One step. qdot (n,) the primary joint velocities (JointMapping.update(...).qdot, without speed caps);
camera_jacobian (6, n) its camera_jacobian; interaction (M, 6) and error (M,) the servo's L and e
(ServoResult.jacobian, .error; None: the primary task is the whole camera twist); q (n,) joint positions
(needed to avoid joint limits); qdot_previous (n,) the last command (needed with max_joint_acceleration);
twist (6,) a task-space secondary motion (camera twist, camera frame); joints (n,) a joint-space one.
Returns a SecondaryTaskResult.)")
      .def_property_readonly("n_joints", [](const PySecondaryTask& p) { return p.task.joints(); })
      .def_property_readonly("projector", [](const PySecondaryTask& p) { return to_string(p.task.options().projector); })
      .def_property_readonly("avoids_joint_limits", [](const PySecondaryTask& p) { return p.task.avoids_joint_limits(); })
      .def("__repr__", [](const PySecondaryTask& p) {
        return "SecondaryTask(n_joints=" + std::to_string(p.task.joints()) + ", projector='" +
               to_string(p.task.options().projector) + "', avoids_joint_limits=" +
               (p.task.avoids_joint_limits() ? "True" : "False") + ")";
      });
}
