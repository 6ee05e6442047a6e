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

For a robot commanded in joint velocities (the servo loop's case) the camera twist is not constant over
a span even when the command is: the joint velocities are, and the camera twist J(q) qdot turns with
the joints. Given the robot's kinematics, the predictor is a Smith predictor whose model is the robot
itself: the camera's displacement from capture to t_c + d is the forward kinematics of the joints -
measured (the joint states the loop reads, interpolated at t_c) up to the last state read, integrated
through the commanded joint velocities (with the same lag) beyond it - and the points (at their depths)
move rigidly with it. Without kinematics, the interaction-matrix integral above.

The servo then runs on the predicted points (its depths stay its own: ibvs.ros.node, twist_of_image).
Without a predictor (delay 0, the default)
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
    """Predict normalised image points (and their depths) over a known delay from the motion commanded
    since their capture (see the module docstring for the method and its references).

        p = FeaturePredictor(delay=0.1, lag=0.0, kinematics=None)
        p.observed(t, q)                            # the joints measured at t (with kinematics)
        p.commanded(t, twist, qdot)                 # each command sent, at the time it was sent
        uv_now, z_now = p.predict(uv, z, t_capture) # the points at t_capture + delay

    delay       seconds from capture to the command's taking effect (> 0)
    lag         seconds: the robot's velocity tracking lag, a first-order time constant (0: none)
    kinematics  None: the points move by the interaction matrix under the commanded camera twists;
                a robot model with camera(q) (world <- camera, e.g. an ibvs.sim robot): the camera's
                displacement is the forward kinematics of the joints, measured up to the last observed
                state and integrated through the commanded joint velocities beyond it (exact for a
                robot whose joints follow their commands), and the points move rigidly with it
    max_step    seconds: the longest Euler step (default 1/60)
    Commands older than `keep` seconds (default 10 delays and at least 1 s) are forgotten.
    """

    def __init__(self, delay: float, lag: float = 0.0, max_step: float = 1.0 / 60.0, keep: Optional[float] = None,
                 kinematics=None):
        self.delay = _real(delay, "delay")
        if self.delay <= 0:
            raise ValueError(f"delay must be > 0 seconds (no delay: no predictor), got {delay!r}")
        self.lag = _real(lag, "lag")
        self.max_step = _real(max_step, "max_step")
        if self.max_step <= 0:
            raise ValueError(f"max_step must be > 0 seconds, got {max_step!r}")
        if kinematics is not None and not callable(getattr(kinematics, "camera", None)):
            raise TypeError("kinematics must have camera(q) -> the 4x4 camera pose (an ibvs.sim robot)")
        self.kinematics = kinematics
        self.keep = max(1.0, 10 * (self.delay + self.lag)) if keep is None else _real(keep, "keep")
        self._t: List[float] = []  # command times, increasing
        self._v: List[np.ndarray] = []  # the command (twist, then qdot if given) from _t[i] on
        self._applied: List[np.ndarray] = []  # the (lagged) command applied at _t[i]
        self._obs_t: List[float] = []  # observed joint states: times, increasing
        self._obs_q: List[np.ndarray] = []

    def reset(self) -> None:
        """Forget every command and observation (the robot is at rest)."""
        for x in (self._t, self._v, self._applied, self._obs_t, self._obs_q):
            x.clear()

    def observed(self, t: float, q) -> None:
        """The joint positions q measured at time t (used with kinematics)."""
        q = np.array(q, dtype=np.float64).reshape(-1)
        if not np.isfinite(q).all() or not math.isfinite(t):
            raise ValueError("observed: the time and the joints must be finite")
        if self._obs_t and t <= self._obs_t[-1]:
            if t == self._obs_t[-1]:
                self._obs_q[-1] = q
            return
        self._obs_t.append(float(t))
        self._obs_q.append(q)
        while len(self._obs_t) > 2 and self._obs_t[1] < t - self.keep:
            del self._obs_t[0], self._obs_q[0]

    def commanded(self, t: float, twist, qdot=None) -> None:
        """The camera twist (6,) commanded at time t (held until the next command), and the joint velocities
        (n,) it was sent as (needed with kinematics)."""
        v = np.array(twist, dtype=np.float64).reshape(6)
        if qdot is not None:
            v = np.concatenate([v, np.asarray(qdot, dtype=np.float64).reshape(-1)])
        if not np.isfinite(v).all() or not math.isfinite(t):
            raise ValueError("commanded: the time and the twist must be finite")
        if self._t and t < self._t[-1]:
            raise ValueError(f"commanded: time {t} is before the last command's {self._t[-1]}")
        if self._v and self._v[-1].size != v.size:  # joint velocities given or not, unlike before: start over
            self._t.clear(), self._v.clear(), self._applied.clear()
        if self._t and t == self._t[-1]:  # a second command at the same time replaces the first
            self._v[-1] = v
            return
        self._applied.append(np.zeros(v.size) if not self._t else self._lagged(len(self._t) - 1, t - self._t[-1]))
        self._t.append(float(t))
        self._v.append(v)
        while len(self._t) > 1 and self._t[1] < t - self.keep:
            del self._t[0], self._v[0], self._applied[0]

    def _lagged(self, i: int, h: float) -> np.ndarray:
        """The applied command h seconds after command i."""
        if self.lag == 0:
            return self._v[i]
        return self._v[i] + (self._applied[i] - self._v[i]) * math.exp(-h / self.lag)

    def _displacement(self, i: int, a: float, b: float) -> np.ndarray:
        """The integral of the applied command over [a, b] within command i's span (from _t[i])."""
        if self.lag == 0:
            return self._v[i] * (b - a)
        ea, eb = math.exp(-(a - self._t[i]) / self.lag), math.exp(-(b - self._t[i]) / self.lag)
        return self._v[i] * (b - a) + (self._applied[i] - self._v[i]) * self.lag * (ea - eb)

    def spans(self, t0: float, t1: float) -> List[Tuple[float, np.ndarray]]:
        """(duration, integral of the applied command) of each step from t0 to t1 (steps <= max_step); the
        integral's first 6 entries are the twist's, the others the joint velocities' (when given)."""
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

    def q_at(self, t: float) -> Optional[np.ndarray]:
        """The joints at time t: interpolated between the observed states, or the last observed one
        integrated through the commanded joint velocities beyond it; None without observations."""
        if not self._obs_t:
            return None
        ts = self._obs_t
        if t <= ts[0]:
            return self._obs_q[0].copy()
        if t <= ts[-1]:
            j = bisect.bisect_right(ts, t) - 1
            if j + 1 >= len(ts):
                return self._obs_q[-1].copy()
            w = (t - ts[j]) / (ts[j + 1] - ts[j])
            return (1 - w) * self._obs_q[j] + w * self._obs_q[j + 1]
        q = self._obs_q[-1].copy()
        for _, d in self.spans(ts[-1], t):
            if d.size == 6 + q.size:
                q += d[6:]
        return q

    def predict(self, uv, depth, t_capture: float) -> Tuple[np.ndarray, np.ndarray]:
        """The points uv (N, 2), normalised, at depths (N,) or one depth, captured at t_capture, predicted
        to t_capture + delay: returns (uv (N, 2), depths (N,))."""
        s = np.array(uv, dtype=np.float64).reshape(-1, 2)
        z = np.array(np.broadcast_to(np.asarray(depth, dtype=np.float64), (len(s),)))
        t0, t1 = float(t_capture), float(t_capture) + self.delay
        if self.kinematics is not None and self._obs_t:
            q0, q1 = self.q_at(t0), self.q_at(t1)
            T = np.linalg.inv(np.asarray(self.kinematics.camera(q1))) @ np.asarray(self.kinematics.camera(q0))
            P = np.column_stack([s * z[:, None], z])  # the points in the capture's camera frame
            Q = P @ T[:3, :3].T + T[:3, 3]  # ... in the camera frame at t1
            return _checked(Q[:, :2] / Q[:, 2:3], Q[:, 2], z)
        for _, d in self.spans(t0, t1):
            x, y = s[:, 0], s[:, 1]
            zdot_dt = -d[2] - y * z * d[3] + x * z * d[4]
            with np.errstate(all="ignore"):  # a point leaving the half-space is refused just below
                s = s + (point_interaction(s, z) @ d[:6]).reshape(-1, 2)
            s, z = _checked(s, z + zdot_dt, z)
        return s, z


def _checked(uv: np.ndarray, z: np.ndarray, z_before: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """The predicted points and depths, or a ValueError when a point would leave the camera's half-space
    (its depth under a millionth of what it was, or not finite): the servo treats it as lost features."""
    bad = ~(np.isfinite(uv).all(axis=1) & np.isfinite(z) & (z > 1e-6 * z_before))
    if bad.any():
        raise ValueError(f"predict: point {int(np.flatnonzero(bad)[0])} leaves the camera's field over the delay "
                         f"(the commanded motion takes it behind the camera)")
    return uv, z
