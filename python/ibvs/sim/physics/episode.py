"""One closed-loop episode of a case on the testbed, through the project's servo on rendered images.

    r = run(ibvs.sim.cases.arm_general_motion("panda"), ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0))
    r.converged, r.frames_to_converge, r.overshoot, r.peak_torque

The loop, frame by frame (the minimal one; ibvs.loop's is the same with its watchdog and logging):
MujocoCamera.read (steps the physics to the frame's delivery) -> ibvs.vision.DotTracker on the image
-> Servo.update (the pixels normalised; depths: the true ones at the exposure, as ibvs.sim.run's depth="exact")
-> ibvs.JointMapping with the arm's Jacobian at the measured joints -> MujocoRobot.send_joint_velocity
(through ibvs.robot.check_command). Desired pixels: the tracker's on the image rendered at the goal
joints (teach by showing); the tracker starts at the projections of the dots at the start.

Converged: every dot within tolerance_px of its desired pixel. Overshoot: how far the image error went
past the goal along its initial direction, max(0, -min_k e_k . e_0 / |e_0|^2) (0 for an error that
decays without crossing zero, 0.05 = it went 5 % of the initial error beyond the goal).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..._core import JointMapping, theta_u
from ...finite import finite_within

__all__ = ["PhysicsResult", "run", "run_loop", "overshoot"]


@dataclass(frozen=True)
class PhysicsResult:
    """A testbed episode. Per frame k (K frames): time (K,) exposure stamps, s; error (K, 2N) measured -
    desired pixels; q, dq (K, n) joints at the frame's delivery; qdot (K, n) the command sent after it.

    outcome: "converged", "lost" (a dot not tracked) or "timeout"; frames_to_converge (-1: not);
    overshoot (see the module); tracking_rms / tracking_max: rad/s, joint velocity minus command over
    every physics step (RMS, largest); peak_torque (n,) N m, the largest |actuator torque| per joint;
    effort (n,) the URDF's limits; final_translation_error (m) between the camera and its goal pose;
    pose_error (run_loop only) (M, 6): the camera's pose in the goal camera's frame (t, theta u) each time the
    world was stepped (each frame read and each wait of the loop)."""

    outcome: str
    frames_to_converge: int
    time: np.ndarray
    error: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    qdot: np.ndarray
    overshoot: float
    tracking_rms: float
    tracking_max: float
    peak_torque: np.ndarray
    effort: np.ndarray
    final_translation_error: float
    pose_error: Optional[np.ndarray] = None

    @property
    def converged(self) -> bool:
        return self.outcome == "converged"


def overshoot(error) -> float:
    """max(0, -min_k e_k . e_0 / |e_0|^2) of errors (K, M): how far past the goal the error went along
    its initial direction, as a fraction of the initial error (0 when e_0 = 0)."""
    e = np.asarray(error, dtype=float).reshape(len(error), -1)
    e = e[np.isfinite(e).all(axis=1)]
    if len(e) == 0 or not (e[0] @ e[0] > 0):
        return 0.0
    return float(max(0.0, -np.min(e @ e[0]) / (e[0] @ e[0])))


def run(case, servo, camera=None, duration: Optional[float] = None, latency: float = 0.0,
        tolerance_px: float = 0.5, world=None, kind: str = "dots", predictor=None) -> PhysicsResult:
    """Run `case` (an ibvs.sim.cases.Case on an example arm: arm_general_motion("panda")...) on the
    testbed with `servo` (an ibvs.Servo for the case's points, fed normalised coordinates of `camera`).

    camera     the testbed's camera (default testbed_camera(320, 240), 30 fps): the case's own camera is
               replaced (MuJoCo renders pinhole images)
    duration   s (default the case's); latency: s from exposure to delivery (MujocoCamera)
    world      a World to reuse (built for this case's robot, target and camera); else one is built and closed
    predictor  None, or a callable (result of Servo.update_pixels, frame, state) -> camera twist (6,) used
               instead of the servo's (a latency compensation; the loop helper's)
    """
    from ...vision import DotTracker
    from .adapters import MujocoCamera, MujocoRobot
    from .world import World, testbed_camera

    camera = testbed_camera(320, 240) if camera is None else camera
    duration = case.duration if duration is None else float(duration)
    own = world is None
    world = World(case.robot, case.target, camera, kind=kind) if own else world
    try:
        arm = world.robot
        points = np.asarray(case.target.points, dtype=float)
        T_wo = np.asarray(case.target.pose, dtype=float)
        P = (T_wo[:3, :3] @ points.T).T + T_wo[:3, 3]  # the points in the frame the target is given in

        def pixels_at(q):
            T = np.linalg.inv(arm.camera(q))
            Pc = (T[:3, :3] @ P.T).T + T[:3, 3]
            return camera.project(Pc[:, :2] / Pc[:, 2:]), Pc[:, 2]

        tracker = DotTracker(len(P), (world.width, world.height))
        tracker.reset(pixels_at(case.goal)[0])
        desired = tracker.track(world.render(case.goal)).pixels
        if not np.isfinite(desired).all():
            raise ValueError("the dots are not all seen at the goal")
        tracker.reset(pixels_at(case.start)[0])
        world.reset(case.start)
        world.monitor(True)
        robot = MujocoRobot(world)
        source = MujocoCamera(world, rate=camera.fps, latency=latency)
        mapping = JointMapping(arm.dof, arm.mount, max_joint_speed=arm.qdot_max, mounting=arm.mounting)
        desired_uv, desired_depth = camera.normalize(desired), pixels_at(case.goal)[1]
        rows = {k: [] for k in ("time", "error", "q", "dq", "qdot")}
        outcome, first = "timeout", -1
        source.open()
        robot.connect()
        try:
            while world.time < duration:
                frame = source.read(1.0)
                if frame is None:
                    continue
                px = tracker.track(frame.image).pixels
                state = robot.state()
                rows["time"].append(frame.stamp)
                rows["q"].append(state.q)
                rows["dq"].append(state.dq)
                if not np.isfinite(px).all():
                    rows["error"].append(np.full(desired.size, np.nan))
                    rows["qdot"].append(np.zeros(arm.dof))
                    outcome = "lost"
                    break
                e = (px - desired).ravel()
                rows["error"].append(e)
                if finite_within(np.linalg.norm(px - desired, axis=1), tolerance_px):
                    outcome, first = "converged", len(rows["time"]) - 1
                    rows["qdot"].append(np.zeros(arm.dof))
                    break
                depth = pixels_at(world.q_at(frame.stamp))[1]
                r = servo.update(camera.normalize(px), depth, desired_uv, desired_depth)
                twist = r.velocity if predictor is None else predictor(r, frame, state)
                T_be, J = arm.kinematics(state.q)
                qdot = (mapping.update(twist, J) if arm.mounting == "eye_in_hand" else
                        mapping.update(twist, J, bMe=T_be)).qdot
                cmd = robot.send_joint_velocity(qdot)
                rows["qdot"].append(np.asarray(cmd.dq, dtype=float))
        finally:
            robot.stop()
            source.close()
        T_err = np.linalg.inv(arm.camera(case.goal)) @ arm.camera(world.q)
        stats = world.monitor(False)
        arrays = {k: np.array(v) for k, v in rows.items()}
        return PhysicsResult(outcome, first, arrays["time"], arrays["error"], arrays["q"], arrays["dq"],
                             arrays["qdot"], overshoot(arrays["error"]), stats["tracking_rms"],
                             stats["tracking_max"], stats["peak_torque"], world.effort.copy(),
                             float(np.linalg.norm(T_err[:3, 3])))
    finally:
        if own:
            world.close()


def run_loop(case, scheme: str = "cartesian", gain: float = 1.0, camera=None, duration: Optional[float] = None,
             latency: float = 0.0, compensate: bool = False, lag: float = 0.0, tolerance_px: Optional[float] = 0.5,
             max_linear_speed: float = 1.0, max_angular_speed: float = 3.0, world=None,
             turn: float = math.nan) -> PhysicsResult:
    """`case` on the testbed through ibvs.loop's ServoLoop, the loop that drives real robots: MujocoCamera
    (frames delivered `latency` s after exposure) -> ibvs.ros.ServoNodeCore (the tracker, the servo of
    `scheme` at `gain` on the constant desired depths, the lost-feature ramp, ibvs.JointMapping) ->
    MujocoRobot, on the PhysicsClock, ended when every dot is within tolerance_px of its goal.

    compensate: predict the features over `latency` (+ the robot's velocity lag `lag`, s) with
    ibvs.loop.latency.FeaturePredictor on the arm's kinematics (the loop's latency compensation, as `ibvs servo`
    sets it up); False: the servo sees the delayed features. max_linear_speed, max_angular_speed: the servo's
    twist caps (m/s, rad/s). The result's arrays come from the loop's JSON-lines log (time: frame stamps;
    error: tracked - desired pixels).
    tolerance_px None: run for `duration` (the outcome is then "timeout" unless something else ended it).
    turn: radians, which way a half-turn about the optical axis goes (NodeParams.turn; NaN: the image noise's).
    """
    import json
    import os
    import tempfile

    from ...loop.latency import FeaturePredictor
    from ...loop.servo_loop import LoopOptions, ServoLoop
    from ...ros.node import NodeParams, ServoNodeCore
    from ...vision import DotTracker
    from .adapters import MujocoCamera, MujocoRobot, PhysicsClock
    from .world import World, testbed_camera

    camera = testbed_camera(320, 240) if camera is None else camera
    duration = case.duration if duration is None else float(duration)
    own = world is None
    world = World(case.robot, case.target, camera) if own else world
    tmp = tempfile.mkdtemp(prefix="ibvs-physics-")
    log = os.path.join(tmp, "loop.jsonl")
    try:
        arm = world.robot
        points = np.asarray(case.target.points, dtype=float)
        T_wo = np.asarray(case.target.pose, dtype=float)
        P = (T_wo[:3, :3] @ points.T).T + T_wo[:3, 3]

        def pixels_at(q):
            T = np.linalg.inv(arm.camera(q))
            Pc = (T[:3, :3] @ P.T).T + T[:3, 3]
            return camera.project(Pc[:, :2] / Pc[:, 2:]), Pc[:, 2]

        teach = DotTracker(len(P), (world.width, world.height))
        teach.reset(pixels_at(case.goal)[0])
        desired = teach.track(world.render(case.goal)).pixels  # teach by showing
        if not np.isfinite(desired).all():
            raise ValueError("the dots are not all seen at the goal")
        world.reset(case.start)
        world.monitor(True)
        clock = PhysicsClock(world)
        robot = MujocoRobot(world)
        source = MujocoCamera(world, rate=camera.fps, latency=latency)
        # the arm's kinematics as the predictor's model, as `ibvs servo` builds it (ibvs.loop.setup)
        predictor = FeaturePredictor(latency, lag, kinematics=arm) if compensate and latency > 0 else None
        params = NodeParams(desired_pixels=desired, depth=pixels_at(case.goal)[1], scheme=scheme, gain=gain,
                            max_linear_speed=max_linear_speed, max_angular_speed=max_angular_speed,
                            initial_pixels=pixels_at(case.start)[0], output="joint_velocities", eMc=arm.mount,
                            joint_names=list(arm.joint_names), max_joint_speed=arm.qdot_max, fps=camera.fps,
                            turn=turn)
        core = ServoNodeCore(params, clock=lambda: int(round(clock.now() * 1e9)),
                             jacobian=lambda q: arm.kinematics(q)[1], predictor=predictor)
        core.set_camera(camera)
        options = LoopOptions(duration=duration, converge_px=tolerance_px, log=log, signals=False,
                              latency=latency if predictor is not None else 0.0, lag=lag)
        inv_goal = np.linalg.inv(arm.camera(case.goal))
        poses = []

        def note(w):
            E = inv_goal @ arm.camera(w.q)
            poses.append(np.concatenate([E[:3, 3], theta_u(E[:3, :3])]))

        world.listeners.append(note)
        try:
            report = ServoLoop(source, robot, core, clock, options, predictor).run()
        finally:
            world.listeners.remove(note)
        with open(log) as f:
            frames = [r for r in map(json.loads, f) if r.get("kind") == "frame"]
        px = np.array([np.asarray(r["pixels"], dtype=float) for r in frames])
        error = (px - desired).reshape(len(px), -1)
        stats = world.monitor(False)
        T_err = np.linalg.inv(arm.camera(case.goal)) @ arm.camera(world.q)
        outcome = {"converged": "converged", "duration": "timeout"}.get(report.outcome, report.outcome)
        first = len(frames) - 1 if outcome == "converged" else -1
        n = arm.dof
        return PhysicsResult(outcome, first, np.array([r["stamp"] for r in frames]), error, np.zeros((0, n)),
                             np.zeros((0, n)), np.array([r["qdot"] for r in frames]), overshoot(error),
                             stats["tracking_rms"], stats["tracking_max"], stats["peak_torque"],
                             world.effort.copy(), float(np.linalg.norm(T_err[:3, 3])), np.array(poses))
    finally:
        if own:
            world.close()
        for f in os.listdir(tmp):
            os.remove(os.path.join(tmp, f))
        os.rmdir(tmp)
