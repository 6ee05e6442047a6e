"""The servo node's logic (ServoNodeCore) with rosbags' message classes and a fake clock: the twist of
the tracked pixels, the lost-feature ramp and stop, malformed messages, joint velocity outputs; the rclpy
wrapper imports without ROS and says so; the launch file compiles and names the console script."""

from __future__ import annotations

import ast
import py_compile
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import ibvs
from ibvs import sim

pytest.importorskip("rosbags", reason='the ros extra is not installed (pip install ".[ros]")')
pytest.importorskip("cv2", reason='the vision extra is not installed (pip install ".[vision]")')
from ibvs import ros, vision  # noqa: E402
from ibvs.ros.node import NodeParams, ServoNodeCore  # noqa: E402

TS = ros.types.typestore()
ROOT = Path(__file__).resolve().parents[2]


class Clock:
    """A fake ROS clock: integer nanoseconds, moved by hand."""

    def __init__(self):
        self.ns = 10**9

    def __call__(self) -> int:
        return self.ns

    def advance(self, seconds: float) -> None:
        self.ns += round(seconds * 1e9)


@pytest.fixture(scope="module")
def scene():
    case = sim.cases.general_motion()
    camera = vision.image_camera(case.camera)
    renderer = vision.Renderer(camera, case.target, "dots")
    goal_px = camera.project(_normalised(case.target, case.goal))
    start_px = camera.project(_normalised(case.target, case.start))
    return dict(camera=camera, renderer=renderer, goal_px=goal_px, start_px=start_px, case=case,
                start_image=renderer.render(case.start), goal_depth=0.5 * np.ones(4))


def _normalised(target, T_wc):
    P = target.world_points() @ np.linalg.inv(T_wc)[:3, :3].T + np.linalg.inv(T_wc)[:3, 3]
    return P[:, :2] / P[:, 2:]


def _core(scene, clock, jacobian=None, **kw):
    params = NodeParams(desired_pixels=scene["goal_px"], depth=0.5, initial_pixels=scene["start_px"], gain=0.8,
                        max_linear_speed=0.5, max_angular_speed=1.0, **kw)
    return ServoNodeCore(params, clock, jacobian=jacobian)


def test_twist_is_the_servo_of_the_tracked_pixels(scene):
    clock = Clock()
    core = _core(scene, clock)
    assert core.on_image(ros.image_msg(scene["start_image"], TS)) is None  # no camera_info yet
    core.on_camera_info(ros.camera_info(scene["camera"], TS))
    msg = core.on_image(ros.image_msg(scene["start_image"], TS, "camera_optical_frame", clock()))
    assert msg.__msgtype__ == "geometry_msgs/msg/TwistStamped" and msg.header.frame_id == "camera_optical_frame"
    assert ros.types.stamp_ns(msg) == clock.ns and core.state == "servoing"
    # by hand: the same tracker and servo
    cam = scene["camera"]
    tracker = vision.DotTracker(4, scene["renderer"].size)
    tracker.reset(scene["start_px"])
    px = tracker.track(scene["start_image"]).pixels
    servo = ibvs.Servo(ibvs.Layout.polar(4), gain=0.8, max_linear_speed=0.5, max_angular_speed=1.0)
    expected = servo.update(cam.normalize(px), 0.5, cam.normalize(scene["goal_px"]), 0.5).velocity
    np.testing.assert_array_equal(ros.twist_of(msg), expected)
    assert np.abs(expected).max() > 0.01


def test_lost_features_ramp_the_last_twist_down_then_stop(scene):
    clock = Clock()
    core = _core(scene, clock, lost_timeout=0.2)
    core.on_camera_info(ros.camera_info(scene["camera"], TS))
    good = ros.twist_of(core.on_image(ros.image_msg(scene["start_image"], TS)))
    dark = np.full_like(scene["start_image"], 10)
    clock.advance(0.05)
    out = ros.twist_of(core.on_image(ros.image_msg(dark, TS)))  # every dot lost: ramp from the last twist
    np.testing.assert_allclose(out, 0.75 * good, rtol=1e-12)
    assert core.state == "ramping" and core.last_error == "features lost"
    clock.advance(0.1)
    np.testing.assert_allclose(ros.twist_of(core.tick()), 0.25 * good, rtol=1e-12)  # no image at all: the watchdog
    clock.advance(0.06)
    assert not ros.twist_of(core.tick()).any() and core.state == "stopped"
    clock.advance(5.0)
    assert not ros.twist_of(core.on_image(ros.image_msg(dark, TS))).any()
    # a dot tracker that lost its dots does not find them again by itself; reset() starts over
    assert not ros.twist_of(core.on_image(ros.image_msg(scene["start_image"], TS))).any()
    core.reset()
    np.testing.assert_array_equal(ros.twist_of(core.on_image(ros.image_msg(scene["start_image"], TS))), good)


def test_tag_node_resumes_when_the_tag_is_seen_again(scene):
    case = scene["case"]
    renderer = vision.Renderer(scene["camera"], case.target, "tag")
    clock = Clock()
    core = ServoNodeCore(NodeParams(desired_pixels=scene["goal_px"], depth=0.5, tracker="tag"), clock)
    core.on_camera_info(ros.camera_info(scene["camera"], TS))
    image = renderer.render(case.start)
    first = ros.twist_of(core.on_image(ros.image_msg(image, TS)))
    clock.advance(1.0)
    assert not ros.twist_of(core.on_image(ros.image_msg(np.zeros_like(image), TS))).any()
    assert core.state == "stopped"
    np.testing.assert_array_equal(ros.twist_of(core.on_image(ros.image_msg(image, TS))), first)
    assert core.state == "servoing"


def test_malformed_messages_never_raise_and_name_the_field(scene):
    clock = Clock()
    core = _core(scene, clock)
    info = ros.camera_info(scene["camera"], TS)
    info.k[4] = np.nan
    core.on_camera_info(info)
    assert core.camera is None and "camera_info.k must be finite" in core.last_error and core.bad_messages == 1
    core.on_camera_info(ros.camera_info(scene["camera"], TS))
    good = ros.twist_of(core.on_image(ros.image_msg(scene["start_image"], TS)))
    bad = ros.image_msg(scene["start_image"], TS)
    bad.encoding = "yuv422"
    clock.advance(0.1)
    out = core.on_image(bad)
    assert "image.encoding: 'yuv422'" in core.last_error and core.bad_messages == 2
    np.testing.assert_allclose(ros.twist_of(out), 0.5 * good, rtol=1e-12)  # treated as a lost frame: the ramp
    short = ros.image_msg(scene["start_image"], TS)
    short.step = 100
    core.on_image(short)
    assert "image.step: 100 bytes is shorter than a row" in core.last_error
    small = ros.image_msg(scene["start_image"][:100], TS)
    core.on_image(small)
    assert "image: 640 x 100 pixels, the camera_info says 640 x 480" in core.last_error
    core.on_joint_state(TS.types["std_msgs/msg/String"](data="q"))
    assert "joint_states.name: the message has no field 'name'" in core.last_error and core.bad_messages == 5


def test_joint_velocity_outputs(scene):
    eMc = sim.pose(t=(0.0, 0.0, 0.1))
    J = np.diag([1.0, 2.0, 1.0, 1.0, 0.5, 1.0])
    names = [f"j{i}" for i in range(6)]
    clock = Clock()
    for output, msgtype in (("joint_velocities", "std_msgs/msg/Float64MultiArray"),
                            ("joint_trajectory", "trajectory_msgs/msg/JointTrajectory")):
        core = _core(scene, clock, output=output, eMc=eMc, joint_names=names, jacobian=lambda q: J)
        core.on_camera_info(ros.camera_info(scene["camera"], TS))
        twist_core = _core(scene, clock)
        twist_core.on_camera_info(ros.camera_info(scene["camera"], TS))
        twist = ros.twist_of(twist_core.on_image(ros.image_msg(scene["start_image"], TS)))
        out = core.on_image(ros.image_msg(scene["start_image"], TS))
        assert out.__msgtype__ == msgtype
        got = ros.array_of(out) if output == "joint_velocities" else np.array(out.points[0].velocities)
        assert not got.any()  # no joint state yet: zero velocities
        js = TS.types["sensor_msgs/msg/JointState"](header=ros.types.header(TS, 0, ""), name=names[::-1],
                                                     position=np.zeros(6), velocity=np.zeros(0), effort=np.zeros(0))
        core.on_joint_state(js)
        core.reset()
        out = core.on_image(ros.image_msg(scene["start_image"], TS))
        got = ros.array_of(out) if output == "joint_velocities" else np.array(out.points[0].velocities)
        np.testing.assert_array_equal(got, ibvs.JointMapping(6, eMc).update(twist, J).qdot)


def test_twist_at_the_mount_frame(scene):
    clock = Clock()
    eMc = sim.pose(t=(0.0, 0.0, 0.1))
    core = _core(scene, clock, twist_frame="mount", eMc=eMc, mount_frame="tool0")
    core.last_twist, core.last_good_ns = np.array([0.0, 0, 0, 1.0, 0, 0]), clock.ns
    msg = core.tick()
    assert msg.header.frame_id == "tool0"
    # a camera turning about its x axis moves the mount 0.1 m behind it at 0.1 m/s along y
    np.testing.assert_allclose(ros.twist_of(msg), [0.0, 0.1, 0.0, 1.0, 0.0, 0.0], atol=1e-15)


@pytest.mark.parametrize("change, message", [
    (dict(desired_pixels=[[1.0, 2.0]]), "desired_pixels must be N >= 3 finite pixels"),
    (dict(depth=[0.5, -1.0, 0.5, 0.5]), "depth must be one or 4 finite depths > 0"),
    (dict(tracker="blob"), "tracker must be 'dots' or 'tag'"),
    (dict(output="effort"), "output must be one of"),
    (dict(gain=0.0), "gain must be a number > 0"),
    (dict(lost_timeout=-1.0), "lost_timeout must be a number > 0"),
    (dict(output="joint_velocities"), "eMc: output 'joint_velocities'"),
    (dict(output="joint_velocities", eMc=np.eye(4)), "joint_names: output 'joint_velocities' needs"),
    (dict(output="joint_velocities", eMc=np.eye(4), joint_names=["a"] * 6), "jacobian: output"),
    (dict(scheme="magic"), "scheme must be one of"),
])
def test_bad_parameters_are_refused_by_name(scene, change, message):
    params = dict(desired_pixels=scene["goal_px"], depth=0.5)
    params.update(change)
    with pytest.raises(ValueError, match=message):
        ServoNodeCore(NodeParams(**params), Clock())


def test_rclpy_wrapper_imports_without_ros_and_says_so():
    code = "import sys; import ibvs.ros.ros2_node as n; assert 'rclpy' not in sys.modules; sys.exit(n.main([]))"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env={"PYTHONPATH": str(Path(ibvs.__file__).resolve().parents[1]), "PATH": "/usr/bin:/bin"})
    if "rclpy" in sys.modules or _has("rclpy"):
        pytest.skip("rclpy is installed here: the wrapper would start a node")
    assert run.returncode == 2 and "needs ROS 2 (rclpy)" in run.stderr, run.stderr


def _has(name: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(name) is not None


def test_launch_file_compiles_and_names_the_console_script(tmp_path):
    launch = Path(ros.__file__).parent / "launch" / "servo.launch.py"
    py_compile.compile(str(launch), cfile=str(tmp_path / "launch.pyc"), doraise=True)
    tree = ast.parse(launch.read_text())
    assert any(isinstance(n, ast.FunctionDef) and n.name == "generate_launch_description" for n in ast.walk(tree))
    text = launch.read_text()
    assert 'executable="ibvs-ros2-servo"' in text
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert 'ibvs-ros2-servo = "ibvs.ros.ros2_node:main"' in pyproject
    # every parameter the launch file sets is one the node declares
    import dataclasses

    declared = {f.name for f in dataclasses.fields(NodeParams)}
    for name in ("desired_pixels", "depth", "scheme", "gain", "tracker", "output", "twist_frame", "lost_timeout"):
        assert f'"{name}":' in text and name in declared


def test_turn_chooses_the_half_turns_way_and_is_checked(monkeypatch):
    """NodeParams.turn: Servo.continue_turn at the start and at every reset (the half-turn's way, not the noise's);
    NaN by default (nothing chosen); refused out of range, or with the partitioned scheme (no polar angles)."""
    import math

    desired = [[300.0, 200.0], [340.0, 200.0], [340.0, 240.0], [300.0, 240.0]]
    calls = []

    class Watched:  # the servo, noting continue_turn
        def __init__(self, servo):
            self.servo = servo

        def continue_turn(self, centre):
            calls.append(centre)
            self.servo.continue_turn(centre)

        def reset(self):
            self.servo.reset()

        def __setattr__(self, name, value):  # the node sets damping, speeds... on the servo itself
            if name == "servo":
                object.__setattr__(self, name, value)
            else:
                setattr(self.servo, name, value)

    from ibvs.study import schemes

    make = schemes.make
    monkeypatch.setattr(schemes, "make", lambda *a, **k: Watched(make(*a, **k)))
    core = ServoNodeCore(NodeParams(desired_pixels=desired, turn=-math.pi), clock=lambda: 0)
    assert calls == [-math.pi]  # at construction
    core.reset()
    assert calls == [-math.pi, -math.pi]  # and at every reset
    core = ServoNodeCore(NodeParams(desired_pixels=desired), clock=lambda: 0)
    core.reset()
    assert calls == [-math.pi, -math.pi]  # NaN: nothing chosen
    monkeypatch.setattr(schemes, "make", make)
    for bad in (4.0, math.inf, -1e300, "pi", True):
        with pytest.raises(ValueError, match="turn"):
            ServoNodeCore(NodeParams(desired_pixels=desired, turn=bad), clock=lambda: 0)
    with pytest.raises(ValueError, match="turn: the 'partitioned' scheme has no consistent angle wrap"):
        ServoNodeCore(NodeParams(desired_pixels=desired, scheme="partitioned", turn=math.pi), clock=lambda: 0)
