"""ibvs.sim.solve_ik, the inverse kinematics of a robot's camera: round trips FK(IK(T)) = T on the Panda
and the UR5 from poses of random joints within their limits, the joints always within the limits, poses
out of reach reported (converged=False, with the residual) rather than answered, determinism, the cases
built with it, and its argument checks."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from ibvs import sim

pytest.importorskip("pinocchio")


@pytest.fixture(scope="module", params=["panda", "ur5"])
def arm(request):
    return sim.cases.arm_robot(request.param)


def random_joints(robot, rng):
    return robot.q_min + rng.random(robot.dof) * (robot.q_max - robot.q_min)


def within(robot, q) -> bool:
    return bool(np.all(q >= robot.q_min) and np.all(q <= robot.q_max))


def test_round_trip_from_random_reachable_poses(arm):
    """FK(IK(FK(q))) = FK(q) to 1e-10 for 25 random q within the limits, the IK started from the middle of
    the ranges (not from q): every one converges, within the limits."""
    rng = np.random.default_rng(2024)
    worst, times = 0.0, []
    for _ in range(25):
        T = arm.camera(random_joints(arm, rng))
        t0 = time.perf_counter()
        r = sim.solve_ik(arm, T)
        times.append(time.perf_counter() - t0)
        assert r.converged, r.message
        assert within(arm, r.q)
        assert r.position_error <= 1e-9 and r.rotation_error <= 1e-9 and r.residual <= 1.5e-9
        worst = max(worst, np.abs(arm.camera(r.q) - T).max())
    assert worst < 1e-10, worst
    assert np.median(times) < 1.0  # typically 20-50 ms


def test_a_start_near_q0_is_found_in_a_few_newton_steps(arm):
    rng = np.random.default_rng(5)
    q = np.array(sim.cases.ARMS[arm.example_name][0]) + rng.uniform(-0.3, 0.3, arm.dof)  # off singularities
    T = arm.camera(q) @ sim.pose(t=(0.01, -0.02, 0.03), r=(0.05, 0.0, -0.1))
    r = sim.solve_ik(arm, T, q)
    assert r.converged and r.attempts == 1 and r.iterations <= 8
    assert np.abs(r.q - q).max() < 0.5  # the nearby solution, not another branch


def test_far_outside_the_workspace_is_reported_not_answered(arm):
    T = sim.pose(t=(5.0, 0.0, 1.0))
    r = sim.solve_ik(arm, T, restarts=3)
    assert not r.converged and r.attempts == 4
    assert within(arm, r.q) and np.isfinite(r.q).all()
    assert 3.0 < r.position_error < 6.0 and math.isfinite(r.rotation_error)  # the best joints' residual
    assert "no joints within the limits" in r.message and "m," in r.message
    with pytest.raises(ValueError, match="camera_pose: no joints within the limits"):
        sim.cases.solve_joints(arm, T, arm.q_min / 2 + arm.q_max / 2)


def test_deterministic(arm):
    rng = np.random.default_rng(9)
    T = arm.camera(random_joints(arm, rng))
    a, b = sim.solve_ik(arm, T, seed=3), sim.solve_ik(arm, T, seed=3)
    assert a.q.tobytes() == b.q.tobytes() and a.iterations == b.iterations and a.attempts == b.attempts


def test_limits_are_respected_by_rejection():
    """A pose the gantry reaches only with joint 1 beyond a (narrowed) limit: not converged, and the joints
    returned stay within the limits; with the URDF's limits the same pose is reached."""
    gantry = sim.Gantry.afma6()
    q = np.array([0.5, 0.1, 0.2, 0.3, 0.4, 0.2])
    T = gantry.camera(q)
    assert sim.solve_ik(gantry, T).converged
    narrow = gantry.with_limits(q_max=np.r_[0.3, gantry.q_max[1:]])
    r = sim.solve_ik(narrow, T, q)
    assert not r.converged and within(narrow, r.q) and r.q[0] == 0.3
    assert r.position_error > 0.1


def test_a_revolute_joint_past_its_limit_is_moved_by_a_whole_turn():
    """Newton from q0 ends with joint 1 past +pi on a UR5 limited to [-pi, pi]: the same pose with joint 1
    one turn lower is within the limits and is the answer, found in the first attempt."""
    ur5 = sim.UrdfRobot(sim.example_robot_urdf("ur5"), "tool0", q_min=np.full(6, -np.pi), q_max=np.full(6, np.pi))
    goal = np.array(sim.cases.ARMS["ur5"][0])
    truth = goal + [np.pi + 0.05 - goal[0] - 2 * np.pi, 0, 0, 0, 0, 0]  # joint 1 at -pi + 0.05
    q0 = goal.copy()
    q0[0] = np.pi - 0.01
    r = sim.solve_ik(ur5, ur5.camera(truth), q0)
    assert r.converged and r.attempts == 1 and within(ur5, r.q)
    assert abs(r.q[0] - truth[0]) < 1e-9


def test_the_cases_use_it():
    """arm_general_motion's start is solve_ik from the goal joints (the same bits)."""
    for name in ("panda", "ur5"):
        case = sim.cases.arm_general_motion(name)
        goal_pose = case.robot.camera(case.goal)
        T = goal_pose @ sim.pose(t=sim.cases.GANTRY_GENERAL_MOTION_T, r=sim.cases.GANTRY_GENERAL_MOTION_R)
        assert sim.solve_ik(case.robot, T, case.goal).q.tobytes() == case.start.tobytes()
    gantry = sim.cases.gantry_general_motion()
    assert np.abs(gantry.robot.camera(gantry.start) - gantry.robot.camera(gantry.goal) @ sim.pose(
        t=sim.cases.GANTRY_GENERAL_MOTION_T, r=sim.cases.GANTRY_GENERAL_MOTION_R)).max() < 1e-12


def test_rotation_vector_of_a_half_turn():
    """The error's rotation vector keeps its axis at a half turn (where R - R^T vanishes)."""
    for axis in (np.array([1.0, 0, 0]), np.array([0, 0.6, 0.8]), np.array([-1.0, 1.0, 1.0]) / math.sqrt(3)):
        for angle in (np.pi, np.pi - 1e-9, 2.0, 1e-12):
            K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
            R = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
            w = sim.ik.rotation_vector(R)
            assert abs(np.linalg.norm(w) - angle) < 1e-8
            assert min(np.abs(w / angle - axis).max(), np.abs(w / angle + axis).max() if angle > 3 else 1) < 1e-6


@pytest.mark.parametrize("kwargs, word", [
    (dict(robot="gantry"), "robot"),
    (dict(camera_pose=np.eye(3)), "camera_pose"),
    (dict(camera_pose=np.full((4, 4), np.nan)), "camera_pose"),
    (dict(camera_pose=np.diag([1.0, 1.0, -1.0, 1.0])), "camera_pose"),  # a reflection
    (dict(camera_pose=2 * np.eye(4)), "camera_pose"),
    (dict(camera_pose=sim.pose(t=(1e7, 0, 0))), "camera_pose"),
    (dict(camera_pose="eye"), "camera_pose"),
    (dict(q0=np.zeros(5)), "q0"),
    (dict(q0=[0, 0, 0, 0, np.inf, 0]), "q0"),
    (dict(tolerance=0.0), "tolerance"),
    (dict(tolerance="1e-9"), "tolerance"),
    (dict(max_iterations=0), "max_iterations"),
    (dict(max_iterations=2.5), "max_iterations"),
    (dict(restarts=-1), "restarts"),
    (dict(seed=-1), "seed"),
    (dict(max_step=0.0), "max_step"),
])
def test_bad_arguments_are_refused_naming_them(kwargs, word):
    args = dict(robot=sim.Gantry.afma6(), camera_pose=sim.Gantry.afma6().camera(np.zeros(6)))
    args.update(kwargs)
    robot, pose = args.pop("robot"), args.pop("camera_pose")
    with pytest.raises((ValueError, TypeError), match=word):
        sim.solve_ik(robot, pose, **args)
