"""A camera on the hand of franky-sim's FR3, rendered by MuJoCo from franky-sim's own scene, for servoing a
FrankyRobot on franky-sim end to end (`ibvs servo` with [source] kind = "franky_scene").

franky-sim steps its MuJoCo scene inside its server process and renders nothing; FrankyScene builds the same
scene here, with franky-sim's own code (franky_sim.mujoco_simulator.MujocoSimulator and add_robot(), as its
server does), adds a camera on the FR3's hand and a target plane of bright dots (what ibvs.vision.DotTracker tracks) through franky-sim's documented
scene-extension hook (elements appended to MujocoSimulator.worldbody before start), and renders it with the
FR3's joints set each frame from the robot's state read through franky (FrankySceneSource). Nothing is
stepped here: the arm's motion is franky-sim's.

The camera's mount is given on the FR3's flange (franky-sim's URDF, assets/fr3_clean.urdf, frame link8:
FrankyRobot's kinematics); MuJoCo's hand body and the URDF's flange are related once, at franky-sim's home
joints (tests/python/test_robot_franky_servo.py checks the two kinematic models agree at other joints).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any, Optional

import numpy as np

from ..finite import finite_within
from ..vision.sources import Frame, FrameSource
from .base import RobotError

__all__ = ["FR3_FLANGE", "FrankyScene", "FrankySceneSource", "franky_sim_urdf"]

#: The flange frame of franky-sim's FR3 URDF (franky_sim_urdf()).
FR3_FLANGE = "link8"
_HOME = (0.0, 0.0, 0.0, -1.57, 0.0, 1.57, 0.785)  # franky-sim's initial joints (franky_sim.DEFAULT_INITIAL_JOINT_POS)
_FLIP = np.diag([1.0, -1.0, -1.0])  # ibvs's camera frame (z forward, y down) <-> MuJoCo's (looks along -z, y up)


def franky_sim_urdf() -> str:
    """The path of franky-sim's FR3 URDF (its assets/fr3_clean.urdf), for ibvs.sim.UrdfRobot(path, "link8")."""
    try:
        import franky_sim
    except ImportError as e:
        raise ImportError("franky-sim is not installed (pip install franky-sim; the test extra has it)") from e
    return str(Path(franky_sim.__file__).parent / "assets" / "fr3_clean.urdf")


def _mujoco():
    """mujoco, rendering headless through OSMesa unless MUJOCO_GL says otherwise (as ibvs.sim.physics does)."""
    os.environ.setdefault("MUJOCO_GL", "osmesa")
    import mujoco

    return mujoco


def _quat(R: np.ndarray) -> np.ndarray:
    """MuJoCo's quaternion (w, x, y, z) of a rotation matrix."""
    q = np.zeros(4)
    _mujoco().mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).ravel())
    return q


def _fmt(x) -> str:
    return " ".join(f"{float(v):.17g}" for v in np.ravel(x))


class FrankyScene:
    """franky-sim's FR3 scene with a hand camera and a black target plane of white dots (module docstring).

    kinematics: the FR3's UrdfRobot on franky-sim's URDF (frame link8) whose mount (flange <- camera, eMc) places
    the camera. camera: a pinhole ibvs.CameraModel with its principal point centred (ibvs.sim.physics's
    testbed_camera()). points: (N, 3) the dots' centres in the target's z = 0 plane (m); target_pose: world <-
    target (4, 4); dot_radius: m; plane: the white plane's half size (m).
    """

    def __init__(self, kinematics: Any, camera: Any, points, target_pose, dot_radius: float = 0.008,
                 plane: float = 0.25) -> None:
        mujoco = _mujoco()
        from franky_sim.mujoco_simulator import MujocoSimulator

        self.kinematics, self.camera = kinematics, camera
        self.width, self.height = int(camera.width), int(camera.height)
        if abs(camera.px - camera.py) > 1e-9 * camera.px or abs(camera.u0 - (self.width - 1) / 2) > 1e-9 \
                or abs(camera.v0 - (self.height - 1) / 2) > 1e-9:
            raise ValueError("camera must have square pixels and its principal point centred (MuJoCo renders so)")
        P = np.asarray(points, dtype=float)
        if P.ndim != 2 or P.shape[1] != 3 or not finite_within(P, np.inf) or np.any(P[:, 2] != 0):
            raise ValueError("points must be (N, 3) finite dot centres in the target's z = 0 plane")
        T_wo = np.asarray(target_pose, dtype=float)
        if T_wo.shape != (4, 4) or not np.isfinite(T_wo).all():
            raise ValueError("target_pose must be a finite (4, 4) world <- target pose")

        sim = MujocoSimulator()
        sim.add_robot()  # robot0_, at the origin, as franky-sim's server builds it
        # hand <- flange, from the two models at franky-sim's home joints
        model0 = mujoco.MjModel.from_xml_string(ET.tostring(sim.scene, encoding="unicode"))
        data0 = mujoco.MjData(model0)
        self._qadr = np.array([model0.jnt_qposadr[model0.joint(f"robot0_fr3_joint{i}").id] for i in range(1, 8)])
        data0.qpos[self._qadr] = _HOME
        mujoco.mj_kinematics(model0, data0)
        hand = model0.body("robot0_hand").id
        T_wh = np.eye(4)
        T_wh[:3, :3], T_wh[:3, 3] = data0.xmat[hand].reshape(3, 3), data0.xpos[hand]
        T_we, _ = kinematics.kinematics(np.array(_HOME))
        hMc = np.linalg.inv(T_wh) @ np.asarray(T_we) @ np.asarray(kinematics.mount, dtype=float)

        # the camera on the hand (MuJoCo's camera looks along its -z, y up), the target in the world
        hand_el = next(e for e in sim.worldbody.iter("body") if e.get("name") == "robot0_hand")
        fovy = math.degrees(2 * math.atan((self.height / 2.0) / camera.py))
        ET.SubElement(hand_el, "camera", name="ibvs_camera", pos=_fmt(hMc[:3, 3]), quat=_fmt(_quat(hMc[:3, :3] @ _FLIP)),
                      fovy=f"{fovy:.17g}", resolution=f"{self.width} {self.height}")
        asset = sim.scene.find("asset")
        ET.SubElement(asset, "material", name="ibvs_white", rgba="1 1 1 1", emission="1", specular="0",
                      shininess="0", reflectance="0")
        ET.SubElement(asset, "material", name="ibvs_black", rgba="0 0 0 1", emission="0", specular="0",
                      shininess="0", reflectance="0")
        body = ET.SubElement(sim.worldbody, "body", name="ibvs_target", pos=_fmt(T_wo[:3, 3]),
                             quat=_fmt(_quat(T_wo[:3, :3])))
        # the plane's visible face towards the camera (the target's -z side: the camera looks along +z at it)
        ET.SubElement(body, "geom", name="ibvs_plane", type="box", size=f"{plane} {plane} 0.0005", pos="0 0 0.001",
                      material="ibvs_black", contype="0", conaffinity="0", mass="0")
        for k, p in enumerate(P):
            ET.SubElement(body, "geom", name=f"ibvs_dot{k}", type="cylinder", size=f"{dot_radius} 0.0002",
                          pos=_fmt([p[0], p[1], -0.0002]), material="ibvs_white", contype="0", conaffinity="0",
                          mass="0")
        for light in sim.worldbody.iter("light"):
            light.set("castshadow", "false")  # no shadow of the arm on the target
        vis = sim.scene.find("visual")
        ET.SubElement(vis, "global", offwidth=str(self.width), offheight=str(self.height))
        self.model = mujoco.MjModel.from_xml_string(ET.tostring(sim.scene, encoding="unicode"))
        self.data = mujoco.MjData(self.model)
        self.data.qpos[self._qadr] = _HOME
        self._mujoco = mujoco
        self._camera_id = self.model.camera("ibvs_camera").id
        self._renderer = None

    def set_joints(self, q) -> None:
        """Pose the FR3 at joints q (7,) (kinematics only)."""
        self.data.qpos[self._qadr] = np.asarray(q, dtype=float)
        self._mujoco.mj_kinematics(self.model, self.data)
        self._mujoco.mj_camlight(self.model, self.data)

    def camera_pose(self, q) -> np.ndarray:
        """world <- camera (4, 4, ibvs's camera frame) in the MuJoCo scene at joints q."""
        self.set_joints(q)
        T = np.eye(4)
        T[:3, :3] = self.data.cam_xmat[self._camera_id].reshape(3, 3) @ _FLIP
        T[:3, 3] = self.data.cam_xpos[self._camera_id]
        return T

    def render(self, q) -> np.ndarray:
        """The hand camera's grey image (height, width) uint8 with the FR3 at joints q."""
        if self._renderer is None:
            try:
                self._renderer = self._mujoco.Renderer(self.model, self.height, self.width)
            except Exception as e:
                raise RuntimeError(f"MuJoCo cannot render ({e}): headless, set MUJOCO_GL=osmesa (libosmesa6) "
                                   "before mujoco is first imported") from e
        self.set_joints(q)
        self._renderer.update_scene(self.data, camera=self._camera_id)
        return self._renderer.render()[:, :, 0].copy()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


class FrankySceneSource(FrameSource):
    """Frames of a FrankyScene at `rate` Hz, the FR3's joints read from `robot` (a FrankyRobot) at each frame's
    time on the robot's clock (its Clock: clock = "robot" for franky-sim); the stamp is that time."""

    def __init__(self, robot: Any, scene: FrankyScene, rate: Optional[float] = None) -> None:
        self.robot, self.scene = robot, scene
        self.camera = scene.camera
        self.rate = float(scene.camera.fps if rate is None else rate)
        if not (math.isfinite(self.rate) and self.rate > 0):
            raise ValueError(f"rate must be a positive number (Hz), got {rate!r}")
        self._start: Optional[float] = None
        self._k = 0

    def open(self) -> None:
        self._start = self.robot.now()
        self._k = 0

    def read(self, timeout: float) -> Optional[Frame]:
        if self._start is None:
            raise RuntimeError("FrankySceneSource: open() it first")
        t = self._start + self._k / self.rate
        now = self.robot.now()
        if t > now + timeout:
            return None
        if self.robot.clock is not None:
            self.robot.clock.sleep_until(t)
        try:
            state = self.robot.state()
        except RobotError:
            return None  # no frame: the loop's watchdogs and its own state read decide
        image = self.scene.render(state.q)
        frame = Frame(image, state.stamp, self._k)
        self._k = max(self._k + 1, int(math.floor((state.stamp - self._start) * self.rate)) + 1)
        return frame

    def close(self) -> None:
        self.scene.close()
