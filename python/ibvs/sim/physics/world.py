"""The MuJoCo world of the physics testbed: an arm of example-robot-data from its URDF, driven by
joint-velocity actuators, a pinhole camera on its flange (eye-in-hand) or fixed in the world
(eye-to-hand), and a textured target plane, rendered headless.

    world = World(ibvs.sim.cases.arm_robot("panda"), target, testbed_camera(320, 240))
    world.reset(q0)
    world.command(qdot)            # joint velocities for the actuators to track
    world.step_to(0.1)             # physics at 1 kHz up to t = 0.1 s
    image = world.render()         # uint8 (height, width): what the camera sees now

The arm: the URDF of the ibvs.sim.UrdfRobot given (its links' inertias; joint frames, axes and
limits), loaded by MuJoCo's URDF reader without its meshes (the .dae visuals are a format MuJoCo
does not read): the bodies carry no geometry, so the arm neither collides nor shows in the images
(the camera sees only the target). Joints outside the chain to the robot's frame (the Panda's
fingers) are fixed at 0, as UrdfRobot locks them at their neutral position.

Added in code (the URDF gives no motor model), per joint:
- armature 0.1 kg m^2: the rotor inertia reflected through the gearbox (a rotor of ~1e-5 kg m^2
  times a gear ratio of ~100, squared), the order of magnitude of both arms' drives;
- damping 0.1 N m s/rad: viscous friction of the order identified on the Panda (Gaz et al., "Dynamic
  identification of the Franka Emika Panda robot", IEEE RA-L 4(4), 2019: 0.04-0.23 N m s/rad);
- gravity compensation through the actuators (MuJoCo's gravcomp, routed to the joints' actuator
  force, actgravcomp), as the arms' controllers compensate gravity themselves;
- a velocity actuator, torque = kv (qdot_commanded - qdot), kv = M_jj(q_ref) / tau: a first-order
  velocity response of time constant tau (default 10 ms) for joint j alone at the reference posture
  (ibvs.sim.cases.ARMS's goal), where M_jj is the joint-space inertia (armature included);
- the joint's total actuator torque (velocity loop + gravity compensation) limited to the URDF's
  <limit effort>.
Integrator: implicitfast (the actuators' velocity derivative handled implicitly), timestep 1 ms.

The camera: MuJoCo's camera looks along its -z with y up; the ibvs camera frame (x right, y down,
z forward) is it turned by pi about x. Its intrinsics are the CameraModel's (focal lengths in pixels
as focal / sensor size, the principal point at the image centre: u0 = (width - 1) / 2 in OpenCV's
pixel-centre convention, which is OpenGL's width / 2), so CameraModel.project gives the pixels of the
rendered points.

The target: a plane holding the texture ibvs.vision.Renderer draws (dots, tag...; texture columns
along the target's x, rows along its y), seen from the target's -z side, lit by the headlight alone
(ambient 1, no diffuse or specular light: the rendered gray levels are the texture's). Eye-to-hand, it
is a static plane moved with the flange before each render (MuJoCo allows planes in static bodies
only); it has neither mass nor contacts.

The rendered dots' centroids and the tag's corners are within 0.5 px of CameraModel.project (160x120,
320x240; in practice 0.03-0.05 px): tests/python/test_physics.py.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from typing import Optional

import numpy as np

from ..._core import CameraModel
from ..._core import sim as _sim

__all__ = ["World", "testbed_camera", "mujoco_module", "INSTALL"]

#: Installs MuJoCo (ibvs is on no package index: from a clone of its repository).
INSTALL = 'pip install ".[physics]" from the ibvs repository root (headless rendering: apt-get install libosmesa6)'

TIMESTEP = 1e-3  # s: physics at 1 kHz
TAU = 0.01  # s: the velocity loop's time constant at the reference posture
ARMATURE = 0.1  # kg m^2 (see the module's docstring)
DAMPING = 0.1  # N m s / rad
MAX_SPEED = 1e3  # rad/s (m/s): the largest joint velocity command World.command takes
# The camera's turn from MuJoCo's (x right, y up, looking along -z) to ibvs's (x right, y down, z forward).
_FLIP = np.diag([1.0, -1.0, -1.0])


def mujoco_module():
    """The mujoco module (a clear ImportError naming the extra when missing). Headless rendering uses
    OSMesa unless MUJOCO_GL says otherwise (set before the first import of mujoco)."""
    os.environ.setdefault("MUJOCO_GL", "osmesa")
    try:
        import mujoco
    except ImportError as e:
        raise ImportError(f"ibvs.sim.physics needs MuJoCo: {INSTALL}") from e
    return mujoco


def testbed_camera(width: int = 320, height: int = 240, fps: float = 30.0, fov: float = 40.0) -> CameraModel:
    """A pinhole camera (no distortion, square pixels, principal point centred) of `fov` degrees across its
    width (40: the start of ibvs.sim.cases.arm_general_motion keeps every dot 30 px or more inside 320x240),
    width x height pixels, fps frames per second."""
    for name, x in (("width", width), ("height", height)):
        if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or not 8 <= x <= 4096:
            raise ValueError(f"{name} must be an int in [8, 4096], got {x!r}")
    if isinstance(fov, bool) or not isinstance(fov, (int, float)) or not 1.0 <= fov <= 170.0:
        raise ValueError(f"fov must be a number of degrees in [1, 170], got {fov!r}")
    f = width / 2.0 / np.tan(np.radians(fov) / 2.0)
    return CameraModel(f, f, (width - 1) / 2.0, (height - 1) / 2.0, width=width, height=height, fps=fps)


def _check_camera(camera) -> tuple:
    if not isinstance(camera, CameraModel):
        raise TypeError(f"camera must be an ibvs.CameraModel, got {type(camera).__name__}")
    w, h = camera.width, camera.height
    if camera.distortion != "none" or w != int(w) or h != int(h) or w < 1 or h < 1:
        raise ValueError("camera must be a pinhole (distortion 'none') with an integer width and height "
                         f"in pixels, got distortion {camera.distortion!r}, {w} x {h}")
    if abs(camera.u0 - (w - 1) / 2) > 1e-9 * w or abs(camera.v0 - (h - 1) / 2) > 1e-9 * h:
        raise ValueError(f"camera: the principal point must be centred ((width - 1) / 2, (height - 1) / 2) = "
                         f"({(w - 1) / 2}, {(h - 1) / 2}), got ({camera.u0}, {camera.v0})")
    return int(w), int(h)


def _urdf_without_meshes(path: str, frame: str) -> str:
    """The URDF's text with no visual or collision elements, every movable joint off the chain from the
    root to `frame` fixed, and MuJoCo's compiler told to keep each link a body (fusestatic off)."""
    root = ET.parse(path).getroot()
    for link in root.findall("link"):
        for tag in ("visual", "collision"):
            for e in link.findall(tag):
                link.remove(e)
    parent_joint = {j.find("child").get("link"): j for j in root.findall("joint")}
    chain, link = set(), frame
    while link in parent_joint:
        chain.add(parent_joint[link].get("name"))
        link = parent_joint[link].find("parent").get("link")
    for j in root.findall("joint"):
        if j.get("name") not in chain and j.get("type") != "fixed":
            j.set("type", "fixed")
    ext = ET.SubElement(root, "mujoco")
    ET.SubElement(ext, "compiler", fusestatic="false", discardvisual="false")
    return ET.tostring(root, encoding="unicode")


def _quat(R: np.ndarray) -> np.ndarray:
    mujoco = mujoco_module()
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=np.float64).ravel())
    return q


class World:
    """The testbed's MuJoCo model and state (see the module's docstring).

    robot       an ibvs.sim.UrdfRobot (ibvs.sim.cases.arm_robot("panda"), UrdfRobot.example("ur5", eMc)):
                its URDF, frame, mount (eMc, or bMc for mounting "eye_to_hand") and joint limits
    target      an ibvs.sim.Target with its points in its z = 0 plane; its pose is world <- target
                (eye-in-hand), or robot frame <- target (eye-to-hand: the target rides on the flange)
    camera      a pinhole ibvs.CameraModel with its principal point centred (testbed_camera())
    kind        the texture: ibvs.vision.Renderer's kind ("dots", "tag", "disc", "polygon"...), drawn by
                Renderer(camera, target, kind, **renderer_options) (dot_radius, tag_id...; its noise and blur
                are not used: the plate's texture only)
    timestep    s, the physics step (1e-3: 1 kHz; within [1/2000, 1/250])
    tau         s, the velocity loop's time constant at q_ref
    q_ref       joints at which the gains are set (default: ibvs.sim.cases.ARMS's goal for an example arm, else
                the middle of the joint ranges)
    history     s of joint positions kept for rendering the past (a camera's latency)
    """

    def __init__(self, robot, target, camera, kind: str = "dots", timestep: float = TIMESTEP, tau: float = TAU,
                 q_ref=None, history: float = 1.0, **renderer_options) -> None:
        mujoco = mujoco_module()
        from ..urdf import UrdfRobot
        from ...vision import Renderer

        if not isinstance(robot, UrdfRobot):
            raise TypeError(f"robot must be an ibvs.sim.UrdfRobot, got {type(robot).__name__}")
        if not isinstance(target, _sim.Target):
            raise TypeError(f"target must be an ibvs.sim.Target, got {type(target).__name__}")
        self.width, self.height = _check_camera(camera)
        for name, x, lo, hi in (("timestep", timestep, 1 / 2000, 1 / 250), ("tau", tau, 1e-3, 1.0),
                                ("history", history, 0.0, 60.0)):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not lo <= x <= hi:
                raise ValueError(f"{name} must be a number in [{lo:g}, {hi:g}], got {x!r}")
        self.mujoco, self.robot, self.camera, self.target, self.kind = mujoco, robot, camera, target, kind
        n = robot.dof
        if q_ref is None:
            from ..cases import ARMS

            q_ref = ARMS[robot.example_name][0] if robot.example_name in ARMS else \
                (np.asarray(robot.q_min) + np.asarray(robot.q_max)) / 2
        q_ref = np.asarray(q_ref, dtype=float)
        if q_ref.shape != (n,) or not np.isfinite(q_ref).all():
            raise ValueError(f"q_ref must be {n} finite joint positions, got {np.shape(q_ref)}")

        spec = mujoco.MjSpec.from_string(_urdf_without_meshes(robot._args[0], robot.frame_name))
        spec.option.timestep = float(timestep)
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        effort = _efforts(robot._args[0])
        self.joint_names = list(robot.joint_names)
        for name in self.joint_names:
            j = spec.joint(name)
            j.armature, j.damping = ARMATURE, [DAMPING, 0.0, 0.0]  # MuJoCo 4: damping polynomial
            j.actgravcomp = True
            j.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
            j.actfrcrange = [-effort[name], effort[name]]
            a = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            a.set_to_velocity(kv=1.0)  # the gain is set below, from the inertia
        for body in spec.bodies:
            body.gravcomp = 1.0
        vis = spec.visual
        vis.headlight.ambient, vis.headlight.diffuse, vis.headlight.specular = [1, 1, 1], [0, 0, 0], [0, 0, 0]
        vis.global_.offwidth, vis.global_.offheight = self.width, self.height

        # The camera, as MuJoCo's (looking along -z), on the flange or in the world.
        mount = np.asarray(robot.mount, dtype=float)
        flange = spec.body(robot.frame_name)
        eye_in_hand = robot.mounting == "eye_in_hand"
        cam = (flange if eye_in_hand else spec.worldbody).add_camera(name="camera")
        cam.pos, cam.quat = mount[:3, 3], _quat(mount[:3, :3] @ _FLIP)
        cam.resolution = [self.width, self.height]
        cam.sensor_size = [self.width / camera.px, self.height / camera.py]  # in units of the focal length
        cam.focal_length = [1.0, 1.0]

        # The target plane with ibvs.vision.Renderer's texture (level 1 of its pyramid: 1024 texels across).
        drawn = Renderer(camera, target, kind=kind, **renderer_options)
        tex = np.clip(np.rint(drawn._pyramid[1]), 0, 255).astype(np.uint8)
        rows, cols = drawn._pyramid[0].shape
        extent = np.array([cols, rows]) * drawn._d0
        centre = drawn._origin + extent / 2
        t = spec.add_texture(name="target", type=mujoco.mjtTexture.mjTEXTURE_2D, width=tex.shape[1],
                             height=tex.shape[0], nchannel=3)
        t.data = np.repeat(tex[:, :, None], 3, axis=2).tobytes()
        mat = spec.add_material(name="target", texuniform=False, texrepeat=[1, 1], specular=0, shininess=0,
                                reflectance=0)
        mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "target"
        # plane frame: the target's, turned by pi about x (its +z, the visible side, towards the camera)
        P = np.asarray(target.pose, dtype=float) @ np.block([[_FLIP, np.r_[centre, 0.0][:, None]],
                                                              [np.zeros((1, 3)), np.ones((1, 1))]])
        # eye-to-hand: MuJoCo allows planes in static bodies only; the plane (massless, contact-free: no dynamics)
        # is in the world and moved to flange <- plane P each time the scene is posed (_posed)
        self._plane_on_flange = None if eye_in_hand else P
        spec.worldbody.add_geom(name="target", type=mujoco.mjtGeom.mjGEOM_PLANE,
                                size=[extent[0] / 2, extent[1] / 2, 1.0], pos=P[:3, 3], quat=_quat(P[:3, :3]),
                                material="target", contype=0, conaffinity=0, mass=0.0)

        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._qadr = np.array([m.jnt_qposadr[m.joint(name).id] for name in self.joint_names])
        self._vadr = np.array([m.jnt_dofadr[m.joint(name).id] for name in self.joint_names])
        self._act = np.array([m.actuator(name).id for name in self.joint_names])
        self._flange = m.body(robot.frame_name).id
        self._camera = m.camera("camera").id
        self._plane = m.geom("target").id
        # gains: kv = M_jj(q_ref) / tau
        self.data.qpos[self._qadr] = q_ref
        mujoco.mj_forward(m, self.data)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, self.data, M)
        self.kv = np.diag(M)[self._vadr] / tau
        m.actuator_gainprm[self._act, 0] = self.kv
        m.actuator_biasprm[self._act, 2] = -self.kv
        self.effort = np.array([effort[name] for name in self.joint_names])
        self.timestep, self.tau = float(timestep), float(tau)
        self._scratch = mujoco.MjData(m)  # for rendering a past state
        self._renderer = None
        self._stats: Optional[np.ndarray] = None
        #: the ibvs.sim.cases.Case the world was built for by MujocoRobot(case=...), else None
        self.case = None
        #: callables listener(world), each called after every step_to that stepped (a recorder's hook)
        self.listeners: list = []
        self._history = np.zeros((max(2, int(round(history / timestep)) + 1), n + 1))
        self.reset(q_ref)

    # -- state --
    def reset(self, q, dq=None) -> None:
        """Joints at q (n,), speeds dq (default 0), time 0, no command."""
        q = self._vector(q, "q")
        dq = np.zeros_like(q) if dq is None else self._vector(dq, "dq")
        mj = self.mujoco
        mj.mj_resetData(self.model, self.data)
        self.data.qpos[self._qadr], self.data.qvel[self._vadr] = q, dq
        mj.mj_forward(self.model, self.data)
        self._history[:] = np.nan
        self._steps = 0
        self._record()

    def _vector(self, x, name: str) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if x.shape != (self.robot.dof,) or not np.isfinite(x).all():
            raise ValueError(f"{name} must be {self.robot.dof} finite numbers, got shape {x.shape}")
        return x

    @property
    def time(self) -> float:
        """The simulated time, s."""
        return float(self.data.time)

    @property
    def q(self) -> np.ndarray:
        return self.data.qpos[self._qadr].copy()

    @property
    def dq(self) -> np.ndarray:
        return self.data.qvel[self._vadr].copy()

    @property
    def torque(self) -> np.ndarray:
        """Each joint's actuator torque now, N m: velocity loop + gravity compensation, within the effort limit."""
        return self.data.qfrc_actuator[self._vadr].copy()

    def command(self, dq) -> None:
        """The joint velocities (n,) the actuators track from now on: finite, within +-MAX_SPEED (MuJoCo resets a
        simulation whose controls are huge: refused here instead)."""
        dq = self._vector(dq, "dq")
        if not (np.abs(dq) <= MAX_SPEED).all():
            raise ValueError(f"dq must be within +-{MAX_SPEED:g} (rad/s or m/s), got {dq.tolist()}")
        self.data.ctrl[self._act] = dq

    @property
    def commanded(self) -> np.ndarray:
        return self.data.ctrl[self._act].copy()

    # -- time --
    def step_to(self, t: float) -> None:
        """Step the physics until the time reaches t (the first step at or past it, to within 1e-6 of a step);
        nothing when t is past."""
        if not np.isfinite(t):
            raise ValueError(f"t must be finite, got {t!r}")
        n = int(np.ceil((t - self.data.time) / self.timestep - 1e-6))
        for _ in range(max(n, 0)):
            self.mujoco.mj_step(self.model, self.data)
            self._steps += 1
            self._record()
            if self._stats is not None:
                err = self.data.qvel[self._vadr] - self.data.ctrl[self._act]
                st = self._stats
                st[0] += 1
                st[1] += err @ err
                st[2] = max(st[2], np.abs(err).max())
                np.maximum(st[3:], np.abs(self.data.qfrc_actuator[self._vadr]), out=st[3:])
        if n > 0:
            for listener in self.listeners:
                listener(self)

    def monitor(self, on: bool) -> dict:
        """Start (on: True) or stop watching every physics step: the joint velocity tracking error (velocity
        minus command, rad/s) and the actuator torques. Returns what was watched since the start:
        {"steps", "tracking_rms", "tracking_max", "peak_torque" (n,)} (zeros when nothing was)."""
        st = self._stats
        n = self.robot.dof
        out = {"steps": 0, "tracking_rms": 0.0, "tracking_max": 0.0, "peak_torque": np.zeros(n)}
        if st is not None and st[0] > 0:
            out = {"steps": int(st[0]), "tracking_rms": float(np.sqrt(st[1] / (st[0] * n))),
                   "tracking_max": float(st[2]), "peak_torque": st[3:].copy()}
        self._stats = np.zeros(3 + n) if on else None
        return out

    def _record(self) -> None:
        row = self._history[self._steps % len(self._history)]
        row[0] = self.data.time
        row[1:] = self.data.qpos[self._qadr]

    @property
    def history(self) -> float:
        """Seconds of past joint positions kept (q_at reaches that far back)."""
        return (len(self._history) - 1) * self.timestep

    def q_at(self, t: float) -> np.ndarray:
        """The joints at time t (the last step at or before t; ValueError beyond the kept history)."""
        k = self._steps - int(np.ceil((self.data.time - t) / self.timestep - 1e-6))
        if k > self._steps or k < 0 or k < self._steps - len(self._history) + 1:
            raise ValueError(f"t = {t!r} is outside the kept history [{self.data.time - self.history:g}, "
                             f"{self.data.time:g}] s")
        return self._history[k % len(self._history), 1:].copy()

    # -- poses and images --
    # (They pose a scratch MjData: after mj_step, data's positions are those before the step's integration.)
    def _posed(self, q):
        d = self._scratch
        d.qpos[:] = self.data.qpos
        d.qpos[self._qadr] = self.q if q is None else self._vector(q, "q")
        self.mujoco.mj_kinematics(self.model, d)
        self.mujoco.mj_camlight(self.model, d)
        if self._plane_on_flange is not None:
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = d.xmat[self._flange].reshape(3, 3), d.xpos[self._flange]
            T = T @ self._plane_on_flange
            d.geom_xpos[self._plane], d.geom_xmat[self._plane] = T[:3, 3], T[:3, :3].ravel()
        return d

    def flange_pose(self, q=None) -> np.ndarray:
        """world <- the robot's frame (4, 4) at joints q (default the current ones): MuJoCo's kinematics."""
        d = self._posed(q)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = d.xmat[self._flange].reshape(3, 3), d.xpos[self._flange]
        return T

    def camera_pose(self, q=None) -> np.ndarray:
        """world <- camera (4, 4) in ibvs's camera frame (x right, y down, z forward) at joints q (default
        the current ones; eye-to-hand: the camera is fixed)."""
        d = self._posed(q)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = d.cam_xmat[self._camera].reshape(3, 3) @ _FLIP, d.cam_xpos[self._camera]
        return T

    def render(self, q=None) -> np.ndarray:
        """The camera's image (height, width) uint8 with the joints at q (default the current ones)."""
        if self._renderer is None:
            try:
                self._renderer = self.mujoco.Renderer(self.model, self.height, self.width)
            except Exception as e:
                raise RuntimeError(f"MuJoCo cannot render ({e}): headless, set MUJOCO_GL=osmesa before mujoco is "
                                   f"first imported, with OSMesa installed ({INSTALL})") from e
        self._renderer.update_scene(self._posed(q), camera=self._camera)
        return self._renderer.render()[:, :, 0].copy()

    def close(self) -> None:
        """Free the renderer (its OpenGL context); idempotent."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> "World":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return (f"World({self.robot!r}, {self.width}x{self.height} camera, {self.kind}, "
                f"{1 / self.timestep:g} Hz, t = {self.time:g} s)")


def _efforts(path: str) -> dict:
    """Each joint's <limit effort> (N m or N) from the URDF."""
    out = {}
    for j in ET.parse(path).getroot().iter("joint"):
        lim = j.find("limit")
        if lim is not None and lim.get("effort") is not None:
            out[j.get("name")] = float(lim.get("effort"))
    return out
