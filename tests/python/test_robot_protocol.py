"""ibvs.robot's protocol: Limits validation, the one limit check (check_command: scaled with the direction
kept, ramped on a reversal, refused at the position limits and the workspace box, bad input refused by name)
and the Robot base's safety paths (a refused or failed command stops the robot, stop/disconnect never raise,
dry run sends nothing), on a recording in-test robot."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs.robot as rb
from ibvs.robot import Command, JointState, LimitError, Limits, RobotError, check_command


def limits3(**kw):
    args = dict(q_min=[-1.0, -1.0, -1.0], q_max=[1.0, 1.0, 1.0], dq_max=[0.5, 0.5, 1.0], ddq_max=[10.0, 10.0, 10.0])
    args.update(kw)
    return Limits(**args)


def at(q, dq=(0.0, 0.0, 0.0)):
    return JointState(q=np.asarray(q, float), dq=np.asarray(dq, float), stamp=0.0)


# --- Limits and JointState ------------------------------------------------------------------------------
@pytest.mark.parametrize("kw, name", [
    (dict(q_min=[0.0, 0.0]), "q_max"),
    (dict(q_max=[1.0, -2.0, 1.0]), "q_min[1]"),
    (dict(dq_max=[0.5, 0.0, 1.0]), "dq_max[1]"),
    (dict(dq_max=[0.5, np.inf, 1.0]), "dq_max[1]"),
    (dict(ddq_max=[1.0, 1.0, np.nan]), "ddq_max[2]"),
    (dict(q_min=[np.nan, 0, 0]), "q_min[0]"),
    (dict(workspace=([0, 0, 0], [1, 1])), "workspace hi"),
    (dict(workspace=([0, 0, 0], [1, -1, 1])), "workspace"),
    (dict(workspace=[0, 0, 0]), "workspace"),
])
def test_limits_refuse_bad_values_by_name(kw, name):
    with pytest.raises(ValueError, match=name.replace("[", r"\[").replace("]", r"\]")):
        limits3(**kw)


def test_limits_are_read_only_arrays_and_allow_unlimited_positions():
    lim = limits3(q_min=[-np.inf, -1, -1], q_max=[np.inf, 1, 1], workspace=([0, 0, 0], [1, 1, 1]))
    assert lim.n == 3 and not lim.q_min.flags.writeable and lim.workspace[1].tolist() == [1, 1, 1]
    with pytest.raises(ValueError):
        lim.dq_max[0] = 2.0
    assert "dq_max" in repr(lim)


def test_joint_state_validates():
    s = JointState(q=[0.1, 0.2], dq=[0, 0], stamp=3)
    assert s.stamp == 3.0 and s.q.dtype == np.float64
    with pytest.raises(ValueError, match="dq"):
        JointState(q=[0.1, 0.2], dq=[0], stamp=0.0)
    with pytest.raises(ValueError, match="stamp"):
        JointState(q=[0.1], dq=[0], stamp=float("nan"))


# --- check_command --------------------------------------------------------------------------------------
def test_within_limits_is_sent_unchanged():
    cmd = check_command([0.1, -0.2, 0.3], at([0, 0, 0], [0.1, -0.2, 0.3]), limits3(), 0.01)
    assert isinstance(cmd, Command) and not cmd.clamped and cmd.reason == ""
    np.testing.assert_array_equal(cmd.dq, [0.1, -0.2, 0.3])


def test_speed_scaled_uniformly_direction_kept():
    dq = np.array([1.0, -0.25, 0.5])  # joint 0 is twice its 0.5 limit
    cmd = check_command(dq, at([0, 0, 0], dq), limits3(), 0.01, last_dq=dq / 2)
    np.testing.assert_allclose(cmd.dq, dq / 2, rtol=0, atol=1e-15)
    assert cmd.clamped and "joint 0 speed" in cmd.reason and "dq_max" in cmd.reason
    np.testing.assert_array_equal(cmd.requested, dq)


def test_acceleration_scaled_uniformly_from_the_last_command():
    lim = limits3(ddq_max=[1.0, 1.0, 1.0])
    dq = np.array([0.4, 0.2, 0.0])
    cmd = check_command(dq, at([0, 0, 0]), lim, 0.1, last_dq=np.zeros(3))  # 0.1 rad/s per period at most
    np.testing.assert_allclose(cmd.dq, dq / 4, atol=1e-15)
    assert cmd.clamped and "acceleration" in cmd.reason
    assert np.all(np.abs(cmd.dq - 0) <= 0.1 + 1e-12)


def test_reversal_is_ramped_within_the_acceleration_limit():
    lim = limits3(ddq_max=[1.0, 1.0, 1.0])
    last = np.array([0.3, 0.0, 0.0])
    cmd = check_command([-0.3, 0.0, 0.0], at([0, 0, 0]), lim, 0.1, last_dq=last)
    np.testing.assert_allclose(cmd.dq, [0.2, 0.0, 0.0], atol=1e-12)  # decelerating by ddq_max dt
    assert cmd.clamped and "ramped" in cmd.reason


def test_measured_velocity_is_the_reference_without_a_last_command():
    lim = limits3(ddq_max=[1.0, 1.0, 1.0])
    cmd = check_command([0.45, 0, 0], at([0, 0, 0], [0.4, 0, 0]), lim, 0.1)
    np.testing.assert_allclose(cmd.dq, [0.45, 0, 0])
    cmd = check_command([0.45, 0, 0], at([0, 0, 0], [0.0, 0, 0]), lim, 0.1)
    np.testing.assert_allclose(cmd.dq, [0.1, 0, 0])


def test_position_limit_refused_within_the_next_period_but_moving_back_in_allowed():
    with pytest.raises(LimitError, match="joint 1 .* would pass its limits"):
        check_command([0.0, 0.2, 0.0], at([0, 0.999, 0], [0, 0.2, 0]), limits3(), 0.01)
    assert not check_command([0.0, 0.2, 0.0], at([0, 0.99, 0], [0, 0.2, 0]), limits3(), 0.01).clamped
    cmd = check_command([0.0, -0.2, 0.0], at([0, 1.5, 0], [0, -0.2, 0]), limits3(), 0.01)
    assert cmd.dq[1] < 0  # outside, back towards the range: allowed
    with pytest.raises(LimitError, match="joint 2"):
        check_command([0.0, 0.0, -0.1], at([0, 0, -1.2], [0, 0, -0.1]), limits3(), 0.01)


class Prismatic:
    """Three prismatic joints along x, y, z carrying the camera: its position is q."""

    def kinematics(self, q):
        T = np.eye(4)
        T[:3, 3] = q
        return T, np.vstack([np.eye(3), np.zeros((3, 3))])


def test_workspace_box_refused_with_a_kinematics_model():
    lim = limits3(workspace=([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]))
    with pytest.raises(LimitError, match="workspace"):
        check_command([0.4, 0, 0], at([0.498, 0, 0], [0.4, 0, 0]), lim, 0.01, kinematics=Prismatic())
    assert not check_command([0.4, 0, 0], at([0.4, 0, 0], [0.4, 0, 0]), lim, 0.01, kinematics=Prismatic()).clamped
    check_command([-0.4, 0, 0], at([0.7, 0, 0], [-0.4, 0, 0]), lim, 0.01, kinematics=Prismatic())  # coming back
    # without a model the box cannot be checked: the joint limits still apply
    check_command([0.4, 0, 0], at([0.498, 0, 0], [0.4, 0, 0]), lim, 0.01)


@pytest.mark.parametrize("dq, name", [
    ([0.1, np.nan, 0.0], r"dq\[1\] is nan"), ([0.1, 0.0, np.inf], r"dq\[2\] is inf"), ([0.1, 0.2], "dq must have shape"),
    ([[0.1, 0.2, 0.3]], "dq must have shape"), ("abc", "dq must be an array"), (None, "dq must be an array"),
])
def test_bad_commands_refused_by_name(dq, name):
    with pytest.raises((ValueError, TypeError), match=name):
        check_command(dq, at([0, 0, 0]), limits3(), 0.01)


def test_bad_state_period_and_last_refused_by_name():
    with pytest.raises(ValueError, match="dt"):
        check_command([0, 0, 0], at([0, 0, 0]), limits3(), 0.0)
    with pytest.raises(ValueError, match="last_dq"):
        check_command([0, 0, 0], at([0, 0, 0]), limits3(), 0.01, last_dq=[0, 0])
    with pytest.raises(ValueError, match="state.q"):
        check_command([0, 0, 0], JointState(q=[0, 0], dq=[0, 0], stamp=0), limits3(), 0.01)
    with pytest.raises(TypeError, match="limits"):
        check_command([0, 0, 0], at([0, 0, 0]), {"dq_max": 1}, 0.01)


# --- the Robot base: safety on every path ---------------------------------------------------------------
class Recording(rb.Robot):
    """An in-test robot recording what reaches it; fail_send / fail_halt / fail_state inject faults."""

    def __init__(self, **kw):
        super().__init__("recording", limits3(), rate=100.0, **kw)
        self.q = np.zeros(3)
        self.sent, self.halts, self.closed = [], 0, 0
        self.fail_send = self.fail_halt = self.fail_state = False

    def _connect(self):
        pass

    def _read_state(self):
        if self.fail_state:
            raise RobotError("link lost")
        return JointState(self.q, np.zeros(3), 0.0)

    def _send(self, dq):
        if self.fail_send:
            raise RobotError("send failed")
        self.sent.append(dq)

    def _halt(self):
        self.halts += 1
        if self.fail_halt:
            raise RobotError("halt failed")

    def _close(self):
        self.closed += 1
        raise OSError("already closed")


def test_robot_requires_connect_and_sends_checked_commands():
    r = Recording()
    with pytest.raises(RobotError, match="not connected"):
        r.state()
    with r:
        cmd = r.send_joint_velocity([0.01, 0.0, 0.0])
        np.testing.assert_array_equal(r.sent[-1], cmd.dq)
        assert r.last_command is cmd and repr(r).startswith("Recording('recording', 3 joints")
        big = r.send_joint_velocity([5.0, 0.0, 0.0])  # velocity and acceleration (10 rad/s² x 0.01 s) bound
        assert big.clamped and abs(r.sent[-1][0] - (0.01 + 0.1)) < 1e-12
    assert r.halts == 1 and r.closed == 1 and not r.connected and isinstance(r.last_error, OSError)


@pytest.mark.parametrize("fault", ["limit", "nan", "send", "state"])
def test_refused_or_failed_command_sends_nothing_and_stops(fault):
    r = Recording()
    r.connect()
    r.q = np.array([0.0, 0.0, 0.9999]) if fault == "limit" else r.q
    r.fail_send, r.fail_state = fault == "send", fault == "state"
    dq = [0.0, 0.0, np.nan] if fault == "nan" else [0.0, 0.0, 0.05]
    error = {"limit": LimitError, "nan": ValueError, "send": RobotError, "state": RobotError}[fault]
    with pytest.raises(error):
        r.send_joint_velocity(dq)
    assert r.sent == [] and r.halts == 1 and r.last_command is None


def test_stop_and_disconnect_never_raise_and_are_idempotent():
    r = Recording()
    r.stop()
    r.disconnect()  # never connected: nothing to do
    assert r.halts == 0
    r.connect()
    r.fail_halt = True
    r.stop()
    r.stop()
    assert r.halts == 2 and isinstance(r.last_error, RobotError)
    r.disconnect()
    r.disconnect()
    assert r.halts == 3 and r.closed == 1


def test_dry_run_checks_but_sends_nothing():
    r = Recording(dry_run=True)
    r.connect()
    cmd = r.send_joint_velocity([5.0, 0.0, 0.0])
    assert cmd.clamped and r.sent == []
    with pytest.raises(ValueError):
        r.send_joint_velocity([np.inf, 0, 0])


def test_open_robot_names_the_kinds():
    with pytest.raises(ValueError, match="robot kind must be one of .*franky"):
        rb.open_robot("kuka")
    assert set(rb.ROBOTS) >= {"sim", "franky", "ur", "ros2_control", "mujoco"}
    with pytest.raises(ValueError, match="robot kind 'ur': unknown option.s. q0 .its options: host, model"):
        rb.open_robot("ur", q0=[0.0] * 6)
