"""Servo: the control law against an independent numpy reference, the paper's qualitative
claims at the first step, closed-loop convergence, and every bad input."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import look

import ibvs

LAYOUTS = {
    "cartesian": ibvs.Layout.cartesian(4),
    "polar": ibvs.Layout.polar(4),
    "hybrid": ibvs.Layout([(0, "cartesian"), (1, "cartesian"), (2, "polar"), (3, "polar")]),
    "stacked": ibvs.Layout.stacked(4),
}


# ---- an independent numpy reference of the same step -------------------------------------------
def ref_blocks(u, v, z, polar):
    if not polar:
        return np.array([[-1 / z, 0, u / z, u * v, -(1 + u * u), v], [0, -1 / z, v / z, 1 + v * v, -u * v, -u]])
    r = np.hypot(u, v)
    c, s = u / r, v / r
    return np.array(
        [[-c / z, -s / z, r / z, (1 + r * r) * s, -(1 + r * r) * c, 0], [s / (r * z), -c / (r * z), 0, c / r, s / r, -1]]
    )


def ref_step(layout, uv, z, uvd, zd, gain, damping, mode, angle_wrap="per_point"):
    J, e, theta_rows = [], [], []
    for i, rep in layout.blocks:
        polar = rep == "polar"
        (u, v), (ud, vd) = uv[i], uvd[i]
        if polar:
            dth = np.arctan2(v, u) - np.arctan2(vd, ud)
            theta_rows.append(len(e) + 1)
            e += [np.hypot(u, v) - np.hypot(ud, vd), (dth + np.pi) % (2 * np.pi) - np.pi]
        else:
            e += [u - ud, v - vd]
        Jc, Jd = ref_blocks(u, v, z[i], polar), ref_blocks(ud, vd, zd[i], polar)
        J.append({"current": Jc, "desired": Jd, "mean": (Jc + Jd) / 2}[mode])
    J, e = np.vstack(J), np.array(e)
    if angle_wrap == "consistent" and theta_rows:  # one rotation: about the circular mean of the differences
        resultant = np.exp(1j * e[theta_rows]).sum()
        if abs(resultant) >= 1e-6 * len(theta_rows):
            mean = np.angle(resultant)
            e[theta_rows] = mean + (e[theta_rows] - mean + np.pi) % (2 * np.pi) - np.pi
    P = np.linalg.pinv(J) if damping == 0 else np.linalg.solve(J.T @ J + damping**2 * np.eye(6), J.T)
    return -gain * P @ e, J, e


@pytest.mark.parametrize("name", LAYOUTS)
@pytest.mark.parametrize("mode", ["current", "desired", "mean"])
@pytest.mark.parametrize("damping", [0.0, 0.02])
@pytest.mark.parametrize("angle_wrap", ["consistent", "per_point"])
def test_law_matches_numpy_reference(rng, name, mode, damping, angle_wrap):
    layout = LAYOUTS[name]
    servo = ibvs.Servo(layout, gain=0.8, damping=damping, jacobian=mode, angle_wrap=angle_wrap)
    for _ in range(20):
        uv, uvd = rng.uniform(-0.3, 0.3, (4, 2)), rng.uniform(-0.3, 0.3, (4, 2))
        z, zd = rng.uniform(0.3, 5, 4), rng.uniform(0.3, 5, 4)
        servo.reset()  # unrelated frames: no branch carried over (the reference has no memory)
        res = servo.update(uv, z, uvd, zd)
        v, J, e = ref_step(layout, uv, z, uvd, zd, 0.8, damping, mode, angle_wrap)
        np.testing.assert_allclose(res.jacobian, J, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(res.error, e, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(res.velocity, v, rtol=1e-8, atol=1e-10)
        assert res.error_norm == pytest.approx(np.linalg.norm(e))
        sv = np.linalg.svd(J, compute_uv=False)
        assert res.sigma_min == pytest.approx(sv[-1], rel=1e-6, abs=1e-7 * sv[0])
        assert res.sigma_max == pytest.approx(sv[0], rel=1e-9)
        assert res.status == ibvs.Status.ok


def test_result_shapes_and_types():
    res = ibvs.Servo(LAYOUTS["stacked"], gain=1.0).update(np.full((4, 2), 0.1) * [[1, 1], [-1, 1], [-1, -1], [1, -1]], 2.0,
                                                           np.full((4, 2), 0.12) * [[1, 1], [-1, 1], [-1, -1], [1, -1]])
    assert res.velocity.shape == (6,) and res.error.shape == (16,) and res.jacobian.shape == (16, 6)
    assert res.velocity.dtype == np.float64 and isinstance(res.error_norm, float)
    assert res.condition == pytest.approx(res.sigma_max / res.sigma_min)
    assert "ServoResult" in repr(res) and "stacked(4)" in repr(ibvs.Servo(LAYOUTS["stacked"], gain=1.0))


def test_diagnostics_off_reports_nan():
    """With diagnostics=False the damped route skips the singular values: sigma_min, sigma_max and
    condition are NaN (not computed), while the twist equals the diagnostics-on twist exactly."""
    start = np.eye(4)
    start[:3, 3] = [0.05, -0.03, -0.2]
    uv, z = look(start)
    uvd, zd = look(np.eye(4))
    on = ibvs.Servo(LAYOUTS["cartesian"], gain=1.0, damping=0.01).update(uv, z, uvd)
    off = ibvs.Servo(LAYOUTS["cartesian"], gain=1.0, damping=0.01, diagnostics=False).update(uv, z, uvd)
    np.testing.assert_array_equal(off.velocity, on.velocity)
    assert np.isnan(off.sigma_min) and np.isnan(off.sigma_max) and np.isnan(off.condition)
    assert np.isfinite(on.condition) and on.condition >= 1.0


def test_condition_is_inf_for_a_singular_jacobian():
    """One point gives a rank-2 J: sigma_min is 0 (to rounding) and condition is inf or huge, never NaN."""
    res = ibvs.Servo(ibvs.Layout.cartesian(1), gain=1.0).update([[0.1, 0.2]], 1.0, [[0.0, 0.0]])
    assert res.sigma_min < 1e-6 * res.sigma_max
    assert not np.isnan(res.condition) and res.condition > 1e6


# ---- the paper's claims, visible in the first control step (Section III-A, Fig. 2) -------------------
def z_rotation_pi():
    uvd, zd = look(np.eye(4))
    T = np.eye(4)
    T[:2, :2] = [[-1, 0], [0, -1]]  # camera rotated by pi about its optical axis
    uv, z = look(T)
    return uv, z, uvd, zd


def test_pi_rotation_cartesian_retreats_polar_rotates():
    uv, z, uvd, zd = z_rotation_pi()
    v_cart = ibvs.Servo(LAYOUTS["cartesian"], gain=1.0).update(uv, z, uvd).velocity
    v_polar = ibvs.Servo(LAYOUTS["polar"], gain=1.0).update(uv, z, uvd).velocity
    # Cartesian IBVS: pure translation backwards along the optical axis, no rotation at all.
    assert v_cart[2] < -0.1
    np.testing.assert_allclose(np.delete(v_cart, 2), 0, atol=1e-9)
    # IBVS-P: pure rotation about the optical axis, |wz| = gain * pi.
    assert abs(v_polar[5]) == pytest.approx(np.pi, rel=1e-9)
    np.testing.assert_allclose(v_polar[:5], 0, atol=1e-9)


def test_pi_rotation_mean_jacobian_is_singular_but_finite():
    uv, z, uvd, zd = z_rotation_pi()
    res = ibvs.Servo(LAYOUTS["cartesian"], gain=1.0, jacobian="mean").update(uv, z, uvd, zd)
    assert res.status == ibvs.Status.singular
    assert np.isfinite(res.velocity).all() and res.sigma_min < 1e-12
    np.testing.assert_allclose(res.velocity, -np.linalg.pinv(res.jacobian, rcond=1e-12) @ res.error, atol=1e-9)


def test_fewer_than_three_points_is_rank_deficient_but_finite():
    res = ibvs.Servo(ibvs.Layout.cartesian(2), gain=1.0).update([[0.1, 0.1], [-0.1, 0.1]], 2.0, [[0.12, 0.1], [-0.1, 0.12]])
    assert res.status == ibvs.Status.singular and np.isfinite(res.velocity).all() and np.linalg.norm(res.velocity) > 0


@pytest.mark.parametrize("damping", [0.0, 0.01])
def test_point_on_optical_axis(damping):
    uv = np.array([[0.0, 0.0], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])
    uvd = uv * 1.2 + [[0.01, 0], [0, 0], [0, 0], [0, 0]]
    res = ibvs.Servo(LAYOUTS["polar"], gain=1.0, damping=damping).update(uv, 1.0, uvd)
    assert res.polar_fallbacks == 1
    assert np.isfinite(res.velocity).all() and np.isfinite(res.jacobian).all()
    np.testing.assert_allclose(res.error[:2], [-0.01, 0.0], atol=1e-15)


# ---- closed loop: exact SE(3) integration at 60 Hz ---------------------------------------------
@pytest.mark.parametrize("name", LAYOUTS)
@pytest.mark.parametrize("mode", ["current", "desired", "mean"])
def test_closed_loop_converges(name, mode):
    uvd, zd = look(np.eye(4))
    T = ibvs.se3_exp([0.03, -0.02, -0.2, 0.02, -0.02, 0.3])
    servo = ibvs.Servo(LAYOUTS[name], gain=2.0, jacobian=mode)
    for _ in range(1200):
        uv, z = look(T)
        res = servo.update(uv, z, uvd, zd)
        if res.error_norm < 1e-9:
            break
        T = T @ ibvs.se3_exp(res.velocity / 60.0)
    assert res.error_norm < 1e-9
    np.testing.assert_allclose(T, np.eye(4), atol=1e-6)


# ---- bad input --------------------------------------------------------------------------------
GOOD = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])


@pytest.mark.parametrize(
    "kwargs, exc, word",
    [
        ({"uv": GOOD[:3]}, ValueError, "uv"),
        ({"uv": GOOD.ravel()}, ValueError, "uv"),
        ({"uv": np.zeros((0, 2))}, ValueError, "uv"),
        ({"uv": np.where(GOOD == 0.1, np.nan, GOOD)}, ValueError, "uv"),
        ({"uv": np.where(GOOD == 0.1, np.inf, GOOD)}, ValueError, "uv"),
        ({"uv": "points"}, TypeError, "uv"),
        ({"uv": None}, TypeError, "uv"),
        ({"uv": [["a", "b"]] * 4}, TypeError, "uv"),
        ({"uv_desired": GOOD[:, :1]}, ValueError, "uv_desired"),
        ({"uv_desired": np.full((4, 2), np.nan)}, ValueError, "uv_desired"),
        ({"depth": -1.0}, ValueError, "depth"),
        ({"depth": 0.0}, ValueError, "depth"),
        ({"depth": np.nan}, ValueError, "depth"),
        ({"depth": [1.0, 1.0, -0.5, 1.0]}, ValueError, r"depth\[2\]"),
        ({"depth": [1.0, 1.0]}, ValueError, "depth"),
        ({"depth": np.ones((4, 1))}, ValueError, "depth"),
        ({"depth": "far"}, TypeError, "depth"),
        ({"depth_desired": [1.0, -1.0, 1.0, 1.0]}, ValueError, "depth_desired"),
    ],
)
def test_update_rejects_bad_input(kwargs, exc, word):
    servo = ibvs.Servo(LAYOUTS["stacked"], gain=1.0, jacobian="mean")
    args = {"uv": GOOD, "depth": 2.0, "uv_desired": GOOD * 1.1, "depth_desired": 2.0}
    args.update(kwargs)
    with pytest.raises(exc, match=word):
        servo.update(**args)


def test_depth_desired_required_for_desired_and_mean():
    for mode in ["desired", "mean"]:
        with pytest.raises(ValueError, match="depth_desired"):
            ibvs.Servo(LAYOUTS["polar"], gain=1.0, jacobian=mode).update(GOOD, 2.0, GOOD)


@pytest.mark.parametrize(
    "kwargs, exc, word",
    [
        ({"gain": -1.0}, ValueError, "gain"),
        ({"gain": 0.0}, ValueError, "gain"),
        ({"gain": float("nan")}, ValueError, "gain"),
        ({"gain": 1.0, "damping": -0.1}, ValueError, "damping"),
        ({"gain": 1.0, "damping": float("inf")}, ValueError, "damping"),
        ({"gain": 1.0, "jacobian": "average"}, ValueError, "jacobian"),
        ({"gain": 1.0, "polar_min_radius": -1.0}, ValueError, "polar_min_radius"),
    ],
)
def test_servo_rejects_bad_options(kwargs, exc, word):
    with pytest.raises(exc, match=word):
        ibvs.Servo(LAYOUTS["polar"], **kwargs)


def test_setters_validate():
    servo = ibvs.Servo(LAYOUTS["polar"], gain=1.0)
    servo.gain = 0.3
    servo.damping = 0.01
    assert servo.gain == 0.3 and servo.damping == 0.01
    with pytest.raises(ValueError, match="gain"):
        servo.gain = -2.0
    with pytest.raises(ValueError, match="damping"):
        servo.damping = -2.0
    assert servo.gain == 0.3


@pytest.mark.parametrize(
    "make, exc, word",
    [
        (lambda: ibvs.Layout.cartesian(0), ValueError, "n"),
        (lambda: ibvs.Layout.stacked(-2), ValueError, "n"),
        (lambda: ibvs.Layout.polar(2.5), TypeError, "n"),
        (lambda: ibvs.Layout([]), ValueError, "blocks"),
        (lambda: ibvs.Layout([(0, "spherical")]), ValueError, r"blocks\[0\]"),
        (lambda: ibvs.Layout([(0, "polar"), (0, 3)]), TypeError, r"blocks\[1\]"),
        (lambda: ibvs.Layout([(-1, "polar")]), ValueError, r"point index\) must be in \[0, "),
        (lambda: ibvs.Layout([(0, "polar"), (0, "polar")]), ValueError, "repeats"),
        (lambda: ibvs.Layout([(5, "polar")], n_points=4), ValueError, "out of range"),
        (lambda: ibvs.Layout([("a", "polar")]), TypeError, "point index"),
        (lambda: ibvs.Layout([(0,)]), TypeError, r"blocks\[0\]"),
        (lambda: ibvs.Layout("polar"), TypeError, "blocks"),
    ],
)
def test_layout_rejects_bad_blocks(make, exc, word):
    with pytest.raises(exc, match=word):
        make()


def test_layout_properties(per_point_hybrid):
    assert per_point_hybrid.rows == 8 and per_point_hybrid.n_points == 4
    assert per_point_hybrid == ibvs.Layout([(0, "cartesian"), (1, "cartesian"), (2, "polar"), (3, "polar")])
    assert per_point_hybrid != ibvs.Layout.cartesian(4)
    assert ibvs.Layout([(0, ibvs.Representation.polar)]) == ibvs.Layout.polar(1)
    assert repr(ibvs.Layout.polar(3)) == "Layout.polar(3)"
    assert ibvs.Layout([(1, "polar")]).n_points == 2
    assert ibvs.Layout([(np.int64(0), "polar")]) == ibvs.Layout.polar(1)


def test_layout_mismatch_between_servo_and_points():
    servo = ibvs.Servo(ibvs.Layout.cartesian(3), gain=1.0)
    with pytest.raises(ValueError, match="uv must hold 3 points"):
        servo.update(GOOD, 1.0, GOOD[:3])


def test_version_matches_distribution_metadata():
    from importlib.metadata import version

    assert ibvs.__version__ == version("ibvs")


def test_cmake_dir_holds_package_config():
    from pathlib import Path

    assert (Path(ibvs.cmake_dir()) / "ibvsConfig.cmake").is_file()


def test_results_are_snapshots_without_copies():
    """Servo.update returns its output buffer itself (no copy): error, jacobian and velocity are
    read-only views of it; a later update writes into another buffer, so a kept result never changes."""
    servo = ibvs.Servo(LAYOUTS["stacked"], gain=1.0)
    uvd = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])
    first = servo.update(uvd * 1.3, 1.0, uvd)
    e1, J1, v1 = first.error.copy(), first.jacobian.copy(), first.velocity.copy()
    view = first.error
    assert not view.flags.writeable and not view.flags.owndata
    assert np.shares_memory(view, first.error)  # a view of the result's buffer, read after read
    with pytest.raises(ValueError):
        view[0] = 1.0
    kept = [servo.update(uvd * (1.0 + 0.1 * k), 1.0, uvd) for k in range(5)]  # results kept: fresh buffers
    assert np.array_equal(first.error, e1) and np.array_equal(first.jacobian, J1) and np.array_equal(first.velocity, v1)
    assert len({r.error.__array_interface__["data"][0] for r in kept}) == 5
    del first, kept, view
    # In a loop that drops its results the servo reuses its buffers: no allocation per call.
    addresses = set()
    for k in range(20):
        res = servo.update(uvd * (1.0 + 0.01 * k), 1.0, uvd)
        addresses.add(res.error.__array_interface__["data"][0])
    assert len(addresses) <= 3
    del res
    # The diagnostics are computed when read, and equal the exact singular values.
    r = servo.update(uvd * 1.3, 1.0, uvd)
    s = np.linalg.svd(r.jacobian, compute_uv=False)
    assert r.sigma_max == pytest.approx(s[0], rel=1e-13) and r.sigma_min == pytest.approx(s[-1], rel=1e-9)


def test_refused_update_leaves_no_stale_values_in_cpp_output():
    """A refusal raises in Python; the servo stays usable and the next result is the new frame's."""
    servo = ibvs.Servo(LAYOUTS["cartesian"], gain=1.0)
    uvd = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])
    with pytest.raises(ValueError, match="depth"):
        servo.update(uvd, 1e-300, uvd)
    with pytest.raises(ValueError, match="pixels"):
        servo.update(uvd * 600 + 320, 1.0, uvd)
    res = servo.update(uvd * 1.1, 1.0, uvd)
    assert res.status == ibvs.Status.ok and np.all(np.isfinite(res.velocity)) and res.sigma_min > 0
