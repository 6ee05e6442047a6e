"""Any arm in the simulator, from its URDF, with Pinocchio (pip install ".[robots]" from the repository root).

    robot = ibvs.sim.UrdfRobot(urdf_path, "tool0", eMc)
    ibvs.sim.run(servo, camera, target, q_start, q_goal, robot=robot)

Frames: world = the URDF's root (the robot's base); e = the URDF frame `frame`
(a link or fixed-joint frame: the flange or tool); c = the camera, eMc = e <- c
(4x4, metres). The joints are those of the kinematic chain from the root to
`frame` (revolute or prismatic, one coordinate each); every other joint (a
gripper's fingers) is locked at its neutral position. Joint position and speed
limits are the URDF's (<limit lower upper velocity>).

The episode loop (C++) calls kinematics(q) once per frame, holding the GIL.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
import numpy as np

from .._core import sim as _sim

__all__ = ["UrdfRobot", "example_robot_urdf", "EXAMPLE_ROBOTS"]

#: URDFs of example-robot-data used by ibvs: name -> (path under its robots/ directory, flange frame).
EXAMPLE_ROBOTS = {
    "panda": ("panda_description/urdf/panda.urdf", "panda_hand"),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0"),
}


def _pinocchio():
    try:
        import pinocchio
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise ImportError('ibvs.sim.UrdfRobot needs Pinocchio: pip install ".[robots]" from the ibvs '
                          'repository root') from e
    return pinocchio


def example_robot_urdf(name: str) -> str:
    """Path of the URDF of one of EXAMPLE_ROBOTS ("panda", "ur5") installed by the example-robot-data
    package (pip install ".[robots]"). It installs its robots under <prefix>/share/example-robot-data/
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
    raise FileNotFoundError(f'{sub} of example-robot-data not found: pip install ".[robots]" from the ibvs '
                            'repository root')


class UrdfRobot(_sim.Robot):
    """An arm from its URDF for ibvs.sim.run(..., robot=...), backed by Pinocchio.

    urdf_path: the URDF file. frame: the end-effector frame (link) name, where the camera is
    mounted. eMc: (4, 4) end-effector <- camera; None = identity.
    jacobian_frame: the frame kinematics() expresses the Jacobian in, "end_effector" (Pinocchio's
    LOCAL, the default) or "base" (LOCAL_WORLD_ALIGNED): both give the same joint velocities.
    damping, singular_region: the JointMapping's (0, 0: the exact minimum-norm inverse).
    q_min, q_max, qdot_max: None (the URDF's position and velocity limits) or (n,) limits
    overriding them (radians or metres per joint, and per second).

    Pickles by its arguments (the Pinocchio model is rebuilt), so sweeps can send it to
    worker processes.
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
        super().__init__(lower, upper, speed, mount, jacobian_frame, float(damping), float(singular_region))
        self._args = (urdf_path, frame, eMc, jacobian_frame, damping, singular_region, q_min, q_max, qdot_max)
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

    def __reduce__(self):
        return (UrdfRobot, self._args)

    def __repr__(self) -> str:
        return f"UrdfRobot({Path(self._args[0]).name!r}, {self.frame_name!r}, {self.dof} joints)"

