"""Reproduce the paper's experiments: every case run, figures drawn, findings tabulated.

    ibvs reproduce [--out DIR] [--quick] [--angle-wrap consistent|per_point]

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
from typing import ClassVar, Optional

import numpy as np

import ibvs

from .. import sim
from ..sim.result import measurement_unit
from . import schemes
from .scenario import ANGLE_WRAPS  # the angle wraps of ibvs.Servo

#: The paper's four schemes (factories in ibvs.study.schemes) and their titles in the figures.
SCHEMES = schemes.PAPER
SCHEME_TITLES = {
    "cartesian": "IBVS (Cartesian, 8x6)",
    "polar": "IBVS-P (polar, 8x6)",
    "hybrid": "per-point hybrid (Cartesian 1-2, polar 3-4, 8x6)",
    "stacked": "stacked hybrid (16x6)",
}
#: The cases `ibvs reproduce` and `ibvs run` know: world -> case name -> factory (ibvs.sim.cases).
CASES = {
    "free": {
        "x-translation": sim.cases.x_translation,
        "z-rotation": sim.cases.z_rotation,
        "general": sim.cases.general_motion,
    },
    "gantry": {"general": sim.cases.gantry_general_motion, "joint-limit": sim.cases.gantry_joint_limit},
    # the Panda by default; `ibvs run --world arm --robot ...` builds the case of another arm
    "arm": {"general": sim.cases.arm_general_motion},
}
#: The case each world runs unless told otherwise.
DEFAULT_CASE = {"free": "z-rotation", "gantry": "general", "arm": "general"}
#: The cases `ibvs reproduce` runs (the paper's).
PAPER_CASES = {"free": ("x-translation", "z-rotation", "general"), "gantry": ("general",)}
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
#: Section III-B, and on an arm) and the error norm under which a run counts as converged.
GAIN = {"free": 1.0, "gantry": 2.0, "arm": 1.0}
DURATION = {"free": 30.0, "gantry": 15.0, "arm": 15.0}
DEPTH = {"free": "exact", "gantry": "pose", "arm": "pose"}
TOLERANCE = 1e-5


def wrap_label(scheme: str, angle_wrap: str) -> str:
    """The angle wrap a scheme runs with, as the summary and the figure titles state it ("-" for
    Cartesian IBVS, which has no angle rows, and the partitioned law, which is not an ibvs.Servo)."""
    return "-" if scheme in ("cartesian", "partitioned") else angle_wrap.replace("_", "-")


@dataclass
class Row:
    """One line of the summary (and of `ibvs run`'s report).

    status: the outcome; event: the point or joint it names ("none" when it names neither);
    frames / time_s: when it converged (-1 / NaN if it did not); error_norm: the servo's error
    norm at the frame the episode ended (the frame convergence was declared at, if it was),
    tolerance its tolerance (NaN: not tested); pixel_error: the worst measured point's
    distance from its goal at that frame (measurement units: `unit`), tolerance_px its
    tolerance (NaN: not tested); peak_v / peak_w: the peaks of the commanded twist (m/s,
    rad/s); peak_v_camera / peak_w_camera: the peak speeds the camera actually moved at, from
    its poses (on a robot, within its joint speed limits); final_t_mm / final_r_deg: the pose
    error at the last frame; joint_limit: the joint reached ("no"; "" in free flight, which
    has no joints)."""

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
    angle_wrap: str = "consistent"
    peak_v_camera: float = math.nan
    peak_w_camera: float = math.nan
    error_norm: float = math.nan
    tolerance: float = math.nan
    pixel_error: float = math.nan
    tolerance_px: float = math.nan
    unit: str = "px"
    judgement: str = ""  # the judged quantities beside their tolerances (ibvs.sim.Result.judged)
    end_frame: int = -1  # the frame the episode ended at

    COLUMNS = (
        "world", "case", "scheme", "status", "event", "frames", "time_s", "error_norm", "tolerance", "pixel_error",
        "tolerance_px", "retreat_m", "path_m", "peak_v", "peak_w", "peak_v_camera", "peak_w_camera", "final_t_mm",
        "final_r_deg", "joint_limit", "figure", "angle_wrap",
    )
    #: Column headers of the printed tables (the pixel columns only where a row has a tolerance_px).
    HEADERS: ClassVar[dict] = {
        "world": "world", "case": "case", "scheme": "scheme", "status": "status", "event": "event",
        "frames": "frames to converge", "time_s": "time (s)", "error_norm": "error norm at the end",
        "tolerance": "tolerance", "pixel_error": "worst point at the end", "tolerance_px": "tolerance_px",
        "retreat_m": "retreat (m)", "path_m": "path (m)", "peak_v": "peak commanded ‖v‖ (m/s)",
        "peak_w": "peak commanded ‖ω‖ (rad/s)", "peak_v_camera": "peak camera ‖v‖ (m/s)",
        "peak_w_camera": "peak camera ‖ω‖ (rad/s)", "final_t_mm": "Δp at the last frame (mm)",
        "final_r_deg": "Δθ at the last frame (°)", "joint_limit": "joint limit", "figure": "paper",
        "angle_wrap": "angle wrap",
    }
    #: Why a cell says n/a, per column (the printed tables never show an empty cell or nan).
    NOT_APPLICABLE: ClassVar[dict] = {
        "frames": "not converged", "time_s": "not converged", "error_norm": "never computed",
        "tolerance": "not tested", "pixel_error": "a point not measured", "tolerance_px": "not tested",
        "peak_v": "no twist commanded", "peak_w": "no twist commanded",
        "peak_v_camera": "the camera never moved (one frame)", "peak_w_camera": "the camera never moved (one frame)",
        "joint_limit": "free-flying camera, no joints", "figure": "no figure of the paper",
        "angle_wrap": "the scheme has no θ rows to wrap",
    }

    def converged(self) -> bool:
        return self.status == "converged"

    def columns(self, pixels: Optional[bool] = None) -> list[str]:
        """The printed columns: COLUMNS without the pixel ones unless `pixels` (default: this row
        has a tolerance_px)."""
        pixels = math.isfinite(self.tolerance_px) if pixels is None else pixels
        return [c for c in self.COLUMNS if pixels or c not in ("pixel_error", "tolerance_px")]

    def value(self, name: str) -> Optional[str]:
        """The cell of column `name`, or None where it does not apply (see NOT_APPLICABLE)."""
        x = getattr(self, name)
        if name == "frames" and x < 0 or name in ("joint_limit", "figure") and x == "" \
                or name == "angle_wrap" and x == "-":
            return None
        if isinstance(x, float):
            return f"{x:.4g}" if math.isfinite(x) else None
        return str(x)

    def cells(self, pixels: Optional[bool] = None) -> list[str]:
        """The printed cells: "n/a" where a value does not apply (format_rows says why)."""
        return [v if v is not None else "n/a" for v in (self.value(c) for c in self.columns(pixels))]

    def report(self) -> list[tuple[str, str]]:
        """(label, text) lines of `ibvs run`: every value with its unit and, where it does not
        apply, n/a and why; the status says what converged means and the error it was judged on
        (`judgement`)."""
        if self.converged():
            status = f"converged at frame {self.frames}: {self.judgement}"
        else:
            status = f"{self.status} at frame {self.end_frame}, not converged: {self.judgement}"
        robot = self.joint_limit != ""
        notes = {
            "peak_v": "the controller's twist" + (", before the robot's joint speed limits" if robot else ""),
            "peak_v_camera": ("how fast the robot moved the camera" if robot else "how fast the camera moved")
                             + ", from its poses",
        }
        out = [("status", status)]
        for name in self.columns(False):
            if name in ("world", "case", "scheme", "status", "figure", "error_norm", "tolerance"):
                continue
            v = self.value(name)
            text = f"n/a ({self.NOT_APPLICABLE[name]})" if v is None else v
            if v is not None and name in notes:
                text += f"  ({notes[name]})"
            out.append((self.HEADERS[name], text))
        return out


def format_rows(rows: list[Row]) -> str:
    """A Markdown table of rows, and a line saying why cells say n/a (if any does)."""
    pixels = any(math.isfinite(r.tolerance_px) for r in rows)
    columns = rows[0].columns(pixels) if rows else list(Row.COLUMNS)
    lines = ["| " + " | ".join(Row.HEADERS[c] for c in columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(row.cells(pixels)) + " |" for row in rows]
    why = {c: Row.NOT_APPLICABLE[c] for c in columns for r in rows if r.value(c) is None}
    if why:
        lines += ["", "n/a: " + "; ".join(f"{Row.HEADERS[c]}: {reason}" for c, reason in why.items()) + "."]
    return "\n".join(lines)


def make_case(world: str, case: str):
    """The Case named `case` of `world` (a key of CASES); ValueError for an unknown one."""
    try:
        return CASES[world][case]()
    except KeyError:
        raise ValueError(f"unknown case {case!r} for world {world!r}; choose from {sorted(CASES[world])}") from None


def run_one(world: str, case: str, scheme: str, *, duration: float | None = None, noise: float = 0.0,
            latency: int = 0, seed: int = 0, gain: float | None = None, depth: str | None = None,
            tolerance: float | None = TOLERANCE, tolerance_px: float | None = None, case_object=None,
            angle_wrap: str = "consistent", vision=None, record=None, goal_pose: str = "taught"):
    """Simulate one (world, case, scheme) (scheme: any name in ibvs.study.schemes.SCHEMES); returns
    (case object, sim.Result). case_object replaces the named case (e.g. another angle);
    angle_wrap is set on the scheme's ibvs.Servo. tolerance, tolerance_px: as in ibvs.sim.run
    (tolerance None: no error-norm test, only the pixel one). vision: None, or an ibvs.sim.Sensor
    for an image episode (its renderer's camera replaces the case's: ibvs.vision.image_camera gives
    a normalised case a 640x480 one). goal_pose: as in ibvs.sim.run."""
    if angle_wrap not in ANGLE_WRAPS:
        raise ValueError(f"angle_wrap must be one of {ANGLE_WRAPS}, got {angle_wrap!r}")
    c = case_object if case_object is not None else make_case(world, case)
    if vision is None:  # a scheme measured in rendered images (klt, keypoints) brings its image sensor
        vision = schemes.sensor_for(scheme, c.camera, c.target)
    camera = c.camera if vision is None else vision.renderer.camera
    servo = schemes.make(scheme, GAIN[world] if gain is None else gain, len(c.target))
    if isinstance(servo, ibvs.Servo):
        servo.angle_wrap = angle_wrap
    target = schemes.target_for(scheme, c.target)  # with the scheme's feature sources, if any
    camera, target = schemes.dense_target(scheme, camera, target)  # photometric: its block from rendered images
    result = sim.run(servo, camera, target, c.start, c.goal, robot=c.robot,
                     duration=DURATION[world] if duration is None else duration, noise=noise, latency=latency,
                     depth=DEPTH[world] if depth is None else depth, seed=seed, tolerance=tolerance,
                     tolerance_px=tolerance_px, vision=vision, record=record, goal_pose=goal_pose)
    return c, result


def summarise(world: str, case: str, scheme: str, result, angle_wrap: str = "consistent") -> Row:
    """One row of the summary table from a run's sim.Result."""
    h, s, m = result.history, result.status, result.metrics
    event = f"point {s.point + 1}" if s.point >= 0 else f"joint q{s.joint + 1}" if s.joint >= 0 else "none"
    frames = m.frames_to_converge
    dt = float(h.time[1] - h.time[0]) if len(h.time) > 1 else float("nan")
    nan = float("nan")
    pixel = result.pixel_error

    def at_end(x):  # at the frame of convergence, else the last value computed
        finite = np.flatnonzero(np.isfinite(x))
        k = s.frame if s.converged else int(finite[-1]) if len(finite) else -1
        return float(x[k]) if 0 <= k < len(x) else nan
    return Row(
        world, case, scheme, s.outcome, event, frames, frames * dt if frames >= 0 else nan,
        m.camera_retreat, m.path_length, m.peak_commanded_linear_speed, m.peak_commanded_angular_speed,
        1e3 * m.final_translation_error, math.degrees(m.final_rotation_error),
        f"q{s.joint + 1}" if s.outcome == "joint_limit" else "no" if result.robot is not None else "",
        FIGURES.get((world, case, scheme), ""), wrap_label(scheme, angle_wrap),
        peak_v_camera=m.peak_linear_speed, peak_w_camera=m.peak_angular_speed,
        error_norm=at_end(h.error_norm), tolerance=nan if result.tolerance is None else float(result.tolerance),
        pixel_error=at_end(pixel), tolerance_px=nan if result.tolerance_px is None else float(result.tolerance_px),
        unit=measurement_unit(result.camera), judgement=result.judged(), end_frame=s.frame,
    )


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


def write_summary(rows: list[Row], checks: list[tuple[str, bool]], out: Path, fig4: dict,
                  angle_wrap: str = "consistent") -> str:
    """Write summary.csv and summary.md into out (the rows, the paper's claims checked, Fig. 4's paths);
    return the table as Markdown."""
    with open(out / "summary.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(Row.COLUMNS)
        for row in rows:
            w.writerow([getattr(row, c) for c in Row.COLUMNS])
    table = format_rows(rows)
    md = ["# ibvs: reproduction of Corke, Spindler & Chaumette (IROS 2009)", "", wrap_sentence(angle_wrap),
          "", table, "", "## Paper claims", ""]
    md += [f"- [{'x' if ok else ' '}] {text}" for text, ok in checks]
    md += ["", "## Fig. 4", ""]
    md += [f"- {name}: {'stays inside' if ok else 'leaves'} the square image" for name, ok in fig4.items()]
    (out / "summary.md").write_text("\n".join(md) + "\n")
    return table


def wrap_sentence(angle_wrap: str) -> str:
    """Which angle wrap the figures use, in words (summary.md and the printed summary)."""
    how = ("consistent: each figure's theta errors wrapped as one rotation, about their circular mean"
           if angle_wrap == "consistent"
           else "per-point: each theta error wrapped into (-π, π] on its own, eq. (13)")
    return (f"Angle wrap of every figure with polar rows (polar, hybrid, stacked; column 'angle wrap'): "
            f"{how}. Cartesian IBVS has no angle rows.")


def reproduce(out: Path, quick: bool = False, stream=sys.stdout,
              angle_wrap: str = "consistent") -> tuple[list[Row], list[tuple[str, bool]]]:
    """What `ibvs reproduce` runs: every case of PAPER_CASES with the paper's four schemes, a figure per run and
    Fig. 4 drawn into out (smaller with quick), summary.md and summary.csv written; returns the rows and the
    paper's claims checked against them."""
    from .. import viz

    if angle_wrap not in ANGLE_WRAPS:
        raise ValueError(f"angle_wrap must be one of {ANGLE_WRAPS}, got {angle_wrap!r}")
    out.mkdir(parents=True, exist_ok=True)
    plan = [(w, c, s) for w in PAPER_CASES for c in PAPER_CASES[w] for s in SCHEMES]
    # A whole episode simulates in milliseconds; the time goes into drawing, so --quick draws smaller.
    dpi = 50 if quick else 100
    rows = []
    t0 = time.perf_counter()
    viz.image_limits().savefig(out / "fig4_image_limits.png", dpi=dpi)
    fig4 = {name: inside for name, (_, inside) in viz.image_limits_paths().items()}
    print(f"[ 0/{len(plan)}] Fig. 4 image-plane limits -> fig4_image_limits.png", file=stream, flush=True)
    for k, (world, case, scheme) in enumerate(plan, 1):
        c, result = run_one(world, case, scheme, angle_wrap=angle_wrap)
        row = summarise(world, case, scheme, result, angle_wrap)
        rows.append(row)
        name = f"{world}_{case}_{scheme}.png"
        fig = FIGURES.get((world, case, scheme))
        wrap = "" if row.angle_wrap == "-" else f", {row.angle_wrap} wrap"
        title = f"{fig + ': ' if fig else ''}{c.description}, {SCHEME_TITLES[scheme]}{wrap}"
        viz.episode(result, title=title).savefig(out / name, dpi=dpi)
        print(f"[{k:2d}/{len(plan)}] {world:6s} {case:13s} {scheme:9s} {row.status:13s} {row.event:9s}"
              f" -> {name}  ({time.perf_counter() - t0:.1f} s)", file=stream, flush=True)
    checks = claims(rows)
    table = write_summary(rows, checks, out, fig4, angle_wrap)
    print("\n" + wrap_sentence(angle_wrap) + "\n\n" + table + "\n", file=stream)
    for text, ok in checks:
        print(f"[{'ok' if ok else 'NOT REPRODUCED'}] {text}", file=stream)
    print(f"\nfigures, summary.md and summary.csv in {out}", file=stream)
    return rows, checks
