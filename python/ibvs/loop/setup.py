"""From a checked config (ibvs.loop.config.load) to a running loop: the clock, the camera, the robot
(ibvs.robot.open_robot), the frame source, the servo core (ibvs.ros.ServoNodeCore) and the latency
predictor, in the order that moves nothing before everything is checked:

    setup = Setup(load("servo.toml"))   # builds the clock, the camera, the robot driver, the source (nothing opened)
    setup.connect()                     # connects the robot and opens the source (errors: unreachable...)
    report = setup.loop().run()         # the servo loop; the robot stopped and disconnected at its end

The camera twist is mapped to joint velocities with the robot's kinematics model (Robot.kinematics: an
ibvs.sim robot such as ibvs.sim.UrdfRobot or ibvs.sim.Gantry): JointMapping with the camera's own
Jacobian, jacobian(q) (camera twist = J(q) qdot).
"""

from __future__ import annotations

import inspect
import math
from typing import Any, Dict, Optional

import numpy as np

from .clock import Clock, RealClock, SimClock
from .config import LoopConfig
from .latency import FeaturePredictor
from .servo_loop import ServoLoop

__all__ = ["SIM_MODELS", "Setup", "camera_of", "open_source"]


def camera_of(table, where: str):
    """An ibvs.sim.Camera from a [camera] table (its keywords, or from = a static constructor)."""
    from .. import sim

    kw = dict(table)
    ctor = sim.Camera
    if "from" in kw:
        name = kw.pop("from")
        choices = sorted(n for n, v in vars(sim.Camera).items() if not n.startswith("_") and callable(v)
                         and isinstance(inspect.getattr_static(sim.Camera, n), staticmethod))
        if name not in choices:
            raise ValueError(f"{where} [camera] from: {name!r} is not one of {', '.join(choices)}")
        ctor = getattr(sim.Camera, name)
    try:
        return ctor(**kw)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where} [camera]: {e}") from None


def _target(table, where: str):
    from .. import sim
    from .config import pose_of

    kw = dict(table)
    if "pose" in kw:
        kw["pose"] = pose_of(kw["pose"], f"{where} [target] pose")
    try:
        return sim.Target(**kw)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where} [target]: {e}") from None


#: The kinematic simulator's robots a config can name ([robot] kind = "sim", model = ...).
SIM_MODELS = ("gantry", "free", "panda", "ur5")


def _sim_options(options: Dict[str, Any], where: str) -> Dict[str, Any]:
    """[robot] kind = "sim": model = "gantry" (ibvs.sim.Gantry.afma6), "panda" / "ur5" (example-robot-data's
    arms with the camera of ibvs.sim.cases) or "free" (the free-flying camera, at pose = { t, r_deg });
    the other keys go to ibvs.robot's SimRobot as they are (q0, rate, hold...)."""
    from .. import sim
    from .config import pose_of

    out = dict(options)
    model = out.pop("model", "gantry")
    if model not in SIM_MODELS:
        raise ValueError(f"{where} model: must be one of {', '.join(SIM_MODELS)}, got {model!r}")
    if model == "free":
        if "pose" in out:
            out["pose"] = pose_of(out["pose"], f"{where} pose")
        return out
    out["robot"] = sim.Gantry.afma6() if model == "gantry" else sim.cases.arm_robot(model)
    return out


def _kinematics_option(options: Dict[str, Any], where: str) -> Dict[str, Any]:
    """A hardware driver's kinematics = "panda" / "ur5" (example-robot-data's arm, ibvs.sim.cases.arm_robot)
    or "gantry", with mount = { t, r_deg } its camera's eMc (default the cases' mount)."""
    from .. import sim
    from .config import pose_of

    out = dict(options)
    name = out.pop("kinematics")
    mount = out.pop("mount", None)
    if name not in SIM_MODELS or name == "free":
        raise ValueError(f"{where} kinematics: must be one of gantry, panda, ur5, got {name!r}")
    eMc = None if mount is None else pose_of(mount, f"{where} mount")
    if name == "gantry":
        model = sim.Gantry.afma6() if eMc is None else sim.Gantry.afma6().with_mount(eMc)
    else:
        model = sim.cases.arm_robot(name, eMc)
    out["kinematics"] = model
    return out


def open_source(kind: str, table: Dict[str, Any], camera, clock: Clock, base, pose=None, target=None,
                where: str = "[source]", robot=None):
    """The FrameSource of a [source] table (not opened)."""
    from ..vision import sources

    t = dict(table)
    t.pop("kind", None)
    if kind == "video":
        return sources.VideoFile(base / t["path"], clock=clock, rate=t.get("rate"), camera=camera)
    if kind == "capture":
        dev = t.pop("device")
        dev = str(base / dev) if isinstance(dev, str) and "!" not in dev and not dev.startswith("/dev/") and \
            (base / dev).exists() else dev
        return sources.OpenCVCapture(dev, clock=clock, camera=camera, **t)
    if kind == "mujoco":  # the physics testbed's camera, in the world of the mujoco robot
        import importlib  # by name, as ibvs.robot's registry opens the mujoco robot: the physics extra's module

        MujocoCamera = importlib.import_module("ibvs.sim.physics").MujocoCamera
        if robot is None or getattr(robot, "world", None) is None:
            raise ValueError(f"{where}: a mujoco source needs the mujoco robot ([robot] kind = \"mujoco\")")
        return MujocoCamera(robot.world, rate=t.get("rate"), latency=float(t.get("latency", 0.0)))
    if kind == "franky_scene":  # franky-sim's own MuJoCo scene, a camera on the FR3's hand (ibvs.robot.franky_scene)
        from ..robot.franky_scene import FrankyScene, FrankySceneSource

        if robot is None or getattr(robot, "kinematics", None) is None or camera is None or target is None:
            raise ValueError(f"{where}: a franky_scene source needs [camera], [target] and the franky robot with its "
                             "kinematics (urdf = \"franky-sim\", mount)")
        try:
            scene = FrankyScene(robot.kinematics, camera, target.points, target.pose,
                                **({"dot_radius": float(t["dot_radius"])} if "dot_radius" in t else {}))
        except (TypeError, ValueError) as e:
            raise ValueError(f"{where}: {e}") from None
        return FrankySceneSource(robot, scene, rate=t.get("rate"))
    if kind == "bag":
        t.setdefault("replay", True)  # at the recorded pace, on the loop's clock
        return sources.RosImageSource(base / t.pop("path"), clock=clock, **t)
    # render: ibvs.vision.Renderer of the target at the robot's camera pose
    from ..vision import Renderer

    rkw = {k: t.pop(k) for k in ("dot_radius", "noise", "blur") if k in t}
    try:
        renderer = Renderer(camera, target, kind=t.pop("render", "dots"), seed=int(t.get("seed", 0)), **rkw)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: {e}") from None
    return sources.RendererSource(renderer, pose, clock=clock, rate=float(t.get("rate", camera.fps)),
                                  latency=float(t.get("latency", 0.0)), drop=float(t.get("drop", 0.0)),
                                  seed=int(t.get("seed", 0)), stop_after=t.get("stop_after"))


class Setup:
    """Everything a config names, built in order (see the module docstring)."""

    def __init__(self, config: LoopConfig, robot=None):
        self.config = config
        doc, where, base = config.doc, str(config.path), config.path.parent
        self.clock: Clock = SimClock() if config.clock == "sim" else RealClock()
        self.camera = camera_of(doc["camera"], where) if "camera" in doc else None
        self.robot = robot if robot is not None else self._open_robot(doc["robot"], where)
        if config.clock == "robot" and getattr(self.robot, "clock", None) is not None:
            self.clock = self.robot.clock  # the robot's world (a physics testbed) keeps the time
        self.kinematics = getattr(self.robot, "kinematics", None)
        if self.kinematics is None or not hasattr(self.kinematics, "jacobian"):
            raise ValueError(f"{where} [robot]: the {doc['robot']['kind']!r} robot has no kinematics model "
                             f"(jacobian(q): the camera Jacobian): the loop cannot map the camera twist to its joints")
        src = doc["source"]
        self.target = _target(doc["target"], where) if src["kind"] in ("render", "franky_scene") else None
        if src["kind"] in ("render", "franky_scene") and self.camera is None:
            raise ValueError(f"{where}: a {src['kind']} source needs a [camera] table")
        self.source = open_source(src["kind"], src, self.camera, self.clock, base, pose=self._camera_pose,
                                  target=self.target, where=f"{where} [source]", robot=self.robot)
        self.core = None
        self.predictor: Optional[FeaturePredictor] = None

    def _open_robot(self, table, where: str):
        try:
            from ..robot import open_robot
        except ImportError as e:
            raise ValueError(f"{where} [robot]: ibvs.robot is not available ({e})") from None
        options = {k: v for k, v in table.items() if k != "kind"}
        if table["kind"] == "sim":
            options = _sim_options(options, f"{where} [robot]")
        elif isinstance(options.get("kinematics"), str):
            options = _kinematics_option(options, f"{where} [robot]")
        try:
            return open_robot(table["kind"], clock=self.clock, **options)
        except TypeError:
            try:
                return open_robot(table["kind"], **options)
            except (TypeError, ValueError) as e:
                raise ValueError(f"{where} [robot]: {e}") from None
        except ValueError as e:
            raise ValueError(f"{where} [robot]: {e}") from None

    def _camera_pose(self) -> np.ndarray:
        """world <- camera at the robot's joints now (for the render source)."""
        return np.asarray(self.kinematics.camera(self.robot.state().q))

    def connect(self) -> None:
        """Connect the robot, open the source, build the servo core (may raise: the robot unreachable,
        the device missing)."""
        self.robot.connect()
        self.source.open()
        camera = self.camera if self.camera is not None else getattr(self.source, "camera", None)
        where = str(self.config.path)
        if camera is None:
            raise ValueError(f"{where}: the camera is unknown: give a [camera] table (the source has no "
                             f"camera_info)")
        self.core = self._core(camera)

    def _core(self, camera):
        from ..ros.node import NodeParams, ServoNodeCore

        doc, o = self.config.doc, self.config.options
        tr, sv = doc["tracker"], doc["servo"]
        n = self.robot.n_joints
        names = list(getattr(self.robot, "joint_names", None) or [f"joint{i + 1}" for i in range(n)])
        initial = tr.get("initial_pixels")
        if initial is None and self.target is not None:  # the rendered target's points at the start pose
            T_cw = np.linalg.inv(self._camera_pose())
            world = np.asarray(self.target.world_points())
            world = world.T if world.shape[0] == 3 and world.shape[1] != 3 else world
            P = (T_cw[:3, :3] @ world.T).T + T_cw[:3, 3]
            initial = camera.project(P[:, :2] / P[:, 2:3])
        params = NodeParams(
            desired_pixels=tr["desired_pixels"], depth=sv.get("depth", 0.5), scheme=sv.get("scheme", "polar"),
            gain=float(sv.get("gain", 0.5)), damping=float(sv.get("damping", 0.0)),
            max_linear_speed=float(sv.get("max_linear_speed", 0.1)),
            max_angular_speed=float(sv.get("max_angular_speed", 0.5)), tracker=tr.get("kind", "dots"),
            initial_pixels=initial, tag_ids=tuple(tr.get("tag_ids", (0,))), output="joint_velocities",
            eMc=np.eye(4), joint_names=names, max_joint_speed=sv.get("max_joint_speed"),
            lost_timeout=float(sv.get("lost_timeout", 0.2)), fps=float(camera.fps),
            turn=float(sv.get("turn", math.nan)))
        self.predictor = FeaturePredictor(o.latency, o.lag, kinematics=self.kinematics) if o.latency > 0 else None
        clock = self.clock
        core = ServoNodeCore(params, clock=lambda: int(round(clock.now() * 1e9)),
                             jacobian=lambda q: self.kinematics.jacobian(q), predictor=self.predictor)
        core.set_camera(camera)
        return core

    def loop(self, signals: bool = True) -> ServoLoop:
        """The ServoLoop of this setup (after connect())."""
        if self.core is None:
            self.connect()
        self.config.options.signals = signals
        return ServoLoop(self.source, self.robot, self.core, self.clock, self.config.options, self.predictor,
                         config=self.config.doc)

    def close(self) -> None:
        """Stop and disconnect the robot, close the source (never raises)."""
        for f in (getattr(self.robot, "stop", None), getattr(self.robot, "disconnect", None), self.source.close):
            try:
                if f is not None:
                    f()
            except Exception:  # noqa: BLE001
                pass
