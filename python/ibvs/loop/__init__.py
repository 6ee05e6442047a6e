"""The real-time servo loop: frames (ibvs.vision.sources) -> tracker -> servo -> robot (ibvs.robot),
on one Clock (RealClock on hardware, a simulated clock in a simulated world)."""

from __future__ import annotations

from .clock import Clock, RealClock, SimClock

__all__ = ["Clock", "RealClock", "SimClock"]
