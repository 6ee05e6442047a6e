"""Episodes recorded as ROS 2 bags (sim.run(record=...), ibvs run --record), read back with rosbags
message for message; written atomically (an interrupted recording leaves nothing, or the old file);
truncated bags and unknown topics refused with errors naming the bag and the topic."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import ibvs
from ibvs import sim

pytest.importorskip("rosbags", reason='the ros extra is not installed (pip install ".[ros]")')
from ibvs import ros  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def gantry_run(tmp_path, name="run.mcap", **kw):
    case = sim.cases.gantry_general_motion()
    servo = ibvs.Servo(ibvs.Layout.polar(4), gain=2.0)
    return sim.run(servo, case.camera, case.target, case.start, case.goal, robot=case.robot, duration=0.5,
                   depth="pose", record=tmp_path / name, **kw)


def test_record_gantry_message_for_message(tmp_path):
    r = gantry_run(tmp_path, noise=0.5, seed=3)
    path = tmp_path / "run.mcap"
    assert path.is_file() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temp left
    K = len(r.history)
    have = ros.topics(path)
    assert have == {"/ibvs/config": ("std_msgs/msg/String", 1),
                    "/ibvs/features_desired": ("std_msgs/msg/Float64MultiArray", 1),
                    "/camera/camera_info": ("sensor_msgs/msg/CameraInfo", K),
                    "/ibvs/features": ("std_msgs/msg/Float64MultiArray", K),
                    "/ibvs/cmd_twist": ("geometry_msgs/msg/TwistStamped", K),
                    "/joint_states": ("sensor_msgs/msg/JointState", K),
                    "/tf": ("tf2_msgs/msg/TFMessage", K)}
    dt_ns = round(1e9 / r.camera.fps)
    seen = {t: [] for t in have}
    for topic, ns, msg in ros.messages(path):
        seen[topic].append((ns, msg))
    for topic in ("/camera/camera_info", "/ibvs/features", "/ibvs/cmd_twist", "/joint_states", "/tf"):
        stamps = [ns for ns, _ in seen[topic]]
        assert stamps == [round(k * 1e9 / r.camera.fps) for k in range(K)], topic  # simulated frame times
        assert abs(stamps[1] - dt_ns) <= 1
    for k in range(K):
        info = seen["/camera/camera_info"][k][1]
        assert ros.types.stamp_ns(info) == seen["/camera/camera_info"][k][0]
        assert ros.camera_model(info, r.camera.fps) == r.camera  # the Afma6 camera, ViSP distortion
        np.testing.assert_array_equal(ros.array_of(seen["/ibvs/features"][k][1]), r.history.measured[k])
        twist = seen["/ibvs/cmd_twist"][k][1]
        assert twist.header.frame_id == "camera_optical_frame"
        np.testing.assert_array_equal(ros.twist_of(twist), r.history.twist[k])
        js = seen["/joint_states"][k][1]
        np.testing.assert_array_equal(ros.joint_positions(js), r.history.q[k])
        np.testing.assert_array_equal(js.velocity, r.history.qdot[k])
        tf = ros.transforms(seen["/tf"][k][1])
        np.testing.assert_allclose(tf[("world", "camera_optical_frame")], r.history.pose[k], atol=1e-15)
        np.testing.assert_allclose(tf[("world", "target")], r.target.pose, atol=1e-15)
        np.testing.assert_allclose(tf[("world", "end_effector")] @ r.robot.mount, r.history.pose[k], atol=1e-14)
    np.testing.assert_array_equal(ros.array_of(seen["/ibvs/features_desired"][0][1]), r.measured_desired)
    config = ros.config.loads(seen["/ibvs/config"][0][1].data)
    assert config["options"]["noise"] == 0.5 and config["options"]["seed"] == 3 and config["options"]["depth"] == "pose"
    assert config["frames"] == K and config["outcome"]["outcome"] == r.status.outcome
    assert config["robot"]["joint_names"] == [f"joint{i}" for i in range(1, 7)]
    servo = ros.servo_from_spec(config["servo"])
    assert ros.servo_spec(servo) == config["servo"]


def test_servo_spec_round_trip_of_every_option():
    servos = [ibvs.Servo(ibvs.Layout([(0, "cartesian"), (1, "polar"), (2, "cylindrical"), (3, "polar")]),
                         ibvs.AdaptiveGain(2.0, 0.5, 10.0), damping=0.01, jacobian="mean", polar_min_radius=0.05,
                         max_linear_speed=0.3, max_angular_speed=1.5, angle_wrap="per_point"),
              ibvs.Servo.automatic_hybrid(5, 0.7),
              ibvs.PartitionedServo(4, 1.5, damping=0.1, segment=(1, 3), max_linear_speed=0.2)]
    task = ibvs.Task(ibvs.Layout.polar(4))  # point weights and a subset of the twist (the Task's options)
    task.point_weights = [1.0, 2.0, 0.5, 1.0]
    task.dof = ["Tx", "Ty", "Tz", "wz"]
    servos.append(ibvs.Servo(task, 0.8, damping=0.02))
    uv = np.array([[0.1, 0.2], [-0.1, 0.15], [-0.12, -0.1], [0.1, -0.1], [0.01, 0.02]])
    for s in servos:
        spec = json.loads(json.dumps(ros.servo_spec(s)))
        copy = ros.servo_from_spec(spec)
        assert ros.servo_spec(copy) == spec
        n = s.layout.n_points
        a = s.update(uv[:n] * 1.3, 0.7, uv[:n], 0.5).velocity
        b = copy.update(uv[:n] * 1.3, 0.7, uv[:n], 0.5).velocity
        np.testing.assert_array_equal(a, b)
    assert ros.servo_spec(servos[-1])["dof"] == [True, True, True, False, False, True]
    lines = ibvs.Task(ibvs.Layout.polar(4)).add(ibvs.LineFeature())
    with pytest.raises(ValueError, match="servo: a Task with feature blocks other than points is not recorded"):
        ros.servo_spec(ibvs.Servo(lines, 1.0))


def test_directory_bag_and_replacing_an_existing_one(tmp_path):
    r = gantry_run(tmp_path, name="bagdir")
    bag = tmp_path / "bagdir"
    assert (bag / "metadata.yaml").is_file() and len(list(bag.glob("*.mcap"))) == 1
    assert ros.topics(bag)["/ibvs/cmd_twist"][1] == len(r.history)
    gantry_run(tmp_path, name="bagdir")  # again: the old bag replaced once the new one is complete
    assert ros.topics(bag)["/tf"][1] == len(r.history)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bagdir"]


def test_record_refusals(tmp_path):
    case = sim.cases.gantry_general_motion()
    servo = ibvs.Servo(ibvs.Layout.polar(4), gain=2.0)
    with pytest.raises(FileNotFoundError, match="record: directory .* does not exist"):
        sim.run(servo, case.camera, case.target, case.start, case.goal, robot=case.robot, duration=0.1,
                record=tmp_path / "no" / "run.mcap")
    (tmp_path / "d.mcap").mkdir()
    with pytest.raises(IsADirectoryError, match="is a directory"):
        sim.run(servo, case.camera, case.target, case.start, case.goal, robot=case.robot, duration=0.1,
                record=tmp_path / "d.mcap")


def test_free_world_normalised_camera_has_no_camera_info(tmp_path):
    case = sim.cases.z_rotation()
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), case.camera, case.target, case.start, case.goal,
                duration=0.2, record=tmp_path / "free.mcap")
    have = ros.topics(tmp_path / "free.mcap")
    assert "/camera/camera_info" not in have and "/camera/image_raw" not in have
    assert have["/ibvs/cmd_twist"][1] == len(r.history)


INTERRUPTED = textwrap.dedent("""
    import os, signal, sys
    # Python's own Ctrl-C handler, even when the test runs in a shell's background job (which starts
    # its children with SIGINT ignored, and Python then leaves it ignored).
    signal.signal(signal.SIGINT, signal.default_int_handler)
    import ibvs
    from ibvs import sim
    from ibvs.ros import recorder
    real, calls = recorder.tf_message, []
    def interrupt(*a, **k):  # the 5th frame's tf: Ctrl-C, in the middle of writing the bag
        calls.append(1)
        if len(calls) == 5:
            os.kill(os.getpid(), signal.SIGINT)
        return real(*a, **k)
    recorder.tf_message = interrupt
    case = sim.cases.gantry_general_motion()
    sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=2.0), case.camera, case.target, case.start, case.goal,
            robot=case.robot, duration=0.5, depth="pose", record=sys.argv[1])
    print("not interrupted")
""")


@pytest.mark.parametrize("existing", [False, True])
def test_sigint_while_recording_leaves_no_half_bag(tmp_path, existing):
    path = tmp_path / "run.mcap"
    if existing:
        path.write_bytes(b"the previous recording")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(ibvs.__file__).resolve().parents[1]),
                                                       os.environ.get("PYTHONPATH", "")]))
    run = subprocess.run([sys.executable, "-c", INTERRUPTED, str(path)], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode != 0 and "KeyboardInterrupt" in run.stderr, run.stdout + run.stderr
    assert "not interrupted" not in run.stdout
    leftovers = sorted(p.name for p in tmp_path.iterdir())
    assert leftovers == (["run.mcap"] if existing else []), leftovers
    if existing:
        assert path.read_bytes() == b"the previous recording"


def test_truncated_bag_and_unknown_topic(tmp_path):
    gantry_run(tmp_path)
    path = tmp_path / "run.mcap"
    with pytest.raises(ValueError, match=r"bag '.*run\.mcap' has no topic '/camera/image_raw' \(its topics: "):
        list(ros.messages(path, ["/camera/image_raw"]))
    data = path.read_bytes()
    for keep in (len(data) // 2, len(data) - 40, 20):
        cut = tmp_path / f"cut{keep}.mcap"
        cut.write_bytes(data[:keep])
        with pytest.raises(ValueError, match=r"bag '.*cut\d+\.mcap'.*(truncated|cannot be read)"):
            list(ros.messages(cut))
    with pytest.raises(FileNotFoundError, match="bag '.*nothing.mcap' does not exist"):
        ros.topics(tmp_path / "nothing.mcap")
    (tmp_path / "text.mcap").write_text("not a bag")
    with pytest.raises(ValueError, match=r"bag '.*text\.mcap' cannot be read"):
        ros.topics(tmp_path / "text.mcap")


def test_cli_run_record_and_rerun(tmp_path):
    out = subprocess.run([sys.executable, "-m", "ibvs", "run", "--world", "gantry", "--duration", "0.3", "--record",
                          "g.mcap"], cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, PYTHONPATH=str(Path(ibvs.__file__).resolve().parents[1])))
    assert "bag" in out.stdout and (tmp_path / "g.mcap").is_file(), out.stdout + out.stderr
    assert ros.topics(tmp_path / "g.mcap")["/ibvs/cmd_twist"][1] == 18
    bad = subprocess.run([sys.executable, "-m", "ibvs", "run", "--record", "g.bag"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120,
                         env=dict(os.environ, PYTHONPATH=str(Path(ibvs.__file__).resolve().parents[1])))
    assert bad.returncode == 2 and "argument --record: 'g.bag' must end in .mcap" in bad.stderr


def test_record_a_urdf_arm_names_its_joints_and_mount_frame(tmp_path):
    pytest.importorskip("pinocchio", reason="the robots extra is not installed")
    case = sim.cases.arm_general_motion("panda")
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), case.camera, case.target, case.start, case.goal,
                robot=case.robot, duration=0.1, depth="pose", record=tmp_path / "arm.mcap")
    names = list(case.robot.joint_names)
    assert names[0] == "panda_joint1" and len(names) == 7
    states = [m for _, _, m in ros.messages(tmp_path / "arm.mcap", ["/joint_states"])]
    assert len(states) == len(r.history) and list(states[0].name) == names
    np.testing.assert_array_equal(ros.joint_positions(states[-1], names), r.history.q[-1])
    tf = ros.transforms(next(m for _, _, m in ros.messages(tmp_path / "arm.mcap", ["/tf"])))
    np.testing.assert_allclose(tf[("world", "panda_hand")] @ case.robot.mount, r.history.pose[0], atol=1e-14)
