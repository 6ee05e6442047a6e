"""ibvs.study.scenario: the set-up a sweep runs, from Python or from a TOML scenario file.

A Scenario is a camera, a target (any points, planar or not), the goal, a robot (None for a
free-flying camera, the gantry, an arm from its URDF: ibvs.sim.UrdfRobot, or any robot ibvs.sim.run
accepts), a distribution of start set-ups around the goal and the control settings:

    import numpy as np
    from ibvs import sim
    from ibvs.study.scenario import Scenario

    mine = Scenario(camera=sim.Camera(800, 800, 320, 240, width=640, height=480, fps=30),
                    target=sim.Target([[-.05, -.05, 0], [.05, -.05, 0], [.05, .05, 0], [-.05, .05, .02]],
                                      sim.pose(t=(0, 0, 0.5))),
                    goal=np.eye(4), ranges={"rz_deg": (0, 180), "tz": (-0.1, 0.1), "noise": (0, 0.5)},
                    depth="estimated", name="mine")

    ibvs.study.sweep.sweep("mine.csv", scenario=mine, episodes=200)

or `ibvs sweep --scenario mine.toml --out mine.csv` with the same in a file (see
docs/sweeps.md and load()).

Each start is an offset from the goal in the goal camera's frame: a rotation (rz_deg about the
optical axis after a tilt of tilt_deg about an image-plane axis at tilt_dir_deg from x) and a
translation (tx, ty, tz, metres), with measurement noise (std, measurement units: pixels for
a pixel camera), latency (frames, an integer) and depth_scale (a factor on the depth the
controller is given). `ranges` gives each a uniform range (lo, hi), lo == hi fixes it; the
parameters not given stay at 0 (depth_scale at 1). `translation` / `rotation` are callables
instead: translation(rng) -> (tx, ty, tz) and rotation(rng) -> a 3x3 rotation or (rx, ry, rz)
radians, given a numpy Generator seeded by (seed, index); module-level functions, so that
process pools and Dask can pickle them. The rows record the resulting rz_deg, tilt_deg,
tilt_dir_deg, tx, ty, tz in both cases.

With a robot, the goal is its joints or a camera pose, and each start is the camera's pose as above,
turned into joints by ibvs.sim.solve_ik from the goal joints; a start it cannot reach within the joint
limits runs no episode (start_outcome says "unreachable"; the sweep's rows keep it).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib
import inspect
import json
import math
import os
import types
from pathlib import Path
from typing import Any, Callable, Mapping, Optional

import numpy as np

from .. import sim
from ..sim.poses import rotation_matrix
from ..sim.result import measurement_unit

__all__ = ["ANGLE_WRAPS", "DEPTH_MODES", "GOAL_POSES", "LIMITS", "PARAMETERS", "ROBOTS", "Scenario", "builtin", "load"]

#: The parameters of an episode's start set-up, in the order they are drawn.
PARAMETERS = ("rz_deg", "tilt_deg", "tilt_dir_deg", "tx", "ty", "tz", "noise", "depth_scale", "latency")
#: Value of a parameter without a range.
DEFAULTS = {"rz_deg": 0.0, "tilt_deg": 0.0, "tilt_dir_deg": 0.0, "tx": 0.0, "ty": 0.0, "tz": 0.0,
            "noise": 0.0, "depth_scale": 1.0, "latency": 0}
#: The values each parameter may take (degrees, metres, measurement units, factor, frames).
LIMITS = {"rz_deg": (-360.0, 360.0), "tilt_deg": (0.0, 180.0), "tilt_dir_deg": (-360.0, 720.0),
          "tx": (-1e3, 1e3), "ty": (-1e3, 1e3), "tz": (-1e3, 1e3), "noise": (0.0, 1e4),
          "depth_scale": (1e-3, 1e3), "latency": (0, 1000)}
#: The depth given to the controller (ibvs.sim.run's depth).
DEPTH_MODES = ("exact", "pose", "desired", "estimated")
#: The angle wraps of ibvs.Servo (its angle_wrap option).
ANGLE_WRAPS = ("consistent", "per_point")
#: The goal pose of the PBVS, 2.5-D and moments blocks (ibvs.sim.run's goal_pose).
GOAL_POSES = ("taught", "given")
#: The error-norm tolerance of a scenario that sets neither tolerance nor tolerance_px.
DEFAULT_TOLERANCE = 1e-5
#: Longest episode (s) and largest gain (1/s) a scenario may ask for.
MAX_DURATION = 3600.0
MAX_GAIN = 1e4


# --------------------------------------------------------------------------- robots


def _gantry(q_min=None, q_max=None, qdot_max=None):
    """The Afma6-like gantry (ibvs.sim.Gantry.afma6), with other joint limits if given."""
    g = sim.Gantry.afma6()
    return g if q_min is None and q_max is None and qdot_max is None else g.with_limits(q_min, q_max, qdot_max)


def _urdf(urdf=None, example=None, frame=None, eMc=None, q_min=None, q_max=None, qdot_max=None, damping=0.0,
          singular_region=0.0):
    """An arm from its URDF (ibvs.sim.UrdfRobot, Pinocchio): `urdf` (a path) and `frame` (where the camera
    is mounted), or `example` ("panda" or "ur5" of example-robot-data; frame: its flange unless given);
    eMc: flange <- camera (4x4; identity if absent); limits and the JointMapping's damping as UrdfRobot's."""
    if (urdf is None) == (example is None):
        raise ValueError("give urdf (a URDF file) or example (" + " or ".join(map(repr, sim.cases.ARMS)) +
                         "), one of them")
    options = dict(eMc=eMc, damping=damping, singular_region=singular_region, q_min=q_min, q_max=q_max,
                   qdot_max=qdot_max)
    if example is not None:
        if not isinstance(example, str) or example not in sim.cases.ARMS:
            raise ValueError(f"example must be one of {', '.join(map(repr, sim.cases.ARMS))}, got {example!r}")
        if frame is not None and frame != sim.urdf.EXAMPLE_ROBOTS[example][1]:
            return sim.UrdfRobot(sim.example_robot_urdf(example), frame, **options)
        return sim.UrdfRobot.example(example, **options)
    if frame is None:
        raise ValueError("frame: the URDF frame the camera is mounted on (e.g. tool0) is required with urdf")
    if not isinstance(urdf, (str, os.PathLike)):
        raise ValueError(f"urdf must be a path, got {type(urdf).__name__}")
    if not Path(urdf).is_file():
        raise ValueError(f"urdf: no such file: {urdf}")
    return sim.UrdfRobot(urdf, frame, **options)


_urdf.path_keys = ("urdf",)  # resolved against the scenario file's directory
_urdf.pose_keys = ("eMc",)  # { t = [...], r = [...] } or r_deg, as every pose of a scenario file

#: Robot kinds a scenario file may name ([robot] kind = "..."): kind -> factory(**other keys). The
#: factory's parameters are the table's keys; its attributes path_keys (paths relative to the file) and
#: pose_keys (pose tables) say how some are read. Register any robot ibvs.sim.run accepts here.
ROBOTS: dict[str, Callable[..., Any]] = {"gantry": _gantry, "urdf": _urdf}


# --------------------------------------------------------------------------- the scenario


def _number(x, name: str, lo: float, hi: float, *, integer: bool = False, open_lo: bool = False) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {type(x).__name__}")
    if integer and float(x) != int(x):
        raise ValueError(f"{name} must be an integer, got {x!r}")
    if not (math.isfinite(x) and (lo < x if open_lo else lo <= x) and x <= hi):
        raise ValueError(f"{name} must be in {'(' if open_lo else '['}{lo:g}, {hi:g}], got {x!r}")
    return int(x) if integer else float(x)


def _callable_name(f) -> str:
    """A stable name of a start callable, for the config hash."""
    if isinstance(f, functools.partial):
        return f"partial({_callable_name(f.func)}, {f.args!r}, {sorted(f.keywords.items())!r})"
    name = getattr(f, "__qualname__", None) or getattr(f, "__name__", None)
    if name is None:  # an instance with __call__: its class (its repr may hold its address, new in every process)
        return f"{type(f).__module__}.{type(f).__qualname__}()"
    return f"{getattr(f, '__module__', '?')}.{name}"


def _canonical(x):
    """JSON-able form of what determines the episodes (native objects through their pickle state)."""
    if x is None or isinstance(x, (bool, str)):
        return x
    if isinstance(x, (int, float, np.integer, np.floating)):
        return float(x)
    if isinstance(x, np.ndarray):
        return _canonical(x.tolist())
    if isinstance(x, Mapping):
        return {str(k): _canonical(v) for k, v in sorted(x.items())}
    if isinstance(x, (list, tuple)):
        return [_canonical(v) for v in x]
    if isinstance(x, (types.FunctionType, types.BuiltinFunctionType, types.MethodType, functools.partial, type)):
        return _callable_name(x)
    if isinstance(x, sim.UrdfRobot):  # its URDF's content, not where it lies; not its Pinocchio objects
        return ["UrdfRobot", _canonical(x.fingerprint())]
    if type(x).__module__.startswith("ibvs._core") and type(x).__reduce__ is not object.__reduce__:
        # native objects that pickle as their constructor's arguments (the feature kinds, FunctionSource):
        # those arguments (their repr may round or leave some out)
        try:
            return [type(x).__name__, _canonical(x.__reduce__()[1])]
        except TypeError:  # its callable does not pickle (FunctionSource, FunctionFeature): the callable's name
            fn = getattr(x, "measure", None) or getattr(x, "fn", None)
            return [type(x).__name__, repr(x), _callable_name(fn)]
    try:  # native objects (Camera, Target, Gantry) through their pickle state
        state = x.__getstate__()
    except (AttributeError, TypeError):
        state = None
    return repr(x) if state is None else [type(x).__name__, _canonical(state)]


@dataclasses.dataclass(frozen=True, eq=False)
class Scenario:
    """What a sweep runs (see the module docstring).

    camera, target: an ibvs.sim.Camera and an ibvs.sim.Target (any number of points >= 1,
        planar or not; depth="pose" needs a planar one).
    goal: the camera's goal pose (4x4, world <- camera), or with a robot its joint positions.
    robot: None (free-flying camera), an ibvs.sim.Gantry, an ibvs.sim.UrdfRobot, or any robot
        ibvs.sim.run accepts (an ibvs.sim.Robot).
    ranges: {parameter: (lo, hi)} of the start distribution (PARAMETERS).
    translation, rotation: callables of a numpy Generator replacing the tx/ty/tz and the
        rz_deg/tilt_deg/tilt_dir_deg ranges.
    gain (1/s), duration (s), depth (DEPTH_MODES), boundary_margin, boundary_gain: as in
        ibvs.sim.run.
    tolerance, tolerance_px: when an episode counts as converged, as in ibvs.sim.run: the error
        norm under tolerance, every measured point within tolerance_px (measurement units:
        pixels) of its goal; None: not tested, but tolerance is DEFAULT_TOLERANCE when neither is
        given (tolerances() gives the pair a run uses).
    angle_wrap: ANGLE_WRAPS, set on every ibvs.Servo a scheme builds ("consistent": the theta
        errors of a frame wrapped as one rotation; "per_point": eq. 13 point by point).
    goal_pose_mode: GOAL_POSES, ibvs.sim.run's goal_pose (the key goal_pose of a scenario file's
        [control]): the goal pose of the schemes' PBVS, 2.5-D and moments blocks taught from the goal's
        image as the depth mode knows it, or given (the true one).
    """

    camera: Any
    target: Any
    goal: Any
    robot: Any = None
    name: str = "custom"
    ranges: Mapping[str, tuple] = dataclasses.field(default_factory=dict)
    translation: Optional[Callable] = None
    rotation: Optional[Callable] = None
    gain: float = 1.0
    duration: float = 20.0
    depth: str = "exact"
    tolerance: Optional[float] = None
    boundary_margin: float = 0.0
    boundary_gain: float = 0.1
    angle_wrap: str = "consistent"
    tolerance_px: Optional[float] = None
    goal_pose_mode: str = "taught"

    def tolerances(self) -> tuple[Optional[float], Optional[float]]:
        """(tolerance, tolerance_px) of ibvs.sim.run: tolerance is DEFAULT_TOLERANCE when neither is set."""
        if self.tolerance is None and self.tolerance_px is None:
            return DEFAULT_TOLERANCE, None
        return self.tolerance, self.tolerance_px

    def criterion(self) -> str:
        """What converged means in this scenario's episodes, in words."""
        tol, px = self.tolerances()
        unit = measurement_unit(self.camera)
        parts = ([] if tol is None else [f"error norm < {tol:g}"]) + \
                ([] if px is None else [f"every measured point within {px:g} {unit} of its goal"])
        return " and ".join(parts)

    def replace(self, **changes) -> "Scenario":
        """A copy with some fields changed (None values are ignored); ranges are merged. goal_pose= is
        goal_pose_mode= (the name sim.run, sweep() and scenario files use; goal_pose() is the goal's pose)."""
        changes = {k: v for k, v in changes.items() if v is not None}
        if "goal_pose" in changes:
            changes["goal_pose_mode"] = changes.pop("goal_pose")
        if "ranges" in changes:
            changes["ranges"] = {**self.ranges, **changes["ranges"]}
        return dataclasses.replace(self, **changes)

    # -- checks

    def validate(self) -> "Scenario":
        """Raise ValueError / TypeError naming the bad field; returns self."""
        if not isinstance(self.camera, sim.Camera):
            raise TypeError(f"camera must be an ibvs.sim.Camera, got {type(self.camera).__name__}")
        if not isinstance(self.target, sim.Target):
            raise TypeError(f"target must be an ibvs.sim.Target, got {type(self.target).__name__}")
        if self.robot is not None and not all(hasattr(self.robot, a) for a in ("camera", "jacobian", "q_min", "q_max")):
            raise TypeError(f"robot must be None, an ibvs.sim.Gantry or another robot ibvs.sim.run accepts, got "
                            f"{type(self.robot).__name__}")
        if not isinstance(self.name, str) or not self.name or any(c in self.name for c in ",\n"):
            raise ValueError(f"name must be a non-empty string without ',' or newlines, got {self.name!r}")
        if not isinstance(self.ranges, Mapping):
            raise TypeError(f"ranges must be a mapping {{parameter: (lo, hi)}}, got {type(self.ranges).__name__}")
        for name, r in self.ranges.items():
            if name not in PARAMETERS:
                raise ValueError(f"ranges: unknown parameter {name!r}; choose from {', '.join(PARAMETERS)}")
            try:
                lo, hi = r
            except (TypeError, ValueError):
                raise ValueError(f"ranges: {name} must be (lo, hi), got {r!r}") from None
            a, b = LIMITS[name]
            lo = _number(lo, f"ranges: {name} lo", a, b, integer=name == "latency")
            hi = _number(hi, f"ranges: {name} hi", a, b, integer=name == "latency")
            if lo > hi:
                raise ValueError(f"ranges: {name} needs lo <= hi, got ({lo:g}, {hi:g})")
        for name in ("translation", "rotation"):
            f = getattr(self, name)
            if f is not None and not callable(f):
                raise TypeError(f"{name} must be a callable of a numpy Generator, got {type(f).__name__}")
        _number(self.gain, "gain", 0.0, MAX_GAIN, open_lo=True)
        _number(self.duration, "duration", 0.0, MAX_DURATION, open_lo=True)
        if self.tolerance is not None:
            _number(self.tolerance, "tolerance", 0.0, 1e6)
        if self.tolerance_px is not None:
            _number(self.tolerance_px, "tolerance_px", 0.0, 1e6, open_lo=True)
        _number(self.boundary_margin, "boundary_margin", 0.0, 1e6)
        _number(self.boundary_gain, "boundary_gain", 0.0, 1e6)
        if self.depth not in DEPTH_MODES:
            raise ValueError(f"depth must be one of {', '.join(DEPTH_MODES)}, got {self.depth!r}")
        if self.angle_wrap not in ANGLE_WRAPS:
            raise ValueError(f"angle_wrap must be one of {', '.join(ANGLE_WRAPS)}, got {self.angle_wrap!r}")
        if not isinstance(self.goal_pose_mode, str) or self.goal_pose_mode not in GOAL_POSES:
            raise ValueError(f"goal_pose must be one of {', '.join(GOAL_POSES)}, got {self.goal_pose_mode!r}")
        if self.depth == "pose" and not self.target.planar:
            raise ValueError('depth: "pose" needs a planar target (a pose estimate of coplanar points)')
        hi_latency = self.ranges.get("latency", (0, 0))[1]
        if hi_latency >= self.duration * self.camera.fps:
            raise ValueError(f"ranges: latency {hi_latency} frames is not shorter than the episode "
                             f"({self.duration * self.camera.fps:g} frames)")
        if self.robot is not None:
            self.goal_joints()  # checked, or a goal pose reached: a ValueError naming the goal otherwise
        goal = self.goal_pose()
        P = _in_camera(self.target, goal)
        if not _in_view(self.camera, P):
            raise ValueError("goal: the camera does not see every target point at the goal")
        return self

    # -- geometry

    def goal_joints(self) -> Optional[np.ndarray]:
        """The robot's goal joint positions (None without a robot); a goal pose is solved once by
        ibvs.sim.solve_ik from the middle of the joint ranges."""
        if self.robot is None:
            return None
        if "_goal_q" not in self.__dict__:  # a cache: the frozen dataclass's fields stay as given
            g = np.asarray(self.goal, dtype=float)
            if g.shape == (4, 4):
                q = _goal_joints(self.robot, g)
            elif g.shape != (self.robot.dof,) or not np.isfinite(g).all():
                raise ValueError(f"goal: {self.robot.dof} finite joint positions or a 4x4 pose, got shape {g.shape}")
            elif self.robot.outside_limits(g) >= 0:
                raise ValueError(f"goal: joint {self.robot.outside_limits(g) + 1} is outside its limits")
            else:
                q = g
            object.__setattr__(self, "_goal_q", q)
        return self.__dict__["_goal_q"]

    def goal_pose(self) -> np.ndarray:
        """The camera's goal pose (4x4, world <- camera)."""
        g = np.asarray(self.goal, dtype=float)
        if self.robot is not None and g.shape != (4, 4):
            return np.asarray(self.robot.camera(self.goal_joints()))
        if g.shape != (4, 4) or not np.isfinite(g).all():
            raise ValueError(f"goal must be a finite 4x4 pose (world <- camera), got shape {g.shape}")
        return g

    def sample(self, seed: int, index: int) -> dict:
        """The parameters of episode `index` (a function of (seed, index) only)."""
        rng = np.random.default_rng([int(seed), int(index)])
        u = rng.random(len(PARAMETERS))
        p = {}
        for k, name in enumerate(PARAMETERS):
            lo, hi = self.ranges.get(name, (DEFAULTS[name], DEFAULTS[name]))
            if name == "latency":
                p[name] = int(min(hi, int(lo) + math.floor(u[k] * (int(hi) - int(lo) + 1))))
            else:
                p[name] = float(lo + u[k] * (hi - lo))
        if self.translation is not None:
            t = np.asarray(self.translation(np.random.default_rng([int(seed), int(index), 2])), dtype=float)
            if t.shape != (3,) or not np.isfinite(t).all():
                raise ValueError(f"translation must return 3 finite numbers (metres), got {t!r}")
            p["tx"], p["ty"], p["tz"] = (float(x) for x in t)
        if self.rotation is not None:
            p.update(_rotation_parameters(self.rotation(np.random.default_rng([int(seed), int(index), 3]))))
        return p

    def start(self, p: Mapping) -> Any:
        """The start (pose, or joints with a robot) of parameters p, or None when the target is not
        entirely in view there or the robot cannot reach it (start_outcome says which)."""
        return self.start_outcome(p)[0]

    def start_outcome(self, p: Mapping) -> tuple:
        """(start, None), or (None, why): "invalid_start" when the target is not entirely in view at the
        start pose, "unreachable" when ibvs.sim.solve_ik (from the goal joints, then its restarts) finds
        no joints within the robot's limits that put the camera there."""
        start_pose = self.goal_pose() @ offset(p)
        if not _in_view(self.camera, _in_camera(self.target, start_pose)):
            return None, "invalid_start"
        if self.robot is None:
            return start_pose, None
        r = sim.solve_ik(self.robot, start_pose, self.goal_joints())
        return (r.q, None) if r.converged else (None, "unreachable")

    def goal_for_run(self):
        return self.goal_joints() if self.robot is not None else self.goal_pose()

    def settings(self) -> dict:
        tol, px = self.tolerances()
        out = {"gain": float(self.gain), "duration": float(self.duration), "depth": self.depth,
               "tolerance": None if tol is None else float(tol), "boundary_margin": float(self.boundary_margin),
               "boundary_gain": float(self.boundary_gain), "angle_wrap": self.angle_wrap}
        if px is not None:  # only then: the config hash of every sweep without it stays as it was
            out["tolerance_px"] = float(px)
        if self.goal_pose_mode != "taught":  # likewise
            out["goal_pose"] = self.goal_pose_mode
        return out

    def key(self) -> str:
        """Hash of everything that determines the episodes (not the name)."""
        desc = {"camera": self.camera, "target": self.target, "goal": np.asarray(self.goal, dtype=float),
                "robot": self.robot, "ranges": {k: list(v) for k, v in self.ranges.items()},
                "translation": self.translation, "rotation": self.rotation, **self.settings()}
        return hashlib.sha1(json.dumps(_canonical(desc), sort_keys=True).encode()).hexdigest()[:10]


def offset(p: Mapping) -> np.ndarray:
    """The start's offset from the goal (4x4, in the goal camera's frame) of parameters p."""
    tilt, d = math.radians(p["tilt_deg"]), math.radians(p["tilt_dir_deg"])
    T = np.eye(4)
    T[:3, :3] = rotation_matrix(tilt * math.cos(d), tilt * math.sin(d), math.radians(p["rz_deg"]))
    T[:3, 3] = (p["tx"], p["ty"], p["tz"])
    return T


def _rotation_parameters(r) -> dict:
    """rz_deg, tilt_deg, tilt_dir_deg of a rotation given as 3x3 or (rx, ry, rz) radians: the rxyz
    angles R = Rx(a) Ry(b) Rz(c) with tilt = |(a, b)| and tilt_dir = atan2(b, a)."""
    r = np.asarray(r, dtype=float)
    if r.shape == (3,) and np.isfinite(r).all():
        r = rotation_matrix(*r)
    if r.shape != (3, 3) or not np.isfinite(r).all() or not np.allclose(r @ r.T, np.eye(3), atol=1e-9) \
            or np.linalg.det(r) < 0:
        raise ValueError("rotation must return a 3x3 rotation matrix or 3 finite angles (rx, ry, rz) in radians")
    b = math.asin(max(-1.0, min(1.0, r[0, 2])))
    a = math.atan2(-r[1, 2], r[2, 2])
    c = math.atan2(-r[0, 1], r[0, 0])
    tilt = math.hypot(a, b)
    return {"rz_deg": math.degrees(c), "tilt_deg": math.degrees(tilt),
            "tilt_dir_deg": math.degrees(math.atan2(b, a)) % 360.0 if tilt > 1e-12 else 0.0}


def _in_camera(target, T_wc: np.ndarray) -> np.ndarray:
    T_cw = np.linalg.inv(T_wc)
    return np.asarray(target.world_points()) @ T_cw[:3, :3].T + T_cw[:3, 3]


def _in_view(camera, P: np.ndarray) -> bool:
    """Every point in front of the camera and on its sensor."""
    if np.any(P[:, 2] <= 1e-3):
        return False
    m = np.asarray(camera.project(P[:, :2] / P[:, 2:], invalid="nan"))  # NaN beyond the model's radius
    u0, u1, v0, v1 = camera.bounds
    return bool(np.all((m[:, 0] >= u0) & (m[:, 0] <= u1) & (m[:, 1] >= v0) & (m[:, 1] <= v1)))


def _goal_joints(robot, pose: np.ndarray) -> np.ndarray:
    """Joint positions placing the camera at `pose`, by ibvs.sim.solve_ik from mid-range."""
    r = sim.solve_ik(robot, pose)
    if not r.converged:
        raise ValueError(f"goal: the robot cannot reach the goal pose ({r.message})")
    return r.q


# --------------------------------------------------------------------------- built-in worlds

#: Start distributions of the built-in worlds.
DEFAULT_RANGES = {
    "free": {
        "rz_deg": (0.0, 180.0), "tilt_deg": (0.0, 10.0), "tilt_dir_deg": (0.0, 360.0),
        "tx": (-0.2, 0.2), "ty": (-0.2, 0.2), "tz": (-0.5, 0.5),
    },
    "gantry": {
        "rz_deg": (0.0, 180.0), "tilt_deg": (0.0, 8.0), "tilt_dir_deg": (0.0, 360.0),
        "tx": (-0.04, 0.04), "ty": (-0.04, 0.04), "tz": (-0.1, 0.1),
    },
    # The gantry's offsets, from the Panda's goal posture (ibvs.sim.cases.arm_general_motion).
    "arm": {
        "rz_deg": (0.0, 180.0), "tilt_deg": (0.0, 8.0), "tilt_dir_deg": (0.0, 360.0),
        "tx": (-0.04, 0.04), "ty": (-0.04, 0.04), "tz": (-0.1, 0.1),
    },
}


@functools.lru_cache(maxsize=None)
def builtin(world: str) -> Scenario:
    """The built-in scenarios: "free" (the paper's free-flying camera and four points, Table I;
    gain 1, 20 s, exact depth), "gantry" (the Afma6-like gantry with the distorted camera and
    a 10 cm square at 0.6 m, Section III-B; gain 2, 15 s, depth from a pose estimate) and "arm"
    (the same camera on the Franka Panda of example-robot-data at the goal posture of
    ibvs.sim.cases.arm_general_motion, the square 0.5 m in front of it; gain 1, 15 s, depth from a
    pose estimate; needs the robots extra). The starts are camera offsets from the goal, drawn from
    DEFAULT_RANGES[world]; on the arm each is solved by ibvs.sim.solve_ik (unreachable ones are
    counted, not run)."""
    if world == "free":
        c = sim.cases.z_rotation()
        return Scenario(c.camera, c.target, np.eye(4), name="free", ranges=dict(DEFAULT_RANGES["free"]),
                        gain=1.0, duration=20.0, depth="exact")
    if world == "gantry":
        c = sim.cases.gantry_general_motion()
        return Scenario(c.camera, c.target, np.asarray(c.goal), robot=c.robot, name="gantry",
                        ranges=dict(DEFAULT_RANGES["gantry"]), gain=2.0, duration=15.0, depth="pose")
    if world == "arm":
        c = sim.cases.arm_general_motion("panda")
        return Scenario(c.camera, c.target, np.asarray(c.goal), robot=c.robot, name="arm",
                        ranges=dict(DEFAULT_RANGES["arm"]), gain=1.0, duration=15.0, depth="pose")
    raise ValueError(f"world must be one of {sorted(DEFAULT_RANGES)}, got {world!r}")


# --------------------------------------------------------------------------- scenario files


def _toml(path: Path) -> dict:
    try:
        import tomllib
    except ImportError:  # Python < 3.11
        import tomli as tomllib
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as e:
        raise ValueError(f"scenario: cannot read {path}: {e.strerror}") from None
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"scenario: {path} is not valid TOML: {e}") from None


def _keys(table: Mapping, allowed, where: str) -> None:
    extra = sorted(set(table) - set(allowed))
    if extra:
        raise ValueError(f"{where}: unknown key {extra[0]!r}; allowed: {', '.join(sorted(allowed))}")


def _pose_of(table, where: str) -> np.ndarray:
    """4x4 pose of {t = [x, y, z], r = [rx, ry, rz] (radians) or r_deg = [...] (degrees)}."""
    if not isinstance(table, Mapping):
        raise ValueError(f"{where} must be a table {{ t = [x, y, z], r_deg = [rx, ry, rz] }}")
    _keys(table, ("t", "r", "r_deg"), where)
    if "r" in table and "r_deg" in table:
        raise ValueError(f"{where}: give r (radians) or r_deg (degrees), not both")
    try:
        return sim.pose(table.get("t", (0, 0, 0)), table["r_deg"], degrees=True) if "r_deg" in table \
            else sim.pose(table.get("t", (0, 0, 0)), table.get("r", (0, 0, 0)))
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None


def _static_constructors(cls) -> list:
    return sorted(n for n, v in vars(cls).items() if not n.startswith("_") and isinstance(v, staticmethod))


def _construct(cls, table: Mapping, where: str, pose_keys=()):
    """cls(**table), or cls.<from>(**rest) with from = the name of one of its static constructors."""
    kw = {k: v for k, v in table.items() if k != "from"}
    for k in pose_keys:
        if k in kw:
            kw[k] = _pose_of(kw[k], f"{where} {k}")
    ctor = cls
    if "from" in table:
        choices = _static_constructors(cls)
        if table["from"] not in choices:
            raise ValueError(f"{where}: from = {table['from']!r} is not a constructor of {cls.__name__}; "
                             f"choose from {', '.join(choices)}")
        ctor = getattr(cls, table["from"])
    try:
        return ctor(**kw)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: {e}") from None


def _import_callable(spec: str, where: str):
    """module:attribute -> the callable (the module must be importable where the sweep runs)."""
    mod, sep, attr = str(spec).partition(":")
    if not sep:
        raise ValueError(f"{where}: expected 'module:function', got {spec!r}")
    try:
        f = getattr(importlib.import_module(mod), attr)
    except (ImportError, AttributeError) as e:
        raise ValueError(f"{where}: cannot import {spec!r} ({e})") from None
    if not callable(f):
        raise ValueError(f"{where}: {spec!r} is not callable")
    return f


def _robot(table, path: Path, where: str):
    """The robot of a [robot] table: ROBOTS[kind](**the other keys), its path keys relative to the file."""
    where = f"{where} [robot]"
    if not isinstance(table, Mapping):
        raise ValueError(f"{where} must be a table with kind = {' or '.join(map(repr, ROBOTS))}")
    r = dict(table)
    kind = r.pop("kind", None)
    if kind not in ROBOTS:
        raise ValueError(f"{where}: kind must be one of {', '.join(ROBOTS)}, got {kind!r}")
    factory = ROBOTS[kind]
    _keys(r, ["kind", *inspect.signature(factory).parameters], where)
    for k in getattr(factory, "path_keys", ()):
        if k in r:
            if not isinstance(r[k], str):
                raise ValueError(f"{where}: {k} must be a path (a string), got {type(r[k]).__name__}")
            r[k] = str(path.parent / r[k])  # an absolute path stays as it is
    for k in getattr(factory, "pose_keys", ()):
        if k in r:
            r[k] = _pose_of(r[k], f"{where} {k}")
    try:
        return factory(**r)
    except (ImportError, TypeError, ValueError, FileNotFoundError) as e:  # ImportError: Pinocchio is missing
        raise ValueError(f"{where}: {e}") from None


#: Keys of a scenario file's [sweep] table: defaults for the sweep (command-line options win).
SWEEP_KEYS = ("episodes", "seed", "schemes")


def load(path) -> tuple[Scenario, dict]:
    """Read a TOML scenario file: returns (Scenario, {episodes, seed, schemes} from its [sweep]
    table). Every error is a ValueError naming the file's table and key. See docs/sweeps.md."""
    path = Path(os.fspath(path))
    doc = _toml(path)
    where = str(path)
    _keys(doc, ("name", "camera", "target", "goal", "robot", "start", "control", "sweep"), where)
    for section in ("camera", "target", "goal"):
        if not isinstance(doc.get(section), Mapping):
            raise ValueError(f"{where}: missing [{section}] table")
    camera = _construct(sim.Camera, doc["camera"], f"{where} [camera]")
    target = _construct(sim.Target, doc["target"], f"{where} [target]", pose_keys=("pose",))
    robot = _robot(doc["robot"], path, where) if "robot" in doc else None
    g = doc["goal"]
    if "joints" in g:
        _keys(g, ("joints",), f"{where} [goal]")
        if robot is None:
            raise ValueError(f"{where} [goal]: joints need a [robot]")
        try:
            goal = np.asarray(g["joints"], dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{where} [goal]: joints must be a list of numbers (radians or metres), got "
                             f"{g['joints']!r}") from None
    else:
        goal = _pose_of(g, f"{where} [goal]")
    start = dict(doc.get("start", {}))
    _keys(start, (*PARAMETERS, "translation", "rotation"), f"{where} [start]")
    translation = _import_callable(start.pop("translation"), f"{where} [start] translation") \
        if "translation" in start else None
    rotation = _import_callable(start.pop("rotation"), f"{where} [start] rotation") if "rotation" in start else None
    ranges = {}
    for k, v in start.items():  # a number fixes the parameter, [lo, hi] is a uniform range
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            v = (v, v)
        ranges[k] = tuple(v) if isinstance(v, list) else v
    control = dict(doc.get("control", {}))
    fields = ("gain", "duration", "depth", "tolerance", "tolerance_px", "boundary_margin", "boundary_gain",
              "angle_wrap", "goal_pose")
    _keys(control, fields, f"{where} [control]")
    if "goal_pose" in control:  # the Scenario's goal_pose_mode (its goal_pose() is the goal's 4x4 pose)
        control["goal_pose_mode"] = control.pop("goal_pose")
    name = doc.get("name", path.stem)
    try:
        scenario = Scenario(camera, target, goal, robot=robot, name=name, ranges=ranges, translation=translation,
                            rotation=rotation, **control).validate()
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: {e}") from None
    options = dict(doc.get("sweep", {}))
    _keys(options, SWEEP_KEYS, f"{where} [sweep]")
    return scenario, options
