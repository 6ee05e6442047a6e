"""URRobot (ur-rtde's speedJ): no UR controller or URSim runs here, so the command mapping and the error paths
are tested with injected stand-ins for RTDEControlInterface and RTDEReceiveInterface that record every call;
the connection error with the real ur-rtde against a closed port on 127.0.0.1."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from ibvs.robot import LimitError, RobotError, open_robot
from ibvs.robot.ur import URRobot, ur_limits

Q0 = np.array([0.1, -1.2, 1.3, -1.6, -1.5, 0.2])


class FakeReceive:
    def __init__(self):
        self.q, self.qd, self.t, self.connected, self.fail, self.calls = Q0.copy(), np.zeros(6), 100.0, True, False, []

    def isConnected(self):
        return self.connected

    def getTimestamp(self):
        if self.fail:
            raise RuntimeError("RTDE receive: socket closed\nmore")
        self.t += 0.002  # the controller's clock runs
        return self.t

    def getActualQ(self):
        return list(self.q)

    def getActualQd(self):
        return list(self.qd)

    def disconnect(self):
        self.calls.append("disconnect")


class FakeControl:
    def __init__(self):
        self.calls, self.accept, self.connected = [], True, True

    def isConnected(self):
        return self.connected

    def speedJ(self, qd, acceleration, t):
        assert isinstance(qd, list) and all(type(x) is float for x in qd)
        self.calls.append(("speedJ", qd, acceleration, t))
        return self.accept

    def speedStop(self, a):
        self.calls.append(("speedStop", a))
        return True

    def disconnect(self):
        self.calls.append("disconnect")


def fake_robot(**kw):
    control, receive = FakeControl(), FakeReceive()
    r = URRobot("ur.example", interfaces=lambda host: (control, receive), **kw)
    return r, control, receive


def test_speedj_mapping():
    r, control, receive = fake_robot(rate=125.0)
    assert r.n_joints == 6 and r.acceleration == pytest.approx(math.pi)
    with r:
        s = r.state()
        np.testing.assert_array_equal(s.q, Q0)
        cmd = r.send_joint_velocity([0.01, -0.02, 0.0, 0.02, 0.0, -0.01])
        assert control.calls[-1] == ("speedJ", [0.01, -0.02, 0.0, 0.02, 0.0, -0.01], math.pi, 0.0)
        assert not cmd.clamped
        receive.qd = cmd.dq.copy()
        big = r.send_joint_velocity([5.0, 0, 0, 0, 0, 0])  # beyond 90 deg/s: scaled, acceleration-bound too
        assert big.clamped and control.calls[-1][1][0] == pytest.approx(0.01 + math.pi / 125.0)
    assert control.calls[-2:] == [("speedStop", math.pi), "disconnect"] and receive.calls == ["disconnect"]


def test_refused_commands_never_reach_speedj_and_stop_the_arm():
    r, control, receive = fake_robot()
    r.connect()
    receive.q = np.r_[2 * math.pi - 0.0501, Q0[1:]]
    with pytest.raises(LimitError, match="joint 0"):
        r.send_joint_velocity([0.5, 0, 0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"dq\[3\]"):
        r.send_joint_velocity([0, 0, 0, np.inf, 0, 0])
    with pytest.raises(ValueError, match="dq must have shape"):
        r.send_joint_velocity(np.zeros(7))
    assert [c[0] for c in control.calls] == ["speedStop"] * 3


def test_controller_refusal_and_lost_link_raise_robot_error():
    r, control, receive = fake_robot()
    r.connect()
    control.accept = False
    with pytest.raises(RobotError, match="speedJ refused"):
        r.send_joint_velocity(np.zeros(6))
    assert control.calls[-1][0] == "speedStop"
    control.accept = True
    receive.fail = True
    with pytest.raises(RobotError, match="RuntimeError: RTDE receive: socket closed$"):
        r.state()
    r.stop()  # nothing can be sent on a lost link; never raises
    r.disconnect()
    assert not r.connected


def test_stale_timestamp_and_closed_connection_are_a_lost_link():
    r, control, receive = fake_robot(rate=100.0, stale_after=0.01)
    r.connect()
    r.state()
    receive.getTimestamp = lambda: 5.0  # frozen controller
    r.state()
    time.sleep(0.02)
    with pytest.raises(RobotError, match="no new state from the controller"):
        r.state()
    r2, control2, receive2 = fake_robot()
    r2.connect()
    receive2.connected = False
    with pytest.raises(RobotError, match="connection to the controller is closed"):
        r2.send_joint_velocity(np.zeros(6))


def test_closed_port_on_loopback_is_one_line_quickly():
    pytest.importorskip("rtde_control", reason='ur-rtde is not installed (pip install ".[ur]")')
    r = open_robot("ur", host="127.0.0.1", connect_timeout=5.0)
    with pytest.raises(RobotError) as e:
        r.connect()
    msg = str(e.value)
    assert "\n" not in msg and "cannot connect" in msg and "127.0.0.1" in msg, msg
    assert not r.connected


def test_a_host_that_never_answers_times_out():
    def hang(host):
        time.sleep(10)

    r = URRobot("10.0.0.1", interfaces=hang, connect_timeout=0.05)
    with pytest.raises(RobotError, match="no answer within 0.05 s"):
        r.connect()


def test_ur_limits_and_arguments():
    lim = ur_limits("ur10e", speed_factor=1.0)
    assert lim.dq_max[0] == pytest.approx(math.radians(120)) and lim.q_max[0] == pytest.approx(2 * math.pi - 0.05)
    for kw in ({"model": "ur5"}, {"speed_factor": 0}, {"margin": 4.0}, {"acceleration": -1.0}):
        with pytest.raises(ValueError):
            ur_limits(**kw)
    for kw, name in [({"host": ""}, "host"), ({"acceleration": 0.0}, "acceleration"),
                     ({"stale_after": float("nan")}, "stale_after"), ({"connect_timeout": 0}, "connect_timeout"),
                     ({"limits": ur_limits().__class__([0], [1], [1], [1])}, "limits must be for 6")]:
        with pytest.raises(ValueError, match=name):
            URRobot(**kw)
