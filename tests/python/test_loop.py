"""The servo loop (ibvs.loop): it converges on the kinematic gantry, and it never leaves the robot moving,
whatever ends it: its duration, convergence, the source ending or dying (watchdog), a stale robot state,
the robot failing, lost features, an exception in the tracker or the servo, a signal. Each path is run
with a robot that records every call (tests/python/loop_world.py): the last motion command must be a
stop, followed by the disconnect. No timing is asserted: the loop runs on a simulated clock."""

from __future__ import annotations

import json
import os
import signal

import numpy as np
import pytest

pytest.importorskip("cv2", reason="the loop's tracker renders and tracks images (the vision extra)")

import loop_world as lw  # noqa: E402
from ibvs.loop import SimClock  # noqa: E402
from ibvs.loop.latency import FeaturePredictor  # noqa: E402
from ibvs.loop.servo_loop import LoopOptions, ServoLoop  # noqa: E402
from ibvs.vision.sources import Frame, FrameSource  # noqa: E402


def _error_px(w, robot):
    return float(np.linalg.norm(w.pixels(robot.q) - w.goal, axis=1).max())


def test_converges_on_the_kinematic_gantry_and_logs_every_frame(tmp_path):
    w = lw.world()
    log = tmp_path / "run.jsonl"
    loop, robot = lw.loop(w, options=LoopOptions(duration=6.0, converge_px=0.5, log=log, signals=False), gain=2.0)
    before = _error_px(w, robot)
    report = loop.run()
    assert report.outcome == "converged" and report.status == 0, report.text()
    assert before > 20 and _error_px(w, robot) < 1.0
    assert not robot.moving_after_exit()
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    assert lines[0]["kind"] == "start" and lines[-1]["kind"] == "end"
    frames = [x for x in lines if x["kind"] == "frame"]
    assert len(frames) == report.frames == report.timing.summary()["frames"] > 10
    assert all(f["sent"] for f in frames) and lines[-1]["outcome"] == "converged"
    # capture-to-command on the simulated clock: nothing elapses while the loop computes
    assert max(f["latency"] for f in frames) == 0.0 and report.timing.late == 0


def test_duration_end_stops_the_robot():
    w = lw.world()
    loop, robot = lw.loop(w, options=LoopOptions(duration=0.5, signals=False))
    report = loop.run()
    assert report.outcome == "duration" and report.status == 0
    assert robot.calls[0] == "connect" and not robot.moving_after_exit()
    assert abs(w.clock.now() - 0.5) < 1.0 / 25


def test_dry_run_reads_the_state_and_sends_nothing(tmp_path):
    w = lw.world()
    log = tmp_path / "dry.jsonl"
    loop, robot = lw.loop(w, options=LoopOptions(duration=0.3, dry_run=True, log=log, signals=False))
    report = loop.run()
    assert report.sent == 0 and not any(isinstance(c, tuple) for c in robot.calls)
    assert "state" in robot.calls and not robot.moving_after_exit()
    frames = [json.loads(x) for x in log.read_text().splitlines() if '"frame"' in x]
    assert frames and not any(f["sent"] for f in frames)
    assert any(np.abs(f["qdot"]).max() > 0 for f in frames)  # computed all the same


def test_source_that_dies_trips_the_watchdog():
    w = lw.world(stop_after=5)
    loop, robot = lw.loop(w, options=LoopOptions(duration=5.0, watchdog=0.3, signals=False))
    report = loop.run()
    assert report.outcome == "watchdog" and report.status == 1 and "no frame" in report.reason
    assert report.frames == 5 and report.timing.missed >= 1
    assert not robot.moving_after_exit()
    assert w.clock.now() < 5 / 30 + 0.3 + 2 / 30  # stopped within a period of the watchdog's time
    # between the last frame and the watchdog, the lost-frame ramp went down, never up
    sends = [np.abs(c[1]).max() for c in robot.calls if isinstance(c, tuple)]
    assert sends[-1] <= sends[4]


def test_stale_robot_state_trips_the_watchdog():
    w = lw.world()
    robot = lw.RecordingRobot(w.clock, w.q0, w.model, stale_after=3)
    loop, _ = lw.loop(w, robot=robot, options=LoopOptions(duration=5.0, state_watchdog=0.1, signals=False))
    report = loop.run()
    assert report.outcome == "watchdog" and "state" in report.reason and not robot.moving_after_exit()


@pytest.mark.parametrize("where", ["state", "send"])
def test_robot_failure_stops_within_one_period(tmp_path, where):
    w = lw.world()
    kw = {"fail_state_at": 4} if where == "state" else {"fail_send_at": 4}
    robot = lw.RecordingRobot(w.clock, w.q0, w.model, **kw)
    bag = tmp_path / "run.mcap"
    options = LoopOptions(duration=5.0, log=tmp_path / "r.jsonl", signals=False,
                          record=bag if pytest.importorskip("rosbags") else None)
    loop, _ = lw.loop(w, robot=robot, options=options)
    report = loop.run()
    assert report.outcome == "robot_error" and report.status == 1 and "the robot failed" in report.reason
    assert report.frames == 4 and not robot.moving_after_exit()
    assert w.clock.now() <= 4 / 30 + 1e-9
    from ibvs import ros

    counts = ros.topics(bag)  # closed and readable
    assert counts[ros.TOPICS["twist"]][1] == 4


def test_lost_features_ramp_to_zero_then_stop():
    w = lw.world()

    class Blank(FrameSource):
        """The renderer's frames, then black ones: every dot lost."""

        def __init__(self, inner, good):
            self.inner, self.good, self.rate, self.camera = inner, good, inner.rate, inner.camera

        def read(self, timeout):
            f = self.inner.read(timeout)
            if f is not None and f.index >= self.good:
                return Frame(np.zeros_like(f.image), f.stamp, f.index)
            return f

    robot = lw.RecordingRobot(w.clock, w.q0, w.model)
    source = Blank(lw.render_source(w, robot), 6)
    loop, _ = lw.loop(w, robot=robot, source=source, options=LoopOptions(duration=5.0, signals=False),
                      lost_timeout=0.2)
    report = loop.run()
    assert report.outcome == "lost" and report.status == 1
    sends = [np.abs(c[1]).max() for c in robot.calls if isinstance(c, tuple)]
    ramp = sends[6:]
    assert len(ramp) >= 5 and all(b <= a + 1e-15 for a, b in zip(ramp, ramp[1:]))  # down, linearly, to 0
    assert sends[-1] == 0.0 and not robot.moving_after_exit()


@pytest.mark.parametrize("part", ["tracker", "servo", "source"])
def test_exception_in_a_part_stops_the_robot_and_is_raised(part):
    w = lw.world()
    loop, robot = lw.loop(w, options=LoopOptions(duration=5.0, signals=False))
    calls = {"n": 0}

    def boom(*a, **k):
        calls["n"] += 1
        if calls["n"] > 3:
            raise RuntimeError(f"{part} exploded")
        return original(*a, **k)

    if part == "tracker":
        loop.core.set_camera(w.camera)
        original = loop.core.tracker.track
        loop.core.tracker.track = boom
    elif part == "servo":
        original = loop.core.joint_velocities
        loop.core.joint_velocities = boom
    else:
        original = loop.source.read
        loop.source.read = boom
    with pytest.raises(RuntimeError, match="exploded"):
        loop.run()
    assert not robot.moving_after_exit()


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_stops_the_robot_then_disconnects(signum):
    w = lw.world()
    loop, robot = lw.loop(w, options=LoopOptions(duration=5.0, signals=True))
    inner = loop.source.read

    def read(timeout):  # the signal arrives while the loop runs (after a few frames)
        f = inner(timeout)
        if f is not None and f.index == 3:
            os.kill(os.getpid(), signum)
        return f

    loop.source.read = read
    previous = signal.getsignal(signum)
    report = loop.run()
    assert report.outcome == "signal" and report.status == 128 + signum
    assert not robot.moving_after_exit() and report.frames <= 5
    assert signal.getsignal(signum) is previous  # the handlers put back


def test_dropped_frames_are_counted():
    w = lw.world(drop=0.3)
    loop, robot = lw.loop(w, options=LoopOptions(duration=1.0, signals=False))
    report = loop.run()
    s = report.timing.summary()
    assert s["dropped"] > 0 and s["frames"] + s["dropped"] in (59, 60, 61)  # 1 s at 60 Hz
    assert not robot.moving_after_exit()


def test_injected_latency_is_measured_and_late_frames_counted():
    w = lw.world(latency=0.1)
    loop, robot = lw.loop(w, options=LoopOptions(duration=1.0, late=0.05, signals=False))
    report = loop.run()
    s = report.timing.summary()
    assert s["latency_ms"]["p50"] == pytest.approx(100.0, abs=1e-6) and s["late"] == s["frames"] > 0
    assert not robot.moving_after_exit()


def test_without_latency_the_servo_sees_the_measured_points_bit_for_bit():
    """No predictor (latency 0, the default): each twist is, to the bit, the servo's on the tracked points,
    computed here independently (a fresh tracker and servo of the same scheme), frame after frame."""
    from ibvs import vision
    from ibvs.study import schemes

    w = lw.world()
    loop, robot = lw.loop(w, options=LoopOptions(duration=0.2, signals=False))
    assert loop.predictor is None and loop.core.predictor is None
    tracker = vision.DotTracker(4, (int(w.camera.width), int(w.camera.height)))
    tracker.reset(w.start_pixels)
    servo = schemes.make("polar", 1.0, 4)
    servo.max_linear_speed, servo.max_angular_speed = 0.5, 1.5
    inner, twists = loop.core.twist_of_image, []

    def both(image, stamp=None):
        got = inner(image, stamp)
        uv = w.camera.normalize(tracker.track(image).pixels)
        want = servo.update(uv, np.full(4, 0.6), w.camera.normalize(w.goal), np.full(4, 0.6)).velocity
        twists.append((got, np.array(want)))
        return got

    loop.core.twist_of_image = both
    loop.run()
    assert len(twists) > 5 and all(np.array_equal(a, b) for a, b in twists)


def test_compensation_removes_the_delay_overshoot():
    """At a gain where the 100 ms delayed loop overshoots, the compensated one does not (kinematic gantry)."""
    overshoot = {}
    for name, predictor in (("raw", None), ("compensated", FeaturePredictor(0.1))):
        w = lw.world(latency=0.1, start=lw.sim.pose(r=(0.0, 0.0, 0.3)))
        loop, robot = lw.loop(w, options=LoopOptions(duration=2.5, signals=False), predictor=predictor, gain=6.0)
        inv_goal = np.linalg.inv(w.model.camera(lw.GOAL_Q))
        rz = []  # the rotation error about the optical axis, at every step of the clock
        w.clock.on_advance(lambda t0, t1: rz.append(lw.ibvs.theta_u((inv_goal @ w.model.camera(robot.q))[:3, :3])[2]))
        loop.run()
        rz = np.array(rz) * np.sign(rz[0])
        overshoot[name] = max(0.0, -rz.min()) / rz[0]
        assert abs(rz[-1]) < 0.01 * rz[0], name  # both converge
    assert overshoot["raw"] > 0.05 and overshoot["compensated"] < 0.05, overshoot


def test_compensated_polar_loop_converges_on_the_servos_own_depths():
    """The predictor's depths stay with the predictor: the servo keeps its constant 0.6 m. Handed the predicted
    per-point depths instead (a millimetre apart), the polar law - condition ~2000 at this start of the latency
    study, 40 mm and 17 degrees off the goal - turned them into another twist and diverged at every delay."""
    start = lw.sim.pose(t=(0.03, -0.02, 0.02), r=(0.0, 0.0, 0.3))
    for delay in (0.025, 0.1):
        w = lw.world(latency=delay, start=start)
        predictor = FeaturePredictor(delay, kinematics=w.model)
        loop, robot = lw.loop(w, options=LoopOptions(duration=8.0, converge_px=0.5, signals=False),
                              predictor=predictor, gain=2.0)
        seen = []

        class Watched:  # the servo, noting the depths it is given
            def __init__(self, servo):
                self.servo = servo

            def update(self, uv, depth, *rest):
                seen.append(np.array(depth))
                return self.servo.update(uv, depth, *rest)

        loop.core.servo = Watched(loop.core.servo)
        report = loop.run()
        assert report.outcome == "converged", (delay, report.outcome)
        assert seen and all(np.array_equal(d, np.full(4, 0.6)) or np.array_equal(d, 0.6) for d in seen)


def test_a_clock_only_the_loop_advances_is_enough():
    # The loop on a SimClock runs without sleeping: 10 s of loop in far less (nothing asserted on time).
    w = lw.world()
    loop, robot = lw.loop(w, options=LoopOptions(duration=10.0, converge_px=0.5, signals=False), gain=2.0)
    report = loop.run()
    assert report.outcome == "converged"
    assert isinstance(w.clock, SimClock)


def test_servo_loop_without_frames_and_no_robot_motion_before_the_first_good_image():
    class Silent(FrameSource):
        rate = 30.0

        def read(self, timeout):
            clock.sleep_until(clock.now() + timeout)
            return None

    w = lw.world()
    clock = w.clock
    robot = lw.RecordingRobot(clock, w.q0, w.model)
    loop = ServoLoop(Silent(), robot, lw.core(w), clock, LoopOptions(duration=2.0, watchdog=0.25, signals=False))
    report = loop.run()
    assert report.outcome == "watchdog"
    sends = [c[1] for c in robot.calls if isinstance(c, tuple)]
    assert all(not s.any() for s in sends) and not robot.moving_after_exit()


def test_a_command_refused_by_the_limits_stops_the_loop_and_the_robot():
    """With the real ibvs.robot protocol: a joint about to pass its position limit refuses the command
    (LimitError, never sent), the robot is halted, the loop ends with robot_error."""
    from ibvs.robot import Limits

    w = lw.world()
    q_lo = w.q0 - 0.5
    q_hi = w.q0 + 0.5
    q_hi[5] = w.q0[5] + 0.01  # the wrist's rotation (0.3 rad to go) is refused 10 mrad on
    lim = Limits(q_lo, q_hi, np.full(6, 2.0), np.full(6, 50.0))
    robot = lw.ProtocolRobot(w.clock, w.q0, w.model, lim)
    source = lw.render_source(w, robot)
    loop, _ = lw.loop(w, robot=robot, source=source, options=LoopOptions(duration=5.0, signals=False))
    report = loop.run()
    assert report.outcome == "robot_error" and "LimitError" in report.reason, report.reason
    sends = [h for h in robot.hooks if isinstance(h, tuple)]
    assert sends and robot.hooks[-2:] == ["halt", "close"] and not robot.dq.any()
    assert robot.q[5] <= q_hi[5] + 1e-12  # never past the limit
    assert not robot.connected


def test_dry_run_with_the_protocol_checks_limits_and_sends_nothing():
    from ibvs.robot import Limits

    w = lw.world()
    lim = Limits(w.q0 - 1, w.q0 + 1, np.full(6, 2.0), np.full(6, 50.0))
    robot = lw.ProtocolRobot(w.clock, w.q0, w.model, lim)
    loop, _ = lw.loop(w, robot=robot, source=lw.render_source(w, robot),
                      options=LoopOptions(duration=0.3, dry_run=True, signals=False))
    report = loop.run()
    assert report.frames > 5 and report.sent == 0
    assert not any(isinstance(h, tuple) for h in robot.hooks) and robot.last_command is not None


def _rendered(w, n):
    """n frames of the gantry at rest at its start (the images a camera would have given)."""
    robot = lw.RecordingRobot(w.clock, w.q0, w.model)
    src = lw.render_source(w, robot)
    return [src.read(1.0) for _ in range(n)]


@pytest.mark.parametrize("kind", ["video", "bag"])
def test_replayed_video_and_bag_run_through_the_loop_to_their_end(tmp_path, kind):
    """A recorded camera (a video file, a ROS 2 bag's images) through the loop, dry run: every frame is
    tracked and its command computed; the end of the recording ends the loop (status 0)."""
    import cv2

    from ibvs.vision.sources import RosImageSource, VideoFile

    w = lw.world()
    frames = _rendered(w, 8)
    if kind == "video":
        path = tmp_path / "cam.avi"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), w.camera.fps,
                                 (int(w.camera.width), int(w.camera.height)), isColor=False)
        for f in frames:
            writer.write(f.image)
        writer.release()
        clock = SimClock()
        source = VideoFile(path, clock=clock)
    else:
        pytest.importorskip("rosbags", reason="bags need rosbags (the ros extra)")
        from ibvs import ros

        ts = ros.types.typestore()
        path = tmp_path / "cam.mcap"
        with ros.BagWriter(path, ts) as bag:
            for f in frames:
                ns = int(round(f.stamp * 1e9))
                bag.write(ros.TOPICS["image"], ros.image_msg(f.image, ts, "cam", ns), ns)
        clock = w.clock
        source = RosImageSource(path, clock=clock, replay=True)
    w2 = lw.world()
    w2.clock = clock
    robot = lw.RecordingRobot(clock, w.q0, w.model)
    loop, _ = lw.loop(w2, robot=robot, source=source,
                      options=LoopOptions(duration=10.0, dry_run=True, signals=False, rerun=tmp_path / "run.rrd"
                                          if kind == "bag" and _has("rerun") else None))
    report = loop.run()
    assert report.outcome == "ended" and report.status == 0 and report.frames == 8
    assert loop.core.state == "servoing" and report.sent == 0 and not robot.moving_after_exit()
    assert report.timing.summary()["latency_ms"]["max"] == 0.0  # stamped on the loop's clock
    if kind == "bag" and _has("rerun"):
        assert (tmp_path / "run.rrd").stat().st_size > 0


def _has(module: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(module) is not None
