"""The paper's claims, reproduced with ibvs.sim (Sections III-A, III-B, V)."""

import numpy as np
import pytest

import ibvs
import ibvs.sim as sim

LAYOUTS = {"cartesian": ibvs.Layout.cartesian(4), "polar": ibvs.Layout.polar(4), "stacked": ibvs.Layout.stacked(4)}


def run_case(case, layout, gain=1.0, **kw):
    kw.setdefault("duration", 20.0)
    return sim.run(ibvs.Servo(LAYOUTS[layout], gain=gain), case.camera, case.target, case.start, case.goal,
                   robot=case.robot, **kw)


def test_z_rotation_pi_polar_is_pure_wz():
    r = run_case(sim.cases.z_rotation(), "polar", tolerance=1e-3)
    assert r.status.outcome == "converged"
    m = np.abs(r.history.twist).max(axis=0)
    assert m[5] > 3.0
    assert m[:5].max() < 1e-9 * m[5]
    assert r.metrics.camera_retreat < 1e-9
    assert np.degrees(r.metrics.final_rotation_error) < 0.1


def test_z_rotation_pi_cartesian_retreats_and_is_flagged():
    r = run_case(sim.cases.z_rotation(), "cartesian", tolerance=1e-3)
    assert not r.converged
    assert r.status.outcome == "diverged"
    assert r.metrics.camera_retreat > 10.0
    tw = r.history.twist
    assert np.all(tw[:-1, 2] < 0)  # backwards along the optical axis, nothing else (last frame: stopped)
    assert np.abs(tw[:, [0, 1, 3, 4, 5]]).max() < 1e-9 * np.abs(tw[:, 2]).max()


def test_z_rotation_pi_stacked_converges():
    r = run_case(sim.cases.z_rotation(), "stacked", tolerance=1e-3)
    assert r.converged
    assert np.degrees(r.metrics.final_rotation_error) < 0.1


def test_x_translation_cartesian_moves_along_x_only():
    r = run_case(sim.cases.x_translation(), "cartesian", tolerance=1e-4)
    assert r.converged
    tw = r.history.twist
    assert np.abs(tw[:, 1:]).max() < 1e-12 * np.abs(tw[:, 0]).max()
    assert r.metrics.path_length == pytest.approx(0.2, abs=1e-3)
    # every camera position on the x axis
    assert np.abs(r.history.pose[:, 1:3, 3]).max() < 1e-12


def test_x_translation_polar_couples_tx_tz_wy():
    r = run_case(sim.cases.x_translation(), "polar", tolerance=1e-4)
    assert r.converged
    m = np.abs(r.history.twist).max(axis=0)
    assert m[2] > 0.05 * m[0] and m[4] > 0.05 * m[0]
    assert max(m[1], m[3], m[5]) < 1e-12 * m[0]


@pytest.mark.parametrize("layout", LAYOUTS)
def test_general_motion_converges(layout):
    r = run_case(sim.cases.general_motion(), layout, duration=30.0, tolerance=1e-5)
    assert r.converged, r
    assert r.metrics.final_translation_error < 1e-3


@pytest.mark.parametrize("layout", LAYOUTS)
def test_gantry_general_motion_reaches_goal_with_distortion(layout):
    case = sim.cases.gantry_general_motion()
    assert case.camera.distortion == "visp" and all(k != 0 for k in case.camera.coefficients)  # kud, kdu
    r = run_case(case, layout, gain=2.0, duration=case.duration, tolerance=1e-5)
    assert r.converged, r
    assert r.metrics.final_translation_error < 1e-3
    assert np.degrees(r.metrics.final_rotation_error) < 0.1
    q = r.history.q
    assert np.all(q >= case.robot.q_min) and np.all(q <= case.robot.q_max)
    assert np.all(np.abs(r.history.qdot) <= case.robot.qdot_max * (1 + 1e-12))
    # desired pose (0, 0, 0.6, 0, 0, 0): target centred 0.6 m ahead at the goal
    T_ct = np.linalg.inv(r.goal) @ case.target.pose
    assert np.allclose(T_ct, np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.6], [0, 0, 0, 1]]), atol=1e-12)


def test_gantry_joint_limit_is_reported():
    case = sim.cases.gantry_joint_limit()
    r = run_case(case, "polar", gain=2.0, duration=case.duration, tolerance=1e-5)
    assert r.status.outcome == "joint_limit"
    assert r.status.joint == 4
    assert r.status.frame == len(r.history) - 1
    assert case.robot.outside_limits(r.history.q[-1]) == -1  # stopped inside the range
    assert run_case(case, "cartesian", gain=2.0, duration=case.duration, tolerance=1e-5).converged
