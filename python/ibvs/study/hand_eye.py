"""Hand-eye studies (docs/hand-eye.md; python docs/scripts/hand_eye.py regenerates its numbers and figure):

- accuracy(): how close ibvs.calibrate_hand_eye comes to the true transform, per mount and method, from data of
  ibvs.sim.collect_hand_eye (12 stations of a Panda) without noise, with 0.3 px of pixel noise, and through a
  rendered and detected tag;
- mount_errors(): what a wrong eMc costs a control law: episodes of the Panda case (ibvs.sim.cases.
  arm_general_motion's camera, target and goal) from random starts, the controller given eMc_hat = eMc dM
  (ibvs.sim.MiscalibratedRobot) while the true eMc moves the camera, dM a rotation of `rotation_deg` about a random
  axis and a translation of `translation_cm` in a random direction; every scheme of ibvs.study.schemes.

Episodes are paired: the same starts and error directions for every scheme and error size (direction k scaled),
so that a change along a row is the error's doing, not the draw's.
"""

from __future__ import annotations

import functools
import math
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Optional, Sequence

import numpy as np

from .. import sim
from ..calibration.hand_eye import METHODS, MOUNTS
from .schemes import SCHEMES, TITLES, make

__all__ = [
    "ROTATIONS_DEG",
    "TRANSLATIONS_CM",
    "accuracy",
    "figure",
    "format_accuracy",
    "format_mount_errors",
    "mount_errors",
    "perturbed_mount",
    "summarise",
]

#: The eMc rotation errors (degrees) and translation errors (cm) of the sweep: a 5 x 5 grid.
ROTATIONS_DEG = (0.0, 2.5, 5.0, 7.5, 10.0)
TRANSLATIONS_CM = (0.0, 1.25, 2.5, 3.75, 5.0)


# --------------------------------------------------------------------------- calibration accuracy

def accuracy(seeds: int = 20, stations: int = 12, arm: str = "panda", tag_seeds: Optional[int] = None) -> list[dict]:
    """Errors of every method against the truth: one row per (mount, measurement, method) with the median and
    maximum over `seeds` data sets of the translation (mm) and rotation (deg) errors of the estimated eMc / bMc.
    Measurements: "exact" (noise-free projections), "0.3 px" (projections plus 0.3 px Gaussian noise), "tag"
    (a 10 cm tag rendered and detected, tag_seeds data sets: default seeds // 2)."""
    tag_seeds = max(1, seeds // 2) if tag_seeds is None else tag_seeds
    rows = []
    for mount in MOUNTS:
        for measurement, scene, noise, vision, n in (("exact", "grid", 0.0, None, seeds),
                                                     ("0.3 px", "grid", 0.3, None, seeds),
                                                     ("tag", "tag", 0.0, "tag", tag_seeds)):
            s = sim.hand_eye_scene(arm, mount, target=scene)
            errors = {m: [] for m in METHODS}
            for seed in range(n):
                data = s.collect(stations=stations, noise_px=noise, seed=seed, vision=vision)
                for m in METHODS:
                    errors[m].append(data.error(data.calibrate(m)))
            for m in METHODS:
                e = np.array(errors[m])
                rows.append({"mount": mount, "measurement": measurement, "method": m, "sets": n,
                             "translation_mm_median": 1e3 * float(np.median(e[:, 0])),
                             "translation_mm_max": 1e3 * float(e[:, 0].max()),
                             "rotation_deg_median": math.degrees(float(np.median(e[:, 1]))),
                             "rotation_deg_max": math.degrees(float(e[:, 1].max()))})
    return rows


def _number(x: float) -> str:
    return f"{x:.1e}" if x < 1e-3 else f"{x:.3f}" if x < 10 else f"{x:.1f}"


def format_accuracy(rows: Sequence[dict]) -> str:
    """The accuracy rows as a Markdown table: per mount and method, median (max) errors per measurement."""
    measurements = list(dict.fromkeys(r["measurement"] for r in rows))
    by = {(r["mount"], r["method"], r["measurement"]): r for r in rows}
    head = "| mount | method | " + " | ".join(f"{m}: mm | {m}: deg" for m in measurements) + " |"
    lines = [head, "|---|---|" + "---:|---:|" * len(measurements)]
    for mount in dict.fromkeys(r["mount"] for r in rows):
        for method in dict.fromkeys(r["method"] for r in rows):
            cells = []
            for m in measurements:
                r = by[(mount, method, m)]
                cells += [f"{_number(r['translation_mm_median'])} ({_number(r['translation_mm_max'])})",
                          f"{_number(r['rotation_deg_median'])} ({_number(r['rotation_deg_max'])})"]
            lines.append(f"| {mount} | {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# --------------------------------------------------------------------------- a wrong eMc in the controller

def perturbed_mount(eMc, rotation_deg: float, translation_cm: float, direction: int, seed: int = 0) -> np.ndarray:
    """eMc dM: dM rotates by rotation_deg about a unit axis and translates by translation_cm along a unit direction
    (in the camera frame), both drawn by numpy default_rng([seed, direction]) (the same for every size)."""
    rng = np.random.default_rng([seed, direction])
    axis, along = rng.standard_normal(3), rng.standard_normal(3)
    axis, along = axis / np.linalg.norm(axis), along / np.linalg.norm(along)
    a = math.radians(rotation_deg)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    dM = np.eye(4)
    dM[:3, :3] = np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K
    dM[:3, 3] = 0.01 * translation_cm * along
    return np.asarray(eMc, dtype=float) @ dM


@functools.lru_cache(maxsize=None)
def _case(arm: str):
    return sim.cases.arm_general_motion(arm)


def _starts(arm: str, n: int, seed: int) -> list[np.ndarray]:
    """n start joints: the case's own start, then offsets of the goal camera (rotation about the optical axis up to
    +-90 deg, tilt up to 8 deg, translation up to 4 cm sideways and 10 cm in depth) reachable with the target in
    view, drawn by default_rng(seed)."""
    case = _case(arm)
    robot, goal = case.robot, np.asarray(case.goal)
    goal_pose = robot.camera(goal)
    rng = np.random.default_rng(seed)
    out = [np.asarray(case.start)]
    for _ in range(200 * n):
        if len(out) >= n:
            break
        d, tilt = rng.uniform(0, 2 * np.pi), math.radians(rng.uniform(0, 8))
        off = sim.pose(t=rng.uniform([-0.04, -0.04, -0.1], [0.04, 0.04, 0.1]),
                       r=(tilt * math.cos(d), tilt * math.sin(d), math.radians(rng.uniform(-90, 90))))
        T_cw = np.linalg.inv(goal_pose @ off)
        P = np.asarray(case.target.world_points()) @ T_cw[:3, :3].T + T_cw[:3, 3]
        px = np.asarray(case.camera.project(P[:, :2] / P[:, 2:], invalid="nan"))
        if not np.all(case.camera.contains(px)):
            continue
        r = sim.solve_ik(robot, goal_pose @ off, goal, restarts=0)
        if r.converged:
            out.append(r.q)
    return out


def _episode(job: tuple) -> dict:
    arm, scheme, start_index, q_start, rotation_deg, translation_cm, direction, seed, duration = job
    case = _case(arm)
    eMc_hat = perturbed_mount(case.robot.mount, rotation_deg, translation_cm, direction, seed)
    robot = sim.MiscalibratedRobot(case.robot, eMc_hat)
    r = sim.run(make(scheme, 1.0, len(case.target)), case.camera, case.target, q_start, case.goal, robot=robot,
                duration=duration, depth="pose", tolerance=1e-5)
    return {"scheme": scheme, "start": start_index, "rotation_deg": rotation_deg, "translation_cm": translation_cm,
            "direction": direction, "outcome": r.status.outcome,
            "time_s": r.metrics.frames_to_converge / case.camera.fps if r.status.outcome == "converged" else math.nan,
            "path_m": r.metrics.path_length}


def mount_errors(arm: str = "panda", schemes: Sequence[str] = tuple(SCHEMES), rotations_deg=ROTATIONS_DEG,
                 translations_cm=TRANSLATIONS_CM, directions: int = 4, starts: int = 6, seed: int = 0,
                 duration: float = 40.0, jobs: Optional[int] = None) -> list[dict]:
    """One row per episode (scheme, start, rotation_deg, translation_cm, direction, outcome, time_s to converge,
    path_m): every scheme from every start with every eMc error of the grid, `directions` error directions per
    size (one for a zero error). Gain 1, depth from the pose of the measured points, tolerance 1e-5, `duration` s.
    jobs: worker processes (default: the CPUs)."""
    q_starts = _starts(arm, starts, seed)
    jobs_list = []
    for scheme in schemes:
        for i, q in enumerate(q_starts):
            for a in rotations_deg:
                for t in translations_cm:
                    for k in range(directions if (a, t) != (0, 0) else 1):
                        jobs_list.append((arm, scheme, i, q, float(a), float(t), k, seed, duration))
    workers = jobs or os.cpu_count() or 1
    if workers == 1:
        return [_episode(j) for j in jobs_list]
    with ProcessPoolExecutor(workers) as pool:
        return list(pool.map(_episode, jobs_list, chunksize=16))


def summarise(rows: Sequence[dict]) -> list[dict]:
    """Per (scheme, rotation_deg, translation_cm): episodes, converged (share in [0, 1]), the median time to converge
    (s) and the median slowdown: time to converge over the same start's time with the exact eMc (episodes where
    both converged), and the outcomes of the others."""
    exact = {(r["scheme"], r["start"]): r["time_s"] for r in rows
             if r["rotation_deg"] == 0 and r["translation_cm"] == 0}
    cells: dict = {}
    for r in rows:
        cells.setdefault((r["scheme"], r["rotation_deg"], r["translation_cm"]), []).append(r)
    out = []
    for (scheme, a, t), rs in cells.items():
        conv = [r for r in rs if r["outcome"] == "converged"]
        ratios = [r["time_s"] / exact[(scheme, r["start"])] for r in conv
                  if math.isfinite(exact.get((scheme, r["start"]), math.nan))]
        failed: dict = {}
        for r in rs:
            if r["outcome"] != "converged":
                failed[r["outcome"]] = failed.get(r["outcome"], 0) + 1
        out.append({"scheme": scheme, "rotation_deg": a, "translation_cm": t, "episodes": len(rs),
                    "converged": len(conv) / len(rs),
                    "time_s": float(np.median([r["time_s"] for r in conv])) if conv else math.nan,
                    "slowdown": float(np.median(ratios)) if ratios else math.nan, "failed": failed})
    return out


def format_mount_errors(summary: Sequence[dict], cells: Sequence[tuple] = ((0, 0), (2.5, 1.25), (5, 2.5), (10, 0),
                                                                            (0, 5), (7.5, 3.75), (10, 5))) -> str:
    """A Markdown table: one row per scheme, one column per (rotation_deg, translation_cm) error, each cell "converged
    share · median slowdown", and the outcomes of the runs that did not converge at the last cell's error."""
    by = {(s["scheme"], s["rotation_deg"], s["translation_cm"]): s for s in summary}
    schemes = list(dict.fromkeys(s["scheme"] for s in summary))
    a_last, t_last = cells[-1]
    lines = ["| scheme | " + " | ".join(f"{a:g}°, {t:g} cm" for a, t in cells) +
             f" | not converged at {a_last:g}°, {t_last:g} cm |", "|---|" + "---:|" * len(cells) + "---|"]
    for scheme in schemes:
        row = []
        for a, t in cells:
            s = by.get((scheme, float(a), float(t)))
            if s is None:
                row.append("n/a")
                continue
            slow = "n/a" if not math.isfinite(s["slowdown"]) else f"×{s['slowdown']:.2f}"
            row.append(f"{100 * s['converged']:.0f} % · {slow}")
        last = by.get((scheme, float(a_last), float(t_last)))
        failed = last["failed"] if last else {}
        row.append(", ".join(f"{n} {k}" for k, n in sorted(failed.items(), key=lambda x: -x[1])) or "—")
        lines.append(f"| {TITLES.get(scheme, scheme)} | " + " | ".join(row) + " |")
    return "\n".join(lines)


def figure(summary: Sequence[dict], path, dpi: int = 90) -> None:
    """Per scheme, the converged share over the 5 x 5 grid of eMc errors (a heat map, the median slowdown written in
    each cell), saved to path (needs matplotlib: the plot extra)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    schemes = list(dict.fromkeys(s["scheme"] for s in summary))
    rot = sorted({s["rotation_deg"] for s in summary})
    tra = sorted({s["translation_cm"] for s in summary})
    by = {(s["scheme"], s["rotation_deg"], s["translation_cm"]): s for s in summary}
    cols = min(4, len(schemes))
    rows = math.ceil(len(schemes) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.0 * rows), squeeze=False, constrained_layout=True)
    image = None
    for ax, scheme in zip(axes.flat, schemes):
        grid = np.array([[100 * by[(scheme, a, t)]["converged"] for t in tra] for a in rot])
        image = ax.imshow(grid, origin="lower", vmin=0, vmax=100, cmap="RdYlGn", aspect="auto")
        for i, a in enumerate(rot):
            for j, t in enumerate(tra):
                slow = by[(scheme, a, t)]["slowdown"]
                ax.text(j, i, "—" if not math.isfinite(slow) else f"{slow:.2f}", ha="center", va="center", fontsize=7)
        ax.set_xticks(range(len(tra)), [f"{t:g}" for t in tra])
        ax.set_yticks(range(len(rot)), [f"{a:g}" for a in rot])
        ax.set_title(TITLES.get(scheme, scheme), fontsize=9)
        ax.set_xlabel("eMc translation error (cm)", fontsize=8)
        ax.set_ylabel("eMc rotation error (deg)", fontsize=8)
    for ax in list(axes.flat)[len(schemes):]:
        ax.axis("off")
    if image is not None:
        fig.colorbar(image, ax=axes, shrink=0.6, label="converged (%); numbers: median slowdown")
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
