"""Latency compensation: the features predicted forward over a known capture-to-command delay.

A frame captured at t_c reaches the servo at t_c + d (exposure, transfer, tracking). The servo then acts
on where the points were, not where they are: at a gain g the loop's phase lag grows with g d, and the
uncompensated loop overshoots, then oscillates (docs/servo-loop.md, "Latency").

Method: a model-based predictor of the features over the delay (the prediction step of a Smith
predictor, Smith 1957, whose plant model is here the interaction matrix). The points move with the
camera's twist v as ds/dt = L_s(s, Z) v, with L_s the interaction matrix of a normalised image point
(Chaumette & Hutchinson, "Visual servo control, Part I", IEEE RAM 2006, eq. (11)):

    L_x = [ -1/Z    0   x/Z    x y   -(1 + x^2)   y ]
          [   0   -1/Z  y/Z  1 + y^2    -x y     -x ]

and the depth as dZ/dt = -vz - y Z wx + x Z wy (the point's motion in the camera frame, -v - w x P).
The twists commanded since capture are known (the loop sent them), so

    s(t_c + d) ~ s(t_c) + integral_{t_c}^{t_c + d} L_s(s(t), Z(t)) v(t) dt

integrated here piecewise: one Euler step per span over which the command was constant (the spans of
the loop's period; a span longer than max_step is cut into steps of max_step). The velocity the robot
actually follows may lag the command: with lag = tau > 0 the twist applied is the command through a
first-order lag (time constant tau, dv/dt = (v_cmd - v) / tau), integrated exactly over each span. The
twist after the last command (the span reaching past now) is the last one, held.

The servo then runs on the predicted points and depths. Without a predictor (delay 0, the default)
nothing of this runs: the servo sees the measured points, bit for bit as before.
"""

from __future__ import annotations

import bisect
import math
from typing import List, Optional, Tuple

import numpy as np

__all__ = ["FeaturePredictor", "point_interaction"]


def point_interaction(uv: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """(2N, 6) interaction matrix of N normalised image points (N, 2) at depths (N,), rows x0, y0, x1, ...
    (Chaumette & Hutchinson 2006, eq. (11))."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    z = np.broadcast_to(np.asarray(depth, dtype=np.float64), (len(uv),))
    x, y, iz = uv[:, 0], uv[:, 1], 1.0 / z
    L = np.zeros((len(uv), 2, 6))
    L[:, 0, 0], L[:, 0, 2], L[:, 0, 3], L[:, 0, 4], L[:, 0, 5] = -iz, x * iz, x * y, -(1 + x * x), y
    L[:, 1, 1], L[:, 1, 2], L[:, 1, 3], L[:, 1, 4], L[:, 1, 5] = -iz, y * iz, 1 + y * y, -x * y, -x
    return L.reshape(-1, 6)


def _real(x, name: str, lo: float = 0.0) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)) or not (
            math.isfinite(x) and x >= lo):
        raise ValueError(f"{name} must be a finite number >= {lo:g} (seconds), got {x!r}")
    return float(x)


class FeaturePredictor:
    """Predict normalised image points (and their depths) over a known delay from the twists commanded
    since their capture (see the module docstring for the method and its references).

        p = FeaturePredictor(delay=0.1, lag=0.0)
        p.commanded(t, twist)                       # each twist sent, at the time it was sent
        uv_now, z_now = p.predict(uv, z, t_capture) # the points at t_capture + delay

    delay     seconds from capture to the command's taking effect (> 0)
    lag       seconds: the robot's velocity tracking lag, a first-order time constant (0: none)
    max_step  seconds: the longest Euler step (default 1/60)
    Twists older than `keep` seconds (default 10 delays and at least 1 s) are forgotten.
    """

    def __init__(self, delay: float, lag: float = 0.0, max_step: float = 1.0 / 60.0, keep: Optional[float] = None):
        self.delay = _real(delay, "delay")
        if self.delay <= 0:
            raise ValueError(f"delay must be > 0 seconds (no delay: no predictor), got {delay!r}")
        self.lag = _real(lag, "lag")
        self.max_step = _real(max_step, "max_step")
        if self.max_step <= 0:
            raise ValueError(f"max_step must be > 0 seconds, got {max_step!r}")
        self.keep = max(1.0, 10 * (self.delay + self.lag)) if keep is None else _real(keep, "keep")
        self._t: List[float] = []  # command times, increasing
        self._v: List[np.ndarray] = []  # the twist commanded from _t[i] on
        self._applied: List[np.ndarray] = []  # the (lagged) twist applied at _t[i]

    def reset(self) -> None:
        """Forget every command (the robot is at rest)."""
        self._t.clear()
        self._v.clear()
        self._applied.clear()

    def commanded(self, t: float, twist) -> None:
        """The camera twist (6,) commanded at time t (held until the next command)."""
        v = np.array(twist, dtype=np.float64).reshape(6)
        if not np.isfinite(v).all() or not math.isfinite(t):
            raise ValueError("commanded: the time and the twist must be finite")
        if self._t and t < self._t[-1]:
            raise ValueError(f"commanded: time {t} is before the last command's {self._t[-1]}")
        if self._t and t == self._t[-1]:  # a second command at the same time replaces the first
            self._v[-1] = v
            return
        self._applied.append(np.zeros(6) if not self._t else self._lagged(len(self._t) - 1, t - self._t[-1]))
        self._t.append(float(t))
        self._v.append(v)
        while len(self._t) > 1 and self._t[1] < t - self.keep:
            del self._t[0], self._v[0], self._applied[0]

    def _lagged(self, i: int, h: float) -> np.ndarray:
        """The applied twist h seconds after command i."""
        if self.lag == 0:
            return self._v[i]
        return self._v[i] + (self._applied[i] - self._v[i]) * math.exp(-h / self.lag)

    def _displacement(self, i: int, a: float, b: float) -> np.ndarray:
        """The integral of the applied twist over [a, b] within command i's span (from _t[i])."""
        if self.lag == 0:
            return self._v[i] * (b - a)
        ea, eb = math.exp(-(a - self._t[i]) / self.lag), math.exp(-(b - self._t[i]) / self.lag)
        return self._v[i] * (b - a) + (self._applied[i] - self._v[i]) * self.lag * (ea - eb)

    def spans(self, t0: float, t1: float) -> List[Tuple[float, np.ndarray]]:
        """(duration, integral of the applied twist) of each step from t0 to t1 (steps <= max_step)."""
        out: List[Tuple[float, np.ndarray]] = []
        if not self._t or t1 <= t0:
            return out
        i = max(0, bisect.bisect_right(self._t, t0) - 1)
        a = max(t0, self._t[0])
        while a < t1:
            end = min(t1, self._t[i + 1] if i + 1 < len(self._t) else math.inf)
            n = max(1, math.ceil((end - a) / self.max_step - 1e-9))
            for k in range(n):
                lo, hi = a + (end - a) * k / n, a + (end - a) * (k + 1) / n
                out.append((hi - lo, self._displacement(i, lo, hi)))
            a = end
            i += 1
        return out

    def predict(self, uv, depth, t_capture: float) -> Tuple[np.ndarray, np.ndarray]:
        """The points uv (N, 2), normalised, at depths (N,) or one depth, captured at t_capture, predicted
        to t_capture + delay: returns (uv (N, 2), depths (N,))."""
        s = np.array(uv, dtype=np.float64).reshape(-1, 2)
        z = np.array(np.broadcast_to(np.asarray(depth, dtype=np.float64), (len(s),)))
        for _, d in self.spans(float(t_capture), float(t_capture) + self.delay):
            x, y = s[:, 0], s[:, 1]
            zdot_dt = -d[2] - y * z * d[3] + x * z * d[4]
            s = s + (point_interaction(s, z) @ d).reshape(-1, 2)
            z = np.maximum(z + zdot_dt, 1e-6 * z)  # never through the camera's plane
        return s, z
