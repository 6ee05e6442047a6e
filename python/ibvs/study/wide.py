"""The wide-field study of issue 23: a 220-degree equidistant fisheye servoed on perspective features
(normalised image points: Cartesian, polar, polar with per-point angle wraps, stacked) and on features
on the sphere (spherical Cartesian, spherical-polar, both stacked), on the same free-camera starts.

    python -m ibvs.study.wide --out DIR [--rotations 19] [--general 200] [--fov 220] [--docs]
    ibvs wide --out DIR ...

Camera: an equidistant fisheye without distortion whose image circle (110 degrees off the axis, a
220-degree lens; --fov, camera(fov) and study(fov=...) choose another full field of view) fills a
square sensor; the paper's square target (+-0.25 m, 3 m in front of the goal camera). Every scheme measures the target's pixels through the lens model: the perspective schemes
normalise them (CameraModel.normalize: x = X/Z, which exists only in front of the camera, below 90
degrees off the axis), the spherical ones lift them to bearings (ibvs.spherical_measurements).

Starts: the paper's free-camera cases (x translation, half-turn about the optical axis, general
motion), rotations about the optical axis from 0 to 180 degrees, and `general` random starts whose
camera is tilted by up to 100 degrees (the target up to about 105 degrees off the axis). A start with a
point at 90 degrees or more off the axis has no normalised coordinates, and ibvs refuses them beyond
|x|, |y| = 10 (84 degrees): the perspective schemes cannot see it ("cannot_see", counted, not run).
Per run: converged (error norm under TOLERANCE), reached (within 1 mm and 1 mrad of the goal), stayed
in view, camera retreat, path length, peak speeds of the commanded twist.

Every run is an ibvs.sim.run episode of a free-flying camera (simulate()): the simulator judges a
point in the lens's view by its image circle, whatever the sign of its depth, and feeds the spherical
blocks the bearings of the measured pixels (sim.SphericalSource). A perspective scheme's start with a
point outside its domain is not run ("cannot_see").
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from ..finite import finite_within

import ibvs

from .. import sim
from . import output, schemes
from .compare import wrap
from .scenario import DEFAULTS, offset

__all__ = ["ANGLE_BINS", "DURATION", "FOV", "FOV_LIMITS", "FPS", "GAIN", "HALF_FOV", "NAMES", "PERSPECTIVE",
           "PERSPECTIVE_LIMIT", "PINHOLE_HALF_FOV", "RANGES", "REACHED", "SCHEMES", "SENSOR", "SPHERICAL", "TOLERANCE",
           "Outcome", "Row", "Trace", "angle_table", "camera", "cannot_see", "check_fov", "case_table", "figures", "findings", "in_camera", "main",
           "make", "off_axis", "page", "perspective_sees", "run", "sample", "sim_target", "simulate", "start_pose",
           "starts", "starts_table", "study", "summarise", "summary", "table", "target_points"]

#: The lens's full field of view (degrees) by default, and the range --fov / fov= accept.
FOV = 220.0
FOV_LIMITS = (90.0, 300.0)
#: The default lens's half field of view (radians): its image circle.
HALF_FOV = math.radians(FOV / 2)
#: The square sensor's side (pixels); the image circle touches its sides.
SENSOR = 1024

#: The runs: gain (1/s), frames per second, seconds, error-norm tolerance, and "reached": within (metres,
#: radians) of the goal pose.
GAIN = 1.0
FPS = 60.0
DURATION = 30.0
TOLERANCE = 1e-6
REACHED = (1e-3, 1e-3)
#: ibvs's domain of normalised coordinates, |X/Z|, |Y/Z| <= 10 (ibvs::max_normalized_coordinate, limits.hpp:
#: 84 to 86 degrees off the axis); beyond it, and behind the image plane, a perspective feature is refused.
PERSPECTIVE_LIMIT = 10.0

#: The simulator's stopping rules: diverged beyond MAX_DISTANCE_RATIO times the start distance to the target
#: or MAX_ERROR_RATIO times the start error norm; collision within STANDOFF times the goal depth of the plate.
MAX_DISTANCE_RATIO = 10.0
MAX_ERROR_RATIO = 100.0
STANDOFF = 0.05
#: The random starts: rotation about the optical axis, tilt (its direction uniform) and translation.
RANGES = {"rz_deg": (0.0, 180.0), "tilt_deg": (0.0, 100.0), "tilt_dir_deg": (0.0, 360.0),
          "tx": (-0.2, 0.2), "ty": (-0.2, 0.2), "tz": (-0.5, 0.5)}
#: A conventional perspective camera for comparison: 90 degrees across (45 off the axis).
PINHOLE_HALF_FOV = math.radians(45.0)

#: The schemes: on normalised image points, on the sphere, and all of them; their names in the tables.
PERSPECTIVE = ("cartesian", "polar", "polar_per_point", "stacked")
SPHERICAL = ("spherical", "spherical_polar", "spherical_stacked")
SCHEMES = PERSPECTIVE + SPHERICAL
NAMES = {"cartesian": "IBVS (x, y)", "polar": "IBVS-P (r, θ)", "polar_per_point": "IBVS-P, θ wrapped per point",
         "stacked": "stacked (x, y, r, θ)", "spherical": "spherical (bx, by, bz)",
         "spherical_polar": "spherical-polar (β, φ)",
         "spherical_stacked": "spherical stacked (b, β, φ)"}
#: Outcomes that mean a point went out of the features' domain.
OUT_OF_VIEW = ("left_image", "left_perspective", "behind_camera", "lost_feature")


def check_fov(fov) -> float:
    """fov (the lens's full field of view, degrees) as a float, or a ValueError naming it."""
    lo, hi = FOV_LIMITS
    if isinstance(fov, bool) or not isinstance(fov, (int, float, np.integer, np.floating)) \
            or not (math.isfinite(fov) and lo <= fov <= hi):
        raise ValueError(f"fov must be a number of degrees in [{lo:g}, {hi:g}] (the lens's full field of view), "
                         f"got {fov!r}")
    return float(fov)


def camera(fov: float = FOV) -> ibvs.CameraModel:
    """The study's lens: equidistant (r = f theta), no distortion, the circle fov/2 degrees off the axis
    (default 110: a 220-degree lens) inscribed in a SENSOR x SENSOR image."""
    f = (SENSOR / 2) / math.radians(check_fov(fov) / 2)
    c = SENSOR / 2
    return ibvs.CameraModel.from_opencv(np.array([[f, 0.0, c], [0.0, f, c], [0.0, 0.0, 1.0]]), [0.0] * 4, SENSOR,
                                        SENSOR, fisheye=True, fps=FPS)


def target_points() -> np.ndarray:
    """The paper's square (world frame, metres): (+-0.25, +-0.25, 3)."""
    return np.asarray(sim.Target.paper().world_points(), dtype=float)


def _task(kinds) -> ibvs.Servo:
    task = ibvs.Task()
    for _ in range(4):
        for k in kinds:
            task.add(k())
    return ibvs.Servo(task, gain=GAIN, damping=0.0)


def make(scheme: str):
    """A servo of `scheme` for the square's four points. polar_per_point: IBVS-P whose theta errors are
    each wrapped into (-pi, pi] alone (angle_wrap="per_point"); `polar` chooses one branch for all points
    (the consistent wrap, paper eq. 13), and so does `spherical_polar` for its azimuths, which join the
    Servo's consistent wrap (Feature.axis_angle_rows)."""
    if scheme == "polar_per_point":
        return ibvs.Servo(ibvs.Layout.polar(4), gain=GAIN, damping=0.0, angle_wrap="per_point")
    if scheme in PERSPECTIVE:
        return schemes.make(scheme, GAIN, 4)
    kinds = {"spherical": (ibvs.SphericalPointFeature,), "spherical_polar": (ibvs.SphericalPolarFeature,),
             "spherical_stacked": (ibvs.SphericalPointFeature, ibvs.SphericalPolarFeature)}
    if scheme not in kinds:
        raise ValueError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
    return _task(kinds[scheme])


def off_axis(P: np.ndarray) -> np.ndarray:
    """The angle (radians) of camera-frame points (N, 3) off the optical axis."""
    return np.arctan2(np.hypot(P[:, 0], P[:, 1]), P[:, 2])


def in_camera(T_wc: np.ndarray, points: np.ndarray) -> np.ndarray:
    """World points (N, 3) in the frame of the camera at T_wc (world <- camera)."""
    R, t = T_wc[:3, :3], T_wc[:3, 3]
    return (points - t) @ R


def perspective_sees(P: np.ndarray) -> bool:
    """Whether the perspective features of camera-frame points P (N, 3) exist: every point in front of the
    camera (Z > 0) with |X/Z|, |Y/Z| <= PERSPECTIVE_LIMIT."""
    return bool(np.all(np.maximum(np.abs(P[:, 0]), np.abs(P[:, 1])) <= PERSPECTIVE_LIMIT * P[:, 2]))


def cannot_see(T_wc: np.ndarray) -> bool:
    """Whether the perspective schemes cannot see the target from pose T_wc (perspective_sees)."""
    return not perspective_sees(in_camera(T_wc, target_points()))


@dataclass
class Trace:
    """A run's history: camera poses (K, 4, 4), twists (K, 6), pixels (K, 4, 2), error norms (K,)."""

    pose: np.ndarray
    twist: np.ndarray
    pixels: np.ndarray
    error_norm: np.ndarray


@dataclass(frozen=True)
class Outcome:
    """What a run did: the metrics of ibvs.sim.Metrics (retreat measured as a distance, see run(); the peak
    speeds are the commanded twist's, Metrics.peak_commanded_*)."""

    outcome: str
    frames: int
    camera_retreat: float
    axial_retreat: float
    path_length: float
    peak_linear_speed: float
    peak_angular_speed: float
    final_translation_error: float
    final_rotation_error: float


def _measure(scheme: str, cam, P: np.ndarray):
    """(pixels, the servo's inputs) of camera-frame points P through the lens (what the simulator feeds
    the servo: normalised points and depths, or for the spherical schemes the bearings and distances)."""
    pixels = cam.from_bearing(P)
    if scheme in PERSPECTIVE:
        return pixels, (cam.normalize(pixels), P[:, 2].copy())
    m = ibvs.spherical_measurements(cam, pixels, np.linalg.norm(P, axis=1))
    return pixels, (np.repeat(m, 2, axis=0) if scheme == "spherical_stacked" else m).ravel()


def sim_target(scheme: str) -> sim.Target:
    """The paper's square as the simulator's Target for `scheme`: its points for the perspective schemes,
    with one sim.SphericalSource per block of the spherical schemes (a point's bearing and distance)."""
    t = sim.Target.paper()
    if scheme in PERSPECTIVE:
        return t
    per_point = 2 if scheme == "spherical_stacked" else 1
    return t.with_features([sim.SphericalSource(i) for i in range(4) for _ in range(per_point)])


def simulate(scheme: str, start: np.ndarray, cam: Optional[ibvs.CameraModel] = None, duration: float = DURATION,
             tolerance: float = TOLERANCE) -> sim.Result:
    """The ibvs.sim.run episode of `scheme` from `start` to the goal (the identity), with the study's
    gain, exact depths, tolerance and the simulator's stopping rules at their defaults (diverged beyond
    MAX_DISTANCE_RATIO times the target's start distance or MAX_ERROR_RATIO times the start error norm,
    collision within STANDOFF times the goal depth)."""
    return sim.run(make(scheme), cam or camera(), sim_target(scheme), start, np.eye(4), duration=duration,
                   depth="exact", tolerance=tolerance, max_depth_ratio=MAX_DISTANCE_RATIO,
                   max_error_ratio=MAX_ERROR_RATIO, standoff_ratio=STANDOFF)


def run(scheme: str, start: np.ndarray, cam: Optional[ibvs.CameraModel] = None, duration: float = DURATION,
        tolerance: float = TOLERANCE, trace: bool = False):
    """One free-camera run of `scheme` from `start` (4x4 world <- camera) to the goal (the identity):
    ibvs.sim.run (simulate()), or for a perspective scheme whose start has a point outside the
    perspective domain (perspective_sees) "cannot_see", not run.

    Returns (Outcome, Trace or None). The outcome is the simulator's (ibvs.sim.OUTCOMES), except
    "left_perspective" for a perspective scheme's run that ends as "diverged" with a point outside the
    perspective domain (ibvs.Servo refuses it: invalid_input, which the simulator reports as diverged); frames the
    number of frames the servo ran; camera_retreat the largest increase of the camera's distance to
    the target's centre over its start value (the simulator's retreat, axial_retreat, is along the
    optical axis, which is meaningless when the target starts beside or behind the camera); path
    length, peak commanded speeds and final errors from ibvs.sim.Metrics."""
    start = np.asarray(start, dtype=float)
    if start.shape != (4, 4) or not np.isfinite(start).all():
        raise ValueError(f"start must be a finite 4x4 pose (world <- camera), got shape {start.shape}")
    R = start[:3, :3]
    if (not finite_within(R, 1.0 + 1e-6) or not finite_within(R.T @ R - np.eye(3), 1e-6)
            or np.linalg.det(R) < 0 or not finite_within(start[3] - (0, 0, 0, 1), 0.0)
            or not finite_within(start[:3, 3], 1e3)):
        raise ValueError("start must be a rigid transform (rotation, translation within 1 km, last row 0 0 0 1)")
    if not (isinstance(duration, (int, float)) and 0 < duration <= 3600):
        raise ValueError(f"duration must be in (0, 3600] seconds, got {duration!r}")
    make(scheme)  # refuses an unknown scheme
    cam = cam or camera()
    if scheme in PERSPECTIVE and cannot_see(start):
        out = Outcome("cannot_see", 0, 0.0, 0.0, 0.0, 0.0, 0.0, float(np.linalg.norm(start[:3, 3])),
                      _angle(start[:3, :3]))
        return out, (Trace(start[None], np.zeros((0, 6)), np.zeros((0, 4, 2)), np.zeros(0)) if trace else None)
    r = simulate(scheme, start, cam, duration, tolerance)
    h, m = r.history, r.metrics
    pose = np.asarray(h.pose)
    centre = target_points().mean(axis=0)
    d = np.linalg.norm(pose[:, :3, 3] - centre, axis=1)
    outcome = r.status.outcome
    if scheme in PERSPECTIVE and outcome == "diverged" and not perspective_sees(in_camera(pose[-1], target_points())):
        outcome = "left_perspective"  # the Servo refused a point beyond its domain (invalid_input: "diverged")
    out = Outcome(outcome, len(h.twist), float(max(0.0, (d - d[0]).max())), float(m.camera_retreat),
                  float(m.path_length), float(m.peak_commanded_linear_speed), float(m.peak_commanded_angular_speed),
                  float(m.final_translation_error), float(m.final_rotation_error))
    if not trace:
        return out, None
    pixels = np.stack([cam.from_bearing(in_camera(T, target_points())) for T in pose[:len(h.twist)]]) \
        if len(h.twist) else np.zeros((0, 4, 2))
    return out, Trace(pose, np.asarray(h.twist).reshape(-1, 6), pixels, np.asarray(h.error_norm))


def _angle(R: np.ndarray) -> float:
    return math.acos(min(1.0, max(-1.0, (np.trace(R) - 1.0) / 2.0)))


@dataclass(frozen=True)
class Row:
    """One run: the study, the start, the scheme and what it did."""

    study: str
    start: str
    scheme: str
    centre_angle_deg: float  # the target's centre off the axis at the start
    max_angle_deg: float  # its farthest point off the axis at the start
    cannot_see: bool  # a point outside the perspective domain at the start (perspective_sees)
    beyond_pinhole: bool  # a point beyond 45 degrees at the start: a 90-degree perspective camera would not see it
    outcome: str
    converged: bool
    reached: bool
    in_view: bool
    camera_retreat: float
    axial_retreat: float
    path_length: float
    peak_linear_speed: float
    peak_angular_speed: float
    final_translation_error: float
    final_rotation_error: float


def summarise(study: str, start: str, scheme: str, T0: np.ndarray, o: Outcome) -> Row:
    """The Row of one run from its start pose and Outcome."""
    P = in_camera(T0, target_points())
    a = off_axis(P)
    reached = bool(o.final_translation_error < REACHED[0] and o.final_rotation_error < REACHED[1])
    return Row(study, start, scheme, math.degrees(off_axis(P.mean(axis=0)[None])[0]), math.degrees(a.max()),
               cannot_see(T0), bool((a > PINHOLE_HALF_FOV).any()), o.outcome, o.outcome == "converged", reached,
               o.outcome not in OUT_OF_VIEW + ("cannot_see",), o.camera_retreat, o.axial_retreat, o.path_length,
               o.peak_linear_speed, o.peak_angular_speed, o.final_translation_error, o.final_rotation_error)


def sample(seed: int, index: int) -> dict:
    """The parameters of random start `index` (a function of (seed, index) only)."""
    rng = np.random.default_rng([int(seed), int(index)])
    return dict(DEFAULTS, **{k: float(lo + rng.random() * (hi - lo)) for k, (lo, hi) in RANGES.items()})


def start_pose(p: dict) -> np.ndarray:
    """The start (4x4 world <- camera; the goal is the identity) of parameters p: the camera turned by rz_deg
    about its optical axis, then tilted by tilt_deg about the axis of the image plane at tilt_dir_deg
    (one rotation: the target ends about tilt_deg off the axis), then moved by (tx, ty, tz)."""
    d, tilt = math.radians(p["tilt_dir_deg"]), math.radians(p["tilt_deg"])
    T = ibvs.se3_exp([0.0, 0.0, 0.0, tilt * math.cos(d), tilt * math.sin(d), 0.0]) @ \
        ibvs.se3_exp([0.0, 0.0, 0.0, 0.0, 0.0, math.radians(p["rz_deg"])])
    T[:3, 3] = (p["tx"], p["ty"], p["tz"])
    return T


def starts(rotations: int = 19, general: int = 200, seed: int = 0,
           fov: float = FOV) -> list[tuple[str, str, np.ndarray]]:
    """(study, label, start pose) of every run (per scheme); random starts with a point beyond the lens's
    circle (fov/2 degrees off the axis) are skipped (no camera sees them)."""
    half = math.radians(check_fov(fov) / 2)
    out = [("paper", c.name, np.asarray(c.start)) for c in
           (sim.cases.x_translation(), sim.cases.z_rotation(), sim.cases.general_motion())]
    for deg in np.linspace(0.0, 180.0, rotations):
        out.append(("rotation", f"rz {deg:g} deg", offset(dict(DEFAULTS, rz_deg=float(deg)))))
    k = n = 0
    while n < general:
        T = start_pose(sample(seed, k))
        if np.all(off_axis(in_camera(T, target_points())) < half):
            out.append(("general", f"#{k}", T))
            n += 1
        k += 1
    return out


#: The start whose runs the figures trace: the paper's half-turn, and the first random start whose target's
#: centre is at least WIDE_TRACE degrees off the axis.
TRACED = "z_rotation"
WIDE_TRACE = 95.0


def _centre_angle(T0: np.ndarray) -> float:
    return math.degrees(off_axis(in_camera(T0, target_points()).mean(axis=0)[None])[0])


def study(rotations: int = 19, general: int = 200, seed: int = 0, schemes_: Sequence[str] = SCHEMES,
          keep: Optional[dict] = None, fov: float = FOV) -> list[Row]:
    """Every run of the study with the lens of full field of view fov (degrees); keep: a dict filled with
    {(start label, scheme): Trace} of the traced runs (TRACED and the first random start WIDE_TRACE degrees
    off the axis)."""
    cam = camera(fov)
    every = starts(rotations, general, seed, fov)
    wide_label = next((lab for st, lab, T0 in every if st == "general" and _centre_angle(T0) >= WIDE_TRACE), None)
    rows = []
    for st, label, T0 in every:
        for scheme in schemes_:
            o, tr = run(scheme, T0, cam, trace=keep is not None and label in (TRACED, wide_label))
            rows.append(summarise(st, label, scheme, T0, o))
            if tr is not None:
                keep[(label, scheme)] = tr
    return rows


# ------------------------------------------------------------------------------------------- the page


def _median(x) -> float:
    x = [v for v in x if math.isfinite(v)]
    return float(np.median(x)) if x else math.nan


def _share(k: int, n: int) -> str:
    return f"{k}/{n} ({100.0 * k / n:.0f} %)" if n else "—"


def table(rows: Sequence[Row], study_names=("paper", "rotation", "general")) -> str:
    """Per scheme over the given studies: converged, reached, cannot see, stayed in view, retreat, path,
    peak speeds (medians and maxima over the runs started)."""
    head = ("| scheme | converged | reached goal | cannot see the start | converged, of the starts it sees | "
            "stayed in view (of runs started) | retreat median / max (m) | path median (m) | "
            "peak v median / max (m/s) | peak ω median / max (rad/s) |")
    lines = [head, "|" + "---|" * 10]
    for scheme in dict.fromkeys(r.scheme for r in rows):
        mine = [r for r in rows if r.scheme == scheme and r.study in study_names]
        ran = [r for r in mine if r.outcome != "cannot_see"]
        if not ran:
            continue
        conv = sum(r.converged for r in mine)
        v = [r.peak_linear_speed for r in ran]
        w = [r.peak_angular_speed for r in ran]
        cells = [
            f"{NAMES[scheme]} (`{scheme}`)",
            _share(conv, len(mine)),
            _share(sum(r.reached for r in mine), len(mine)),
            _share(len(mine) - len(ran), len(mine)),
            _share(conv, len(ran)),
            _share(sum(r.in_view for r in ran), len(ran)),
            f"{_median([r.camera_retreat for r in ran]):.3f} / {max(r.camera_retreat for r in ran):.3f}",
            f"{_median([r.path_length for r in ran]):.3f}",
            f"{_median(v):.2f} / {max(v):.3g}",
            f"{_median(w):.2f} / {max(w):.3g}",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _cell(r: Row) -> str:
    if r.reached:
        return f"{r.camera_retreat:.2f} m"
    return r.outcome.replace("_", " ") if r.outcome != "converged" else "converged, not reached"


def case_table(rows: Sequence[Row], study_name: str) -> str:
    """Per scheme and start of one study: the retreat (m) when it reached the goal, else the outcome."""
    mine = [r for r in rows if r.study == study_name]
    labels = list(dict.fromkeys(r.start for r in mine))
    short = [x.replace("rz ", "").replace(" deg", "°").replace("_", " ") for x in labels]
    lines = ["| scheme | " + " | ".join(short) + " |", "|" + "---|" * (1 + len(labels))]
    for scheme in dict.fromkeys(r.scheme for r in mine):
        by = {r.start: r for r in mine if r.scheme == scheme}
        lines.append(f"| `{scheme}` | " + " | ".join(_cell(by[x]) for x in labels) + " |")
    return "\n".join(lines)


#: Bins of the target centre's start angle off the axis (degrees) for the general starts.
ANGLE_BINS = (0.0, 30.0, 60.0, 80.0, 90.0, 120.0)


def angle_table(rows: Sequence[Row]) -> str:
    """Converged share per scheme and bin of the target centre's start angle (general starts)."""
    gen = [r for r in rows if r.study == "general"]
    bins = list(zip(ANGLE_BINS[:-1], ANGLE_BINS[1:]))
    counts = []
    for lo, hi in bins:
        counts.append(len({r.start for r in gen if lo <= r.centre_angle_deg < hi}))
    head = "| scheme | " + " | ".join(f"{lo:g}–{hi:g}° ({n} starts)" for (lo, hi), n in zip(bins, counts)) + " |"
    lines = [head, "|" + "---|" * (1 + len(bins))]
    for scheme in dict.fromkeys(r.scheme for r in gen):
        cells = []
        for lo, hi in bins:
            b = [r for r in gen if r.scheme == scheme and lo <= r.centre_angle_deg < hi]
            cells.append(f"{100.0 * sum(r.converged for r in b) / len(b):.0f} %" if b else "—")
        lines.append(f"| `{scheme}` | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def figures(rows: Sequence[Row], keep: dict, out: Path, fov: float = FOV) -> list[str]:
    """Write the figures of the study's rows (its lens: fov degrees) into out; returns their file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    style = {s: ("--" if s in PERSPECTIVE else "-") for s in SCHEMES}
    rot = [r for r in rows if r.study == "rotation"]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for scheme in dict.fromkeys(r.scheme for r in rot):
        mine = [r for r in rot if r.scheme == scheme]
        deg = [float(r.start.split()[1]) for r in mine]
        ax[0].plot(deg, [r.camera_retreat if r.reached else np.nan for r in mine], "o" + style[scheme], label=scheme,
                   ms=3)
        ax[1].plot(deg, [r.peak_angular_speed if r.reached else np.nan for r in mine], "o" + style[scheme],
                   label=scheme, ms=3)
    ax[0].set(xlabel="rotation about the optical axis (deg)", ylabel="camera retreat (m)",
              title="retreat (gaps: goal not reached)")
    ax[1].set(xlabel="rotation about the optical axis (deg)", ylabel="peak |ω| (rad/s)", title="peak angular speed")
    ax[1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    names.append("wide_rotation.png")
    fig.savefig(out / names[-1], dpi=90)
    plt.close(fig)

    gen = [r for r in rows if r.study == "general"]
    if gen:
        edges = np.arange(0.0, 121.0, 10.0)
        fig, ax = plt.subplots(figsize=(7, 4))
        for scheme in dict.fromkeys(r.scheme for r in gen):
            share = []
            for lo, hi in zip(edges[:-1], edges[1:]):
                b = [r for r in gen if r.scheme == scheme and lo <= r.centre_angle_deg < hi]
                share.append(100.0 * sum(r.converged for r in b) / len(b) if b else np.nan)
            ax.plot((edges[:-1] + edges[1:]) / 2, share, "o" + style[scheme], label=scheme, ms=4)
        ax.axvspan(90.0, 120.0, color="grey", alpha=0.15, lw=0)
        ax.text(91.0, 50.0, "behind the\nimage plane", fontsize=7)
        ax.set(xlabel="target centre off the optical axis at the start (deg, bins of 10)",
               ylabel="converged (%)", title="random starts: converged share by start angle", xlim=(0, 120),
               ylim=(-3, 103))
        ax.legend(fontsize=7)
        fig.tight_layout()
        names.append("wide_angle.png")
        fig.savefig(out / names[-1], dpi=90)
        plt.close(fig)

    half = [(s, tr) for (lab, s), tr in keep.items() if lab == TRACED]
    wide_runs = [(lab, s, tr) for (lab, s), tr in keep.items() if lab != TRACED and s in SPHERICAL]
    if half:
        lens_deg = check_fov(fov) / 2  # the lens's circle off the axis
        f = (SENSOR / 2) / math.radians(lens_deg)
        fig, ax = plt.subplots(1, 2, figsize=(11, 4.6))
        for scheme, tr in half:
            t = np.arange(len(tr.pose)) / FPS
            d = np.linalg.norm(tr.pose[:, :3, 3] - target_points().mean(axis=0), axis=1)
            ax[0].plot(t, d, style[scheme], label=scheme)
        ax[0].set(xlabel="time (s)", ylabel="camera to target centre (m)", ylim=(0, 8),
                  title="the half-turn about the optical axis (π exactly)")
        ax[0].legend(fontsize=7)
        if wide_runs:
            for (label, scheme, tr), colour in zip(wide_runs, ("C0", "C1", "C2")):
                outcome = next(x.outcome for x in rows if x.start == label and x.scheme == scheme)
                for i in range(tr.pixels.shape[1]):
                    ax[1].plot(tr.pixels[:, i, 0], tr.pixels[:, i, 1], color=colour, lw=0.8,
                               label=f"{scheme}: {outcome.replace('_', ' ')}" if i == 0 else None)
                ax[1].plot(tr.pixels[0, :, 0], tr.pixels[0, :, 1], "o", color=colour, ms=3)
            goal = camera(fov).from_bearing(in_camera(np.eye(4), target_points()))
            ax[1].plot(goal[:, 0], goal[:, 1], "k+")
            for deg, ls in ((lens_deg, "-"), (90.0, ":")):
                ax[1].add_patch(plt.Circle((SENSOR / 2, SENSOR / 2), f * math.radians(deg), fill=False, ls=ls,
                                           color="grey"))
            r = [x for x in rows if x.start == wide_runs[0][0]][0]
            ax[1].set(xlim=(0, SENSOR), ylim=(SENSOR, 0), aspect="equal",
                      title=f"random start {r.start}: the target {r.centre_angle_deg:.0f}° off the axis "
                            "(o: start, +: goal)")
            ax[1].title.set_fontsize(9)
            ax[1].legend(fontsize=7, loc="lower left")
        else:
            ax[1].axis("off")
        fig.suptitle("left: distance to the target (cartesian and spherical run off the top); right: the fisheye "
                     f"image (pixels; circles: 90° dotted, the lens's {lens_deg:g}° solid)", fontsize=9)
        fig.tight_layout()
        names.append("wide_traces.png")
        fig.savefig(out / names[-1], dpi=90)
        plt.close(fig)
    return names


def starts_table(rows: Sequence[Row]) -> str:
    """What the perspective schemes and a pinhole camera could see of each study's starts."""
    lines = ["| starts | number | target centre off the axis (deg) | a point beyond 45° (a 90° pinhole cannot see "
             "them) | beyond the perspective domain (cannot see) | a point at or beyond 90° |", "|" + "---|" * 6]
    for st in dict.fromkeys(r.study for r in rows):
        one = list({r.start: r for r in rows if r.study == st}.values())
        a = [r.centre_angle_deg for r in one]
        lines.append(f"| {st} | {len(one)} | {min(a):.0f}–{max(a):.0f} | {sum(r.beyond_pinhole for r in one)} | "
                     f"{sum(r.cannot_see for r in one)} | {sum(r.max_angle_deg >= 90.0 for r in one)} |")
    return "\n".join(lines)


def _find(rows, study_name, start, scheme) -> Optional[Row]:
    return next((r for r in rows if r.study == study_name and r.start == start and r.scheme == scheme), None)


def summary(rows: Sequence[Row]) -> list[str]:
    """The page's "In short" bullets, their numbers from the rows."""
    gen = [r for r in rows if r.study == "general"]
    n = len({r.start for r in gen})
    blind = {r.start for r in gen if r.cannot_see}

    def conv(scheme, starts=None):
        return sum(r.converged for r in gen if r.scheme == scheme and (starts is None or r.start in starts))

    out = []
    if n and any(r.scheme == "spherical" for r in gen):
        out.append(f"- Spherical point features (`spherical`) converged from {conv('spherical')} of {n} random starts "
                   f"up to 100° off the axis, {conv('spherical', blind)} of them among the {len(blind)} that no "
                   "perspective feature can see; the perspective Cartesian features from "
                   f"{conv('cartesian')}.")
    h = _find(rows, "paper", "z_rotation", "spherical_polar")
    if h is not None and n and all(any(r.scheme == s for r in gen) for s in ("polar", "polar_per_point")):
        sweep = [r for r in rows if r.study == "rotation" and r.scheme == "spherical_polar"]
        still = sum(r.reached and r.camera_retreat < 1e-6 for r in sweep)
        half = (f"at the exact half-turn too (path {h.path_length:.0e} m)" if h.reached and h.camera_retreat < 1e-6
                else f"but not at the exact half-turn, where they end as *{h.outcome.replace('_', ' ')}*")
        out.append(f"- Spherical-polar features, whose azimuth errors take part in the Servo's consistent wrap (paper "
                   f"eq. 13) as IBVS-P's θ errors do, turn the camera about its axis without retreat (under 1e-6 m) "
                   f"from {still} of the sweep's {len(sweep)} angles, {half}; from the random starts they converged "
                   f"{conv('spherical_polar')} times, IBVS-P {conv('polar')}, IBVS-P with its θ errors wrapped per "
                   f"point {conv('polar_per_point')}.")
    if n and any(r.scheme == "spherical_stacked" for r in gen):
        best = max(SCHEMES, key=lambda s: conv(s))
        most = "the most of the seven schemes" if best == "spherical_stacked" else f"`{best}` most ({conv(best)})"
        out.append(f"- Stacked on the sphere (`spherical_stacked`: the bearing and (β, φ) of each point) the features "
                   f"converged from {conv('spherical_stacked')} of the {n} random starts ({most}), "
                   f"{conv('spherical_stacked', blind)} of the {len(blind)} unseen ones; median camera retreat over its runs "
                   f"{_median([r.camera_retreat for r in gen if r.scheme == 'spherical_stacked']):.3f} m.")
    r = _find(rows, "rotation", "rz 150 deg", "spherical")
    c = _find(rows, "rotation", "rz 150 deg", "cartesian")
    if r is not None and c is not None:
        out.append(f"- The sphere does not cure the retreat: turned by 150° about the axis, the spherical point "
                   f"features retreat {r.camera_retreat:.2f} m, the Cartesian ones {c.camera_retreat:.2f} m.")
    return out


def findings(rows: Sequence[Row]) -> list[str]:
    """The bullets of "What shows", their numbers from the rows."""
    gen = [r for r in rows if r.study == "general"]
    out = []
    if gen:
        blind = {r.start for r in gen if r.cannot_see}
        n = len({r.start for r in gen})
        sph = {s: sum(r.converged for r in gen if r.scheme == s and r.start in blind) for s in SPHERICAL}
        out.append(f"- **What a perspective feature cannot see.** {len(blind)} of the {n} random starts have a point "
                   "outside the perspective domain (behind the image plane, or beyond |x|, |y| = 10 where ibvs "
                   "refuses normalised coordinates, 84–86° off the axis): the perspective schemes cannot start "
                   "there, whatever the lens. From those starts the spherical schemes converged "
                   + ", ".join(f"`{s}` {sph[s]}" for s in SPHERICAL) + f" times of {len(blind)} "
                   "(tests/python/test_wide.py: the spherical point features converge from a start 100° off the "
                   "axis; the count of such starts equals one made independently from the geometry).")
        seen = sorted({r.start for r in gen} - blind)
        on_seen = {s: sum(r.converged for r in gen if r.scheme == s and r.start in seen) for s in SCHEMES}
        outs = {s: {r.start: r.outcome for r in gen if r.scheme == s} for s in SCHEMES}
        out.append(f"- **Random starts the perspective schemes see** ({len(seen)}), converged: "
                   + ", ".join(f"`{s}` {on_seen[s]}" for s in SCHEMES if any(r.scheme == s for r in gen))
                   + ". The spherical Cartesian features do about as the perspective Cartesian ones "
                   "(both chase each point straight to its goal) and, unlike them, keep going beyond 84°.")
        if all(outs[s] for s in ("polar", "polar_per_point", "spherical_polar")):
            agree = sum(outs["polar"][x] == outs["spherical_polar"][x] for x in seen)
            fails = [r for r in gen if r.scheme in ("spherical_polar", "spherical_stacked") and not r.converged]
            back = sum(r.outcome == "target_backside" for r in fails)
            near = [x for x in seen if _find(rows, "general", x, "polar").centre_angle_deg < 30.0]
            near_conv = {s: sum(outs[s][x] == "converged" for x in near) for s in ("polar", "polar_per_point",
                                                                                   "spherical_polar")}
            out.append(f"- **Spherical-polar features against IBVS-P.** Of the {len(seen)} random starts the "
                       f"perspective schemes see, `spherical_polar` converged from {on_seen['spherical_polar']}, "
                       f"`polar` from {on_seen['polar']}, and the two end the same way from {agree}; "
                       f"`polar_per_point` (IBVS-P with its θ errors wrapped per point) from "
                       f"{on_seen['polar_per_point']}. Near the axis (the target's centre within 30°, {len(near)} "
                       f"starts, turned by up to 180°): `polar` {near_conv['polar']}, `spherical_polar` "
                       f"{near_conv['spherical_polar']}, `polar_per_point` {near_conv['polar_per_point']}: turned by "
                       "most of a half-turn, errors wrapped point by point fall on both sides of ±π, the points pull "
                       "different ways and the law throws the camera sideways; one branch for all (the consistent "
                       "wrap, which the azimuths of the spherical-polar blocks join) turns it (tested at two such "
                       "starts). The spherical stacked features carry the same azimuth rows: "
                       f"{on_seen['spherical_stacked']} against the stacked perspective features' "
                       f"{on_seen['stacked']}. {back} of the {len(fails)} failures of `spherical_polar` and "
                       "`spherical_stacked` end behind the target's plane, at a median peak speed of "
                       f"{_median([r.peak_linear_speed for r in fails]):.0f} m/s. Farther off the axis all polar "
                       "kinds suffer the weakness the paper finds in IBVS-P for translations: the azimuths of the "
                       "four points lie close together while the goal's spread round the circle.")
    h = {s: _find(rows, "paper", "z_rotation", s) for s in SCHEMES}
    sp, pl, pp = h.get("spherical_polar"), h.get("polar"), h.get("polar_per_point")
    if sp is not None and pl is not None and pp is not None:
        out.append(f"- **The half-turn with spherical-polar features** (the paper's z-rotation of exactly π): "
                   f"`polar` ends as *{pl.outcome.replace('_', ' ')}* (retreat {pl.camera_retreat:.1e} m, path "
                   f"{pl.path_length:.1e} m), `spherical_polar` as *{sp.outcome.replace('_', ' ')}* (retreat "
                   f"{sp.camera_retreat:.1e} m, path {sp.path_length:.1e} m), `polar_per_point` as "
                   f"*{pp.outcome.replace('_', ' ')}* after {pp.path_length:.1f} m at up to "
                   f"{pp.peak_linear_speed:.0f} m/s. At exactly π the four azimuth errors are ±π, and each wrapped "
                   "on its own (`SphericalPolarFeature.error`, eq. 13 read point by point) one of them rounds to "
                   "the other branch (−π); the Servo takes the azimuth rows (`Feature.axis_angle_rows`) into the "
                   "circular mean of its consistent wrap with the polar points' θ rows and re-wraps them about it, "
                   "so all four lie on one branch and the law commands a pure rotation about the axis (tested; "
                   "with `angle_wrap=\"per_point\"` the split stays, as in `polar_per_point`).")
    rot = {s: _find(rows, "rotation", "rz 150 deg", s) for s in SCHEMES}
    if all(rot.get(s) for s in ("cartesian", "spherical", "stacked", "spherical_stacked")):
        gone = sum(not r.in_view for r in rows if r.scheme in SPHERICAL)
        out.append(f"- **About the optical axis** (150°): the spherical Cartesian features retreat as the Cartesian "
                   f"ones do ({rot['spherical'].camera_retreat:.2f} m against {rot['cartesian'].camera_retreat:.2f} "
                   "m: near the axis a bearing is the image point with a third coordinate, and each point is chased "
                   "straight to its goal), the stacked spherical features as the stacked ones "
                   f"({rot['spherical_stacked'].camera_retreat:.2f} m against {rot['stacked'].camera_retreat:.2f} m; "
                   "tested). The sphere does not cure the retreat; only the polar coordinates do. "
                   f"{gone} of the {sum(r.scheme in SPHERICAL for r in rows)} spherical runs left the lens's view.")
    peaks = {s: _median([r.peak_linear_speed for r in rows if r.scheme == s and r.outcome != "cannot_see"])
             for s in SCHEMES}
    out.append("- **Peak twist**: no speed limit is applied (gain 1, damping 0, as in the comparison). Median peak "
               "linear speeds: " + ", ".join(f"`{s}` {v:.1f} m/s" for s, v in peaks.items() if math.isfinite(v))
               + ". The polar kinds' peaks come from the wide starts, where their laws throw the camera sideways; "
               "a robot would clip them (ibvs.Servo's max_linear_speed / max_angular_speed), which changes their "
               "paths.")
    out.append(_collisions(rows))
    out.append("- Not in this study: image noise, depth estimation (the depths and distances are exact), speed "
               "limits, a lens with distortion (the model is exact here), Mei's omnidirectional model, and images "
               "rendered through the lens (the renderer draws them: docs/wide.md servoes one episode on them).")
    return out


def _collisions(rows: Sequence[Row]) -> str:
    """The bullet of "What shows" on the collisions: how many per scheme."""
    hit = [r for r in rows if r.outcome == "collision"]
    if not hit:
        return "- **Collisions.** No run collides."
    per = {s: sum(r.scheme == s for r in hit) for s in SCHEMES}
    return (f"- **Collisions.** {len(hit)} runs collide (" + ", ".join(f"`{s}` {n}" for s, n in per.items() if n)
            + "); an earlier "
            "version of this page, whose Python loop measured the standoff from the square's centre and called "
            "every crossing of its plane target backside, counted most of them (those that pass by the plate's "
            "edge) as converged and those that go through the plate as target backside.")


def page(rows: Sequence[Row], figure_names: Sequence[str], rotations: int, general: int, seed: int,
         seconds: float, fov: float = FOV) -> str:
    """docs/wide-study.md (the study's lens: fov degrees)."""
    fov = check_fov(fov)
    c = camera(fov)
    parts = [
        f"# Wide field of view: perspective against spherical features on a {fov:g}° fisheye",
        "",
        "Regenerated by `ibvs wide --out DIR --docs` (or `python -m ibvs.study.wide`), which writes this page and its "
        f"figures: {len(rows)} runs ({len(set(r.scheme for r in rows))} schemes; the paper's three free-camera cases, "
        f"{rotations} angles about the optical axis from 0 to 180°, {general} random starts up to 100° off the "
        f"axis (seed {seed})), {seconds:.0f} s on one core. Features on the sphere and the lens models: "
        "[wide.md](wide.md); the laws on a perspective camera: [compare.md](compare.md).",
        "",
        f"**Set-up.** A free-flying camera with an equidistant fisheye, r = f θ, no distortion, f = {c.px:.1f} px, "
        f"whose image circle, {fov / 2:g}° off the axis (a {fov:g}° lens), is inscribed in a "
        f"{SENSOR} × {SENSOR} sensor; the paper's target (the square (±0.25, ±0.25) m, 3 m in front of the goal "
        "camera); gain 1, damping 0, exact depths, 60 frames/s, 30 s. Every scheme measures the target's pixels "
        "through the lens model: the perspective schemes (`cartesian`, `polar`, `stacked`, the Layouts of "
        "ibvs.study.schemes, and `polar_per_point`, IBVS-P with `angle_wrap=\"per_point\"`: each point's θ error "
        "wrapped on its own, eq. 13 read point by point) normalise them with "
        "`CameraModel.normalize`, (x, y) = (X/Z, Y/Z); the spherical ones "
        "lift them to bearings with `ibvs.spherical_measurements` and servo four `SphericalPointFeature` blocks "
        "(`spherical`, 12 rows), four `SphericalPolarFeature` blocks (`spherical_polar`, 8 rows; their azimuth "
        "errors take part in the Servo's consistent wrap, as `polar`'s θ errors) or both per point "
        "(`spherical_stacked`, 20 rows). Random starts: rotation about the axis 0–180°, tilt 0–100° in a uniform "
        "direction, translation ±0.2, ±0.2, ±0.5 m (starts with a point beyond the lens's circle are drawn again). "
        "Every run is an `ibvs.sim.run` episode of a free camera (the twist held for a frame; its stopping rules: "
        "diverged, collision, target backside, left image, converged, singular, timeout); for this lens the "
        "simulator judges a point in view by the lens's image circle, whatever the sign of its depth, and feeds "
        "the spherical blocks the bearings of the measured pixels (`sim.SphericalSource`); "
        "tests/python/test_wide.py checks that a run equals a direct `ibvs.sim.run` call. *Collision* is the "
        f"simulator's: the camera through the plate or within {STANDOFF * 3.0:.2f} m of it (the disc about the "
        "square's centre through its corners; target backside: behind its plane beyond it). "
        "A perspective run the Servo refuses because a point went beyond |x|, |y| = 10 "
        "(`Status.invalid_input`, which the simulator reports as diverged) is counted as having left the "
        "perspective domain.",
        "",
        "**Columns.** *converged*: the task's error norm under "
        f"{TOLERANCE:g} within 30 s (each task in its own units); *reached goal*: the camera within 1 mm and 1 mrad "
        "of the goal; *cannot see the start*: a start with a point outside the perspective domain (behind the "
        "image plane, or |x| or |y| above 10, ibvs's limit on normalised coordinates, 84–86° off the axis), not run "
        "for the perspective schemes, run for the spherical ones; *stayed in view*: no point left the lens's circle, "
        "nor, for the perspective schemes, their domain; *retreat*: the largest increase of the camera's distance "
        "to the target's centre (the simulator measures it along the optical axis, which means nothing when the "
        "target starts beside the camera); the camera's path length; the peak speeds of the commanded twist; "
        "medians and "
        "maxima over the runs started.",
        "",
        "**In short.**",
        "",
    ] + summary(rows) + [
        "",
        "## All starts",
        "",
        table(rows),
        "",
        "Random starts only:",
        "",
        table(rows, ("general",)),
        "",
        "What could be seen of the starts:",
        "",
        starts_table(rows),
        "",
        "## The paper's cases and the rotations about the optical axis",
        "",
        "The camera retreat of each scheme when it reached the goal, otherwise what ended the run:",
        "",
        case_table(rows, "paper"),
        "",
        case_table(rows, "rotation"),
        "",
        "## By the target's start angle",
        "",
        "Converged share of the random starts, by the angle of the target's centre off the optical axis:",
        "",
        angle_table(rows),
        "",
    ]
    for name in figure_names:
        parts += [f"![{name}](figures/{name})", ""]
    parts += ["## What shows, and what is tested", ""] + findings(rows) + [""]
    return wrap("\n".join(parts))


def build_parser():
    """The parser of `ibvs wide` (one-line errors, exit status 2; --out tried for writing when parsed)."""
    from ..cli import args as a

    p = a.Parser(prog="ibvs wide", description="A 220-degree fisheye (--fov: another) servoed on perspective features "
                 "(Cartesian, polar, stacked) and on features on the sphere (spherical, spherical-polar, stacked), on "
                 "the paper's cases, rotations and random wide starts.",
                 epilog=a.exit_status("the study ran; its files are written"))
    a.add_output(p, "--out", type=a.out_dir, default="ibvs-wide",
                 help="output directory: wide.csv, wide-study.md, figures (created if missing)")
    p.add_argument("--rotations", type=a.number(2, 181, integer=True), default=19,
                   help="angles about the optical axis from 0 to 180 deg, 2 to 181 (19)")
    p.add_argument("--general", type=a.number(0, 100000, integer=True), default=200,
                   help="random starts, tilted up to 100 deg, 0 to 100000 (200)")
    p.add_argument("--seed", type=a.number(0, a.SEED_MAX, integer=True), default=0)
    p.add_argument("--fov", type=a.number(*FOV_LIMITS), default=FOV, metavar="DEGREES",
                   help=f"the fisheye's full field of view, degrees in [{FOV_LIMITS[0]:g}, {FOV_LIMITS[1]:g}] "
                        f"({FOV:g}): its image circle, fov/2 off the axis, inscribed in the sensor")
    p.add_argument("--docs", action="store_true",
                   help="also write docs/wide-study.md and docs/figures/wide_*.png of this repository")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    """`ibvs wide`: run the study, write wide.csv, wide-study.md and the figures (and docs/ with --docs)."""
    p = build_parser()
    args = p.parse_args(argv)
    docs = output.docs_dir(p, args.docs)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    keep: dict = {}
    rows = study(args.rotations, args.general, args.seed, keep=keep, fov=args.fov)
    seconds = time.perf_counter() - t0
    output.write(rows, out, docs, "wide.csv", "wide-study.md", lambda d: figures(rows, keep, d, args.fov),
                 lambda names: page(rows, names, args.rotations, args.general, args.seed, seconds, args.fov))
    print(table(rows))
    print(f"{len(rows)} runs in {seconds:.0f} s; written to {out}" + (" and docs/" if args.docs else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
