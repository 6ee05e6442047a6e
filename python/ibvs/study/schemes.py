"""The control laws by name: what `ibvs run`, `ibvs sweep`, ibvs.study.sweep and
ibvs.study.reproduce mean by a scheme.

SCHEMES maps a name to a factory(gain, n_points) returning a servo for n_points image
points: an ibvs.Servo or an ibvs.PartitionedServo, anything ibvs.sim.run accepts. The
factories are module-level functions so that process pools and Dask can pickle them;
register_scheme adds more.
"""

from __future__ import annotations

import functools
import inspect
from typing import Any, Callable

import ibvs


def cartesian(gain: float, n_points: int = 4):
    """Classic IBVS, eq. (3): (u, v) per point."""
    return ibvs.Servo(ibvs.Layout.cartesian(n_points), gain=gain, damping=0.0)


def polar(gain: float, n_points: int = 4):
    """IBVS-P, -(eq. 7): (r, theta) per point."""
    return ibvs.Servo(ibvs.Layout.polar(n_points), gain=gain, damping=0.0)


def hybrid(gain: float, n_points: int = 4):
    """Per-point hybrid (Section V, Fig. 5): the first half of the points Cartesian, the rest polar."""
    half = n_points // 2
    blocks = [(i, "cartesian" if i < half else "polar") for i in range(n_points)]
    return ibvs.Servo(ibvs.Layout(blocks), gain=gain, damping=0.0)


def stacked(gain: float, n_points: int = 4):
    """Both blocks for every point (u, v, r, theta): 4N x 6 (Fig. 8)."""
    return ibvs.Servo(ibvs.Layout.stacked(n_points), gain=gain, damping=0.0)


def cylindrical(gain: float, n_points: int = 4):
    """The (r, r theta) features of Iwatsuki & Okiyama."""
    return ibvs.Servo(ibvs.Layout.cylindrical(n_points), gain=gain, damping=0.0)


def automatic(gain: float, n_points: int = 4):
    """IBVS-P with a point's rows Cartesian while it or its goal is near the principal point."""
    return ibvs.Servo.automatic_hybrid(n_points, gain=gain)


def partitioned(gain: float, n_points: int = 4):
    """Partitioned IBVS (Corke & Hutchinson 2001): wz from the angle of the segment from point 0
    to point 1, Tz from the square root of the polygon's area, the other four DOF Cartesian."""
    return ibvs.PartitionedServo(n_points, gain=gain)


#: Scheme name -> factory(gain, n_points) -> servo.
SCHEMES: dict[str, Callable[..., Any]] = {
    "cartesian": cartesian,
    "polar": polar,
    "hybrid": hybrid,
    "stacked": stacked,
    "cylindrical": cylindrical,
    "automatic": automatic,
    "partitioned": partitioned,
}

#: What each built-in scheme is, for titles and --help.
TITLES = {
    "cartesian": "IBVS (Cartesian)",
    "polar": "IBVS-P (polar)",
    "hybrid": "per-point hybrid (Cartesian / polar)",
    "stacked": "stacked hybrid (u, v, r, θ)",
    "cylindrical": "cylindrical (r, rθ)",
    "automatic": "automatic hybrid",
    "partitioned": "partitioned (Corke & Hutchinson)",
}

#: The four schemes of the paper.
PAPER = ("cartesian", "polar", "hybrid", "stacked")


@functools.lru_cache(maxsize=None)
def _takes_points(factory) -> bool:
    try:
        params = list(inspect.signature(factory).parameters.values())
    except (TypeError, ValueError):
        return True
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 2 or any(p.kind == p.VAR_POSITIONAL for p in params)


def make(scheme, gain: float, n_points: int = 4):
    """A servo of `scheme` (a name in SCHEMES, or a factory) for n_points points. Factories
    written for the paper's four points, factory(gain), are accepted when n_points is 4."""
    factory = SCHEMES[scheme] if isinstance(scheme, str) else scheme
    if _takes_points(factory):
        return factory(gain, n_points)
    servo = factory(gain)
    if servo.layout.n_points != n_points:
        raise ValueError(f"scheme: its factory makes a servo for {servo.layout.n_points} points, the target has "
                         f"{n_points}; write it as factory(gain, n_points)")
    return servo


def register_scheme(name: str, factory: Callable[..., Any], *, replace: bool = False) -> None:
    """Add a scheme: factory(gain, n_points) returns a servo for n_points points (anything
    ibvs.sim.run accepts as servo; factory(gain) is accepted for four-point targets). Raises
    ValueError if the name exists (unless replace)."""
    if not isinstance(name, str) or not name or any(c in name for c in ",: \t\n"):
        raise ValueError(f"name must be a non-empty string without ',', ':' or spaces, got {name!r}")
    if not callable(factory):
        raise TypeError(f"factory must be callable (gain, n_points -> servo), got {type(factory).__name__}")
    if name in SCHEMES and not replace:
        raise ValueError(f"name: scheme {name!r} is already registered (pass replace=True)")
    SCHEMES[name] = factory
