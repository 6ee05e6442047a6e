"""Reproduce the paper's experiments: every case run, figures drawn, findings tabulated.

    ibvs reproduce [--out DIR] [--quick]

Free-flying camera (Section III-A, Table I; Figs. 1-3 and 5): x-translation 0.2, z-rotation
pi and general motion, each with Cartesian IBVS, IBVS-P, the per-point hybrid (Cartesian for
points 1-2, polar for 3-4) and the stacked 16x6 hybrid. Fig. 4: image-plane limits in r-theta.
Gantry with the calibrated, distorted camera (Section III-B; Figs. 6-8): general motion with
the same four schemes, depth from a pose estimate as in the paper.
"""

from __future__ import annotations

import csv
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import ibvs
from ibvs import sim

#: Scheme name -> layout for the paper's four points.
SCHEMES = {
    "cartesian": lambda: ibvs.Layout.cartesian(4),
    "polar": lambda: ibvs.Layout.polar(4),
    "hybrid": lambda: ibvs.Layout([(0, "cartesian"), (1, "cartesian"), (2, "polar"), (3, "polar")]),
    "stacked": lambda: ibvs.Layout.stacked(4),
}
SCHEME_TITLES = {
    "cartesian": "IBVS (Cartesian, 8x6)",
    "polar": "IBVS-P (polar, 8x6)",
    "hybrid": "per-point hybrid (Cartesian 1-2, polar 3-4, 8x6)",
    "stacked": "stacked hybrid (16x6)",
}
CASES = {
    "free": {
        "x-translation": sim.cases.x_translation,
        "z-rotation": sim.cases.z_rotation,
        "general": sim.cases.general_motion,
    },
    "gantry": {"general": sim.cases.gantry_general_motion},
}
#: Paper figure each (world, case, scheme) reproduces.
FIGURES = {
    ("free", "x-translation", "polar"): "Fig. 1",
    ("free", "z-rotation", "polar"): "Fig. 2",
    ("free", "general", "polar"): "Fig. 3",
    ("free", "z-rotation", "hybrid"): "Fig. 5",
    ("gantry", "general", "cartesian"): "Fig. 6",
    ("gantry", "general", "polar"): "Fig. 7",
    ("gantry", "general", "stacked"): "Fig. 8",
}
#: Control settings per world: gain (1/s), episode length (s), the depth the controller is
#: given (exact in simulation as in Section III-A; from a pose estimate on the gantry as in
#: Section III-B) and the error norm under which a run counts as converged.
GAIN = {"free": 1.0, "gantry": 2.0}
DURATION = {"free": 30.0, "gantry": 15.0}
DEPTH = {"free": "exact", "gantry": "pose"}
TOLERANCE = 1e-5


@dataclass
class Row:
    """One line of the summary."""

    world: str
    case: str
    scheme: str
    status: str
    event: str
    frames: int
    time_s: float
    retreat_m: float
    path_m: float
    peak_v: float
    peak_w: float
    final_t_mm: float
    final_r_deg: float
    joint_limit: str
    figure: str

    COLUMNS = (
        "world", "case", "scheme", "status", "event", "frames", "time_s", "retreat_m", "path_m",
        "peak_v", "peak_w", "final_t_mm", "final_r_deg", "joint_limit", "figure",
    )
    HEADERS = (
        "world", "case", "scheme", "status", "event", "frames to converge", "time (s)", "retreat (m)", "path (m)",
        "peak |v| (m/s)", "peak |ω| (rad/s)", "final Δp (mm)", "final Δθ (°)", "joint limit", "paper",
    )

    def cells(self) -> list[str]:
        out = []
        for name in self.COLUMNS:
            x = getattr(self, name)
            out.append(f"{x:.4g}" if isinstance(x, float) else str(x))
        return out


def make_case(world: str, case: str):
    try:
        return CASES[world][case]()
    except KeyError:
        raise ValueError(f"unknown case {case!r} for world {world!r}; choose from {sorted(CASES[world])}") from None


def run_one(world: str, case: str, scheme: str, *, duration: float | None = None, noise: float = 0.0,
            latency: int = 0, seed: int = 0, gain: float | None = None, depth: str | None = None):
    """Simulate one (world, case, scheme); returns (case object, sim.Result)."""
    c = make_case(world, case)
    servo = ibvs.Servo(SCHEMES[scheme](), gain=GAIN[world] if gain is None else gain, damping=0.0)
    result = sim.run(servo, c.camera, c.target, c.start, c.goal, robot=c.robot,
                     duration=DURATION[world] if duration is None else duration, noise=noise, latency=latency,
                     depth=DEPTH[world] if depth is None else depth, seed=seed, tolerance=TOLERANCE)
    return c, result


def summarise(world: str, case: str, scheme: str, result) -> Row:
    h, s, m = result.history, result.status, result.metrics
    ok = np.isfinite(h.twist).all(axis=1)
    tw = h.twist[ok]
    event = f"point {s.point + 1}" if s.point >= 0 else f"joint q{s.joint + 1}" if s.joint >= 0 else ""
    frames = m.frames_to_converge
    dt = float(h.time[1] - h.time[0]) if len(h.time) > 1 else float("nan")
    return Row(
        world, case, scheme, s.outcome, event, frames, frames * dt if frames >= 0 else float("nan"),
        m.camera_retreat, m.path_length,
        float(np.linalg.norm(tw[:, :3], axis=1).max()) if len(tw) else float("nan"),
        float(np.linalg.norm(tw[:, 3:], axis=1).max()) if len(tw) else float("nan"),
        1e3 * m.final_translation_error, math.degrees(m.final_rotation_error),
        f"q{s.joint + 1}" if s.outcome == "joint_limit" else "no" if world == "gantry" else "",
        FIGURES.get((world, case, scheme), ""),
    )


def image_bounds(camera) -> tuple[tuple[float, float], tuple[float, float]]:
    """Image bounds in normalised coordinates ((u_min, u_max), (v_min, v_max)); a pixel sensor's
    corners are undistorted with the camera model."""
    u0, u1, v0, v1 = (float(x) for x in camera.bounds)
    (a, b), (c, d) = np.asarray(camera.normalize([[u0, v0], [u1, v1]]))
    return (a, c), (b, d)


def target_points(target) -> np.ndarray:
    """(N, 3) target points in the world frame."""
    return np.asarray(target.world_points())


def claims(rows: list[Row]) -> list[tuple[str, bool]]:
    """The paper's qualitative findings, checked against this run's rows."""
    r = {(x.world, x.case, x.scheme): x for x in rows}
    get = r.get

    def conv(*key):
        return get(key) is not None and get(key).status == "converged"

    out = [
        ("z-rotation π: IBVS-P converges (Fig. 2)", conv("free", "z-rotation", "polar")),
        ("z-rotation π: Cartesian IBVS does not converge and retreats along the optical axis",
         get(("free", "z-rotation", "cartesian")) is not None
         and not conv("free", "z-rotation", "cartesian")
         and get(("free", "z-rotation", "cartesian")).retreat_m > 0.5),
        ("z-rotation π: the stacked hybrid converges", conv("free", "z-rotation", "stacked")),
        ("z-rotation π: the per-point hybrid converges with some camera retreat (Fig. 5)",
         conv("free", "z-rotation", "hybrid") and get(("free", "z-rotation", "hybrid")).retreat_m > 0.0),
        ("x-translation and general motion: every scheme converges (Figs. 1, 3)",
         all(conv("free", c, s) for c in ("x-translation", "general") for s in SCHEMES)),
        ("gantry general motion: IBVS, IBVS-P and the stacked hybrid converge (Figs. 6-8)",
         all(conv("gantry", "general", s) for s in ("cartesian", "polar", "stacked"))),
    ]
    return out


def write_summary(rows: list[Row], checks: list[tuple[str, bool]], out: Path, fig4: dict) -> str:
    with open(out / "summary.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(Row.COLUMNS)
        for row in rows:
            w.writerow([getattr(row, c) for c in Row.COLUMNS])
    lines = ["| " + " | ".join(Row.HEADERS) + " |", "|" + "---|" * len(Row.HEADERS)]
    lines += ["| " + " | ".join(row.cells()) + " |" for row in rows]
    table = "\n".join(lines)
    md = ["# ibvs: reproduction of Corke, Spindler & Chaumette (IROS 2009)", "", table, "", "## Paper claims", ""]
    md += [f"- [{'x' if ok else ' '}] {text}" for text, ok in checks]
    md += ["", "## Fig. 4", ""]
    md += [f"- {name}: {'stays inside' if ok else 'leaves'} the square image" for name, ok in fig4.items()]
    (out / "summary.md").write_text("\n".join(md) + "\n")
    return table


def reproduce(out: Path, quick: bool = False, stream=sys.stdout) -> tuple[list[Row], list[tuple[str, bool]]]:
    from . import plots

    out.mkdir(parents=True, exist_ok=True)
    plan = [(w, c, s) for w in CASES for c in CASES[w] for s in SCHEMES]
    # A whole episode simulates in milliseconds; the time goes into drawing, so --quick draws smaller.
    dpi = 50 if quick else 100
    rows = []
    t0 = time.perf_counter()
    fig4 = plots.image_limits_figure(str(out / "fig4_image_limits.png"), dpi=dpi)
    print(f"[ 0/{len(plan)}] Fig. 4 image-plane limits -> fig4_image_limits.png", file=stream, flush=True)
    for k, (world, case, scheme) in enumerate(plan, 1):
        c, result = run_one(world, case, scheme)
        row = summarise(world, case, scheme, result)
        rows.append(row)
        name = f"{world}_{case}_{scheme}.png"
        fig = FIGURES.get((world, case, scheme))
        title = f"{fig + ': ' if fig else ''}{c.description}, {SCHEME_TITLES[scheme]}"
        limits = (np.asarray(c.robot.q_min), np.asarray(c.robot.q_max)) if c.robot is not None else None
        plots.run_figure(result, title, image_bounds(c.camera), target_points(c.target),
                         str(out / name), joint_limits=limits, dpi=dpi)
        print(f"[{k:2d}/{len(plan)}] {world:6s} {case:13s} {scheme:9s} {row.status:13s} {row.event:9s}"
              f" -> {name}  ({time.perf_counter() - t0:.1f} s)", file=stream, flush=True)
    checks = claims(rows)
    table = write_summary(rows, checks, out, fig4)
    print("\n" + table + "\n", file=stream)
    for text, ok in checks:
        print(f"[{'ok' if ok else 'NOT REPRODUCED'}] {text}", file=stream)
    print(f"\nfigures, summary.md and summary.csv in {out}", file=stream)
    return rows, checks
