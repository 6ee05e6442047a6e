"""Arms from their URDF in the simulator (ibvs.sim.UrdfRobot, Pinocchio): the Franka Panda (7 joints)
and the UR5 (6) of example-robot-data converge under IBVS, and the camera pose the C++ loop records
at every frame is Pinocchio's forward kinematics of the recorded joints (a model loaded separately,
with the gripper's joints, times eMc); limits, events, pickling, Python robots and their errors."""

from __future__ import annotations

import pickle

import numpy as np
import pinocchio as pin
import pytest

import ibvs
from ibvs import sim


@pytest.fixture(scope="module", params=["panda", "ur5"])
def case(request):
    return sim.cases.arm_general_motion(request.param)


def independent_camera_poses(case, q):
    """world <- camera at each row of q, from a Pinocchio model of the full URDF (fingers at rest)."""
    name = case.name.split("_")[0]
    model = pin.buildModelFromUrdf(sim.example_robot_urdf(name))
    data = model.createData()
    fid = model.getFrameId(sim.urdf.EXAMPLE_ROBOTS[name][1])
    out = []
    for qk in q:
        full = pin.neutral(model)
        full[: len(qk)] = qk  # the arm's joints come first in both URDFs
        pin.framesForwardKinematics(model, data, full)
        out.append(data.oMf[fid].homogeneous @ case.robot.mount)
    return np.array(out)


@pytest.mark.parametrize("layout", [ibvs.Layout.cartesian(4), ibvs.Layout.stacked(4)], ids=["cartesian", "stacked"])
def test_general_motion_converges_and_follows_pinocchio(case, layout):
    robot = case.robot
    r = sim.run(ibvs.Servo(layout, gain=1.0), case.camera, case.target, case.start, case.goal, robot=robot,
                duration=case.duration, depth="pose", tolerance=1e-5)
    assert r.converged, r
    assert r.metrics.final_translation_error < 1e-3 and np.degrees(r.metrics.final_rotation_error) < 0.1
    h = r.history
    n = robot.dof
    assert h.q.shape == (len(h), n) and h.qdot.shape == (len(h), n)
    assert np.allclose(h.q[0], case.start) and np.all(np.isfinite(h.manipulability[:-1]))
    # the joints integrate the commanded velocities, inside their position and speed limits
    assert np.allclose(h.q[1:], h.q[:-1] + h.qdot[:-1] / case.camera.fps, atol=1e-15)
    assert np.all(h.q >= robot.q_min) and np.all(h.q <= robot.q_max)
    assert np.all(np.abs(h.qdot) <= robot.qdot_max * (1 + 1e-12))
    # the camera pose after every step is Pinocchio's forward kinematics of the joints
    assert np.abs(h.pose - independent_camera_poses(case, h.q)).max() < 1e-12
    # the joint velocities are the robot's mapping of the commanded twist, scaled to the speed limits,
    # and move the camera with (that fraction of) the twist
    for k in range(0, len(h) - 1, len(h) // 5):
        jv = robot.joint_velocity(h.q[k], h.twist[k])
        s = min(1.0, np.min(robot.qdot_max / np.abs(jv)))
        assert np.allclose(h.qdot[k], s * jv, rtol=0, atol=1e-12)
        assert np.allclose(robot.jacobian(h.q[k]) @ h.qdot[k], s * h.twist[k], rtol=0, atol=1e-12)


def test_urdf_robot_model(case):
    robot = case.robot
    name = case.name.split("_")[0]
    n = {"panda": 7, "ur5": 6}[name]
    assert robot.dof == n and robot.model.nq == n and len(robot.joint_names) == n
    assert robot.frame == "end_effector" and robot.frame_name == sim.urdf.EXAMPLE_ROBOTS[name][1]
    model = pin.buildModelFromUrdf(sim.example_robot_urdf(name))  # the URDF's limits of the arm's joints
    assert np.array_equal(robot.q_min, model.lowerPositionLimit[:n])
    assert np.array_equal(robot.q_max, model.upperPositionLimit[:n])
    assert np.array_equal(robot.qdot_max, model.velocityLimit[:n])
    T, J = robot.kinematics(case.goal)
    assert T.shape == (4, 4) and J.shape == (6, n)
    assert np.allclose(robot.camera(case.goal), T @ robot.mount)
    # the goal posture is well away from singularities
    assert np.linalg.svd(robot.jacobian(case.goal), compute_uv=False)[-1] > 0.2


def test_pickles_and_base_frame(case):
    robot = case.robot
    again = pickle.loads(pickle.dumps(robot))
    assert isinstance(again, sim.UrdfRobot) and again.dof == robot.dof
    assert np.array_equal(again.camera(case.start), robot.camera(case.start))
    base = sim.UrdfRobot(*robot._args[:3], jacobian_frame="base")
    assert base.frame == "base"
    assert np.allclose(base.jacobian(case.start), robot.jacobian(case.start), atol=1e-14)
    v = np.array([0.01, -0.02, 0.03, 0.1, 0.0, -0.1])
    assert np.allclose(base.joint_velocity(case.start, v), robot.joint_velocity(case.start, v), atol=1e-12)


def test_joint_limit_outcome():
    case = sim.cases.arm_general_motion("ur5")
    q_max = case.robot.q_max.copy()
    q_max[0] = case.start[0] + 0.02  # the base joint turns by more than 0.02 rad towards the goal
    q_min = case.robot.q_min.copy()
    q_min[0] = case.start[0] - 0.02
    robot = sim.UrdfRobot(*case.robot._args[:3], q_min=q_min, q_max=q_max)
    r = sim.run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0), case.camera, case.target, case.start, case.goal,
                robot=robot, duration=5.0)
    assert r.status.outcome == "joint_limit" and r.status.joint == 0
    assert robot.outside_limits(r.history.q[-1]) == -1  # stopped inside its range


class Failing(sim.Robot):
    """A Python robot (a 6-joint 'robot' moving its end effector freely) that can fail on demand."""

    def __init__(self, fail_at=None, bad=None):
        super().__init__(np.full(6, -10.0), np.full(6, 10.0), np.full(6, 1.0), np.eye(4))
        self.calls, self.fail_at, self.bad = 0, fail_at, bad

    def kinematics(self, q):
        self.calls += 1
        if self.calls == self.fail_at:
            raise RuntimeError("encoder lost")
        T = sim.pose(t=q[:3], r=q[3:])
        if self.bad == "shape":
            return T, np.eye(5)
        if self.bad == "type":
            return T
        J = np.eye(6)  # not exact for rotations; enough for these checks
        return T, J


def test_python_robot_errors_reach_the_caller():
    case = sim.cases.general_motion()
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0)
    start, goal = np.array([0.05, -0.03, 0.1, 0, 0, 0]), np.zeros(6)
    goal_pose = np.eye(4)
    run = lambda robot: sim.run(servo, case.camera, case.target, start, goal_pose, robot=robot, duration=1.0)  # noqa: E731
    r = run(Failing())
    assert r.history.q.shape == (60, 6) and r.status.outcome == "timeout" and r.history.error_norm[-1] < 0.1
    with pytest.raises(RuntimeError, match="encoder lost"):
        run(Failing(fail_at=5))  # mid-run: the loop stops and the exception is raised
    with pytest.raises(RuntimeError, match="encoder lost"):
        run(Failing(fail_at=1))  # at the start
    with pytest.raises(ValueError, match=r"J\) must have shape \(6, 6\)"):
        run(Failing(bad="shape"))
    with pytest.raises(TypeError, match="tuple"):
        run(Failing(bad="type"))
    with pytest.raises(ValueError, match="start must have shape"):
        sim.run(servo, case.camera, case.target, np.zeros(7), goal, robot=Failing(), duration=1.0)
    with pytest.raises(TypeError, match="kinematics"):
        sim.Robot(np.zeros(2), np.ones(2), np.ones(2), np.eye(4)).camera(np.zeros(2))


def test_bad_robot_arguments():
    urdf = sim.example_robot_urdf("ur5")
    with pytest.raises(ValueError, match="frame 'hand' is not in the URDF"):
        sim.UrdfRobot(urdf, "hand")
    with pytest.raises(TypeError, match="frame"):
        sim.UrdfRobot(urdf, 3)
    with pytest.raises(ValueError, match="urdf_path"):
        sim.UrdfRobot("/nonexistent.urdf", "tool0")
    with pytest.raises(TypeError, match="urdf_path"):
        sim.UrdfRobot(None, "tool0")
    with pytest.raises(ValueError, match="mount|eMc"):
        sim.UrdfRobot(urdf, "tool0", 2 * np.eye(4))
    with pytest.raises(ValueError, match="jacobian_frame"):
        sim.UrdfRobot(urdf, "tool0", jacobian_frame="world")
    with pytest.raises(ValueError, match="qdot_max"):
        sim.UrdfRobot(urdf, "tool0", qdot_max=np.ones(7))
    with pytest.raises(ValueError, match="not moved by any joint"):
        sim.UrdfRobot(urdf, "base_link")
    with pytest.raises(TypeError, match="damping"):
        sim.UrdfRobot(urdf, "tool0", damping="x")
    with pytest.raises(ValueError, match="q_min < q_max"):
        sim.Robot(np.ones(2), np.zeros(2), np.ones(2), np.eye(4))
    with pytest.raises(ValueError, match="qdot_max"):
        sim.Robot(np.zeros(2), np.ones(2), np.ones(3), np.eye(4))
    with pytest.raises(ValueError, match="name must be one of"):
        sim.example_robot_urdf("kuka")
    with pytest.raises(TypeError, match="robot must be an ibvs.sim.Robot"):
        case = sim.cases.general_motion()
        sim.run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0), case.camera, case.target, case.start, case.goal,
                robot="panda")
