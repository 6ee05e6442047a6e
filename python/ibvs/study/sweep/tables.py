"""The sweep's tables: its rows aggregated per scheme and bin (aggregate), as Markdown
(format_table) and as a figure (figure, through ibvs.viz.sweep_summary)."""

from __future__ import annotations

import math
import os
from typing import Iterable, Optional, Sequence, Union

import numpy as np

from ... import sim
from ..schemes import SCHEMES
from ..scenario import PARAMETERS

# What ibvs.study.sweep re-exports (and documents); the other names here are its own helpers.
__all__ = ["ROTATION_BINS", "NOT_RUN", "outcomes", "bins_for", "aggregate", "starts", "format_starts",
           "format_table", "figure"]

#: Default bins of the optical-axis rotation (degrees).
ROTATION_BINS = tuple(range(0, 181, 30))


#: Outcomes of starts that ran no episode, counted apart from the outcome columns: the target not
#: entirely in view at the start, and a start the robot cannot reach (ibvs.sim.solve_ik).
NOT_RUN = ("invalid_start", "unreachable")


def outcomes(rows: Iterable[dict] = ()) -> list[str]:
    """The outcome columns of a table: ibvs.sim.OUTCOMES, then any other outcome in rows (but
    those of NOT_RUN, which are counted apart)."""
    names = list(sim.OUTCOMES)
    for r in rows:
        o = r["outcome"]
        if o not in names and o not in NOT_RUN:
            names.append(o)
    return names


def bins_for(rows: Sequence[dict], by: str = "rz_deg", width: Optional[float] = None) -> list[float]:
    """Bin edges for the values of `by` in rows: ROTATION_BINS (or multiples of width from 0 to
    180) when by is rz_deg and every value is in [0, 180]; else multiples of width (default: six
    bins) spanning the values."""
    xs = [r[by] for r in rows if math.isfinite(r[by])] or [0.0]
    lo, hi = min(xs), max(xs)
    if by == "rz_deg" and lo >= 0 and hi <= 180:
        lo, hi = 0.0, 180.0
        if width is None:
            return [float(b) for b in ROTATION_BINS]
    if width is None:
        width = (hi - lo) / 6 or 1.0
    a, b = math.floor(lo / width), max(math.ceil(hi / width), math.floor(lo / width) + 1)
    if b - a > 10_000:
        raise ValueError(f"bins: width {width:g} makes {b - a} bins; use a larger width")
    return [k * width for k in range(a, b + 1)]


def _median(xs) -> float:
    xs = [x for x in xs if math.isfinite(x)]
    return float(np.median(xs)) if xs else math.nan


def aggregate(rows: Iterable[dict], by: str = "rz_deg", bins: Optional[Sequence[float]] = None) -> list[dict]:
    """Per scheme and bin of `by` (edges `bins`, last bin closed; default bins_for(rows, by)):
    n (episodes with a valid start), the fraction of each outcome (a key per outcome of
    outcomes(rows): converged, left_image, ..., timeout, and any added later), time (median
    time to converge, s, converged only), the medians of retreat (camera retreat, m), path
    (camera path length, m), peak_linear_speed (m/s) and peak_angular_speed (rad/s) of the
    commanded twist, peak_camera_linear_speed and peak_camera_angular_speed (the speed the
    camera actually moved at, from its poses: on a robot within its joint speed limits; NaN in a
    file written before they were recorded) over the valid episodes, invalid (starts skipped:
    target not in view) and unreachable (starts skipped: no joints within the robot's limits put
    the camera there). Every
    row of the table also holds "outcomes", the list of outcome keys. Deterministic: rows are
    taken in (index, scheme) order."""
    if by not in PARAMETERS:
        raise ValueError(f"by must be one of {PARAMETERS}, got {by!r}")
    rows = sorted(rows, key=lambda r: (r["index"], r["scheme"]))
    edges = bins_for(rows, by) if bins is None else [float(b) for b in bins]
    if len(edges) < 2 or any(b >= a for a, b in zip(edges[1:], edges)) or not all(map(math.isfinite, edges)):
        raise ValueError(f"bins must be at least two finite increasing edges, got {list(bins)}")
    names = outcomes(rows)
    order = list(SCHEMES)  # registry order, then any other scheme
    schemes = sorted(dict.fromkeys(r["scheme"] for r in rows), key=lambda s: (order.index(s) if s in order
                                                                                 else len(order), s))
    groups: dict = {}
    for r in rows:
        x = r[by]
        k = int(np.searchsorted(edges, x, side="right")) - 1
        if k == len(edges) - 1 and x == edges[-1]:
            k -= 1
        if 0 <= k < len(edges) - 1:
            groups.setdefault((r["scheme"], k), []).append(r)
    table = []
    for s in schemes:
        for k in range(len(edges) - 1):
            g = groups.get((s, k), [])
            valid = [r for r in g if r["outcome"] not in NOT_RUN]
            n = len(valid)
            t = {"scheme": s, "bin": f"[{edges[k]:g}, {edges[k + 1]:g}{']' if k == len(edges) - 2 else ')'}",
                 "lo": edges[k], "hi": edges[k + 1], "n": n}
            for o in names:
                t[o] = sum(r["outcome"] == o for r in valid) / n if n else math.nan
            t["time"] = _median(r["time_to_converge"] for r in valid if r["outcome"] == "converged")
            for key, col in (("retreat", "camera_retreat"), ("path", "path_length"),
                             ("peak_linear_speed", "peak_linear_speed"), ("peak_angular_speed", "peak_angular_speed"),
                             ("peak_camera_linear_speed", "peak_camera_linear_speed"),
                             ("peak_camera_angular_speed", "peak_camera_angular_speed")):
                t[key] = _median(r[col] for r in valid)
            t["invalid"] = sum(r["outcome"] == "invalid_start" for r in g)
            t["unreachable"] = sum(r["outcome"] == "unreachable" for r in g)
            t["outcomes"] = names
            table.append(t)
    return table


def starts(rows: Iterable[dict]) -> dict:
    """How many start set-ups (episode indices) the rows hold: "starts" in all, "run" (episodes ran),
    and one count per outcome of NOT_RUN ("invalid_start", "unreachable"). The start, not the rows:
    every scheme of an index shares it."""
    by_index = {}
    for r in rows:
        by_index.setdefault((r["config"], r["index"]), r["outcome"] if r["outcome"] in NOT_RUN else "run")
    counts = {"starts": len(by_index), "run": 0, **{o: 0 for o in NOT_RUN}}
    for what in by_index.values():
        counts[what] += 1
    return counts


def format_starts(rows: Iterable[dict]) -> str:
    """One line of starts(rows): how many ran, how many the robot could not reach, how many had the
    target out of view."""
    c = starts(rows)
    return (f"{c['starts']} starts: {c['run']} run, {c['unreachable']} unreachable by the robot (outcome "
            f"unreachable: no joints within its limits put the camera there), {c['invalid_start']} with the "
            f"target not entirely in view (outcome invalid_start)")


_METRIC_COLUMNS = (("time", "time (s)"), ("retreat", "retreat (m)"), ("path", "path (m)"),
                   ("peak_linear_speed", "peak commanded ‖T‖ (m/s)"),
                   ("peak_angular_speed", "peak commanded ‖ω‖ (rad/s)"),
                   ("peak_camera_linear_speed", "peak camera ‖T‖ (m/s)"),
                   ("peak_camera_angular_speed", "peak camera ‖ω‖ (rad/s)"),
                   ("invalid", "invalid starts"), ("unreachable", "unreachable starts"))


_EMPTY = "a bin without a valid start (n = 0) has no values"


def _why(t: dict, key: str) -> str:
    """Why the value of `key` in table row t is NaN."""
    if not t["n"]:
        return _EMPTY
    if key == "time":
        return "no episode of the bin converged"
    if key.startswith("peak_camera"):
        return "not in the CSV (written by an older ibvs), or no episode moved the camera"
    return "no episode of the bin has a value"


def format_table(table: list[dict], by: str = "rz_deg") -> str:
    """Markdown table of aggregate(): a column per outcome (% of the valid starts), then the
    medians; a cell without a value says n/a, and the lines under the table why."""
    names = list(table[0]["outcomes"]) if table else list(sim.OUTCOMES)
    columns = [("scheme", "scheme"), ("bin", by), ("n", "n")] + [(o, o) for o in names] + list(_METRIC_COLUMNS)
    lines = ["| " + " | ".join(h for _, h in columns) + " |", "|" + "---|" * len(columns)]
    why: dict = {}
    for t in table:
        cells = []
        for k, header in columns:
            x = t[k]
            if isinstance(x, float) and math.isnan(x):
                cells.append("n/a")
                why.setdefault(_why(t, k), []).append(header if k not in names else "outcomes")
            elif k in names:
                cells.append(f"{100 * x:.1f} %")
            elif isinstance(x, float):
                cells.append(f"{x:.4g}")
            else:
                cells.append(str(x))
        lines.append("| " + " | ".join(cells) + " |")
    if why:
        lines.append("")
        lines += [f"n/a{'' if reason == _EMPTY else ' (' + ', '.join(dict.fromkeys(headers)) + ')'}: {reason}"
                  for reason, headers in why.items()]
    return "\n".join(lines)


def figure(table: list[dict], path: Union[str, os.PathLike], by: str = "rz_deg", dpi: int = 90) -> None:
    """Save ibvs.viz.sweep_summary(table, by): every outcome's rate and the median retreat,
    path and peak twist against the bins of `by`, one curve per scheme."""
    from ... import viz

    viz.sweep_summary(table, by).savefig(os.fspath(path), dpi=dpi)
