"""The paper's Fig. 4: the square image's border in the r-theta plane and two straight-line polar
paths, one that stays in the image and one that leaves it (ibvs.viz.image_limits)."""

from __future__ import annotations

import numpy as np

from .drawing import new_figure

# What ibvs.viz re-exports (and documents); the other names here are its own helpers.
__all__ = ["square_perimeter_r", "image_limits_paths", "image_limits"]


def square_perimeter_r(theta: np.ndarray, half_width: float) -> np.ndarray:
    """Radius of the border of the square image [-b, b]^2 in direction theta: b / max(|cos|, |sin|)."""
    return half_width / np.maximum(np.abs(np.cos(theta)), np.abs(np.sin(theta)))


def image_limits_paths(half_width: float = 0.3) -> dict:
    """Fig. 4's two straight-line polar paths, {name: (samples, inside)}: samples (2, 400) of
    (r, theta), inside whether every sample is within the square image [-b, b]^2. A->B lies in
    the image's largest inscribed circle; C->D joins two corners and leaves the image."""
    ends = {
        "A→B": ((0.4 * half_width, -2.6), (0.9 * half_width, 1.2)),
        "C→D": ((4 / 3 * half_width, 0.75), (4 / 3 * half_width, -0.75)),
    }
    s = np.linspace(0, 1, 400)
    out = {}
    for name, ((r0, t0), (r1, t1)) in ends.items():
        r, t = r0 + s * (r1 - r0), t0 + s * (t1 - t0)
        out[name] = (np.array([r, t]), bool(np.all(r <= square_perimeter_r(t, half_width) + 1e-12)))
    return out


def image_limits(half_width: float = 0.3, *, fig=None):
    """Fig. 4: the square image's border in r-theta, its largest inscribed circle shaded, a
    feasible straight-line polar path A->B and an infeasible C->D, also drawn in the u-v plane."""
    from matplotlib.patches import Circle

    fig = new_figure(fig, (13, 5.2))
    ax, ax2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.6, 1]})
    th = np.linspace(-np.pi, np.pi, 1441)
    b = half_width
    ax.fill_between(th, 0, b, color="0.85", label="largest inscribed circle")
    ax.plot(th, square_perimeter_r(th, b), "k-", lw=1.2, label="image border")
    ax2.add_patch(Circle((0, 0), b, color="0.85"))
    ax2.plot([-b, b, b, -b, -b], [-b, -b, b, b, -b], "k-", lw=1.2)
    for (name, (rt, inside)), colour in zip(image_limits_paths(b).items(), ["tab:blue", "tab:red"]):
        r, t = rt
        for a, (x, y) in [(ax, (t, r)), (ax2, (r * np.cos(t), r * np.sin(t)))]:
            a.plot(x, y, "-", color=colour, lw=2, label=f"{name}: {'stays in' if inside else 'leaves'} the image")
            a.plot(x[0], y[0], "o", color=colour)
            a.plot(x[-1], y[-1], "*", color=colour, ms=11)
            a.annotate(name[0], (x[0], y[0]), textcoords="offset points", xytext=(5, 5))
            a.annotate(name[-1], (x[-1], y[-1]), textcoords="offset points", xytext=(5, 5))
    ax.set_xlim(-np.pi, np.pi)
    ax.set_ylim(0, b * 1.5)
    ax.set(xlabel=r"$\theta$ (rad)", ylabel="r (normalised)", title=f"Fig. 4: square image plane ±{b:g} in r-θ space")
    ax.legend(fontsize=8, loc="upper right")
    ax2.set_aspect("equal")
    ax2.set_xlim(-1.5 * b, 1.5 * b)
    ax2.set_ylim(1.5 * b, -1.5 * b)
    ax2.set(xlabel="u (normalised)", ylabel="v (normalised)", title="the same straight polar paths in the image")
    ax2.legend(fontsize=8, loc="lower right")
    return fig
