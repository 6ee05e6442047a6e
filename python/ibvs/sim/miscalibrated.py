"""The simulator's calibration errors: a robot whose controller believes a wrong hand-eye transform
(MiscalibratedRobot), and a camera whose controller believes wrong intrinsics (MiscalibratedCamera).

A robot whose controller believes a wrong hand-eye transform: the camera moves with the robot's true eMc while the
episode's JointMapping turns the servo's twist into joint velocities with another one (the calibration's estimate).

    robot = ibvs.sim.UrdfRobot.example("panda", eMc_true)
    believed = ibvs.sim.MiscalibratedRobot(robot, eMc_estimate)
    ibvs.sim.run(servo, camera, target, q_start, q_goal, robot=believed)    # the camera where eMc_true puts it

How (no change to the C++ loop, which has one mount per robot): this robot's mount is the controller's eMc_hat, and
its kinematics(q) reports the end effector at T_we eMc eMc_hat^-1, so that the camera the loop places at
kinematics(q) times the mount is the true one (T_we eMc), with the true end-effector Jacobian in the end-effector
frame. The mapping then computes qdot = (cVe_hat eJe)^+ v, as a controller with eMc_hat does; the camera moves
with cVe eJe qdot, which is v only when eMc_hat = eMc. camera(q) and the episode's poses are the true camera's;
jacobian(q) and joint_velocity(q, v) are the controller's (with eMc_hat).

A camera whose controller believes wrong intrinsics (focal lengths, principal point, distortion):

    true = ibvs.CameraModel.from_opencv(K, dist, 640, 480)
    believed = ibvs.CameraModel.from_opencv(K_hat, None, 640, 480)     # e.g. the distortion ignored
    ibvs.sim.run(servo, true, target, start, goal, vision=ibvs.sim.MiscalibratedCamera(true, believed))

How (no change to the C++ loop, which normalises the sensor's pixels with the episode's camera): the sensor reports,
for the true pixels p, the pixels true.project(believed.normalize(p)), which the episode's (true) model normalises
to believed.normalize(p): the controller sees every pixel through the believed model, the goal's included (teach by
showing), and so does everything computed from its points (the pose depth mode's ibvs.PlanarPose estimate, of every
frame and of the goal: the goal pose PBVS, 2.5-D and the moments aim at; the moments, the 2.5-D reference point).
Whether a point is in the image is judged on its true pixel.
"""

from __future__ import annotations

import numpy as np

from .._core import CameraModel
from .._core import sim as _sim
from ..calibration.rigid import as_pose_stack, invert

__all__ = ["MiscalibratedCamera", "MiscalibratedRobot"]


class MiscalibratedRobot(_sim.Robot):
    """robot (any ibvs.sim.Robot: a UrdfRobot, the Gantry) driven by a controller that believes its camera mount is
    controller_mount (4x4, end effector <- camera) while the camera stays where robot.mount puts it. The joint
    limits, speed limits, damping and singular region are robot's; the Jacobian is passed to the mapping in the
    end-effector frame. Pickles by its arguments (sweeps' worker processes).

    true_mount: robot.mount (eMc). controller_mount: eMc_hat, the mapping's (also .mount).
    """

    def __init__(self, robot, controller_mount) -> None:
        if not isinstance(robot, _sim.Robot):
            raise TypeError(f"robot must be an ibvs.sim.Robot (a UrdfRobot, a Gantry...), got {type(robot).__name__}")
        if isinstance(robot, MiscalibratedRobot):
            robot = robot.robot  # the believed mount replaces the earlier one
        if robot.mounting != "eye_in_hand":
            raise ValueError("robot must carry its camera (mounting 'eye_in_hand'): MiscalibratedRobot models a wrong eMc, "
                             f"got mounting {robot.mounting!r}")
        eMc_hat = as_pose_stack([controller_mount], "controller_mount")[0]
        super().__init__(robot.q_min, robot.q_max, robot.qdot_max, eMc_hat, "end_effector", robot.damping,
                         robot.singular_region)
        self.robot = robot
        self.true_mount = np.array(robot.mount, dtype=float)
        self.controller_mount = eMc_hat
        self._shift = self.true_mount @ invert(eMc_hat)  # e <- e_hat: the reported end effector's place on the true one
        self._base_frame = robot.frame == "base"

    def kinematics(self, q):
        """(T_we eMc eMc_hat^-1, the true end-effector Jacobian (6, n) in the end-effector frame) at q (n,)."""
        T, J = self.robot.kinematics(q)
        T, J = np.asarray(T, dtype=float), np.asarray(J, dtype=float)
        if self._base_frame:  # bJe -> eJe: both halves rotated into the end-effector frame
            Rt = T[:3, :3].T
            J = np.vstack([Rt @ J[:3], Rt @ J[3:]])
        return T @ self._shift, J

    def __reduce__(self):
        return (MiscalibratedRobot, (self.robot, self.controller_mount))

    def __repr__(self) -> str:
        return f"MiscalibratedRobot({self.robot!r})"


class MiscalibratedCamera(_sim.Sensor):
    """The measurement of a camera (the true model, the one given to ibvs.sim.run) whose controller believes the
    model `believed` (another ibvs.CameraModel: wrong focal lengths, principal point or distortion): pass it as
    ibvs.sim.run(..., camera=camera, vision=MiscalibratedCamera(camera, believed)). The servo's points are then
    believed.normalize(p) for every true pixel p (see the module docstring). A pixel the believed model cannot
    normalise, or whose normalisation the true model cannot project (beyond either's max_radius), is reported lost
    (NaN: the episode ends as lost_feature). noise: std (pixels) of Gaussian noise added to the true pixels but at
    the goal, seeded by the run's seed.
    """

    def __init__(self, camera, believed, noise: float = 0.0) -> None:
        super().__init__()
        for name, c in (("camera", camera), ("believed", believed)):
            if not isinstance(c, CameraModel):
                raise TypeError(f"{name} must be an ibvs.CameraModel, got {type(c).__name__}")
        if isinstance(noise, bool) or not isinstance(noise, (int, float, np.integer, np.floating)):
            raise TypeError(f"noise must be a number (pixels), got {type(noise).__name__}")
        if not (np.isfinite(noise) and noise >= 0.0):
            raise ValueError(f"noise must be finite and >= 0 (pixels), got {noise!r}")
        self.camera, self.believed, self.noise = camera, believed, float(noise)
        self._rng = np.random.default_rng(0)

    def reset(self, seed: int) -> None:
        self._rng = np.random.default_rng(seed)

    def measure(self, frame: int, pose, projected, twist) -> np.ndarray:
        """(N, 2) pixels: true.project(believed.normalize(projected (+ noise))), NaN where either model cannot map."""
        p = np.array(projected, dtype=float)
        if self.noise > 0.0 and frame >= 0:
            p += self._rng.normal(0.0, self.noise, p.shape)
        return self.camera.project(self.believed.normalize(p, invalid="nan"), invalid="nan")

    def __reduce__(self):
        return (MiscalibratedCamera, (self.camera, self.believed, self.noise))

    def __repr__(self) -> str:
        return f"MiscalibratedCamera({self.camera!r}, believed={self.believed!r})"
