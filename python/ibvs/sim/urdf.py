"""Any arm in the simulator, from its URDF, with Pinocchio (pip install ".[robots]" from the ibvs
repository root).

    robot = ibvs.sim.UrdfRobot(urdf_path, "tool0", eMc)
    robot = ibvs.sim.UrdfRobot.example("panda", eMc)        # an arm of example-robot-data
    ibvs.sim.run(servo, camera, target, q_start, q_goal, robot=robot)
    q = ibvs.sim.solve_ik(robot, camera_pose, q0).q        # joints for a camera pose (ibvs.sim.ik)

Frames: world = the URDF's root (the robot's base); e = the URDF frame `frame`
(a link or fixed-joint frame: the flange or tool); c = the camera, eMc = e <- c
(4x4, metres). The joints are those of the kinematic chain from the root to
`frame` (revolute or prismatic, one coordinate each); every other joint (a
gripper's fingers) is locked at its neutral position. Joint position and speed
limits are the URDF's (<limit lower upper velocity>).

The episode loop (C++) calls kinematics(q) once per frame, holding the GIL.
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

import numpy as np

from .._core import sim as _sim

__all__ = ["UrdfRobot", "example_robot_urdf", "EXAMPLE_ROBOTS"]

#: Installs Pinocchio and example-robot-data (ibvs is on no package index: from a clone of its repository).
INSTALL = 'pip install ".[robots]" from the ibvs repository root'
#: URDFs of example-robot-data used by ibvs: name -> (path under its robots/ directory, flange frame).
EXAMPLE_ROBOTS = {
    "panda": ("panda_description/urdf/panda.urdf", "panda_hand"),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0"),
}


def _pinocchio():
    try:
        import pinocchio
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise ImportError(f"ibvs.sim.UrdfRobot needs Pinocchio: {INSTALL}") from e
    return pinocchio


def example_robot_urdf(name: str) -> str:
    """Path of the URDF of one of EXAMPLE_ROBOTS ("panda", "ur5") installed by the example-robot-data
    package (pip install ".[robots]" from the ibvs repository root). It installs its robots under <prefix>/share/example-robot-data/
    robots with its Python path at <prefix>/lib/pythonX.Y/site-packages; this looks, as its own loader
    does, three levels above every entry of sys.path."""
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {type(name).__name__}")
    if name not in EXAMPLE_ROBOTS:
        raise ValueError(f"name must be one of {sorted(EXAMPLE_ROBOTS)}, got {name!r}")
    sub = EXAMPLE_ROBOTS[name][0]
    for p in sys.path:
        path = Path(p or os.getcwd()) / ".." / ".." / ".." / "share" / "example-robot-data" / "robots" / sub
        if path.is_file():
            return str(path.resolve())
    raise FileNotFoundError(f"{sub} of example-robot-data not found: {INSTALL}")


class UrdfRobot(_sim.Robot):
    """An arm from its URDF for ibvs.sim.run(..., robot=...), backed by Pinocchio.

    urdf_path: the URDF file. frame: the end-effector frame (link) name, where the camera is
    mounted. eMc: (4, 4) end-effector <- camera; None = identity.
    jacobian_frame: the frame kinematics() expresses the Jacobian in, "end_effector" (Pinocchio's
    LOCAL, the default) or "base" (LOCAL_WORLD_ALIGNED): both give the same joint velocities.
    damping, singular_region: the JointMapping's (0, 0: the exact minimum-norm inverse).
    q_min, q_max, qdot_max: None (the URDF's position and velocity limits) or (n,) limits
    overriding them (radians or metres per joint, and per second).
    mounting: "eye_in_hand" (the camera on `frame`, eMc) or "eye_to_hand": the camera fixed in the
    world and eMc its world <- camera pose bMc, the target riding on `frame`; the episode then runs in
    that frame (Target.pose = frame <- target; camera(q) = bMe(q)^-1 bMc; docs/arms.md, Eye-to-hand).

    UrdfRobot.example(name, eMc) builds one of EXAMPLE_ROBOTS. Pickles by its arguments (the
    Pinocchio model is rebuilt; an example by its name, so a worker on another machine loads its own
    copy of example-robot-data), so sweeps can send it to worker processes and Dask.
    """

    def __init__(
        self,
        urdf_path,
        frame: str,
        eMc=None,
        jacobian_frame: str = "end_effector",
        damping: float = 0.0,
        singular_region: float = 0.0,
        q_min=None,
        q_max=None,
        qdot_max=None,
        mounting: str = "eye_in_hand",
    ) -> None:
        pin = _pinocchio()
        if not isinstance(urdf_path, (str, os.PathLike)):
            raise TypeError(f"urdf_path must be a path, got {type(urdf_path).__name__}")
        if not Path(urdf_path).is_file():
            raise ValueError(f"urdf_path: no such file: {urdf_path}")
        if not isinstance(frame, str):
            raise TypeError(f"frame must be a str (a frame of the URDF), got {type(frame).__name__}")
        for name, x in (("damping", damping), ("singular_region", singular_region)):
            if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
                raise TypeError(f"{name} must be a real number, got {type(x).__name__}")
        if jacobian_frame not in ("end_effector", "base"):
            raise ValueError(f"jacobian_frame must be 'end_effector' or 'base', got {jacobian_frame!r}")
        full = pin.buildModelFromUrdf(str(urdf_path))
        if not full.existFrame(frame):
            names = sorted({f.name for f in full.frames})
            raise ValueError(f"frame {frame!r} is not in the URDF; its frames: {', '.join(names)}")
        chain = set(full.supports[full.frames[full.getFrameId(frame)].parentJoint]) - {0}
        for j in sorted(chain):
            if full.joints[j].nq != 1 or full.joints[j].nv != 1:
                raise ValueError(
                    f"joint {full.names[j]!r} ({full.joints[j].shortname()}) has {full.joints[j].nq} coordinates: "
                    "UrdfRobot handles revolute and prismatic joints (a continuous joint needs limits)"
                )
        if not chain:
            raise ValueError(f"frame {frame!r} is not moved by any joint")
        locked = [j for j in range(1, full.njoints) if j not in chain]
        model = pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full
        for name, x in (("q_min", q_min), ("q_max", q_max), ("qdot_max", qdot_max)):
            if x is not None and np.shape(x) != (model.nq,):
                raise ValueError(f"{name} must have shape ({model.nq},) for the {model.nq} joints, got {np.shape(x)}")
        lower = np.array(model.lowerPositionLimit) if q_min is None else q_min
        upper = np.array(model.upperPositionLimit) if q_max is None else q_max
        speed = np.array(model.velocityLimit, dtype=float)
        speed[~(speed > 0)] = np.inf  # no <limit velocity>: no limit
        speed = speed if qdot_max is None else qdot_max
        mount = np.eye(4) if eMc is None else eMc
        super().__init__(lower, upper, speed, mount, jacobian_frame, float(damping), float(singular_region), mounting)
        self._args = (urdf_path, frame, eMc, jacobian_frame, damping, singular_region, q_min, q_max, qdot_max,
                      mounting)
        self.example_name = None  # set by example()
        self._pin = pin
        self.model = model
        self.data = model.createData()
        self.frame_name = frame
        self.frame_id = model.getFrameId(frame)
        self.joint_names = [model.names[j] for j in range(1, model.njoints)]
        self._reference = pin.LOCAL if jacobian_frame == "end_effector" else pin.LOCAL_WORLD_ALIGNED

    def kinematics(self, q):
        """(world <- end effector (4, 4), end-effector Jacobian (6, n) in jacobian_frame) at q (n,)."""
        pin = self._pin
        pin.computeJointJacobians(self.model, self.data, q)  # also the joint placements
        T = pin.updateFramePlacement(self.model, self.data, self.frame_id)
        return T.homogeneous, pin.getFrameJacobian(self.model, self.data, self.frame_id, self._reference)

    @staticmethod
    def example(name: str, eMc=None, jacobian_frame: str = "end_effector", damping: float = 0.0,
                singular_region: float = 0.0, q_min=None, q_max=None, qdot_max=None,
                mounting: str = "eye_in_hand") -> "UrdfRobot":
        """One of EXAMPLE_ROBOTS ("panda": Franka Panda, 7 joints, camera frame panda_hand; "ur5":
        Universal Robots UR5, 6 joints, tool0) from example-robot-data; the other arguments as UrdfRobot's."""
        robot = UrdfRobot(example_robot_urdf(name), EXAMPLE_ROBOTS[name][1], eMc, jacobian_frame, damping,
                          singular_region, q_min, q_max, qdot_max, mounting)
        robot.example_name = name
        return robot

    def fingerprint(self) -> dict:
        """What determines this robot's kinematics and limits, independent of where its URDF lies: the
        example's name or a digest of the URDF's content, the frame, eMc and the other arguments (the
        config hash of a sweep over it: ibvs.study.scenario.Scenario.key)."""
        path, frame, eMc, *rest, mounting = self._args
        names = ("jacobian_frame", "damping", "singular_region", "q_min", "q_max", "qdot_max")
        urdf = {"example": self.example_name} if self.example_name else \
            {"urdf_sha256": hashlib.sha256(Path(path).read_bytes()).hexdigest()}
        as_list = (lambda x: None if x is None else np.asarray(x, dtype=float).tolist())
        out = {**urdf, "frame": frame, "eMc": as_list(eMc),
               **{k: (as_list(v) if k.startswith("q") else v) for k, v in zip(names, rest)}}
        if mounting != "eye_in_hand":  # only then, so that the eye-in-hand keys of existing sweeps stay
            out["mounting"] = mounting
        return out

    def __reduce__(self):
        if self.example_name:
            return (_rebuilt, (UrdfRobot.example, (self.example_name, *self._args[2:]), self.secondary_task))
        return (_rebuilt, (UrdfRobot, self._args, self.secondary_task))

    def __repr__(self) -> str:
        what = self.example_name or Path(self._args[0]).name
        tail = ", eye_to_hand" if self.mounting == "eye_to_hand" else ""
        return f"UrdfRobot({what!r}, {self.frame_name!r}, {self.dof} joints{tail})"


def _rebuilt(make, args, secondary):
    """Unpickling a UrdfRobot: make(*args), then its secondary task's settings (None: none)."""
    robot = make(*args)
    if secondary is not None:
        robot.set_secondary_task(**secondary)
    return robot
