"""ibvs.viz: figures of simulated episodes, comparisons of runs, sweeps and the paper's Fig. 4.

    from ibvs import sim
    import ibvs.viz

    result = sim.run(servo, case.camera, case.target, case.start, case.goal)
    fig = result.plot()                            # the same as ibvs.viz.episode(result)
    fig.savefig("run.png")
    ibvs.viz.compare([a, b], ["polar", "cartesian"]).savefig("compare.png")
    ibvs.viz.animate(result, "run.gif", speed=2)

Every function builds a matplotlib.figure.Figure directly, without pyplot, so none of them
selects or changes matplotlib's backend: save the figure with fig.savefig(...), return it from
a notebook cell, or pass fig=plt.figure() to draw into a figure that pyplot manages (then
plt.show() shows it). Needs matplotlib: pip install ".[plot]" from the repository root.

Modules: episode_figure (episode), comparison (compare), fig4 (image_limits), sweep_figure
(sweep_summary), animation (animate), rerun_log (rerun: Rerun, the rerun extra) and drawing (the
helpers, colours and styles they share);
this package re-exports their public functions.

Colours and styles are the same in every panel: one colour per target point, one line style
per feature coordinate (u solid, v dashed, r dash-dot, theta dotted, r theta dash-dot-dot);
twist components x, y, z in red, green, blue, translations solid and rotations dashed.
"""

from __future__ import annotations

from .animation import animate
from .comparison import compare
from .drawing import AXIS_COLOURS, COORDINATE_STYLES, TWIST_LABELS
from .episode_figure import episode
from .fig4 import image_limits, image_limits_paths, square_perimeter_r
from .rerun_log import rerun
from .sweep_figure import sweep_summary

__all__ = ["AXIS_COLOURS", "COORDINATE_STYLES", "TWIST_LABELS", "animate", "compare", "episode", "image_limits",
           "image_limits_paths", "rerun", "square_perimeter_r", "sweep_summary"]
