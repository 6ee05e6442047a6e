"""Ros2ControlRobot: the commands published are std_msgs/Float64MultiArray in the controller's joint order,
checked by the limits first; joint states come from sensor_msgs/JointState messages in any order; a missing
or stale joint state and a failing publisher are RobotErrors; stop publishes zeros. Built and read with
rosbags' message classes (no live ros2_control graph here)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rosbags", reason='the ros extra is not installed (pip install ".[ros]")')

from ibvs import ros  # noqa: E402
from ibvs.loop import SimClock  # noqa: E402
from ibvs.robot import LimitError, Limits, RobotError, open_robot  # noqa: E402
from ibvs.robot.ros2_control import Ros2ControlRobot, ros2_control_robot  # noqa: E402

TS = ros.types.typestore()
NAMES = ["shoulder", "elbow", "wrist"]
LIMITS = Limits([-1, -1, -1], [1, 1, 1], [0.5, 0.5, 0.5], [5.0, 5.0, 5.0])


def joint_state(names, q, dq=()):
    return TS.types["sensor_msgs/msg/JointState"](
        header=ros.types.header(TS, 0, ""), name=list(names), position=np.array(q, float),
        velocity=np.array(dq, float), effort=np.zeros(0))


def make(**kw):
    sent, clock = [], SimClock()
    r = open_robot("ros2_control", joint_names=NAMES, publish=sent.append, limits=LIMITS, rate=10.0, clock=clock, **kw)
    return r, sent, clock


def test_commands_are_float64_arrays_in_the_controllers_order():
    r, sent, clock = make()
    r.connect()
    with pytest.raises(RobotError, match="no joint state received yet"):
        r.state()
    r.feed(joint_state(["wrist", "gripper", "shoulder", "elbow"], [0.3, 0.01, 0.1, 0.2], [0.0, 0.0, 0.0, 0.0]))
    s = r.state()
    np.testing.assert_array_equal(s.q, [0.1, 0.2, 0.3])
    cmd = r.send_joint_velocity([0.1, -0.2, 0.3])
    msg = sent[-1]
    assert type(msg).__name__ == "std_msgs__msg__Float64MultiArray"
    np.testing.assert_array_equal(ros.array_of(msg), cmd.dq)
    assert msg.layout.dim[0].size == 3
    big = r.send_joint_velocity([3.0, 0.0, 0.0])
    assert big.clamped and ros.array_of(sent[-1])[0] == pytest.approx(0.5)
    r.disconnect()
    np.testing.assert_array_equal(ros.array_of(sent[-1]), np.zeros(3))  # stopped


def test_refused_never_published_and_stopped():
    r, sent, clock = make()
    r.connect()
    r.feed(joint_state(NAMES, [0.99, 0.0, 0.0]))
    with pytest.raises(LimitError, match="joint 0"):
        r.send_joint_velocity([0.5, 0.0, 0.0])
    assert len(sent) == 1 and not ros.array_of(sent[0]).any()  # only the stop's zeros


def test_stale_states_bad_messages_and_a_failing_publisher():
    r, sent, clock = make()
    r.connect()
    r.feed(joint_state(NAMES, [0.0, 0.0, 0.0], [0.1, 0.0, 0.0]))
    assert r.state().dq[0] == 0.1
    clock.sleep_until(0.31)  # 3 periods of 0.1 s and more
    with pytest.raises(RobotError, match="joint states are lost"):
        r.state()
    with pytest.raises(ValueError, match="joint 'elbow' is not in the message"):
        r.feed(joint_state(["shoulder", "wrist"], [0.0, 0.0]))
    with pytest.raises(ValueError, match="joint_states.velocity"):
        r.feed(joint_state(NAMES, [0.0, 0.0, 0.0], [0.0, np.nan, 0.0]))

    def broken(msg):
        raise OSError("publisher destroyed")

    r2 = Ros2ControlRobot(NAMES, broken, LIMITS, rate=10.0, clock=clock)
    r2.connect()
    r2.feed(joint_state(NAMES, [0.0, 0.0, 0.0]))
    with pytest.raises(RobotError, match="publisher destroyed"):
        r2.send_joint_velocity([0.1, 0.0, 0.0])
    r2.disconnect()  # never raises, though the stop cannot be published
    assert isinstance(r2.last_error, RobotError)


@pytest.mark.parametrize("kw, match", [
    ({"joint_names": []}, "joint_names"), ({"joint_names": ["a", "a", "b"]}, "joint_names"),
    ({"joint_names": "abc"}, "joint_names"), ({"publish": 3}, "publish"),
    ({"limits": Limits([0], [1], [1], [1])}, "limits"), ({"stale_after": 0.0}, "stale_after"),
])
def test_bad_arguments(kw, match):
    args = dict(joint_names=NAMES, publish=print, limits=LIMITS)
    args.update(kw)
    with pytest.raises((ValueError, TypeError), match=match):
        Ros2ControlRobot(**args)


def test_rclpy_wiring_names_what_is_missing():
    with pytest.raises(ImportError, match="ROS 2"):
        ros2_control_robot(object(), NAMES, LIMITS)
