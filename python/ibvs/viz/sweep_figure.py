"""The figure of a sweep's aggregate table: ibvs.viz.sweep_summary."""

from __future__ import annotations

import math
from typing import Sequence

from .drawing import new_figure

# What ibvs.viz re-exports (and documents); the other names here are its own helpers.
__all__ = ["sweep_summary"]


def sweep_summary(table: Sequence[dict], by: str = "rz_deg", *, fig=None):
    """Figure of ibvs.study.sweep.aggregate(): per scheme (one colour each) against the bins of
    `by`, the fraction of every outcome (one panel each, converged first) and the medians of
    the camera retreat, the camera path length, the peak commanded twist (linear and angular) and
    the peak speed the camera actually moved at (on a robot, within its joint speed limits)."""
    if not table:
        raise ValueError("table: empty (no rows to plot)")
    outcomes = list(table[0]["outcomes"])
    metrics = [("retreat", "median camera retreat (m)"), ("path", "median camera path (m)"),
               ("peak_linear_speed", "median peak commanded ‖T‖ (m/s)"),
               ("peak_angular_speed", "median peak commanded ‖ω‖ (rad/s)"),
               ("peak_camera_linear_speed", "median peak camera ‖T‖ (m/s)"),
               ("peak_camera_angular_speed", "median peak camera ‖ω‖ (rad/s)")]
    metrics = [(k, name) for k, name in metrics if k in table[0]]
    panels = [(o, f"{o} (%)") for o in outcomes] + metrics
    cols = 4
    rows = math.ceil(len(panels) / cols)
    fig = new_figure(fig, (4.2 * cols, 3.2 * rows + 0.6))
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    label = {"rz_deg": "rotation about the optical axis (deg)"}.get(by, by)
    schemes = list(dict.fromkeys(t["scheme"] for t in table))
    for ax, (key, name) in zip(axes, panels):
        for s in schemes:
            ts = [t for t in table if t["scheme"] == s]
            x = [(t["lo"] + t["hi"]) / 2 for t in ts]
            y = [t[key] * (100 if key in outcomes else 1) for t in ts]
            ax.plot(x, y, "o-", ms=3, lw=1.2, label=s)
        if key in outcomes:
            ax.set_ylim(-3, 103)
        ax.set_title(name, fontsize=10)
        ax.set_xlabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=min(len(schemes), 7))
    return fig
