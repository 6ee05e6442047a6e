"""Joint-limit avoidance over random arm starts: how many runs that end at a joint limit converge when the robot
runs ibvs.SecondaryTask's avoidance (Marey & Chaumette 2010; ViSP's thresholds) in the null space of the task.

    rows = sweep(("panda", "ur5"), starts=50)     # one row per (arm, start, law, setting)
    print(format_shares(shares(rows)))

Starts: joints drawn uniformly within +-spread rad of the arm's goal (sim.cases.ARMS, the target 0.5 m in front of
the camera, sim.cases.arm_general_motion) and inside the limits, kept when all four points are in the image at
least `margin` px from its border and in front of the camera. Each start runs without avoidance ("off") and with
it for each projector; same servo, camera, depth and duration.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from .. import Layout, Servo
from .. import sim

__all__ = ["Row", "random_starts", "sweep", "shares", "format_shares"]

LAWS = {"cartesian": Layout.cartesian, "polar": Layout.polar, "stacked": Layout.stacked}
SETTINGS = ("off", "classical", "large")


@dataclass(frozen=True)
class Row:
    arm: str
    start: int
    law: str
    setting: str  # "off", or the avoidance's projector
    outcome: str
    frames: int


def random_starts(arm: str, starts: int, spread: float = 0.8, margin: float = 20.0, seed: int = 0):
    """(case, [q_start, ...]): `starts` random starts of arm_general_motion(arm) (see the module docstring)."""
    case = sim.cases.arm_general_motion(arm)
    robot, camera, target = case.robot, case.camera, case.target
    lo, hi = np.asarray(robot.q_min), np.asarray(robot.q_max)
    rng = np.random.default_rng(seed)
    P = np.c_[target.points, np.ones(len(target.points))] @ np.asarray(target.pose).T  # world
    out = []
    for _ in range(200 * starts):
        if len(out) == starts:
            break
        q = np.clip(case.goal + rng.uniform(-spread, spread, robot.dof), lo + 1e-3, hi - 1e-3)
        p = (np.linalg.inv(robot.camera(q)) @ P.T)[:3]
        if np.any(p[2] < 0.1) or np.any(np.hypot(p[0] / p[2], p[1] / p[2]) > 1.0):  # far off the sensor anyway
            continue
        px = camera.project((p[:2] / p[2]).T)
        if np.all(np.isfinite(px)) and np.all(px >= margin) and np.all(px[:, 0] <= camera.width - margin) \
                and np.all(px[:, 1] <= camera.height - margin):
            out.append(q)
    return case, out


def sweep(arms=("panda", "ur5"), starts: int = 50, laws=("stacked", "cartesian"), settings=SETTINGS,
          duration: float = 15.0, gain: float = 1.0, seed: int = 0) -> list[Row]:
    """Every start of every arm with every law and setting (see the module docstring); exact depths."""
    rows = []
    for arm in arms:
        case, qs = random_starts(arm, starts, seed=seed)
        robot = case.robot
        for law in laws:
            for setting in settings:
                if setting == "off":
                    robot.clear_secondary_task()
                else:
                    robot.set_secondary_task(setting)
                for k, q in enumerate(qs):
                    r = sim.run(Servo(LAWS[law](4), gain=gain), case.camera, case.target, q, case.goal, robot=robot,
                                duration=duration, depth="exact", tolerance=1e-5)
                    rows.append(Row(arm, k, law, setting, r.status.outcome, r.status.frame))
        robot.clear_secondary_task()
    return rows


def shares(rows) -> dict:
    """{(arm, law, setting): Counter of outcomes}."""
    out: dict = {}
    for r in rows:
        out.setdefault((r.arm, r.law, r.setting), Counter())[r.outcome] += 1
    return out


def format_shares(table: dict) -> str:
    """A Markdown table: per arm, law and setting, the share of converged and joint_limit runs (and the rest)."""
    lines = ["| arm | law | avoidance | converged | joint_limit | other |", "|---|---|---|---|---|---|"]
    for (arm, law, setting), c in sorted(table.items(), key=lambda kv: (kv[0][0], kv[0][1], SETTINGS.index(kv[0][2]))):
        n = sum(c.values())
        other = ", ".join(f"{k} {v}" for k, v in sorted(c.items()) if k not in ("converged", "joint_limit")) or "–"
        lines.append(f"| {arm} | {law} | {setting} | {c['converged']}/{n} ({100 * c['converged'] / n:.0f} %) | "
                     f"{c['joint_limit']}/{n} ({100 * c['joint_limit'] / n:.0f} %) | {other} |")
    return "\n".join(lines)
