"""Image-boundary potential (paper Section IV, Fig. 4 C -> D): IBVS-P loses a point on the
corner-to-corner case; with boundary_margin every point stays in view and it converges."""

import numpy as np
import pytest

import ibvs
import ibvs.sim as sim


def run(case, **kw):
    servo = ibvs.Servo(ibvs.Layout.polar(4), gain=1.0)
    kw = {"duration": case.duration, "tolerance": 1e-5, **kw}
    return sim.run(servo, case.camera, case.target, case.start, case.goal, **kw)


def test_corner_to_corner_geometry():
    case = sim.cases.corner_to_corner()
    assert case.extra["C"] == (0.36, 0.75) and case.extra["D"] == (0.36, -0.75)
    r = run(case, duration=0.02)  # one frame: the start as the controller sees it
    rt0 = r.history.rtheta[0]
    assert np.allclose(rt0[:, 0], 0.36) and np.isclose(rt0[0, 1], 0.75)
    ud = r.uv_desired
    assert np.isclose(np.arctan2(ud[0, 1], ud[0, 0]), -0.75) and np.allclose(np.hypot(*ud.T), 0.36)
    # start and goal in view, the straight polar path C -> D not (r = 0.36 > 0.3 at theta = 0)
    assert np.abs(ud).max() < 0.3 and np.abs(r.history.uv[0]).max() < 0.3


def test_plain_ibvs_p_loses_a_point():
    r = run(sim.cases.corner_to_corner())
    assert r.status.outcome == "left_image" and r.status.point >= 0
    assert r.metrics.camera_retreat < 1e-9


def test_boundary_potential_keeps_every_point_in_view_and_converges():
    case = sim.cases.corner_to_corner()
    r = run(case, boundary_margin=0.03, boundary_gain=0.1)
    assert r.status.outcome == "converged", r
    uv = r.history.uv
    assert np.abs(uv).max() < 0.3  # every point, every frame
    assert r.metrics.camera_retreat > 0.1  # it got there by retreating
    assert r.metrics.final_rotation_error < 1e-4 and r.metrics.final_translation_error < 1e-4
    # the retreat is all in Tz; rotation about the optical axis does the rest
    assert np.nanmax(np.abs(r.history.twist[:, [0, 1, 3, 4]])) < 1e-6


@pytest.mark.parametrize("gain", [0.02, 0.1, 0.5])
def test_boundary_gains(gain):
    r = run(sim.cases.corner_to_corner(), boundary_margin=0.03, boundary_gain=gain)
    assert r.status.outcome == "converged" and np.abs(r.history.uv).max() < 0.3


def test_inert_far_from_the_border():
    case = sim.cases.z_rotation()
    a = run(case, duration=3.0)
    b = run(case, duration=3.0, boundary_margin=0.05)
    assert np.array_equal(a.history.twist, b.history.twist)


def test_boundary_arguments():
    case = sim.cases.corner_to_corner()
    with pytest.raises(ValueError, match="boundary_margin"):
        run(case, boundary_margin=-1.0)
    with pytest.raises(ValueError, match="boundary_gain"):
        run(case, boundary_margin=0.03, boundary_gain=float("nan"))
    with pytest.raises(TypeError, match="boundary_margin"):
        run(case, boundary_margin="0.03")
