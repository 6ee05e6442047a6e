"""A small kinematic world for the servo-loop tests: the Afma6-like gantry carrying the distorted camera
in front of the 10 cm square (ibvs.sim.cases' gantry set-up), a robot that records every call and
integrates its last command on a SimClock, and the loop's parts built around them."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

import ibvs
from ibvs import sim
from ibvs.loop import SimClock
from ibvs.loop.servo_loop import LoopOptions, ServoLoop
from ibvs.robot import JointState, Limits, Robot, RobotError
from ibvs.ros.node import NodeParams, ServoNodeCore

GOAL_Q = np.array(sim.cases.GANTRY_GOAL_Q)
START_OFFSET = sim.pose(t=(0.02, 0.02, 0.03), r=(0.03, -0.03, 0.3))  # the start, in the goal camera frame


class RecordingRobot:
    """Duck-typed ibvs.robot.Robot on a SimClock: q integrates the last commanded dq exactly; `calls` lists
    what was called, in order ("connect", "state", ("send", dq), "stop", "disconnect"). fail_state_at: the
    state() call (0, 1, ...) from which the link is "lost" (raises ConnectionError); fail_send_at: the same
    for send_joint_velocity; stale_after: from that state() call on, the stamp stops advancing."""

    def __init__(self, clock: SimClock, q0, model=None, fail_state_at=None, fail_send_at=None, stale_after=None,
                 error=RobotError):
        self.kinematics = model if model is not None else sim.Gantry.afma6()
        self.n_joints = self.kinematics.dof
        self.rate, self.name = 1000.0, "recording"
        self.clock, self.q, self.dq = clock, np.array(q0, dtype=float), np.zeros(self.kinematics.dof)
        self.calls: list = []
        self.fail_state_at, self.fail_send_at, self.stale_after, self.error = fail_state_at, fail_send_at, \
            stale_after, error
        self.n_state = self.n_send = 0
        self.stamp = 0.0
        clock.on_advance(self._advance)

    def _advance(self, t0, t1):
        self.q = self.q + self.dq * (t1 - t0)

    def connect(self):
        self.calls.append("connect")

    def state(self):
        k, self.n_state = self.n_state, self.n_state + 1
        self.calls.append("state")
        if self.fail_state_at is not None and k >= self.fail_state_at:
            raise self.error("the robot's server is gone")
        if self.stale_after is None or k < self.stale_after:
            self.stamp = self.clock.now()
        return SimpleNamespace(q=self.q.copy(), dq=self.dq.copy(), stamp=self.stamp)

    def send_joint_velocity(self, dq, state=None):
        k, self.n_send = self.n_send, self.n_send + 1
        if self.fail_send_at is not None and k >= self.fail_send_at:
            raise self.error("send failed")
        self.calls.append(("send", np.array(dq)))
        self.dq = np.array(dq, dtype=float)
        return SimpleNamespace(dq=self.dq, clamped=False, reason="")

    def stop(self):
        self.calls.append("stop")
        self.dq = np.zeros(self.n_joints)

    def disconnect(self):
        self.stop()
        self.calls.append("disconnect")

    def moving_after_exit(self) -> bool:
        """True unless the last call that commands motion is a stop (and the robot was disconnected after)."""
        motion = [c for c in self.calls if c == "stop" or (isinstance(c, tuple) and c[0] == "send")]
        return not (motion and motion[-1] == "stop" and self.calls[-1] == "disconnect" and not self.dq.any())


def world(latency=0.0, drop=0.0, stop_after=None, start=None, noise=0.0):
    """(clock, camera, target, robot model, goal pixels, start pixels...); start: the start camera pose in the
    goal camera's frame (4x4)."""
    clock = SimClock()
    model = sim.Gantry.afma6()
    cam = ibvs.CameraModel.afma6()
    goal_pose = model.camera(GOAL_Q)
    target = sim.Target.square(0.1, goal_pose @ sim.pose(t=(0.0, 0.0, 0.6)))
    q0 = sim.solve_ik(model, goal_pose @ (START_OFFSET if start is None else start), GOAL_Q).q

    def pixels(q):
        T_cw = np.linalg.inv(model.camera(q))
        P = (T_cw[:3, :3] @ np.asarray(target.world_points()).T).T + T_cw[:3, 3]
        return cam.project(P[:, :2] / P[:, 2:3])

    return SimpleNamespace(clock=clock, camera=cam, target=target, model=model, q0=q0, goal=pixels(GOAL_Q),
                           start_pixels=pixels(q0), pixels=pixels, latency=latency, drop=drop, stop_after=stop_after,
                           noise=noise)


def render_source(w, robot, **kw):
    from ibvs.vision import Renderer
    from ibvs.vision.sources import RendererSource

    renderer = Renderer(w.camera, w.target, "dots", noise=w.noise)
    return RendererSource(renderer, lambda: w.model.camera(robot.q), clock=w.clock, rate=w.camera.fps,
                          latency=w.latency, drop=w.drop, stop_after=w.stop_after, **kw)


def core(w, gain=1.0, predictor=None, lost_timeout=0.2, scheme="polar"):
    params = NodeParams(desired_pixels=w.goal, depth=0.6, scheme=scheme, gain=gain, max_linear_speed=0.5,
                        max_angular_speed=1.5, initial_pixels=w.start_pixels, output="joint_velocities",
                        eMc=np.eye(4), joint_names=[f"j{i}" for i in range(6)], lost_timeout=lost_timeout,
                        fps=w.camera.fps)
    c = ServoNodeCore(params, clock=lambda: int(round(w.clock.now() * 1e9)), jacobian=w.model.jacobian,
                      predictor=predictor)
    c.set_camera(w.camera)
    return c


def loop(w, robot=None, source=None, options=None, predictor=None, gain=1.0, **core_kw):
    robot = robot if robot is not None else RecordingRobot(w.clock, w.q0, w.model)
    source = source if source is not None else render_source(w, robot)
    options = options if options is not None else LoopOptions(duration=2.0, signals=False)
    return ServoLoop(source, robot, core(w, gain, predictor, **core_kw), w.clock, options, predictor), robot


class ProtocolRobot(Robot):
    """The kinematic gantry as an ibvs.robot.Robot (the real protocol: every command checked by
    check_command, a refused one stops the robot); `hooks` lists the hooks called, in order."""

    def __init__(self, clock: SimClock, q0, model, limits: Limits, rate: float = 60.0):
        super().__init__("protocol gantry", limits, rate, model, clock)  # rate: the loop's (the check's period)
        self.q, self.dq, self.hooks = np.array(q0, dtype=float), np.zeros(6), []
        clock.on_advance(lambda t0, t1: setattr(self, "q", self.q + self.dq * (t1 - t0)))

    def _connect(self):
        self.hooks.append("connect")

    def _read_state(self):
        return JointState(self.q.copy(), self.dq.copy(), self.clock.now())

    def _send(self, dq):
        self.hooks.append(("send", np.array(dq)))
        self.dq = np.array(dq)

    def _halt(self):
        self.hooks.append("halt")
        self.dq = np.zeros(6)

    def _close(self):
        self.hooks.append("close")
