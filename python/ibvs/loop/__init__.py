"""The real-time servo loop: frames (ibvs.vision.sources) -> tracker -> servo -> robot (ibvs.robot), on one
Clock (RealClock on hardware, a simulated clock in a simulated world).

    from ibvs.loop import ServoLoop, LoopOptions
    report = ServoLoop(source, robot, core, clock, LoopOptions(duration=10, log="run.jsonl")).run()

or `ibvs servo CONFIG.toml` (ibvs.loop.config, ibvs.loop.setup). Modules: clock (Clock, RealClock,
SimClock), servo_loop (the loop, its outcomes), latency (the feature predictor), config and setup (the
config file), timing and recording (what a run writes).
"""

from __future__ import annotations

from .clock import Clock, RealClock, SimClock
from .latency import FeaturePredictor
from .servo_loop import LoopOptions, LoopReport, ServoLoop

__all__ = ["Clock", "FeaturePredictor", "LoopOptions", "LoopReport", "RealClock", "ServoLoop", "SimClock"]
