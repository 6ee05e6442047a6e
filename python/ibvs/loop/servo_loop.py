"""The servo loop: frames -> tracker -> servo -> robot, at the camera's rate, on one Clock.

    loop = ServoLoop(source, robot, core, clock, LoopOptions(duration=10, log="run.jsonl"))
    report = loop.run()            # LoopReport: outcome, reason, timing; the robot is stopped

Each frame (FrameSource.read): the robot's joint state is read, ServoNodeCore (ibvs.ros.node: the
tracker, the servo, the lost-feature ramp and ibvs.JointMapping - the ROS node's logic, shared) turns
the image into a camera twist and joint velocities, the robot is sent them (checked by its limits;
dry run: computed and logged, not sent), the latency predictor (options.latency > 0) is told the
twist, and the frame's timing is logged. A read that brings no frame within one period sends the
ramp's command instead (ServoNodeCore.ramp_twist).

The loop ends (LoopReport.outcome):
  "duration"     options.duration seconds passed on the clock (status 0)
  "converged"    every tracked point within options.converge_px of its goal (status 0)
  "ended"        the source has no more frames (a video, a bag) (status 0)
  "lost"         the features were lost and the ramp reached zero (status 1)
  "watchdog"     no frame for options.watchdog seconds, or a robot state older than
                 options.state_watchdog (status 1)
  "robot_error"  the robot failed (RobotError, a refused command: LimitError) (status 1)
  "error"        an exception in the tracker, the servo or the source: re-raised after the stop
  "signal"       SIGINT or SIGTERM (status 130 or 143)
Whatever ends it, the robot is sent zero velocity (Robot.stop) and disconnected, and the log, the bag
and the Rerun recording are closed, in a finally block: the robot is never left moving.
"""

from __future__ import annotations

import math
import signal
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Dict, Optional

import numpy as np

from ..finite import finite_within
from .clock import Clock, RealClock
from .recording import BagRecording, LoopLog, RerunRecording
from .timing import Timing

__all__ = ["LoopOptions", "LoopReport", "ServoLoop", "STATUS"]

#: Exit status of each outcome (the `ibvs servo` command's; a signal's is 128 + its number).
STATUS = {"duration": 0, "converged": 0, "ended": 0, "lost": 1, "watchdog": 1, "robot_error": 1, "error": 1,
          "signal": 130}


@dataclass
class LoopOptions:
    """The loop's settings ([loop] of an `ibvs servo` config; docs/servo-loop.md).

    rate            nominal frames per second (None: the source's); the read timeout is one period
    duration        seconds to run (on the clock); None: until something else ends it
    watchdog        seconds without a frame before the loop stops
    state_watchdog  seconds: a robot state older than this stops the loop
    late            seconds of capture-to-command latency beyond which a frame counts as late
                    (None: one period plus `latency`)
    latency         the known capture-to-command delay, seconds, compensated by predicting the features
                    over it (ibvs.loop.latency); 0: no compensation (the servo sees the measured points)
    lag             the robot's velocity tracking lag, seconds (first order), in that prediction
    converge_px     stop when every tracked point is within this many pixels of its goal (None: never)
    dry_run         compute and log the commands, send none (the robot's state is still read)
    log             JSON-lines log path (None: none); record: MCAP bag path; rerun: .rrd path
    record_images   put the images in the bag and the Rerun recording too
    signals         handle SIGINT / SIGTERM (in the main thread): stop the robot, end with 130 / 143
    """

    rate: Optional[float] = None
    duration: Optional[float] = None
    watchdog: float = 0.5
    state_watchdog: float = 0.5
    late: Optional[float] = None
    latency: float = 0.0
    lag: float = 0.0
    converge_px: Optional[float] = None
    dry_run: bool = False
    log: Optional[Any] = None
    record: Optional[Any] = None
    rerun: Optional[Any] = None
    record_images: bool = False
    signals: bool = True


@dataclass
class LoopReport:
    """How a run ended: outcome (see the module docstring), reason (one line), status (exit status),
    timing (Timing), frames, commands sent, and the log's path."""

    outcome: str
    reason: str
    status: int
    timing: Timing
    frames: int = 0
    sent: int = 0
    log: Optional[str] = None
    last_error: Optional[BaseException] = field(default=None, repr=False)

    def text(self) -> str:
        where = f"; log {self.log}" if self.log else ""
        return f"{self.outcome}: {self.reason}{where}\n{self.timing.text()}"


class _Stop(Exception):
    def __init__(self, outcome: str, reason: str, status: Optional[int] = None):
        super().__init__(reason)
        self.outcome, self.reason = outcome, reason
        self.status = STATUS[outcome] if status is None else status


def _robot_errors():
    """The exceptions that mean "the robot failed": ibvs.robot's RobotError and LimitError when there."""
    try:
        from ..robot import LimitError, RobotError
    except ImportError:  # ibvs.robot not there yet: only duck-typed robots
        return (ConnectionError,)
    return (RobotError, LimitError, ConnectionError)


class ServoLoop:
    """The servo loop (see the module docstring).

    source     an ibvs.vision.sources.FrameSource (open or not)
    robot      an ibvs.robot.Robot (connected or not); its kinematics map twists to joints (ServoNodeCore)
    core       an ibvs.ros.ServoNodeCore with output "joint_velocities" and the camera set (set_camera),
               its clock the loop's (integer nanoseconds)
    clock      the Clock of the frames' stamps and the robot's (RealClock by default)
    options    LoopOptions
    predictor  the latency predictor (ibvs.loop.latency.FeaturePredictor) the core uses, told each twist
    """

    def __init__(self, source, robot, core, clock: Optional[Clock] = None, options: Optional[LoopOptions] = None,
                 predictor=None, config: Optional[Dict[str, Any]] = None):
        self.source, self.robot, self.core = source, robot, core
        self.clock = clock if clock is not None else RealClock()
        self.options = options if options is not None else LoopOptions()
        self.predictor = predictor if predictor is not None else getattr(core, "predictor", None)
        self.config = config or {}
        self._signal: Optional[int] = None

    # ------------------------------------------------------------------ control

    def request_stop(self, signum: int) -> None:
        """Stop at the next step as for signal signum (what the SIGINT / SIGTERM handlers call)."""
        self._signal = int(signum)

    def _install_signals(self):
        if not self.options.signals or threading.current_thread() is not threading.main_thread():
            return {}
        old = {}
        for s in (signal.SIGINT, signal.SIGTERM):
            old[s] = signal.signal(s, lambda signum, _frame: self.request_stop(signum))
        return old

    def _check_signal(self) -> None:
        if self._signal is not None:
            name = signal.Signals(self._signal).name
            raise _Stop("signal", f"{name}: stopped the robot", 128 + self._signal)

    # ------------------------------------------------------------------ the run

    def run(self) -> LoopReport:
        """Run until something ends the loop (see the module docstring); the robot stopped and disconnected."""
        o = self.options
        rate = float(o.rate or getattr(self.source, "rate", 30.0) or 30.0)
        period = 1.0 / rate
        late = o.late if o.late is not None else period + o.latency
        timing = Timing(late)
        log = LoopLog(o.log)
        report = LoopReport("error", "", 1, timing, log=None if o.log is None else str(o.log))
        bag = rerun = None
        old_handlers = self._install_signals()
        try:
            log.write("start", config=self.config, dry_run=o.dry_run, rate=rate, clock=type(self.clock).__name__)
            if o.record is not None:
                bag = BagRecording(o.record, self.core.camera, list(self.core.params.joint_names), o.record_images)
            if o.rerun is not None:
                rerun = RerunRecording(o.rerun, self.core.desired, o.record_images)
            self.robot.connect()
            if o.dry_run and hasattr(self.robot, "dry_run"):
                self.robot.dry_run = True  # ibvs.robot.Robot: checks the limits, sends nothing
            self.source.open()
            self._run(rate, period, timing, log, bag, rerun, report)
        except _Stop as s:
            report.outcome, report.reason, report.status = s.outcome, s.reason, s.status
        except _robot_errors() as e:
            report.outcome, report.status, report.last_error = "robot_error", 1, e
            report.reason = f"the robot failed: {type(e).__name__}: {' '.join(str(e).split())}"
        except BaseException as e:
            report.outcome, report.status, report.last_error = "error", 1, e
            report.reason = f"{type(e).__name__}: {' '.join(str(e).split())}"
            raise
        finally:
            self._stop_robot()
            log.write("end", outcome=report.outcome, reason=report.reason, frames=report.frames, sent=report.sent,
                      timing=timing.summary())
            for closing in (bag, rerun):
                if closing is not None:
                    try:
                        closing.close()
                    except Exception:  # noqa: BLE001 - the robot is stopped; a recorder's failure is only reported
                        pass
            log.close()
            try:
                self.source.close()
            except Exception:  # noqa: BLE001
                pass
            for s, h in old_handlers.items():
                signal.signal(s, h)
        return report

    def _stop_robot(self) -> None:
        """Zero velocity, then disconnect; neither may raise (ibvs.robot's never do; a duck-typed one might)."""
        for step in ("stop", "disconnect"):
            try:
                getattr(self.robot, step)()
            except Exception:  # noqa: BLE001 - the next step must still run
                pass

    def _run(self, rate, period, timing: Timing, log: LoopLog, bag, rerun, report: LoopReport) -> None:
        o, clock, core, robot = self.options, self.clock, self.core, self.robot
        t_start = clock.now()
        t_end = math.inf if o.duration is None else t_start + float(o.duration)
        last_frame_t, last_index = t_start, None
        converge = None if o.converge_px is None else float(o.converge_px)
        while True:
            self._check_signal()
            now = clock.now()
            if now >= t_end:
                raise _Stop("duration", f"ran {o.duration:g} s")
            frame = self.source.read(min(1.5 * period, max(0.0, t_end - now)))
            self._check_signal()
            if frame is None:
                now = clock.now()
                if getattr(self.source, "ended", False):
                    raise _Stop("ended", "the source has no more frames")
                if now >= t_end:
                    continue
                timing.missed += 1
                if now - last_frame_t >= o.watchdog:
                    log.write("event", t=now, what="watchdog: no frame")
                    raise _Stop("watchdog", f"no frame for {now - last_frame_t:.3g} s (watchdog {o.watchdog:g} s)")
                self._command(core.ramp_twist(), None, None, log, report)
                continue
            t0 = time.perf_counter()
            last_frame_t = clock.now()
            if last_index is not None and frame.index > last_index + 1:
                timing.dropped += frame.index - last_index - 1
            last_index = frame.index
            state = robot.state()
            if clock.now() - state.stamp > o.state_watchdog:
                log.write("event", t=clock.now(), what="watchdog: robot state")
                raise _Stop("watchdog", f"the robot's state is {clock.now() - state.stamp:.3g} s old (watchdog "
                                        f"{o.state_watchdog:g} s)")
            core.q = np.asarray(state.q, dtype=np.float64)
            if self.predictor is not None:
                self.predictor.observed(state.stamp, core.q)
            image = frame.image if frame.image.ndim == 2 else _gray(frame.image)
            twist = core.twist_of_image(image, frame.stamp)
            cmd = self._command(twist, frame, state, log, report, timing=timing, t0=t0, image=image, bag=bag,
                                rerun=rerun)
            if core.state == "waiting" and clock.now() - t_start > o.watchdog:
                log.write("event", t=clock.now(), what=f"features never found: {core.last_error}")
                raise _Stop("lost", f"the features were not found within the watchdog's {o.watchdog:g} s "
                                    f"({core.last_error})")
            if core.state == "stopped":
                log.write("event", t=clock.now(), what=f"features lost: {core.last_error}")
                raise _Stop("lost", f"features lost ({core.last_error}); ramped to zero")
            if converge is not None and cmd is not None and core.pixels is not None:
                if finite_within(np.linalg.norm(core.pixels - core.desired, axis=1), converge):
                    raise _Stop("converged", f"every point within {converge:g} px of its goal at frame "
                                             f"{frame.index}")

    def _command(self, twist, frame, state, log: LoopLog, report: LoopReport, timing: Optional[Timing] = None,
                 t0: float = 0.0, image=None, bag=None, rerun=None):
        """Send the joint velocities of `twist` (None: nothing yet, zero), log the frame; the Command or None."""
        o, clock, core, robot = self.options, self.clock, self.core, self.robot
        twist = np.zeros(6) if twist is None else np.asarray(twist, dtype=np.float64)
        qdot = core.joint_velocities(twist)
        cmd, sent = None, False
        if not o.dry_run or hasattr(robot, "dry_run"):
            cmd = robot.send_joint_velocity(qdot, state) if state is not None else robot.send_joint_velocity(qdot)
            sent = not o.dry_run
            report.sent += sent
        t_cmd = clock.now()
        if self.predictor is not None:
            self.predictor.commanded(t_cmd, twist, qdot)
        if frame is None:
            return cmd
        report.frames += 1
        latency = t_cmd - frame.stamp
        q = None if state is None else state.q
        if bag is not None:
            bag.frame(frame.stamp, image, core.pixels, twist, q, qdot)
        if rerun is not None:
            rerun.frame(frame.index, frame.stamp, image, core.pixels, twist, core.error_norm, latency)
        late = latency > timing.late_threshold
        log.write("frame", index=frame.index, stamp=frame.stamp, t=t_cmd, latency=latency, late=late, state=core.state,
                  error_norm=core.error_norm, pixels=core.pixels, twist=twist, qdot=qdot, sent=sent,
                  clamped=bool(getattr(cmd, "clamped", False)), reason=str(getattr(cmd, "reason", "") or ""))
        timing.frame(latency, time.perf_counter() - t0)
        return cmd


def _gray(image: np.ndarray) -> np.ndarray:
    import cv2

    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
