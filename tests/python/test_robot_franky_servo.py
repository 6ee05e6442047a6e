"""The paper's half-turn about the optical axis, end to end on a Franka client: `ibvs servo CONFIG.toml` drives
franky-sim's FR3 through franky-control over a loopback address, the camera rendered by MuJoCo on the FR3's
hand in franky-sim's own scene (ibvs.robot.franky_scene), the dots tracked on the images; it converges.

The turn: exactly pi about the optical axis. Every dot's polar angle error is then a tie (+-pi) that the
rendered images' sub-pixel errors would break either way, while the FR3's seventh joint (+-2.97 rad in
franky-sim's model, the camera on its axis) can turn pi one way only from any start: `[servo] turn = -pi`
(Servo.continue_turn) chooses the way the joint allows (the camera turns negatively, joint 7 from +0.5 to
-2.64). franky-sim starts at its home joints; the arm is first moved to the start with franky's own
JointMotion."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("franky", reason='franky-control is not installed (pip install ".[franka]")')
pytest.importorskip("franky_sim", reason="franky-sim is not installed (the test extra)")
pytest.importorskip("mujoco", reason='mujoco is not installed (pip install ".[physics]")')
pytest.importorskip("pinocchio", reason='the robots extra is not installed (pip install ".[robots]")')
pytest.importorskip("cv2", reason='the loop\'s dot tracker needs OpenCV (the vision extra)')

import franky_sim_server  # noqa: E402

from ibvs import sim  # noqa: E402
from ibvs.cli.main import main  # noqa: E402
from ibvs.robot.franky_scene import FR3_FLANGE, FrankyScene, franky_sim_urdf  # noqa: E402
from ibvs.sim import physics  # noqa: E402

HOME = np.array([0.0, 0.0, 0.0, -1.57, 0.0, 1.57, 0.785])
START = np.r_[HOME[:6], 0.5]  # asked for; the test servos from where franky-sim's arm then stands
TURN = -np.pi  # about the optical axis, the way [servo] turn chooses (the module docstring)
MOUNT_T = (0.0, 0.0, 0.13)  # the camera 13 cm along the flange's z: on joint 7's axis, past the fingers
SQUARE = np.array([[-0.05, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.05, 0.05, 0.0]])
DEPTH = 0.35


def case(q_start=START):
    """The FR3's kinematics with the camera, the camera, the target's pose, the start and goal pixels."""
    kin = sim.UrdfRobot(franky_sim_urdf(), FR3_FLANGE, sim.pose(t=MOUNT_T))
    camera = physics.testbed_camera(320, 240, fps=30.0, fov=60.0)
    T_start = kin.camera(q_start)
    T_goal = T_start @ sim.pose(r=(0.0, 0.0, TURN))  # the half-turn about the optical axis
    T_wo = T_goal @ sim.pose(t=(0.0, 0.0, DEPTH))  # the target plane facing the goal camera
    pixels = []
    for T in (T_start, T_goal):
        P = (np.linalg.inv(T) @ T_wo @ np.c_[SQUARE, np.ones(4)].T).T[:, :3]
        pixels.append(camera.project(P[:, :2] / P[:, 2:]))
    return kin, camera, T_wo, pixels[0], pixels[1]


def test_scene_camera_agrees_with_the_kinematics_and_projection():
    """franky-sim's MJCF (the scene) and its URDF (the kinematics) place the hand camera alike at other joints;
    the rendered dots' centroids are the camera model's projections of their centres."""
    import cv2

    kin, camera, T_wo, start_px, _ = case()
    scene = FrankyScene(kin, camera, SQUARE, T_wo)
    try:
        rng = np.random.default_rng(7)
        for q in (START, HOME, START + rng.uniform(-0.4, 0.4, 7)):
            np.testing.assert_allclose(scene.camera_pose(q), kin.camera(q), atol=1e-9)
        img = scene.render(START)
        n, _, stats, centroids = cv2.connectedComponentsWithStats((img > 128).astype(np.uint8))
        assert n == 5  # the background and four dots
        found = centroids[1:]
        d = np.linalg.norm(found[:, None, :] - start_px[None], axis=2)
        assert d.min(axis=0).max() < 0.5, d.min(axis=0)
    finally:
        scene.close()


def test_half_turn_converges_through_ibvs_servo_on_franky_sim(tmp_path, capsys):
    import franky

    proc, host = franky_sim_server.start()
    try:
        robot = franky.Robot(host, realtime_config=franky.RealtimeConfig.Ignore)
        robot.move(franky.JointMotion(START))  # to the start, with franky's own motion
        t = robot.state.time.to_sec()
        while robot.state.time.to_sec() < t + 0.3:  # settled (franky-sim's time)
            pass
        q_start = robot.current_joint_state.position
        assert abs(q_start[6] - START[6]) < 0.3 and q_start[6] + TURN > -2.95, q_start
        del robot  # franky-sim serves one client
        kin, camera, T_wo, start_px, goal_px = case(q_start)
        fmt = (lambda a: "[" + ", ".join("[" + ", ".join(f"{v:.6f}" for v in row) + "]" for row in a) + "]")
        cfg = tmp_path / "franky.toml"
        cfg.write_text(f"""
[camera]
px = {float(camera.px)!r}
py = {float(camera.py)!r}
u0 = {float(camera.u0)!r}
v0 = {float(camera.v0)!r}
width = 320
height = 240
fps = 30.0

[source]
kind = "franky_scene"

[target]
points = {fmt(SQUARE)}
pose = {{ t = [{', '.join(repr(float(x)) for x in T_wo[:3, 3])}], r = [{', '.join(repr(float(x)) for x in _rxyz(T_wo))}] }}

[tracker]
kind = "dots"
desired_pixels = {fmt(goal_px)}
initial_pixels = {fmt(start_px)}

[servo]
scheme = "polar"
gain = 1.5
depth = {DEPTH}
max_linear_speed = 0.1
max_angular_speed = 1.2
turn = {TURN!r}  # the half-turn's way: joint 7 can turn -pi from +0.5, not +pi

[robot]
kind = "franky"
host = "{host}"
rate = 30.0
clock = "robot"
stale_after = 0.5  # franky-sim on a loaded machine can miss a period (test_robot_franky.py)
urdf = "franky-sim"
mount = {{ t = [{MOUNT_T[0]}, {MOUNT_T[1]}, {MOUNT_T[2]}] }}

[loop]
duration = 6.0
watchdog = 0.5
converge_px = 1.0
clock = "robot"
log = "{tmp_path / 'run.jsonl'}"
""")
        try:
            status = main(["servo", str(cfg)])
        except SystemExit as e:
            status = e.code
        out = capsys.readouterr()
        assert status in (0, None), out.err
        assert "converged" in out.out, out.out
        end = json.loads((tmp_path / "run.jsonl").read_text().splitlines()[-1])
        assert end["kind"] == "end" and end["outcome"] == "converged", end
        print(out.out)
        # the arm turned its seventh joint by about pi and stands still
        check = franky.Robot(host, realtime_config=franky.RealtimeConfig.Ignore)
        q = check.current_joint_state.position
        assert abs(q[6] - (q_start[6] + TURN)) < 0.02, q
        assert np.abs(q[:6] - q_start[:6]).max() < 0.05, q
        del check
    finally:
        franky_sim_server.stop(proc)


def _rxyz(T):
    """Angles (rx, ry, rz) with R = Rx Ry Rz (ibvs.sim.pose's convention, ViSP's rxyz) of a pose's rotation."""
    R = T[:3, :3]
    a = (np.arctan2(-R[1, 2], R[2, 2]), np.arcsin(np.clip(R[0, 2], -1, 1)), np.arctan2(-R[0, 1], R[0, 0]))
    np.testing.assert_allclose(sim.pose(T[:3, 3], a), T, atol=1e-12)
    return a
