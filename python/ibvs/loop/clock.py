"""The loop's clock: one time base for frame stamps, robot-state stamps and the loop's period.

    clock = RealClock()            # time.monotonic / time.sleep: hardware, real cameras
    t = clock.now()                # seconds
    clock.sleep_until(t + 1 / 30)  # wait for the next period

A simulated world provides its own Clock whose sleep_until(t) advances the world to t (the kinematic
simulator: SimClock here; the MuJoCo testbed: ibvs.sim.physics), so the same loop runs faster than
real time in tests and at real time on hardware.
"""

from __future__ import annotations

import abc
import math
import time
from typing import Callable, List, Optional

__all__ = ["Clock", "RealClock", "SimClock"]


class Clock(abc.ABC):
    """A time base in seconds. now() never goes backwards; sleep_until(t) returns at (or after) t, at
    once when t is in the past."""

    @abc.abstractmethod
    def now(self) -> float:
        """The current time, seconds."""

    @abc.abstractmethod
    def sleep_until(self, t: float) -> None:
        """Wait until now() >= t (a simulated clock advances its world to t instead)."""


class RealClock(Clock):
    """The host's monotonic clock (time.monotonic); sleep_until sleeps (time.sleep)."""

    def now(self) -> float:
        return time.monotonic()

    def sleep_until(self, t: float) -> None:
        if not math.isfinite(t):
            raise ValueError(f"t must be finite, got {t!r}")
        while True:
            left = t - time.monotonic()
            if left <= 0:
                return
            time.sleep(left)


class SimClock(Clock):
    """A simulated clock: sleep_until(t) advances the time to t and calls each listener with (t0, t1),
    e.g. the kinematic simulator's robot integrating its commanded velocity over [t0, t1]. It never
    sleeps for real, so a loop on it runs as fast as the host can compute.

    start   the initial time, seconds
    """

    def __init__(self, start: float = 0.0):
        if not math.isfinite(start):
            raise ValueError(f"start must be finite, got {start!r}")
        self._t = float(start)
        self._listeners: List[Callable[[float, float], None]] = []

    def now(self) -> float:
        return self._t

    def on_advance(self, listener: Callable[[float, float], None]) -> None:
        """Call listener(t0, t1) each time the clock advances from t0 to t1 > t0."""
        self._listeners.append(listener)

    def advance(self, dt: float) -> None:
        """Advance by dt >= 0 seconds."""
        self.sleep_until(self._t + dt)

    def sleep_until(self, t: float) -> None:
        if not math.isfinite(t):
            raise ValueError(f"t must be finite, got {t!r}")
        if t <= self._t:
            return
        t0, self._t = self._t, float(t)
        for listener in self._listeners:
            listener(t0, self._t)


def clock_or_real(clock: Optional[Clock]) -> Clock:
    """The given clock, or a RealClock."""
    return RealClock() if clock is None else clock
