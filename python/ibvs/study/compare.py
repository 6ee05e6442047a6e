"""The comparison of issue 21: every classical answer to the half-turn about the optical axis and
the camera retreat, on the same free-camera cases, side by side.

    python -m ibvs.study.compare --out DIR [--rotations 7] [--general 12] [--docs]
    ibvs compare --out DIR ...

Schemes (ibvs.study.schemes): IBVS (cartesian), IBVS-P (polar), stacked, cylindrical, partitioned,
image moments with alpha from third-order moments (moments) and from second-order ones (moments_pi,
modulo pi), 2.5-D (reference point 0) and both PBVS variants (pbvs: camera to desired camera,
pbvs_object: camera to object). Every scheme runs on one target: the asymmetric planar
quadrilateral TARGET_XY (3 m in front of the goal camera, its area's centre of gravity on the optical
axis at the goal), because the paper's square is centrally symmetric: its orientation alpha from
third-order moments is undefined, and from second-order moments too (mu20 = mu02, mu11 = 0), so no
moments task can servo on it (moments_target refuses it). The pose schemes take the true pose
(depth "exact", times depth_scale): the comparison of the laws, not of a pose estimator.

Studies (the default size, 10 schemes x 83 starts, runs in about 15 s on one core):
  * paper: the paper's free-camera cases (x translation, rotation by 180 deg about z, general motion);
  * rotation: rotation about the optical axis from 0 to 180 deg (`rotations` angles, default 19);
  * general: `general` (default 50) random starts of the free world's distribution (seeded);
  * depth: one general start with every depth (and the pose's translation) scaled by depth_scale;
  * calibration: the same start seen by a 480x480 pixel camera (focal length 800 px: the same +-0.3 image) whose
    controller believes wrong intrinsics (CALIBRATIONS: focal length scaled, principal point offset, radial
    distortion ignored) through ibvs.sim.MiscalibratedCamera, every scheme with the pose depth mode (depths and
    pose from ibvs.PlanarPose on the points the wrong model gives); the pose schemes' goal pose (and 2.5-D's Z*)
    is estimated the same way from the goal's image (teach by showing).
Per run: converged (the task's error norm under TOLERANCE), reached (the camera within 1 mm and
1 mrad of the goal), stayed in the image (no point left the +-0.3 image), camera retreat, camera path
length, peak camera speeds, final pose error.
"""

from __future__ import annotations

import textwrap

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

import ibvs

from .. import sim
from . import output, schemes
from .scenario import DEFAULT_RANGES, DEFAULTS, Scenario, offset

#: The schemes compared, in table order.
SCHEMES = ("cartesian", "polar", "stacked", "cylindrical", "partitioned", "moments", "moments_pi", "2.5d", "pbvs",
           "pbvs_object")
#: Short names for the table.
NAMES = {"cartesian": "IBVS", "polar": "IBVS-P", "stacked": "stacked", "cylindrical": "cylindrical",
         "partitioned": "partitioned", "moments": "image moments", "moments_pi": "image moments",
         "2.5d": "2.5-D", "pbvs": "PBVS, to desired camera", "pbvs_object": "PBVS, to object"}
#: The orientation each row uses (the other rows: none).
ALPHA = {"moments": "α from 3rd-order moments (full turn)", "moments_pi": "α from 2nd-order moments (mod π)"}
#: An asymmetric planar quadrilateral (target frame, metres), about the paper's square's size; its area's
#: centre of gravity is moved to the origin by target().
TARGET_XY = np.array([[0.30, 0.18], [-0.22, 0.26], [-0.27, -0.20], [0.16, -0.24]])
DEPTH = 3.0
GAIN = 1.0
DURATION = 20.0
TOLERANCE = 1e-6
REACHED = (1e-3, 1e-3)  # metres, radians
DEPTH_SCALES = (0.5, 0.8, 1.25, 2.0)
#: The start of the depth study: general, every axis.
DEPTH_START = dict(DEFAULTS, rz_deg=60.0, tilt_deg=8.0, tilt_dir_deg=30.0, tx=0.1, ty=-0.05, tz=-0.3)
#: The calibration study's true camera: its focal length (px) ...
FOCAL = 800.0
#: ... and half its square image's side (px), the principal point at its centre: the normalised +-0.3 image.
HALF = 240.0
#: The radial distortion (OpenCV's k1) of the calibration case where the controller ignores it (3.5 % at the
#: image's corners).
K1 = -0.2
#: The calibration errors, label -> (believed focal length / true, believed principal point - true (px),
#: the true camera has the distortion K1 that the controller ignores). "none": the pose depth mode's baseline.
CALIBRATIONS = {
    "none": (1.0, (0.0, 0.0), False),
    "f ×0.8": (0.8, (0.0, 0.0), False),
    "f ×0.9": (0.9, (0.0, 0.0), False),
    "f ×1.1": (1.1, (0.0, 0.0), False),
    "f ×1.25": (1.25, (0.0, 0.0), False),
    "c +(24, −16) px": (1.0, (24.0, -16.0), False),
    "k1 ignored": (1.0, (0.0, 0.0), True),
}


def target() -> sim.Target:
    """The compared target: TARGET_XY with its area's centre of gravity at the origin, DEPTH in
    front of the goal camera (the world origin, looking along +z)."""
    m = ibvs.MomentsFeature.of_polygon(TARGET_XY)
    xy = TARGET_XY - np.asarray(m[1:3]) / m[0]
    T = np.eye(4)
    T[2, 3] = DEPTH
    return sim.Target(np.column_stack([xy, np.zeros(len(xy))]), T)


def scenario() -> Scenario:
    """The free world of the sweeps (its camera and start distribution) with the compared target."""
    c = sim.cases.z_rotation()
    return Scenario(c.camera, target(), np.eye(4), name="compare", ranges=dict(DEFAULT_RANGES["free"]),
                    gain=GAIN, duration=DURATION, depth="exact", tolerance=TOLERANCE)


@dataclass(frozen=True)
class Row:
    """One run: the study, the start's label, the scheme and what it did."""

    study: str
    start: str
    scheme: str
    depth_scale: float
    outcome: str
    converged: bool
    reached: bool
    in_image: bool
    camera_retreat: float
    path_length: float
    peak_linear_speed: float
    peak_angular_speed: float
    final_translation_error: float
    final_rotation_error: float


def cameras(calibration: str) -> tuple:
    """(the true camera, the camera the controller believes) of a CALIBRATIONS label (ibvs.CameraModel, pixels)."""
    scale, (du, dv), distorted = CALIBRATIONS[calibration]
    K = np.array([[FOCAL, 0.0, HALF], [0.0, FOCAL, HALF], [0.0, 0.0, 1.0]])
    K_hat = np.array([[scale * FOCAL, 0.0, HALF + du], [0.0, scale * FOCAL, HALF + dv], [0.0, 0.0, 1.0]])
    true = ibvs.CameraModel.from_opencv(K, [K1, 0.0, 0.0, 0.0] if distorted else None, 2 * HALF, 2 * HALF)
    return true, ibvs.CameraModel.from_opencv(K_hat, None, 2 * HALF, 2 * HALF)


def run(scheme: str, start: np.ndarray, depth_scale: float = 1.0, setup: Optional[Scenario] = None,
        calibration: Optional[str] = None):
    """One free-camera run of `scheme` from `start` (4x4 world <- camera): the sim.Result. calibration: None,
    or a CALIBRATIONS label: the pixel camera of cameras(calibration), its controller believing the wrong one
    (sim.MiscalibratedCamera), with the pose depth mode."""
    setup = setup or scenario()
    servo = schemes.make(scheme, setup.gain, len(setup.target))
    camera, depth, vision = setup.camera, setup.depth, None
    if calibration is not None:
        camera, believed = cameras(calibration)
        depth, vision = "pose", sim.MiscalibratedCamera(camera, believed)
    return sim.run(servo, camera, schemes.target_for(scheme, setup.target), start, setup.goal_pose(),
                   duration=setup.duration, depth=depth, depth_scale=depth_scale, tolerance=TOLERANCE, vision=vision)


def summarise(study: str, start: str, scheme: str, result, depth_scale: float = 1.0) -> Row:
    """The Row of one run: its outcome, whether it reached the goal, retreat, path and peak speeds."""
    s, m = result.status, result.metrics
    reached = bool(m.final_translation_error < REACHED[0] and m.final_rotation_error < REACHED[1])
    return Row(study, start, scheme, depth_scale, s.outcome, bool(s.converged), reached, s.outcome != "left_image",
               m.camera_retreat, m.path_length, m.peak_linear_speed, m.peak_angular_speed,
               m.final_translation_error, m.final_rotation_error)


def starts(rotations: int = 19, general: int = 50, seed: int = 0) -> list[tuple[str, str, np.ndarray, float]]:
    """(study, label, start pose, depth_scale) of every run (per scheme); the calibration study's label is the
    CALIBRATIONS label."""
    setup = scenario()
    out = []
    for case in (sim.cases.x_translation(), sim.cases.z_rotation(), sim.cases.general_motion()):
        out.append(("paper", case.name, np.asarray(case.start), 1.0))
    for deg in np.linspace(0.0, 180.0, rotations):
        out.append(("rotation", f"rz {deg:g} deg", offset(dict(DEFAULTS, rz_deg=float(deg))), 1.0))
    k = 0
    while sum(1 for s in out if s[0] == "general") < general:  # random starts with the target in view
        start, _ = setup.start_outcome(setup.sample(seed, k))
        if start is not None:
            out.append(("general", f"#{k}", start, 1.0))
        k += 1
    for scale in DEPTH_SCALES:
        out.append(("depth", f"depth x{scale:g}", offset(DEPTH_START), scale))
    for label in CALIBRATIONS:
        out.append(("calibration", label, offset(DEPTH_START), 1.0))
    return out


def study(rotations: int = 19, general: int = 50, seed: int = 0, schemes_: Sequence[str] = SCHEMES,
          keep: Optional[dict] = None) -> list[Row]:
    """Every run of the comparison (see the module docstring); keep: a dict filled with the sim.Result
    of the figures' runs, {(start label, scheme): result}."""
    setup = scenario()
    rows = []
    for st, label, start, scale in starts(rotations, general, seed):
        for scheme in schemes_:
            r = run(scheme, start, scale, setup, label if st == "calibration" else None)
            rows.append(summarise(st, label, scheme, r, scale))
            if keep is not None and label in ("z_rotation", "general_motion", "rz 150 deg"):
                keep[(label, scheme)] = r
    return rows


def _median(x) -> float:
    x = [v for v in x if math.isfinite(v)]
    return float(np.median(x)) if x else math.nan


def table(rows: Sequence[Row]) -> str:
    """The summary table (markdown): one row per scheme over the paper, rotation and general starts,
    then the depth study's final translation error."""
    head = ("| scheme | α | converged | reached goal | stayed in image | retreat median / max (m) | "
            "path median (m) | peak v median (m/s) | peak ω median (rad/s) | "
            + " | ".join(f"pose error, depth ×{s:g} (mm)" for s in DEPTH_SCALES) + " |")
    lines = [head, "|" + "---|" * (9 + len(DEPTH_SCALES))]
    for scheme in dict.fromkeys(r.scheme for r in rows):
        mine = [r for r in rows if r.scheme == scheme and r.study not in ("depth", "calibration")]
        depth = {r.depth_scale: r for r in rows if r.scheme == scheme and r.study == "depth"}
        n = len(mine)
        retreat = [r.camera_retreat for r in mine]
        cells = [
            NAMES.get(scheme, scheme) + f" (`{scheme}`)",
            ALPHA.get(scheme, "—"),
            f"{sum(r.converged for r in mine)}/{n}",
            f"{sum(r.reached for r in mine)}/{n}",
            f"{sum(r.in_image for r in mine)}/{n}",
            f"{_median(retreat):.3f} / {max(retreat):.3f}",
            f"{_median([r.path_length for r in mine]):.3f}",
            f"{_median([r.peak_linear_speed for r in mine]):.3f}",
            f"{_median([r.peak_angular_speed for r in mine]):.3f}",
        ]
        for s in DEPTH_SCALES:
            r = depth.get(s)
            cells.append("—" if r is None else (f"{r.final_translation_error * 1000:.1f}" if r.in_image else r.outcome))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _cell(r: Row) -> str:
    """A calibration run's final pose error, or what ended it; "(timeout)" when it had not converged in 20 s."""
    if not r.in_image:
        return r.outcome.replace("_", " ")
    cell = f"{r.final_translation_error * 1000:.1f} mm, {np.degrees(r.final_rotation_error):.2f}°"
    return cell if r.converged else f"{cell} ({r.outcome.replace('_', ' ')})"


def calibration_table(rows: Sequence[Row]) -> str:
    """Per scheme and calibration error: converged and in-image counts, the final camera pose error."""
    cal = [r for r in rows if r.study == "calibration"]
    labels = list(dict.fromkeys(r.start for r in cal))
    lines = ["| scheme | converged | stayed in image | " + " | ".join(labels) + " |", "|" + "---|" * (3 + len(labels))]
    for scheme in dict.fromkeys(r.scheme for r in cal):
        by = {r.start: r for r in cal if r.scheme == scheme}
        mine = list(by.values())
        counts = f"{sum(r.converged for r in mine)}/{len(mine)} | {sum(r.in_image for r in mine)}/{len(mine)}"
        lines.append(f"| `{scheme}` | {counts} | " + " | ".join(_cell(by[x]) for x in labels) + " |")
    return "\n".join(lines)


def rotation_table(rows: Sequence[Row]) -> str:
    """Per scheme and angle about the optical axis: the outcome, the retreat (m) when it reached the goal."""
    rot = [r for r in rows if r.study == "rotation"]
    labels = list(dict.fromkeys(r.start for r in rot))
    lines = ["| scheme | " + " | ".join(x.replace("rz ", "") for x in labels) + " |", "|" + "---|" * (1 + len(labels))]
    for scheme in dict.fromkeys(r.scheme for r in rot):
        by = {r.start: r for r in rot if r.scheme == scheme}
        cells = [f"{by[x].camera_retreat:.2f}" if by[x].reached else
                 ("not reached" if by[x].outcome in ("converged", "timeout") else by[x].outcome.replace("_", " "))
                 for x in labels]
        lines.append(f"| `{scheme}` | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def figures(rows: Sequence[Row], keep: dict, out: Path) -> list[str]:
    """Write the figures into out; returns their file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    rot = [r for r in rows if r.study == "rotation"]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for scheme in dict.fromkeys(r.scheme for r in rot):
        mine = [r for r in rot if r.scheme == scheme]
        deg = [float(r.start.split()[1]) for r in mine]
        ax[0].plot(deg, [r.camera_retreat if r.in_image else np.nan for r in mine], "o-", label=scheme, ms=3)
        ax[1].plot(deg, [r.path_length if r.in_image else np.nan for r in mine], "o-", label=scheme, ms=3)
    ax[0].set(xlabel="rotation about the optical axis (deg)", ylabel="camera retreat (m)",
              title="retreat (gaps: a point left the image)")
    ax[1].set(xlabel="rotation about the optical axis (deg)", ylabel="camera path length (m)", title="path length")
    ax[1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    names.append("compare_rotation.png")
    fig.savefig(out / names[-1], dpi=90)
    plt.close(fig)

    for label in ("rz 150 deg", "general_motion"):
        runs = [(s, r) for (lab, s), r in keep.items() if lab == label]
        if not runs:
            continue
        cols = 5
        fig, axes = plt.subplots(math.ceil(len(runs) / cols), cols, figsize=(2.6 * cols, 2.6 * math.ceil(len(runs) / cols)))
        for a, (scheme, r) in zip(np.ravel(axes), runs):
            uv = r.history.uv
            for i in range(uv.shape[1]):
                a.plot(uv[:, i, 0], uv[:, i, 1], lw=0.8)
                a.plot(r.uv_desired[i, 0], r.uv_desired[i, 1], "k+")
            a.add_patch(plt.Rectangle((-0.3, -0.3), 0.6, 0.6, fill=False, ls=":", color="grey"))
            a.set(xlim=(-0.35, 0.35), ylim=(0.35, -0.35), aspect="equal", title=f"{scheme}: {r.status.outcome}")
            a.title.set_fontsize(8)
            a.tick_params(labelsize=6)
        for a in np.ravel(axes)[len(runs):]:
            a.axis("off")
        fig.suptitle(f"image paths, {label.replace('_', ' ')} (dotted: the image; +: goal)", fontsize=9)
        fig.tight_layout()
        names.append(f"compare_image_{label.replace(' ', '_')}.png")
        fig.savefig(out / names[-1], dpi=90)
        plt.close(fig)

    dep = [r for r in rows if r.study == "depth"]
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for scheme in dict.fromkeys(r.scheme for r in dep):
        mine = [r for r in dep if r.scheme == scheme]
        ax.plot([r.depth_scale for r in mine], [max(r.final_translation_error, 1e-9) if r.in_image else np.nan
                                                for r in mine], "o-", label=scheme, ms=3)
    ax.set(xscale="log", yscale="log", xlabel="depth scale (estimate / true)", ylabel="final camera position error (m)",
           title="sensitivity to depth error")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    names.append("compare_depth.png")
    fig.savefig(out / names[-1], dpi=90)
    plt.close(fig)

    cal = [r for r in rows if r.study == "calibration"]
    if cal:
        labels = list(dict.fromkeys(r.start for r in cal))
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        order = list(dict.fromkeys(r.scheme for r in cal))
        for j, scheme in enumerate(order):
            by = {r.start: r for r in cal if r.scheme == scheme}
            x = [labels.index(lab) + 0.6 * (j / max(len(order) - 1, 1) - 0.5) for lab in labels if lab in by]
            ok = [by[lab] if by[lab].in_image else None for lab in labels if lab in by]
            marker = "o" if scheme in IMAGE_BASED else ("s" if scheme.startswith("moments") else "^")
            ax[0].plot(x, [max(r.final_translation_error * 1000, 1e-3) if r else np.nan for r in ok], marker, ms=4,
                       label=scheme)
            ax[1].plot(x, [max(np.degrees(r.final_rotation_error), 1e-5) if r else np.nan for r in ok], marker, ms=4,
                       label=scheme)
        for a, what in zip(ax, ("final camera position error (mm)", "final camera rotation error (deg)")):
            a.set(yscale="log", ylabel=what, xticks=range(len(labels)))
            a.set_xticklabels(labels, rotation=30, fontsize=7)
        ax[0].set_title("sensitivity to calibration error (missing: a point left the image)", fontsize=9)
        ax[1].legend(fontsize=7, ncol=2)
        fig.tight_layout()
        names.append("compare_calibration.png")
        fig.savefig(out / names[-1], dpi=90)
        plt.close(fig)
    return names


def moments_limit(rows: Sequence[Row]) -> str:
    """The bullet on the moments task's false goals, from the rows."""
    rows = [r for r in rows if r.study != "calibration"]
    false = [r for r in rows if r.scheme == "moments" and r.converged and not r.reached]
    n = sum(1 for r in rows if r.scheme == "moments" and r.study != "depth")
    if not false:
        return "- `moments` reached the goal from every start it converged from."
    worst = max(false, key=lambda r: r.final_translation_error)
    return (f"- **A limit of the moments task**: `moments` converges (its six features equal to the goal's) from "
            f"every start but reaches the goal from {sum(r.reached for r in rows if r.scheme == 'moments' and r.study != 'depth')}"
            f" of {n}; from the others (tilted starts, and the depth study's) it settles at a pose up to "
            f"{worst.final_translation_error * 1000:.0f} mm and {np.degrees(worst.final_rotation_error):.1f}° from "
            "the goal with its features at the goal's (from the depth study's start: to 1e-10 with a tolerance of 1e-10, "
            "the pose 176 mm and 3.3° away): for "
            "this 0.5 m object at 3 m the invariants r1, r2 hardly tell a sideways shift from a turn about the x or y "
            "axis (the smallest singular value of the interaction matrix at the goal is 1.8e-3 against 3.2 for the "
            "largest), so a depth error does not matter there either.")


#: The schemes whose task is a function of the image alone (with the depths only in their interaction matrix).
IMAGE_BASED = ("cartesian", "polar", "stacked", "cylindrical", "partitioned")


def calibration_notes(rows: Sequence[Row]) -> str:
    """The bullet on the calibration study, from its rows."""
    cal = [r for r in rows if r.study == "calibration"]
    if not cal:
        return "- The calibration study did not run."
    by = {(r.scheme, r.start): r for r in cal}
    image = [r for r in cal if r.scheme in IMAGE_BASED]
    done = [r for r in image if r.converged]
    near = [r for r in image if not r.converged and r.in_image and r.final_translation_error < 1e-3]
    stuck = [r for r in image if not r.converged and r.in_image and r.final_translation_error >= 1e-3]
    lost = [r for r in image if not r.in_image]
    says = lambda rs: ", ".join(f"`{r.scheme}` with {r.start}" for r in rs)  # noqa: E731
    mm = lambda r: f"{r.final_translation_error * 1000:.0f} mm"  # noqa: E731
    text = ("- **Calibration errors** (the last table): the image-based laws' error is zero where the image is the "
            "taught one, so their final pose does not depend on the calibration: every one of their "
            f"{len(done)} converged runs ended within {max(r.final_translation_error for r in done) * 1000:.1f} mm "
            f"of the goal, Cartesian IBVS under every error "
            f"({sum(r.converged for r in image if r.scheme == 'cartesian')}/{len(CALIBRATIONS)}). Their path and "
            "speed do depend on it, since their interaction matrix is "
            f"evaluated on the wrong points: {len(near)} runs were within 1 mm of the goal but not yet converged "
            "after 20 s")
    if stuck:
        text += "; " + says(stuck) + " were still " + ", ".join(mm(r) for r in stuck) + " from it"
    if lost:
        text += "; " + says(lost) + " lost a point at the image border"
    pose = [r for r in cal if r.scheme in ("pbvs", "pbvs_object", "2.5d")]
    s, d = CALIBRATIONS["f ×0.8"][0], np.hypot(*CALIBRATIONS["c +(24, −16) px"][1])
    if pose:
        ok = [r for r in pose if r.converged]
        text += (f". PBVS and 2.5-D are taught the goal the same way: the simulator's pose depth mode estimates the "
                 "goal's pose (and 2.5-D's Z*) with `ibvs.PlanarPose` from the goal's image through the same wrong "
                 "model, as it estimates the current pose from the current image. Their error is then zero where the "
                 "two estimates agree, i.e. where the image is the goal's, since the estimate is a function of the "
                 f"image alone, so they too end at the goal under every error: {len(ok)} of their {len(pose)} runs "
                 "converged" + (f", within {max(r.final_translation_error for r in ok) * 1e6:.0f} µm and "
                                f"{np.degrees(max(r.final_rotation_error for r in ok)) * 3600:.0f}″ of the goal"
                                if ok else "")
                 + ". The calibration biases both estimates alike, and the bias cancels: a focal length s times the "
                 f"true one shows the planar target at s times its distance (the goal's {DEPTH:g} m at "
                 f"{s * DEPTH:g} m for s = {s:g}; tested). A user who *gives* the goal pose instead (a c*Mo measured, "
                 "not taught) keeps the current estimate's bias to the end, the classical sensitivity of a "
                 "position-based law to calibration: PBVS then stops where the estimate equals the given pose, "
                 f"Z*·|1/s − 1| from the goal ({DEPTH * abs(1 / s - 1) * 1000:.0f} mm for s = {s:g}), Z*·d/f sideways "
                 f"for a principal point offset d ({DEPTH * d / FOCAL * 1000:.0f} mm for |d| = {d:.1f} px). "
                 "`sim.run(..., goal_pose=\"given\")` runs that case (tests/python/test_sim_goal_pose.py, from this "
                 "study's general start, not in the table): `pbvs` and `pbvs_object` then end within 2 µm of that "
                 f"prediction ({DEPTH * abs(1 / s - 1) * 1000:.0f} mm behind the goal for s = {s:g}, "
                 f"{DEPTH * abs(1 / 1.25 - 1) * 1000:.0f} mm ahead of it for s = 1.25, "
                 f"({-DEPTH * CALIBRATIONS['c +(24, −16) px'][1][0] / FOCAL * 1000:.0f}, "
                 f"{-DEPTH * CALIBRATIONS['c +(24, −16) px'][1][1] / FOCAL * 1000:.0f}) mm to the side for "
                 "c +(24, −16) px), where taught they end at the goal. 2.5-D takes x*, y* and Z* from the goal's image "
                 "either way, only c*R from the goal pose, and the estimate of this fronto-parallel goal has its true "
                 "rotation: given, it still ends at the goal (within 4 µm); at a goal seen tilted (25° about y, −15° "
                 "about x) it ends turned by the goal estimate's rotation bias, 0.42°, 0.28°, 1.98° for f ×0.8, "
                 "f ×1.25, c +(24, −16) px (the bias: 0.42°, 0.28°, 1.99°), 23, 15, 109 mm from the goal.")
    else:
        text += "."
    mom = [r for r in cal if r.scheme == "moments"]
    if mom:
        far = [r for r in mom if r.in_image and not r.reached]
        text += (" `moments` (its plane from the current estimate, its a* and Z* from the goal's) reached the goal "
                 f"under {sum(r.reached for r in mom)} of the {len(mom)} calibrations"
                 + (" and settled " + ", ".join(mm(r) for r in far) + " from it (with "
                    + ", ".join(r.start for r in far) + ": the false goal of the previous bullet)" if far else "")
                 + ": which equilibrium it reaches depends on its path, which the calibration changes.")
    return text


def wrap(text: str, width: int = 120) -> str:
    """Paragraphs and list items of a Markdown page wrapped at `width` characters (the docs' line limit,
    tests/python/test_docs_lines.py); headings, table rows and figures left as they are."""
    out = []
    for line in text.split("\n"):
        if len(line) <= width or line.startswith(("|", "#", "![")):
            out.append(line)
        else:
            indent = "  " if line.startswith("- ") else ""
            out.append(textwrap.fill(line, width, subsequent_indent=indent, break_long_words=False,
                                     break_on_hyphens=False))
    return "\n".join(out)


def page(rows: Sequence[Row], figure_names: Sequence[str], rotations: int, general: int, seconds: float) -> str:
    """docs/compare.md."""
    n_runs = len(rows)
    parts = [
        "# The comparison: ten control laws against the half-turn and the retreat, side by side",
        "",
        "Regenerated by `ibvs compare --out DIR --docs` (or `python -m ibvs.study.compare`), which writes this page "
        "and its figures: "
        f"{n_runs} runs ({len(set(r.scheme for r in rows))} schemes; the paper's three free-camera cases, "
        f"{rotations} angles about the optical axis from 0 to 180°, {general} random general starts of the free "
        f"world's distribution (seed 0), {len(DEPTH_SCALES)} depth scales, {len(CALIBRATIONS)} camera calibrations), "
        f"{seconds:.0f} s on one core. "
        "Larger: `--rotations 37 --general 1000` (10,410 runs, one to two minutes).",
        "",
        "**Set-up.** The paper's free-flying camera (normalised image ±0.3, gain 1, 20 s, exact depth) and one target "
        "for every scheme: an **asymmetric planar quadrilateral** (vertices "
        + ", ".join(f"({x:.2f}, {y:.2f})" for x, y in TARGET_XY)
        + " m, moved so that its area's centre of gravity is on the optical axis, 3 m in front of the goal camera). "
        "Not the paper's square: the square is centrally symmetric, so the orientation α of its image is undefined "
        "both from second-order moments (μ20 = μ02, μ11 = 0) and from third-order ones (every odd centred moment "
        "vanishes), and a half-turn leaves its image unchanged; the `moments` scheme refuses it with that reason. "
        "Schemes (`ibvs.study.schemes`, usable as `ibvs sweep --schemes ...` and `ibvs run --scheme ...`): the point "
        "laws on the four vertices; `moments` and `moments_pi` the six Tahri & Chaumette features (xn, yn, an, the "
        "rotation invariants p, α) of the quadrilateral as a region, α from third-order moments (over the full turn) "
        "or from second-order ones (modulo π); `2.5d` the 2.5-D features of vertex 0; `pbvs` (camera to desired "
        "camera) and `pbvs_object` (camera to object) on the true pose, so that the laws are compared, not a pose "
        "estimator (in a sweep they take the scenario's depth mode, e.g. `ibvs.PlanarPose`'s estimate with "
        "`depth=\"pose\"`).",
        "",
        "**Columns.** Over the paper's cases, the rotations and the general starts: *converged* the task's error "
        f"norm under {TOLERANCE:g} within 20 s (each task in its own units), *reached goal* the camera within 1 mm "
        "and 1 mrad of the goal pose, *stayed in image* no vertex left the ±0.3 image (the run stops there), the "
        "camera's retreat (largest increase of the target's depth along the optical axis), its path length and "
        "peak speeds (medians over the runs). Depth study: one general start (60° about z, 8° tilt, "
        "(0.1, −0.05, −0.3) m) with every depth the controller is given, and the pose's translation, scaled; the "
        "final camera position error. Calibration study: below.",
        "",
        table(rows),
        "",
        "## About the optical axis",
        "",
        "The camera retreat (m) of each scheme from each angle about the optical axis (the target's plane parallel "
        "to the image), when it reached the goal; otherwise what ended the run:",
        "",
        rotation_table(rows),
        "",
    ]
    for name in figure_names:
        if name != "compare_calibration.png":
            parts += [f"![{name}](figures/{name})", ""]
    parts += [
        "## Calibration error",
        "",
        "The depth study's start seen by a pixel camera — a 480×480 pinhole of focal length 800 px, i.e. the same "
        "±0.3 image — whose controller believes wrong intrinsics: the focal length scaled, the principal point "
        "offset, or (last column) a true radial distortion k1 = −0.2 (3.5 % at the image's corners) ignored. "
        "`ibvs.sim.MiscalibratedCamera` gives the controller every pixel, the goal's included (teach by showing), "
        "through the wrong model, exactly as a user with that calibration; every scheme takes its depths and pose "
        "from `ibvs.PlanarPose` on those points (depth mode \"pose\": the same perturbation for all, and `none` "
        "its baseline). The pose schemes (`pbvs`, `pbvs_object`, `2.5d`) compare that estimated current pose with "
        "the goal's pose estimated the same way from the goal's image (and 2.5-D's Z* with it), as a user who "
        "teaches the goal by showing it; the moments take their plane from the estimated pose, a* and Z* from the "
        "goal's. "
        "Per scheme: runs converged within 20 s and runs whose points stayed in the image, then the final camera "
        "pose error (position, rotation) or what ended the run; *(timeout)*: not converged within 20 s.",
        "",
        calibration_table(rows),
        "",
    ]
    if "compare_calibration.png" in figure_names:
        parts += ["![compare_calibration.png](figures/compare_calibration.png)", ""]
    parts += [
        "## What shows, and what is tested",
        "",
        "- **About the optical axis** (the table above): Cartesian IBVS retreats, without bound at 180° (the "
        "paper's Fig. 2), and the stacked law retreats by up to 2 m; the polar and cylindrical laws, `moments`, "
        "2.5-D and both PBVS variants turn the camera about its axis without retreat. `moments` does so with no "
        "translation at all (tests/python/test_compare.py: retreat and sideways motion under 1e-6 m from 90°, "
        "150° and 180°). `moments_pi` (α modulo π) reads a turn beyond 90° as the opposite turn below 90° and "
        "settles on the half-turn, where every one of its features equals the goal's: *converged*, goal not "
        "reached (tested at 150°). The partitioned law is slow here: with gain 1 its rotation about z is not "
        "finished within 20 s from 60° on.",
        "- **Straight lines** (tested in the simulator, 60 frames/s, gain 1): `pbvs` keeps the camera centre within "
        "0.10 % of the path's length of the straight line, `2.5d` its reference point's image within 0.24 %, both "
        "halving when the frame time halves (the simulator holds each twist for a frame). `pbvs` therefore has the "
        "shortest camera paths, but its image is free (its reference point's image leaves its line by 13 %).",
        "- **Depth errors** (the last columns): the point laws' error is zero only at the goal, so a depth error "
        "changes their path, not their end — but from this start the polar, stacked and cylindrical laws lose a "
        "point at the image border under most scalings, where Cartesian IBVS reaches the goal. PBVS converges "
        "where its scaled translation is zero: the camera at Z*/s from the target (3 m → 1.5 m for s = 2; tested). "
        "2.5-D does the same here, because the simulator gives its Z from the depth mode against the goal's true "
        "Z* (depth \"exact\": a goal given); with Z/Z* from a homography (as Malis et al. do), or with the pose "
        "depth mode, which estimates Z* and the goal's pose from the goal's image with the same scale, the error "
        "does not depend on s (tested).",
        moments_limit(rows),
        calibration_notes(rows),
        "",
    ]
    return wrap("\n".join(parts))


def build_parser():
    """The parser of `ibvs compare` (one-line errors, exit status 2; --out tried for writing when parsed)."""
    from ..cli import args as a

    p = a.Parser(prog="ibvs compare", description="Compare IBVS, IBVS-P, stacked, cylindrical, partitioned, image "
                 "moments, 2.5-D and both PBVS variants on the same cases.",
                 epilog=a.exit_status("the study ran; its files are written"))
    a.add_output(p, "--out", type=a.out_dir, default="ibvs-compare",
                 help="output directory: compare.csv, compare.md, figures (created if missing)")
    p.add_argument("--rotations", type=a.number(2, 181, integer=True), default=19,
                   help="angles about the optical axis from 0 to 180 deg, 2 to 181 (19)")
    p.add_argument("--general", type=a.number(0, 10000, integer=True), default=50,
                   help="random general starts, 0 to 10000 (50)")
    p.add_argument("--seed", type=a.number(0, a.SEED_MAX, integer=True), default=0)
    p.add_argument("--docs", action="store_true",
                   help="also write docs/compare.md and docs/figures/compare_*.png of this repository")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    """`ibvs compare`: run the study, write compare.csv, compare.md and the figures (and docs/ with --docs)."""
    p = build_parser()
    args = p.parse_args(argv)
    docs = output.docs_dir(p, args.docs)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    keep: dict = {}
    rows = study(args.rotations, args.general, args.seed, keep=keep)
    seconds = time.perf_counter() - t0
    output.write(rows, out, docs, "compare.csv", "compare.md", lambda d: figures(rows, keep, d),
                 lambda names: page(rows, names, args.rotations, args.general, seconds))
    print(table(rows))
    print(f"{len(rows)} runs in {seconds:.0f} s; written to {out}" + (" and docs/" if args.docs else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
