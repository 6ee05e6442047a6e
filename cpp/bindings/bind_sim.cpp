// Bindings of the simulator (ibvs._core.sim). Argument conversion only; the
// Python face with run(), the result object and the paper's cases is
// python/ibvs/sim/.
#include "convert.hpp"
#include "ibvs/ibvs.hpp"
#include "ibvs/sim/sim.hpp"
#include "py_servo.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <limits>
#include <string>

namespace py = pybind11;
using namespace ibvs;
using namespace ibvs::sim;
using namespace ibvs::py_convert;

namespace ibvs::py_sources {
void raise_kept(const Target& t);  // bind_sources.cpp: a Python feature source's exception, after a run
}

namespace {

using RowMatrix4 = Eigen::Matrix<double, 4, 4, Eigen::RowMajor>;

Pose pose_arg(py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
    throw py::value_error(std::string(name) + " must be a 4x4 pose, got shape " + shape_of(a));
  return Eigen::Map<const RowMatrix4>(a.data());
}

Joints joints_arg(py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 1 || a.shape(0) != 6)
    throw py::value_error(std::string(name) + " must be 6 joint positions, got shape " + shape_of(a));
  const Joints q = Eigen::Map<const Joints>(a.data());
  if (!q.allFinite()) throw py::value_error(std::string(name) + " must be finite");
  return q;
}

/// (n,) joint values of a robot with n joints.
JointVector joint_vector_arg(py::handle obj, const char* name, int n) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 1 || a.shape(0) != n)
    throw py::value_error(std::string(name) + " must have shape (" + std::to_string(n) + ",), got " + shape_of(a));
  return Eigen::Map<const Eigen::VectorXd>(a.data(), n);
}

/// (n,) finite joint positions of a robot with n joints.
JointVector q_arg(py::handle obj, int n) {
  JointVector q = joint_vector_arg(obj, "q", n);
  if (!q.allFinite()) throw py::value_error("q must be finite");
  return q;
}

/// (n,) limits, 1 <= n <= max_joints (n from the first of them).
JointVector limits_arg(py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 1 || a.shape(0) < 1 || a.shape(0) > max_joints)
    throw py::value_error(std::string(name) + " must have shape (n,) with 1 <= n <= " + std::to_string(max_joints) +
                          ", got " + shape_of(a));
  return Eigen::Map<const Eigen::VectorXd>(a.data(), a.shape(0));
}

// A Python exception cannot cross the noexcept episode loop: a trampoline keeps
// the first one (keep() in its catch (...)), returns false so that the episode
// stops, and the binding raises it after the run.
class KeptError {
 public:
  void keep() const noexcept {
    if (!error) error = std::current_exception();
  }
  bool failed() const noexcept { return static_cast<bool>(error); }
  void forget() noexcept { error = nullptr; }
  /// Raises the kept exception, if any (and forgets it).
  void raise() const {
    if (!error) return;
    std::exception_ptr e = error;
    error = nullptr;
    std::rethrow_exception(e);
  }

 private:
  mutable std::exception_ptr error;
};

// ibvs.sim.Robot for Python subclasses: kinematics() calls the subclass's
// kinematics(q) -> (T_we (4, 4), J (6, n)); exceptions are kept (KeptError).
class PyRobot : public Robot, public KeptError {
 public:

  bool kinematics(const JointVector& q, Pose& T_we, RobotJacobian& J) const noexcept override {
    try {
      py::gil_scoped_acquire gil;
      py::function f = py::get_override(static_cast<const Robot*>(this), "kinematics");
      if (!f) throw py::type_error("a subclass of ibvs.sim.Robot must define kinematics(q) -> (T_we, J)");
      const py::object r = f(py::array_t<double>(q.size(), q.data()));
      if (!py::isinstance<py::tuple>(r) || py::len(r) != 2)
        throw py::type_error("kinematics(q) must return a tuple (T_we (4, 4), J (6, n))");
      const auto t = r.cast<py::tuple>();
      T_we = pose_arg(t[0], "kinematics(q)[0] (T_we)");
      const CArray a = as_array(t[1], "kinematics(q)[1] (J)");
      if (a.ndim() != 2 || a.shape(0) != 6 || a.shape(1) != dof())
        throw py::value_error("kinematics(q)[1] (J) must have shape (6, " + std::to_string(dof()) + "), got " +
                              shape_of(a));
      J = Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>>(a.data(), 6, dof());
      return true;
    } catch (...) {
      keep();
      return false;
    }
  }
};

// ibvs.sim.Sensor for Python subclasses (ibvs.vision.ImageSensor): measure()
// calls the subclass's measure(frame, pose, projected, twist) -> (N, 2) pixels
// (NaN rows: lost points) and reset() its reset(seed). A Python exception is
// kept (KeptError): measure() returns false (the episode stops, diverged)
// and the binding raises it after the run (or at once for the goal frame).
class PySensor : public Sensor, public KeptError {
 public:
  void reset(std::uint64_t seed) noexcept override {
    try {
      py::gil_scoped_acquire gil;
      forget();
      py::function f = py::get_override(static_cast<const Sensor*>(this), "reset");
      if (f) f(seed);
    } catch (...) {
      keep();
    }
  }

  bool measure(const SensorFrame& frame, Eigen::Ref<Points> measured) noexcept override {
    if (failed()) return false;  // reset() failed
    try {
      py::gil_scoped_acquire gil;
      py::function f = py::get_override(static_cast<const Sensor*>(this), "measure");
      if (!f) throw py::type_error("a subclass of ibvs.sim.Sensor must define measure(frame, pose, projected, twist)");
      const Eigen::Index n = measured.cols();
      Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> proj = frame.projected->transpose();
      const py::object r = f(frame.frame, Eigen::Matrix4d(*frame.pose), proj, Eigen::VectorXd(*frame.twist));
      const CArray a = as_array(r, "measure(...) (the measured points)");
      if (a.ndim() != 2 || a.shape(0) != n || a.shape(1) != 2)
        throw py::value_error("measure(...) must return the measured points with shape (" + std::to_string(n) +
                              ", 2), got " + shape_of(a));
      measured = Eigen::Map<const Eigen::Matrix<double, 2, Eigen::Dynamic>>(a.data(), 2, n);
      return true;
    } catch (...) {
      keep();
      return false;
    }
  }
};

// kinematics() of any robot from Python: (T_we, J), or the robot's exception.
py::tuple kinematics_of(const Robot& r, const JointVector& q) {
  Pose T;
  RobotJacobian J;
  const bool ok = r.kinematics(q, T, J);
  if (auto* p = dynamic_cast<const PyRobot*>(&r)) p->raise();
  if (!ok) throw py::value_error("the robot's kinematics failed at q");
  return py::make_tuple(Eigen::Matrix4d(T), Eigen::MatrixXd(J));
}

// Robot methods that call kinematics(): a Python robot's exception is raised as itself.
template <class F>
auto calling_kinematics(const Robot& r, F f) {
  try {
    return f();
  } catch (const std::invalid_argument&) {
    if (auto* p = dynamic_cast<const PyRobot*>(&r)) p->raise();
    throw;
  }
}

Twist twist_arg(py::handle obj, const char* name) {
  const CArray a = as_array(obj, name);
  if (a.ndim() != 1 || a.shape(0) != 6) throw py::value_error(std::string(name) + " must have shape (6,), got " + shape_of(a));
  return Eigen::Map<const Twist>(a.data());
}

// Copy of the first `rows` rows of a row-major matrix as an array of the given trailing shape.
py::array_t<double> rows_of(const RowMatrix& M, int rows, std::vector<py::ssize_t> tail) {
  std::vector<py::ssize_t> shape{rows};
  shape.insert(shape.end(), tail.begin(), tail.end());
  py::array_t<double> out(shape);
  std::copy_n(M.data(), static_cast<std::size_t>(rows) * M.cols(), out.mutable_data());
  return out;
}
py::array_t<double> rows_of(const Eigen::VectorXd& v, int rows) {
  py::array_t<double> out(rows);
  std::copy_n(v.data(), rows, out.mutable_data());
  return out;
}

DepthMode depth_mode(py::handle obj) {
  if (!py::isinstance<py::str>(obj))
    throw py::type_error("depth must be 'exact', 'pose', 'desired' or 'estimated', got " +
                         std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  const auto s = obj.cast<std::string>();
  if (s == "exact") return DepthMode::exact;
  if (s == "pose") return DepthMode::pose;
  if (s == "desired") return DepthMode::desired;
  if (s == "estimated") return DepthMode::estimated;
  throw py::value_error("depth must be 'exact', 'pose', 'desired' or 'estimated', got '" + s + "'");
}

GoalPose goal_pose_of(py::handle obj) {
  if (!py::isinstance<py::str>(obj))
    throw py::type_error("goal_pose must be 'taught' or 'given', got " +
                         std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  const auto s = obj.cast<std::string>();
  if (s == "taught") return GoalPose::taught;
  if (s == "given") return GoalPose::given;
  throw py::value_error("goal_pose must be 'taught' or 'given', got '" + s + "'");
}

// A fresh C++ servo with exactly the layout and options of the C++ servo the
// Python ibvs.Servo / ibvs.PartitionedServo holds (the episode owns its servo;
// the run never mutates the caller's). A Servo copy keeps its diagnostics on:
// the history records sigma_min.
AnyServo servo_copy(py::handle obj) {
  if (py::isinstance<py_servo::PyServo>(obj)) {
    const Servo& s = obj.cast<const py_servo::PyServo&>().servo;
    ServoOptions o = s.options();
    o.diagnostics = true;
    return Servo(s.task(), o);  // its points and its feature blocks (a Layout's Task: the same law, bit for bit)
  }
  if (py::isinstance<py_servo::PyPartitioned>(obj)) {
    const PartitionedServo& s = obj.cast<const py_servo::PyPartitioned&>().servo;
    return PartitionedServo(s.layout().n_points(), s.options());
  }
  throw py::type_error("servo must be an ibvs.Servo or an ibvs.PartitionedServo, got " +
                       std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
}

py::dict result_dict(const EpisodeResult& r, bool robot) {
  const History& h = r.history;
  const int k = h.frames;
  const py::ssize_t n = r.uv_desired.cols(), m = h.error.cols();
  py::dict d;
  d["outcome"] = to_string(r.status.outcome);
  d["frame"] = r.status.frame;
  d["point"] = r.status.point;
  d["joint"] = r.status.joint;
  d["feature"] = r.status.feature;
  d["frames_to_converge"] = r.metrics.frames_to_converge;
  d["camera_retreat"] = r.metrics.camera_retreat;
  d["path_length"] = r.metrics.path_length;
  d["final_translation_error"] = r.metrics.final_translation_error;
  d["final_rotation_error"] = r.metrics.final_rotation_error;
  d["time"] = rows_of(h.time, k);
  d["pose"] = rows_of(h.pose, k, {4, 4});
  d["twist"] = rows_of(h.twist, k, {6});
  d["uv"] = rows_of(h.uv, k, {n, 2});
  d["rtheta"] = rows_of(h.rtheta, k, {n, 2});
  d["depth"] = rows_of(h.depth, k, {n});
  d["measured"] = rows_of(h.measured, k, {n, 2});
  d["projected"] = rows_of(h.projected, k, {n, 2});
  d["error"] = rows_of(h.error, k, {m});
  d["measurements"] = rows_of(h.measurements, k, {static_cast<py::ssize_t>(h.measurements.cols())});
  d["measurements_desired"] = Eigen::VectorXd(r.measurements_desired);
  d["error_norm"] = rows_of(h.error_norm, k);
  d["sigma_min"] = rows_of(h.sigma_min, k);
  if (robot) {
    const py::ssize_t nq = h.q.cols();
    d["q"] = rows_of(h.q, k, {nq});
    d["qdot"] = rows_of(h.qdot, k, {nq});
    d["manipulability"] = rows_of(h.manipulability, k);
  }
  py::array_t<double> uvd({n, py::ssize_t{2}});
  std::copy_n(r.uv_desired.data(), 2 * n, uvd.mutable_data());
  d["uv_desired"] = uvd;
  py::array_t<double> md({n, py::ssize_t{2}});
  std::copy_n(r.measured_desired.data(), 2 * n, md.mutable_data());
  d["measured_desired"] = md;
  d["depth_desired"] = Eigen::VectorXd(r.depth_desired);
  d["goal"] = Eigen::Matrix4d(r.goal);
  return d;
}

/// Appends the feature sources of a Python sequence to t (each validated against its points).
void add_features(Target& t, py::handle features) {
  if (features.is_none()) return;
  if (py::isinstance<py::str>(features) || !py::isinstance<py::sequence>(features))
    throw py::type_error("features must be a sequence of ibvs.sim.FeatureSource (e.g. LineSource(0, 1)), got " +
                         type_name(features));
  const py::sequence seq = py::reinterpret_borrow<py::sequence>(features);
  for (std::size_t k = 0; k < seq.size(); ++k) {
    if (!py::isinstance<FeatureSource>(seq[k]))
      throw py::type_error("features[" + std::to_string(k) +
                           "] must be an ibvs.sim.FeatureSource (e.g. LineSource(0, 1)), got " + type_name(seq[k]));
    t.add(seq[k].cast<const FeatureSource&>());
  }
}

/// Robot.set_secondary_task: the settings validated with the robot, the old ones kept if refused.
void set_secondary(Robot& r, py::handle projector, bool avoid, py::handle rho, py::handle rho1, py::handle lambda_tune,
                   py::handle qddot_max, py::handle switch_low, py::handle switch_high) {
  SecondaryTaskOptions o;
  o.projector = projector_arg(projector);
  o.rho = real(rho, "rho");
  o.rho1 = real(rho1, "rho1");
  o.lambda_tune = real(lambda_tune, "lambda_tune");
  o.switch_low = real(switch_low, "switch_low");
  o.switch_high = real(switch_high, "switch_high");
  JointVector acc;
  if (!qddot_max.is_none()) {
    const CArray a = as_array(qddot_max, "qddot_max");
    if (a.ndim() == 0) acc = JointVector::Constant(r.dof(), *a.data());
    else acc = joint_vector_arg(qddot_max, "qddot_max", r.dof());
  }
  const SecondaryTaskOptions old = r.secondary;
  const bool old_on = r.secondary_task, old_avoid = r.avoid_joint_limits;
  const JointVector old_acc = r.qddot_max;
  r.secondary = o;
  r.secondary_task = true;
  r.avoid_joint_limits = avoid;
  r.qddot_max = acc;
  try {
    r.validate();
  } catch (...) {
    r.secondary = old;
    r.secondary_task = old_on;
    r.avoid_joint_limits = old_avoid;
    r.qddot_max = old_acc;
    throw;
  }
}

/// Robot.secondary_task: None, or the keyword arguments of set_secondary (also the pickled state).
py::object secondary_settings(const Robot& r) {
  if (!r.secondary_task) return py::none();
  py::dict d;
  d["projector"] = to_string(r.secondary.projector);
  d["avoid_joint_limits"] = r.avoid_joint_limits;
  d["rho"] = r.secondary.rho;
  d["rho1"] = r.secondary.rho1;
  d["lambda_tune"] = r.secondary.lambda_tune;
  d["qddot_max"] = r.qddot_max.size() ? py::cast(Eigen::VectorXd(r.qddot_max)) : py::none();
  d["switch_low"] = r.secondary.switch_low;
  d["switch_high"] = r.secondary.switch_high;
  return std::move(d);
}

/// set_secondary from the dict secondary_settings returns (a pickled robot's state).
void restore_secondary(Robot& r, py::handle settings) {
  if (settings.is_none()) return;
  const py::dict d = py::reinterpret_borrow<py::dict>(settings);
  set_secondary(r, d["projector"], d["avoid_joint_limits"].cast<bool>(), d["rho"], d["rho1"], d["lambda_tune"],
                d["qddot_max"], d["switch_low"], d["switch_high"]);
}

}  // namespace

void bind_sim(py::module_& m) {
  py::module_ s = m.def_submodule("sim", "Closed-loop simulator (C++). Use ibvs.sim, not this module.");

  py::class_<FeatureSource, std::shared_ptr<FeatureSource>>(s, "FeatureSource", R"(How the simulator measures one feature block of a Task on the target.

A Target carries one source per feature block of the servo's Task, in the Task's order
(Target(points, features=[...])). Each frame a source writes its block's measurement from the true
pose of the target, the controller's points and what the depth mode knows (docs/simulator.md,
"Feature sources"). The kinds: LineSource, SegmentSource, EllipseSource, MomentsSource, PbvsSource,
Point25DSource, SphericalSource, and FunctionSource (a Python callable's); others are added in C++ (ibvs/sim/source.hpp).)")
      .def_property_readonly("size", &FeatureSource::size, "Values in one measurement (its Feature's size).")
      .def("__repr__", [](const FeatureSource& f) { return "<ibvs feature source " + f.describe() + ">"; });

  py::class_<LineSource, FeatureSource, std::shared_ptr<LineSource>>(s, "LineSource", R"(An image line (ibvs.LineFeature) through target points i and j.

LineSource(i, j, k=None): (rho, theta) of the line through the controller's points i and j (with the
sensor's noise, distortion and latency, as LineFeature.measure of them), and the plane (A, B, C) that
holds the 3-D line from the pose the depth mode gives: the target's z = 0 plane (k None: both points
in it), or the plane through points i, j and k (a non-planar target).)")
      .def(py::init([](py::handle i, py::handle j, py::handle k) {
             const int n = max_points;
             return std::make_shared<LineSource>(int_in(i, "i", 0, n), int_in(j, "j", 0, n),
                                                 k.is_none() ? -1 : int_in(k, "k", 0, n));
           }),
           py::arg("i"), py::arg("j"), py::arg("k") = py::none())
      .def_property_readonly("i", &LineSource::i, "The line's first target point.")
      .def_property_readonly("j", &LineSource::j, "The line's second target point.")
      .def_property_readonly("k", [](const LineSource& l) -> py::object { return l.k() < 0 ? py::none() : py::cast(l.k()); },
                             "The plane's third point, or None: the target's z = 0 plane.")
      .def("__repr__",
           [](const LineSource& l) {
             return "LineSource(" + std::to_string(l.i()) + ", " + std::to_string(l.j()) +
                    (l.k() >= 0 ? ", " + std::to_string(l.k()) : "") + ")";
           })
      .def(py::pickle([](const LineSource& l) { return py::make_tuple(l.i(), l.j(), l.k()); },
                      [](const py::tuple& t) {
                        if (t.size() != 3) throw py::value_error("LineSource: bad pickle state");
                        return std::make_shared<LineSource>(t[0].cast<int>(), t[1].cast<int>(), t[2].cast<int>());
                      }));

  py::class_<Target>(s, "Target", R"(Points (N, 3) in the target frame, the target's world pose (4x4) and its feature sources.

Target(points, pose=None, features=None): features, one ibvs.sim.FeatureSource per feature block of
the servo's Task, in the Task's order (e.g. [LineSource(0, 1), LineSource(1, 2)]).)")
      .def(py::init([](py::handle pts, py::handle pose, py::handle features) {
             const CArray a = as_array(pts, "points");
             if (a.ndim() != 2 || a.shape(1) != 3)
               throw py::value_error("points must have shape (N, 3), got " + shape_of(a));
             Target t;
             t.points = Eigen::Map<const Eigen::Matrix3Xd>(a.data(), 3, a.shape(0));
             t.pose = pose.is_none() ? Pose(Pose::Identity()) : pose_arg(pose, "pose");
             t.validate();
             add_features(t, features);
             return t;
           }),
           py::arg("points"), py::arg("pose") = py::none(), py::arg("features") = py::none())
      .def_property_readonly(
          "features",
          [](const Target& t) {
            py::list l;
            for (const auto& src : t.sources) l.append(py::cast(std::const_pointer_cast<FeatureSource>(src)));
            return l;
          },
          "The feature sources, in the order of the Task's feature blocks.")
      .def(
          "with_features",
          [](const Target& t, py::handle features) {
            Target out = t;
            out.sources.clear();
            add_features(out, features);
            return out;
          },
          py::arg("features"), "A copy of the target (points, pose) with these feature sources instead.")
      .def_static("paper", &Target::paper, "Paper Table I: the points (+-0.25, +-0.25, 3) in the world.")
      .def_static(
          "square",
          [](py::handle side, py::handle pose) {
            return Target::square(real(side, "side"), pose.is_none() ? Pose(Pose::Identity()) : pose_arg(pose, "pose"));
          },
          py::arg("side") = 0.1, py::arg("pose") = py::none(),
          "Four dots at the corners of a square (side in metres) in the target's z = 0 plane.")
      .def_property_readonly("points", [](const Target& t) { return Eigen::MatrixX3d(t.points.transpose()); },
                             "(N, 3), target frame.")
      .def_property_readonly("pose", [](const Target& t) { return Eigen::Matrix4d(t.pose); }, "world <- target, 4x4.")
      .def("world_points", [](const Target& t) { return Eigen::MatrixX3d(t.world_points().transpose()); },
           "(N, 3), world frame.")
      .def_property_readonly("planar", [](const Target& t) { return t.planar(); })
      .def("__len__", &Target::size)
      .def("__repr__", &Target::describe)
      .def(py::pickle(
          [](const Target& t) {
            py::list sources;
            for (const auto& src : t.sources) sources.append(py::cast(std::const_pointer_cast<FeatureSource>(src)));
            return py::make_tuple(Eigen::MatrixX3d(t.points.transpose()), Eigen::Matrix4d(t.pose), sources);
          },
          [](const py::tuple& s) {
            if (s.size() != 2 && s.size() != 3) throw py::value_error("Target: bad pickle state");
            Target t;
            t.points = s[0].cast<Eigen::MatrixX3d>().transpose();
            t.pose = s[1].cast<Eigen::Matrix4d>();
            t.validate();
            if (s.size() == 3)
              for (const py::handle src : s[2].cast<py::list>()) t.add(src.cast<const FeatureSource&>());
            return t;
          }));

  py::class_<Robot, PyRobot>(s, "Robot", R"(A robot carrying the camera, for ibvs.sim.run(..., robot=...).

Subclass it in Python and define kinematics(q) -> (T_we, J): the world (base) <- end-effector pose
(4, 4) and the end-effector Jacobian (6, n) at the joints q (n,), in `frame` ("end_effector": linear
velocity of the end effector's origin and angular velocity in the end-effector frame, Pinocchio's
LOCAL; "base": both in the base frame, Pinocchio's LOCAL_WORLD_ALIGNED). ibvs.sim.UrdfRobot is one.

Robot(q_min, q_max, qdot_max, mount, frame="end_effector", damping=0.0, singular_region=0.0,
      mounting="eye_in_hand")
  q_min, q_max (n,)  joint position limits (m or rad); qdot_max (n,) speed limits > 0 (inf = none)
  mount (4, 4)       end-effector <- camera (eMc); with mounting="eye_to_hand" the fixed camera's
                     base <- camera pose bMc, the target riding on the end effector: the episode then
                     runs in the end effector's frame (Target.pose = end effector <- target, camera(q)
                     = bMe(q)^-1 bMc, a goal pose is that; see docs/arms.md, Eye-to-hand)
  damping, singular_region  of the JointMapping that turns the camera twist into joint velocities
The episode loop calls kinematics() once per frame and holds the GIL for such a robot.)")
      .def(py::init([](py::handle q_min, py::handle q_max, py::handle qdot_max, py::handle mount, py::handle frame,
                       py::handle damping, py::handle singular_region, py::handle mounting) {
             auto r = std::make_unique<PyRobot>();
             r->q_min = limits_arg(q_min, "q_min");
             const int n = r->dof();
             r->q_max = joint_vector_arg(q_max, "q_max", n);
             r->qdot_max = joint_vector_arg(qdot_max, "qdot_max", n);
             r->mount = pose_arg(mount, "mount");
             r->mapping.frame = frame_arg(frame);
             r->mapping.damping = real(damping, "damping");
             r->mapping.singular_region = real(singular_region, "singular_region");
             r->mapping.mounting = mounting_arg(mounting);
             r->validate();
             return r;
           }),
           py::arg("q_min"), py::arg("q_max"), py::arg("qdot_max"), py::arg("mount"), py::arg("frame") = "end_effector",
           py::arg("damping") = 0.0, py::arg("singular_region") = 0.0, py::arg("mounting") = "eye_in_hand")
      .def_property_readonly("dof", &Robot::dof, "Number of joints n.")
      .def_property_readonly("q_min", [](const Robot& r) { return Eigen::VectorXd(r.q_min); }, "(n,) lower joint limits.")
      .def_property_readonly("q_max", [](const Robot& r) { return Eigen::VectorXd(r.q_max); }, "(n,) upper joint limits.")
      .def_property_readonly("qdot_max", [](const Robot& r) { return Eigen::VectorXd(r.qdot_max); },
                             "(n,) joint speed limits.")
      .def_property_readonly("mount", [](const Robot& r) { return Eigen::Matrix4d(r.mount); },
                             "end-effector <- camera (eMc), 4x4; eye_to_hand: base <- camera (bMc).")
      .def_property_readonly("mounting", [](const Robot& r) { return to_string(r.mapping.mounting); },
                             "'eye_in_hand' (camera on the end effector) or 'eye_to_hand' (camera fixed, target on it).")
      .def_property_readonly("frame", [](const Robot& r) { return to_string(r.mapping.frame); },
                             "Frame of the Jacobian kinematics() returns: 'end_effector' or 'base'.")
      .def_property_readonly("damping", [](const Robot& r) { return r.mapping.damping; })
      .def_property_readonly("singular_region", [](const Robot& r) { return r.mapping.singular_region; })
      .def(
          "kinematics", [](Robot& r, py::handle q) { return kinematics_of(r, q_arg(q, r.dof())); },
          py::arg("q"), "(T_we (4, 4) world <- end-effector, J (6, n) end-effector Jacobian in `frame`) at q.")
      .def(
          "camera",
          [](Robot& r, py::handle q) {
            const JointVector qv = q_arg(q, r.dof());
            return calling_kinematics(r, [&] { return Eigen::Matrix4d(r.camera(qv)); });
          },
          py::arg("q"), "world <- camera, 4x4 (eye_to_hand: end effector <- camera, bMe(q)^-1 bMc).")
      .def(
          "jacobian",
          [](Robot& r, py::handle q) {
            const JointVector qv = q_arg(q, r.dof());
            return calling_kinematics(r, [&] { return Eigen::MatrixXd(r.camera_jacobian(qv)); });
          },
          py::arg("q"), "(6, n) camera Jacobian: camera twist (camera frame) = J @ qdot.")
      .def(
          "joint_velocity",
          [](Robot& r, py::handle q, py::handle v) {
            const JointVector qv = q_arg(q, r.dof());
            const Twist t = twist_arg(v, "twist");
            return calling_kinematics(r, [&] { return Eigen::VectorXd(r.joint_velocity(qv, t)); });
          },
          py::arg("q"), py::arg("twist"),
          "Joint velocities (n,) for the camera twist at q, by the robot's JointMapping (before the speed limits).")
      .def(
          "set_secondary_task",
          &set_secondary,
          py::arg("projector") = "classical", py::arg("avoid_joint_limits") = true, py::arg("rho") = 0.1,
          py::arg("rho1") = 0.3, py::arg("lambda_tune") = 0.7, py::arg("qddot_max") = py::none(),
          py::arg("switch_low") = 0.1, py::arg("switch_high") = 0.7,
          R"(Run a SecondaryTask after the joint mapping in every episode of this robot (in place): joint-limit
avoidance (Marey & Chaumette, IROS 2010; ViSP's thresholds rho, rho1, gain lambda_tune) in the null space of
the servo's task given by `projector` ("classical" or "large", Marey & Chaumette ICRA 2010), then the caps
qdot_max and qddot_max (None, a number or (n,) joint accelerations > 0, inf = none; period 1 / fps).)")
      .def(
          "clear_secondary_task",
          [](Robot& r) {
            r.secondary_task = false;
            r.avoid_joint_limits = false;
            r.qddot_max.resize(0);
            r.secondary = SecondaryTaskOptions{};
          },
          "Back to the joint mapping alone (the default).")
      .def_property_readonly(
          "secondary_task",
          &secondary_settings,
          "None, or the settings of set_secondary_task().")
      .def(
          "outside_limits", [](const Robot& r, py::handle q) { return r.outside_limits(q_arg(q, r.dof())); },
          py::arg("q"), "Index of the first joint outside its range, or -1.")
      .def("__repr__", &Robot::describe);

  py::class_<Gantry, Robot>(s, "Gantry", "Afma6-like gantry: 3 prismatic joints + 3-revolute wrist, camera on the flange.")
      .def_static("afma6", &Gantry::afma6, "ViSP vpAfma6 defaults with the distorted-camera mount.")
      .def_readonly("coupling", &Gantry::coupling)
      .def_readonly("offset", &Gantry::offset)
      .def(
          "with_limits",
          [](const Gantry& g, py::handle qmin, py::handle qmax, py::handle qdmax) {
            Gantry o = g;
            if (!qmin.is_none()) o.q_min = joints_arg(qmin, "q_min");
            if (!qmax.is_none()) o.q_max = joints_arg(qmax, "q_max");
            if (!qdmax.is_none()) o.qdot_max = joints_arg(qdmax, "qdot_max");
            o.validate();
            return o;
          },
          py::arg("q_min") = py::none(), py::arg("q_max") = py::none(), py::arg("qdot_max") = py::none(),
          "A copy with other joint position / speed limits.")
      .def(
          "with_mount",
          [](const Gantry& g, py::handle mount, py::handle mounting) {
            Gantry o = g;
            o.mount = pose_arg(mount, "mount");
            o.mapping.mounting = mounting_arg(mounting);
            o.validate();
            return o;
          },
          py::arg("mount"), py::arg("mounting") = "eye_in_hand",
          "A copy with another camera mount: eMc (eye_in_hand) or, with mounting='eye_to_hand', the fixed "
          "camera's world <- camera pose (the target then rides on the flange).")
      .def("end_effector", [](const Gantry& g, py::handle q) { return Eigen::Matrix4d(g.end_effector(joints_arg(q, "q"))); },
           py::arg("q"), "world <- end-effector, 4x4.")
      .def(
          "manipulability", [](const Gantry& g, py::handle q) { return g.manipulability(joints_arg(q, "q")); },
          py::arg("q"), "|det jacobian(q)| = |cos q5|.")
      .def("__repr__", &Gantry::describe)
      // Pickling (process pools, Dask): every field, re-validated on load.
      .def(py::pickle(
          [](const Gantry& g) {
            return py::make_tuple(Eigen::VectorXd(g.q_min), Eigen::VectorXd(g.q_max), Eigen::VectorXd(g.qdot_max),
                                  Eigen::Matrix4d(g.mount), g.coupling, g.offset, g.mapping.singular_region,
                                  g.mapping.damping, to_string(g.mapping.mounting), secondary_settings(g));
          },
          [](const py::tuple& s) {
            if (s.size() < 8 || s.size() > 10) throw py::value_error("Gantry: bad pickle state");
            Gantry g = Gantry::afma6();
            g.q_min = s[0].cast<Eigen::VectorXd>();
            g.q_max = s[1].cast<Eigen::VectorXd>();
            g.qdot_max = s[2].cast<Eigen::VectorXd>();
            g.mount = s[3].cast<Eigen::Matrix4d>();
            g.coupling = s[4].cast<double>();
            g.offset = s[5].cast<double>();
            g.mapping.singular_region = s[6].cast<double>();
            g.mapping.damping = s[7].cast<double>();
            if (s.size() >= 9) g.mapping.mounting = mounting_arg(s[8]);
            g.validate();
            if (s.size() == 10) restore_secondary(g, s[9]);
            return g;
          }));

  py::class_<Sensor, PySensor, std::shared_ptr<Sensor>>(s, "Sensor", R"(What the simulated camera reports each frame, for ibvs.sim.run(..., vision=...).

Subclass it in Python (ibvs.vision.ImageSensor is one) and define
  measure(frame, pose, projected, twist) -> (N, 2) measured points, pixels (measurement units);
                 a NaN row = that point is lost (the episode ends as lost_feature, its index)
  reset(seed)    (optional) called at the start of every run with the run's seed
frame is -1 for the goal image (teach by showing), then 0, 1, ...; pose (4, 4) world <- camera;
projected (N, 2) the true projections (to initialise tracks at frames -1 and 0 only, as a user
clicks on the dots); twist (6,) the camera twist commanded at the previous frame (zero at frames
-1 and 0), the motion during the exposure. The default measurement (no sensor) is the projection
plus the run's Gaussian noise. The episode loop holds the GIL for such a sensor; an exception in
it stops the episode and is raised by run().)")
      .def(py::init([]() { return std::make_shared<PySensor>(); }));

  s.def(
      "_run",
      [](py::handle servo, const CameraModel& camera, const Target& target, py::handle start, py::handle goal,
          py::handle robot, double duration, double noise, int latency, py::handle depth,
          std::uint64_t seed, double tolerance, double tolerance_px, double max_depth_ratio, double max_error_ratio,
          bool stop_on_singular, double depth_scale, double boundary_margin, double boundary_gain,
          double standoff_ratio, py::handle sensor, bool keep_lost, py::handle goal_pose, double turn) {
        EpisodeOptions o;
        o.duration = duration;
        o.noise = noise;
        o.latency = latency;
        o.depth = depth_mode(depth);
        o.seed = seed;
        o.tolerance = tolerance;
        o.tolerance_px = tolerance_px;
        o.max_depth_ratio = max_depth_ratio;
        o.max_error_ratio = max_error_ratio;
        o.stop_on_singular = stop_on_singular;
        o.depth_scale = depth_scale;
        o.boundary_margin = boundary_margin;
        o.boundary_gain = boundary_gain;
        o.standoff_ratio = standoff_ratio;
        o.keep_lost = keep_lost;
        o.goal_pose = goal_pose_of(goal_pose);
        o.turn = turn;
        std::shared_ptr<Sensor> py_sensor_held;
        PySensor* py_sensor = nullptr;
        if (!sensor.is_none()) {
          if (!py::isinstance<Sensor>(sensor))
            throw py::type_error("sensor must be an ibvs.sim.Sensor (e.g. an ibvs.vision.ImageSensor) or None, got " +
                                 std::string(py::str(py::type::handle_of(sensor).attr("__name__"))));
          py_sensor_held = sensor.cast<std::shared_ptr<Sensor>>();
          py_sensor = dynamic_cast<PySensor*>(py_sensor_held.get());
        }
        // A Python sensor's exception, raised instead of the episode's own error or result.
        const auto raise_sensor = [&] {
          if (py_sensor) py_sensor->raise();
          ibvs::py_sources::raise_kept(target);  // and a Python feature source's (sim.FunctionSource)
        };
        AnyServo sv = servo_copy(servo);
        if (!robot.is_none()) {
          if (!py::isinstance<Robot>(robot))
            throw py::type_error("robot must be an ibvs.sim.Robot (e.g. a Gantry or a UrdfRobot) or None, got " +
                                 std::string(py::str(py::type::handle_of(robot).attr("__name__"))));
          // The C++ gantry is copied and run without the GIL; a Python robot is
          // shared for the call (the caller holds it) and needs the GIL.
          Robot& rb = robot.cast<Robot&>();
          auto* py_robot = dynamic_cast<PyRobot*>(&rb);
          std::shared_ptr<Robot> held;
          if (py_robot) held = std::shared_ptr<Robot>(&rb, [](Robot*) {});
          else held = std::make_shared<Gantry>(robot.cast<const Gantry&>());
          const int n = rb.dof();
          const JointVector qs = joint_vector_arg(start, "start", n);
          const CArray g = as_array(goal, "goal");
          const bool goal_joints = g.ndim() == 1;
          const JointVector qg = goal_joints ? joint_vector_arg(goal, "goal", n) : JointVector();
          const Pose pg = goal_joints ? Pose() : pose_arg(goal, "goal");
          Episode e(std::move(sv), camera, target, held, o);
          if (py_sensor_held) e.set_sensor(py_sensor_held);
          const EpisodeResult* r = nullptr;
          try {
            std::optional<py::gil_scoped_release> release;
            if (!py_robot && !py_sensor) release.emplace();
            r = goal_joints ? &e.run(qs, qg) : &e.run(qs, pg);
          } catch (const std::invalid_argument&) {
            if (py_robot) py_robot->raise();  // the robot's own error, raised in kinematics()
            raise_sensor();
            throw;
          }
          if (py_robot) py_robot->raise();
          raise_sensor();
          return result_dict(*r, true);
        }
        const Pose ps = pose_arg(start, "start"), pg = pose_arg(goal, "goal");
        Episode e(std::move(sv), camera, target, o);
        if (py_sensor_held) e.set_sensor(py_sensor_held);
        const EpisodeResult* r;
        try {
          std::optional<py::gil_scoped_release> release;
          if (!py_sensor) release.emplace();
          r = &e.run(ps, pg);
        } catch (const std::invalid_argument&) {
          raise_sensor();
          throw;
        }
        raise_sensor();
        return result_dict(*r, false);
      },
      py::arg("servo"), py::arg("camera"), py::arg("target"), py::arg("start"), py::arg("goal"),
      py::arg("robot") = py::none(), py::arg("duration") = 10.0, py::arg("noise") = 0.0, py::arg("latency") = 0,
      py::arg("depth") = "exact", py::arg("seed") = 0, py::arg("tolerance") = 1e-4,
      py::arg("tolerance_px") = 0.0, py::arg("max_depth_ratio") = 10.0,
      py::arg("max_error_ratio") = 100.0, py::arg("stop_on_singular") = true, py::arg("depth_scale") = 1.0,
      py::arg("boundary_margin") = 0.0, py::arg("boundary_gain") = 0.1, py::arg("standoff_ratio") = 0.05,
      py::arg("sensor") = py::none(), py::arg("keep_lost") = false, py::arg("goal_pose") = "taught",
      py::arg("turn") = std::numeric_limits<double>::quiet_NaN(),
      "Runs one episode; returns a dict of arrays and scalars (see ibvs.sim.run).");
}
