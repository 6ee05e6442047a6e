"""Partitioned IBVS (Corke & Hutchinson 2001): feature Jacobians against central differences,
the decoupled laws, convergence without retreat on the z-rotation pi, and bad input."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import look
from test_jacobian import moved_uv

import ibvs

GOOD = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])


def test_feature_jacobians_match_finite_differences(rng):
    for _ in range(100):
        n = rng.integers(3, 7)
        uv, z = rng.uniform(-0.4, 0.4, (n, 2)), rng.uniform(0.3, 5.0, n)
        if ibvs.area_scale(uv) < 0.05 or np.hypot(*(uv[1] - uv[0])) < 0.05:
            continue  # keep the central-difference truncation error (~h^2 / size^3) small
        P = np.column_stack([uv * z[:, None], z])
        h = 1e-6
        Jt, Js = [], []
        for d in h * np.eye(6):
            a = np.array([moved_uv(p, d) for p in P])
            b = np.array([moved_uv(p, -d) for p in P])
            Jt.append(ibvs.wrap_angle(ibvs.segment_angle(a, 0, 1) - ibvs.segment_angle(b, 0, 1)) / (2 * h))
            Js.append((ibvs.area_scale(a) - ibvs.area_scale(b)) / (2 * h))
        Ja, Jsa = ibvs.segment_angle_jacobian(uv, z, 0, 1), ibvs.area_scale_jacobian(uv, z)
        np.testing.assert_allclose(Ja, Jt, rtol=1e-6, atol=1e-6 * max(1, np.abs(Ja).max()))
        np.testing.assert_allclose(Jsa, Js, rtol=1e-6, atol=1e-6 * max(1, np.abs(Jsa).max()))


def test_feature_jacobians_are_the_stubs_shape():
    """(6,) arrays, as the stub _core.pyi says: its docstrings and the signatures help() shows (no [1, 6] row)."""
    stub = (Path(ibvs.__file__).parent / "_core.pyi").read_text()
    for name, call in (("segment_angle_jacobian", lambda: ibvs.segment_angle_jacobian(GOOD, 1.0, 0, 1)),
                       ("area_scale_jacobian", lambda: ibvs.area_scale_jacobian(GOOD, 1.0))):
        J = call()
        assert isinstance(J, np.ndarray) and J.shape == (6,) and J.dtype == np.float64, (name, J.shape)
        declared = re.search(rf"def {name}\(.*\) -> (\w+):\n\s+\"\"\"(\(\d+,\))", stub)
        assert declared and declared.groups() == ("_FloatArray", "(6,)"), name
        assert "[1, 6]" not in getattr(ibvs, name).__doc__, name


def test_area_scale_and_angle_values():
    assert ibvs.area_scale(GOOD) == pytest.approx(0.2)
    assert ibvs.segment_angle(GOOD, 0, 1) == pytest.approx(np.pi)


def test_segment_angle_refuses_what_its_jacobian_refuses():
    """Two coincident points have no segment: both refuse them with the same ValueError (segment_angle said 0.0)."""
    uv = np.array([[0.1, -0.05], [0.1, -0.05], [-0.2, 0.3]])
    messages = []
    for call in (lambda: ibvs.segment_angle(uv, 0, 1), lambda: ibvs.segment_angle(uv, 1, 0),
                 lambda: ibvs.segment_angle_jacobian(uv, [1.0, 1.5, 2.0], 0, 1)):
        with pytest.raises(ValueError, match=r"^uv: points i and j coincide \(theta_z undefined\)$") as e:
            call()
        messages.append(str(e.value))
    assert len(set(messages)) == 1
    for call in (lambda: ibvs.segment_angle(uv, 0, 0), lambda: ibvs.segment_angle_jacobian(uv, 1.0, 2, 2)):
        with pytest.raises(ValueError, match="distinct"):
            call()
    assert np.isfinite(ibvs.segment_angle(uv, 0, 2)) and np.isfinite(ibvs.segment_angle_jacobian(uv, 1.0, 0, 2)).all()
    uv[1, 0] = np.nextafter(0.1, 1.0)  # one ulp apart: a segment
    assert ibvs.segment_angle(uv, 0, 1) == 0.0 and np.isfinite(ibvs.segment_angle_jacobian(uv, 1.0, 0, 1)).all()


def test_decoupled_laws_at_the_first_step():
    uv = np.array([[0.1, 0.09], [-0.12, 0.1], [-0.1, -0.1], [0.11, -0.13]])
    uvd = 2 * GOOD
    res = ibvs.PartitionedServo(4, gain=0.8).update(uv, 1.0, uvd)
    wz = 0.8 * ibvs.wrap_angle(ibvs.segment_angle(uv, 0, 1) - ibvs.segment_angle(uvd, 0, 1))
    assert res.velocity[5] == pytest.approx(wz, abs=1e-15)
    assert res.velocity[2] == pytest.approx(0.8 * np.log(ibvs.area_scale(uvd) / ibvs.area_scale(uv)), abs=1e-15)
    J = res.jacobian
    b = -(0.8 * (uv - uvd).ravel() + J[:, 2] * res.velocity[2] + J[:, 5] * res.velocity[5])
    np.testing.assert_allclose(res.velocity[[0, 1, 3, 4]], np.linalg.pinv(J[:, [0, 1, 3, 4]]) @ b, atol=1e-10)


def run(start, frames=4000, **kw):
    uvd, zd = look(np.eye(4))
    T = ibvs.se3_exp(start)
    z0, retreat, lateral = T[2, 3], 0.0, 0.0
    servo = ibvs.PartitionedServo(4, gain=1.0, **kw)
    for _ in range(frames):
        uv, z = look(T)
        retreat = max(retreat, z0 - T[2, 3])
        res = servo.update(uv, z, uvd, zd)
        lateral = max(lateral, np.abs(res.velocity[[0, 1, 3, 4]]).max())
        if res.error_norm < 1e-9:
            break
        T = T @ ibvs.se3_exp(res.velocity / 60.0)
    return res, T, retreat, lateral


def test_z_rotation_pi_is_a_pure_rotation_without_retreat():
    res, T, retreat, lateral = run([0, 0, 0, 0, 0, np.pi - 1e-6])
    assert res.error_norm < 1e-9 and retreat < 1e-9 and lateral < 1e-9
    np.testing.assert_allclose(T, np.eye(4), atol=1e-6)


@pytest.mark.parametrize("start", [[0.2, 0, 0, 0, 0, 0], [0.1, -0.08, -0.3, 0.1, -0.08, 1.2]])
@pytest.mark.parametrize("damping", [0.0, 0.001])
def test_converges_on_translation_and_general_motion(start, damping):
    res, T, _, _ = run(start, damping=damping)
    assert res.error_norm < 1e-9
    np.testing.assert_allclose(T, np.eye(4), atol=1e-6)


@pytest.mark.parametrize(
    "make, exc, word",
    [
        (lambda: ibvs.PartitionedServo(2, gain=1.0), ValueError, "n_points"),
        (lambda: ibvs.PartitionedServo(4.5, gain=1.0), TypeError, "n_points"),
        (lambda: ibvs.PartitionedServo(4, gain=-1.0), ValueError, "gain"),
        (lambda: ibvs.PartitionedServo(4, gain=1.0, damping=-1.0), ValueError, "damping"),
        (lambda: ibvs.PartitionedServo(4, gain=1.0, segment=(1, 1)), ValueError, "segment"),
        (lambda: ibvs.PartitionedServo(4, gain=1.0, segment=(0, 9)), ValueError, "segment"),
        (lambda: ibvs.PartitionedServo(4, gain=1.0, segment="ab"), TypeError, "segment"),
        (lambda: ibvs.PartitionedServo(4, gain=1.0).update(GOOD[:3], 1.0, GOOD), ValueError, "uv"),
        (lambda: ibvs.PartitionedServo(4, gain=1.0).update(GOOD, -1.0, GOOD), ValueError, "depth"),
        (lambda: ibvs.PartitionedServo(4, gain=1.0).update(GOOD, 1.0, np.nan * GOOD), ValueError, "uv_desired"),
        (lambda: ibvs.PartitionedServo(4, gain=1.0).update(GOOD, 1.0, "x"), TypeError, "uv_desired"),
        (lambda: ibvs.PartitionedServo(4, gain=1.0).update(GOOD * [1, 0], 1.0, GOOD), ValueError, "uv"),
    ],
)
def test_bad_input_raises_naming_the_argument(make, exc, word):
    with pytest.raises(exc, match=word):
        make()


def test_properties():
    s = ibvs.PartitionedServo(4, gain=0.5, segment=(1, 3))
    assert s.n_points == 4 and s.segment == (1, 3) and s.layout == ibvs.Layout.cartesian(4)
    s.gain = 0.7
    assert s.gain == 0.7 and "PartitionedServo(4" in repr(s)


def test_speed_limits_are_kept_and_readable():
    servo = ibvs.PartitionedServo(4, gain=5.0, max_linear_speed=0.05, max_angular_speed=0.2)
    assert (servo.max_linear_speed, servo.max_angular_speed) == (0.05, 0.2)
    assert ibvs.PartitionedServo(4, gain=1.0).max_linear_speed == np.inf
    uvd, zd = look(np.eye(4))
    uv, z = look(ibvs.se3_exp([0.1, -0.08, -0.3, 0.1, -0.08, 1.2]))
    res = servo.update(uv, z, uvd, zd)
    assert res.saturated
    assert np.linalg.norm(res.velocity[:3]) <= 0.05 + 1e-12 and np.linalg.norm(res.velocity[3:]) <= 0.2 + 1e-12
