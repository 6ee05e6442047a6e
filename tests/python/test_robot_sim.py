"""SimRobot: the kinematic simulator's robots behind the Robot protocol, on a SimClock. Sent the joint
velocities (or the free camera's twists) an ibvs.sim episode applied, frame by frame, it goes through the
same joints and camera poses as the episode (the simulator's own C++ integration: an independent path);
it integrates exactly over irregular time steps, stops by itself after `hold`, and refuses by name."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs
from ibvs import sim
from ibvs.robot import LimitError, Limits, open_robot
from ibvs.robot.sim import SimClock, SimRobot, _rotation_vector


def replay(robot, velocities, dt):
    """Send each velocity for one period dt; the states after each."""
    out = []
    for k, v in enumerate(velocities):
        cmd = robot.send_joint_velocity(v)
        assert not cmd.clamped, cmd.reason
        robot.clock.sleep_until((k + 1) * dt)
        out.append((robot.state(), robot.camera_pose()))
    return out


def test_gantry_follows_the_simulators_episode():
    case = sim.cases.gantry_general_motion()
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), case.camera, case.target, case.start, case.goal,
                robot=case.robot, duration=2.0)
    h = r.history
    dt = h.time[1] - h.time[0]
    robot = SimRobot(case.robot, q0=h.q[0], rate=1 / dt)
    assert robot.limits.dq_max.tolist() == case.robot.qdot_max.tolist()
    with robot:
        states = replay(robot, h.qdot[:-1], dt)
    q = np.array([s.q for s, _ in states])
    np.testing.assert_allclose(q, h.q[1:], atol=1e-12)
    np.testing.assert_allclose(np.array([T for _, T in states]), h.pose[1:], atol=1e-10)
    assert states[-1][0].stamp == pytest.approx((len(h.q) - 1) * dt)


def test_panda_follows_the_simulators_episode():
    pytest.importorskip("pinocchio", reason='the robots extra is not installed (pip install ".[robots]")')
    case = sim.cases.arm_general_motion("panda")
    r = sim.run(ibvs.Servo(ibvs.Layout.stacked(4), gain=1.0), case.camera, case.target, case.start, case.goal,
                robot=case.robot, duration=1.0, depth="pose")
    h = r.history
    dt = h.time[1] - h.time[0]
    robot = open_robot("sim", robot=case.robot, q0=h.q[0], rate=1 / dt)
    with robot:
        states = replay(robot, h.qdot[:-1], dt)
    np.testing.assert_allclose(np.array([s.q for s, _ in states]), h.q[1:], atol=1e-12)
    np.testing.assert_allclose(np.array([T for _, T in states]), h.pose[1:], atol=1e-10)


def test_free_camera_follows_the_simulators_episode():
    case = sim.cases.z_rotation()
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), case.camera, case.target, case.start, case.goal,
                duration=2.0)
    h = r.history
    dt = h.time[1] - h.time[0]
    lim = Limits(np.full(6, -np.inf), np.full(6, np.inf), np.full(6, 5.0), np.full(6, 1e3))
    robot = SimRobot(pose=h.pose[0], limits=lim, rate=1 / dt)
    with robot:
        states = replay(robot, h.twist[:-1], dt)
    np.testing.assert_allclose(np.array([T for _, T in states]), h.pose[1:], atol=1e-10)
    T = states[-1][1]
    np.testing.assert_allclose(states[-1][0].q[:3], T[:3, 3])
    np.testing.assert_allclose(robot.kinematics.camera(states[-1][0].q), T, atol=1e-12)


def test_exact_over_irregular_steps_and_stops_after_hold():
    g = sim.Gantry.afma6()
    q0 = (g.q_min + g.q_max) / 2
    robot = SimRobot(g, q0=q0, rate=10.0, hold=0.5)
    robot.connect()
    dq = np.array([0.01, -0.02, 0.0, 0.05, 0.0, -0.03])
    robot.send_joint_velocity(dq)
    for t in (0.013, 0.1, 0.37, 0.37, 0.49):
        robot.clock.sleep_until(t)
        s = robot.state()
        np.testing.assert_allclose(s.q, q0 + dq * t, atol=1e-15)
        np.testing.assert_array_equal(s.dq, dq)
        assert s.stamp == t
    robot.clock.sleep_until(2.0)  # no command for longer than hold: stopped at 0.5 s
    s = robot.state()
    np.testing.assert_allclose(s.q, q0 + dq * 0.5, atol=1e-15)
    assert not s.dq.any()
    robot.send_joint_velocity(dq)
    robot.stop()
    robot.clock.sleep_until(3.0)
    np.testing.assert_allclose(robot.state().q, q0 + dq * 0.5, atol=1e-15)
    robot.disconnect()


def test_sim_limits_refuse_and_dry_run():
    g = sim.Gantry.afma6()
    q0 = g.q_max - 1e-4
    robot = SimRobot(g, q0=q0, rate=10.0)
    robot.connect()
    with pytest.raises(LimitError, match="joint 0"):
        robot.send_joint_velocity([0.01, 0, 0, 0, 0, 0])
    robot.clock.sleep_until(1.0)
    np.testing.assert_array_equal(robot.state().q, q0)  # nothing was sent
    dry = SimRobot(g, q0=(g.q_min + g.q_max) / 2, rate=10.0, dry_run=True)
    dry.connect()
    cmd = dry.send_joint_velocity([0.1, 0, 0, 0, 0, 0])
    dry.clock.sleep_until(1.0)
    assert cmd.dq[0] == 0.1 and not dry.state().dq.any()


@pytest.mark.parametrize("kw, match", [
    ({"robot": "afma6"}, "robot must be an ibvs.sim.Robot"),
    ({"robot": sim.Gantry.afma6()}, "q0"),
    ({"robot": sim.Gantry.afma6(), "q0": np.zeros(5)}, "q0 must have shape"),
    ({"pose": np.eye(3)}, "pose"),
    ({"q0": np.zeros(6)}, "q0 is for an arm"),
    ({"robot": sim.Gantry.afma6(), "q0": np.zeros(6), "pose": np.eye(4)}, "pose is for the free camera"),
    ({"hold": 0.001}, "hold"),
    ({"limits": Limits([0], [1], [1], [1])}, "limits must be for 6 joints"),
])
def test_sim_robot_refuses_bad_arguments(kw, match):
    with pytest.raises((ValueError, TypeError), match=match):
        SimRobot(**kw)


def test_sim_clock_and_rotation_vector():
    c = SimClock(1.0)
    c.sleep_until(0.5)
    assert c.now() == 1.0
    c.sleep_until(2.5)
    assert c.now() == 2.5
    with pytest.raises(ValueError):
        c.sleep_until(float("nan"))
    rng = np.random.default_rng(3)
    for angle in (0.0, 1e-8, 0.3, 2.0, np.pi - 1e-9, np.pi):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        w = axis * angle
        R = ibvs.se3_exp(np.r_[0, 0, 0, w])[:3, :3]
        back = _rotation_vector(R)
        np.testing.assert_allclose(ibvs.se3_exp(np.r_[0, 0, 0, back])[:3, :3], R, atol=1e-9)
        assert np.linalg.norm(back) <= np.pi + 1e-12
