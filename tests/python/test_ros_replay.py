"""Replay, the known answer: an image-in-the-loop episode recorded as a bag (dots and tag, with noise,
latency and each depth mode), replayed through the tracker and the servo, gives the recorded twists
to 1e-9 (to the last bit with the desired and the planar pose's depths; the exact and estimated depths
come from /tf's quaternions: ~1e-14 and ~1e-12), and the recorded pixels exactly. Also: `ibvs replay` (CSV, bag with the twists added), and what it refuses."""

from __future__ import annotations

import csv
import os
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


def record(tmp_path, kind, depth, name="run.mcap", scheme="polar", **kw):
    case = sim.cases.general_motion()
    camera = vision.image_camera(case.camera)
    servo = {"polar": ibvs.Servo(ibvs.Layout.polar(4), gain=1.0, damping=0.01, max_linear_speed=2.0),
             "partitioned": ibvs.PartitionedServo(4, 1.0)}[scheme]
    path = tmp_path / name
    r = sim.run(servo, camera, case.target, case.start, case.goal, duration=kw.pop("duration", 0.5), vision=kind,
                depth=depth, record=path, **kw)
    return r, path


def compare(r, path):
    rep = ros.replay(path)
    recorded = ros.recorded_twists(path)
    K = len(r.sensor.frames)
    assert len(rep) == K and len(recorded) >= K - 1
    np.testing.assert_array_equal(rep.pixels, r.history.measured[:K])  # the tracker saw what it saw
    np.testing.assert_array_equal(rep.desired, r.measured_desired)
    worst = 0.0
    for s, tw in zip(rep.stamps, rep.twist):
        if int(s) in recorded:
            worst = max(worst, float(np.abs(recorded[int(s)] - tw).max()))
    assert worst <= 1e-9, worst
    return rep, worst


@pytest.mark.parametrize("kind, depth, kw", [
    ("dots", "pose", dict(noise=0.5, seed=4)),
    ("dots", "exact", dict(latency=2)),
    ("dots", "estimated", dict(noise=0.2, latency=1)),
    ("tag", "desired", dict(depth_scale=1.3)),
    ("tag", "pose", dict(latency=1, noise=0.3)),
])
def test_replay_gives_the_recorded_twists(tmp_path, kind, depth, kw):
    r, path = record(tmp_path, kind, depth, **kw)
    assert r.status.outcome in ("timeout", "converged")  # every frame measured, the servo ran each
    rep, worst = compare(r, path)
    if depth in ("desired", "pose"):
        assert worst == 0.0  # the same computation as the simulator's: to the last bit
    print(f"{kind} {depth}: largest twist difference {worst:.3g}")
    assert rep.status[0] == "ok"


def test_replay_partitioned_servo_and_converged_run(tmp_path):
    r, path = record(tmp_path, "dots", "pose", scheme="partitioned", duration=10.0, tolerance_px=1.0)
    assert r.status.outcome == "converged"
    compare(r, path)


def test_replay_of_a_lost_feature_stops_where_the_episode_stopped(tmp_path):
    case = sim.cases.general_motion()
    camera = vision.image_camera(case.camera)
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), camera, case.target, case.start, case.goal,
                duration=1.0, vision="dots", depth="desired", latency=1, noise=0.3, record=tmp_path / "lost.mcap")
    assert r.status.outcome == "lost_feature"
    rep = ros.replay(tmp_path / "lost.mcap")
    assert rep.status[-1] == "lost_feature" and len(rep) == r.status.frame + 1


def test_replay_a_real_robots_bag_with_arguments(tmp_path):
    """Without /ibvs/config (a real robot's bag): tracker, scheme, desired pixels and depth from the arguments."""
    r, path = record(tmp_path, "tag", "desired")
    from rosbags.typesys import Stores, get_typestore, get_types_from_msg

    custom = get_typestore(Stores.ROS2_HUMBLE)  # a robot's own message type, which rosbags does not know
    custom.register(get_types_from_msg("int32 gripper\nstring mode", "my_robot_msgs/msg/Status"))
    plain = tmp_path / "plain.mcap"
    with ros.BagWriter(plain, custom) as out:
        for topic, ns, msg in ros.messages(path, ["/camera/image_raw", "/camera/camera_info"]):
            out.write(topic, msg, ns)
        out.write("/status", custom.types["my_robot_msgs/msg/Status"](gripper=3, mode="auto"), 5)
    with pytest.raises(ValueError, match="desired_pixels: the bag has no /ibvs/config"):
        ros.replay(plain, tracker="tag", scheme="polar")
    with pytest.raises(ValueError, match="tracker: give 'dots' or 'tag'"):
        ros.replay(plain, desired_pixels=r.measured_desired)
    rep = ros.replay(plain, tracker="tag", scheme="polar", gain=1.0, desired_pixels=r.measured_desired,
                     depth_desired=r.depth_desired)
    servo = ibvs.Servo(ibvs.Layout.polar(4), gain=1.0)  # the scheme's servo on the tracked pixels, by hand
    uv_d = r.camera.normalize(r.measured_desired)
    for k in range(3):
        expected = servo.update(r.camera.normalize(r.history.measured[k]), r.depth_desired, uv_d, r.depth_desired)
        np.testing.assert_array_equal(rep.twist[k], expected.velocity)
    counts = ros.write_bag(rep, plain, tmp_path / "out.mcap")  # the robot's own types copied as they are
    assert counts["/status"] == 1 and counts[ros.REPLAY_TWIST_TOPIC] == len(rep)
    (status,) = [m for _, _, m in ros.messages(tmp_path / "out.mcap", ["/status"])]
    assert (status.gripper, status.mode) == (3, "auto")
    with pytest.raises(ValueError, match="initial_pixels: the dot tracker needs the dots' pixels"):
        ros.replay(plain, tracker="dots", scheme="polar", desired_pixels=r.measured_desired, depth_desired=0.5)


def test_replay_refusals(tmp_path):
    r, path = record(tmp_path, "dots", "pose", duration=0.1)
    with pytest.raises(ValueError, match=r"image_topic: bag '.*run\.mcap' has no topic '/cam/image' \(its topics: "):
        ros.replay(path, image_topic="/cam/image")
    with pytest.raises(ValueError, match=r"depth must be one of"):
        ros.replay(path, depth="guess")
    with pytest.raises(ValueError, match=r"scheme: 'magic' is not one of"):
        ros.replay(path, scheme="magic")
    with pytest.raises(ValueError, match=r"desired_pixels must be 4 finite pixels"):
        ros.replay(path, desired_pixels=[[1.0, 2.0]])
    case = sim.cases.general_motion()
    camera = vision.image_camera(case.camera)
    sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), camera, case.target, case.start, case.goal, duration=0.1,
            vision="dots", boundary_margin=20.0, record=tmp_path / "b.mcap")
    with pytest.raises(ValueError, match="image-boundary potential"):
        ros.replay(tmp_path / "b.mcap")


def _cli(tmp_path, *args):
    env = dict(os.environ, PYTHONPATH=str(Path(ibvs.__file__).resolve().parents[1]))
    return subprocess.run([sys.executable, "-m", "ibvs", *map(str, args)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600, env=env)


def test_cli_replay_writes_csv_and_bag(tmp_path):
    r, path = record(tmp_path, "tag", "pose", latency=1)
    out = _cli(tmp_path, "replay", path, "--out", "twists.csv", "--bag-out", "with_twists.mcap")
    assert out.returncode == 0, out.stdout + out.stderr
    assert "largest difference 0\n" in out.stdout  # tag, pose depths: to the last bit
    with open(tmp_path / "twists.csv") as f:
        rows = list(csv.DictReader(f))
    K = len(r.sensor.frames)
    assert len(rows) == K and rows[0]["status"] == "ok"
    for k in (0, K - 1):
        got = [float(rows[k][c]) for c in ("Tx", "Ty", "Tz", "wx", "wy", "wz")]
        np.testing.assert_array_equal(got, r.history.twist[k])  # repr floats: read back exactly
        assert float(rows[k]["u2"]) == r.history.measured[k, 2, 0]
    have = ros.topics(tmp_path / "with_twists.mcap")
    assert have[ros.REPLAY_TWIST_TOPIC] == ("geometry_msgs/msg/TwistStamped", K)
    assert {t: c for t, (_, c) in have.items() if t != ros.REPLAY_TWIST_TOPIC} == \
        {t: c for t, (_, c) in ros.topics(path).items()}
    replayed = ros.recorded_twists(tmp_path / "with_twists.mcap", ros.REPLAY_TWIST_TOPIC)
    original = ros.recorded_twists(path)
    assert all(np.array_equal(replayed[s], original[s]) for s in original)


def test_cli_replay_errors_are_one_line(tmp_path):
    r, path = record(tmp_path, "tag", "pose", duration=0.1)
    for args, message in [
        (("replay", "nothing.mcap", "--out", "t.csv"), "argument BAG: no bag 'nothing.mcap'"),
        (("replay", path, "--out", "t.txt"), "argument --out: 't.txt' must end in .csv"),
        (("replay", path, "--out", "t.csv", "--image-topic", "/x"), "image_topic: bag"),
        (("replay", path, "--out", "t.csv", "--bag-out", path), "argument --bag-out: must not be the bag replayed"),
        (("replay", path, "--out", "t.csv", "--desired-pixels", "1,2,3"), "argument --desired-pixels: expected U,V"),
    ]:
        out = _cli(tmp_path, *args)
        assert out.returncode == 2 and message in out.stderr and len(out.stderr.strip().splitlines()) == 1, \
            (args, out.stderr)
