"""Property-based tests (hypothesis) of the eye-to-hand JointMapping and of ibvs.SecondaryTask. The rule of
test_properties.py: every input is answered with finite numbers or refused with ValueError/TypeError naming the
argument; a valid rigid bMe and finite inputs of moderate size are never refused, and an accepted secondary task
leaves the primary task's feature velocity alone (classical projector)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import ibvs
from test_properties import hostile_arrays
from ibvs import sim

from test_properties_more import ENTRY, refused_by_name

# Moderate entries: zero or 1e-6 <= |x| <= 3 (a subnormal Jacobian has singular values whose inverse overflows:
# refused, as documented, for eye-in-hand and eye-to-hand alike).
MODERATE = st.floats(-3.0, 3.0).map(lambda x: 0.0 if abs(x) < 1e-6 else x)
ANGLE = st.floats(-4.0, 4.0)


@st.composite
def poses(draw):
    """A rigid pose (most), or any 4x4 array."""
    if draw(st.integers(0, 3)) == 0:
        return draw(hostile_arrays(np.float64, (4, 4), elements=ENTRY))
    T = np.eye(4)
    T[:3, :3] = sim.poses.rotation_matrix(*(draw(ANGLE) for _ in range(3)))
    T[:3, 3] = [draw(MODERATE) for _ in range(3)]
    return T


def rigid(T) -> bool:
    R = T[:3, :3]
    if not np.isfinite(T).all() or np.abs(T).max() > 1e6:
        return False
    return bool(np.isfinite(T).all() and np.abs(R.T @ R - np.eye(3)).max() <= 1e-9
                and abs(np.linalg.det(R) - 1) <= 1e-9 and np.all(T[3] == (0, 0, 0, 1)))


@settings(max_examples=150)
@given(st.integers(1, 9), poses(), poses(), st.sampled_from(["end_effector", "base"]), st.data(), st.booleans())
def test_eye_to_hand_mapping_finite_or_refused(n, bMc, bMe, frame, data, hostile):
    elements = ENTRY if hostile else MODERATE
    J = data.draw(hostile_arrays(np.float64, (6, n), elements=elements))
    twist = data.draw(hostile_arrays(np.float64, 6, elements=elements))
    try:
        m = ibvs.JointMapping(n, bMc, frame=frame, mounting="eye_to_hand")
        r = m.update(twist, J, bMe=bMe)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "bMc", "bMe", "twist", "jacobian"), e
        poisoned = not (np.isfinite(J).all() and np.isfinite(twist).all() and np.abs(J).max() < 1e100
                        and np.abs(twist).max() < 1e100)  # hostile_arrays put a NaN, inf or 1e200+ in
        assert hostile or poisoned or not (rigid(bMc) and rigid(bMe)), ("refused within the documented limits", e)
        return
    assert np.isfinite(r.qdot).all() and np.isfinite(r.camera_jacobian).all()


SECONDARY_ARGUMENTS = ("n_joints", "projector", "q_min", "q_max", "rho", "rho1", "lambda_tune", "max_joint_speed",
                       "max_joint_acceleration", "period", "switch_low", "switch_high", "qdot", "camera_jacobian",
                       "interaction", "error", "q", "qdot_previous", "twist", "joints", "task_gram")
OPTION = st.one_of(st.sampled_from([0.1, 0.3, 0.7, 0.0, -1.0, 0.5, 1.0, 2.0, math.inf, math.nan]), st.none())


@settings(max_examples=150)
@given(st.integers(1, 9), st.sampled_from(["classical", "large", "big", 3]), st.booleans(), OPTION, OPTION, OPTION,
       OPTION, OPTION, st.integers(1, 12), st.data(), st.booleans())
def test_secondary_task_finite_or_refused(n, projector, limits, rho, rho1, speed, accel, period, m, data, hostile):
    elements = ENTRY if hostile else MODERATE
    vec = lambda size: data.draw(hostile_arrays(np.float64, size, elements=elements))  # noqa: E731
    kwargs = {k: v for k, v in dict(rho=rho, rho1=rho1, max_joint_speed=speed, max_joint_acceleration=accel,
                                    period=period).items() if v is not None}
    if limits:
        lo = vec(n)
        with np.errstate(over="ignore"):  # two hostile 9e307s add up to inf: a q_max the task must refuse or take
            kwargs.update(q_min=lo, q_max=lo + np.abs(vec(n)) + 0.5)
    L, e, Jc, qdot1 = vec((m, 6)), vec(m), vec((6, n)), vec(n)
    try:
        task = ibvs.SecondaryTask(n, projector=projector, **kwargs)
        r = task.update(qdot1, Jc, L, e, q=vec(n), qdot_previous=vec(n), twist=vec(6), joints=vec(n))
    except (ValueError, TypeError) as err:
        assert refused_by_name(err, *SECONDARY_ARGUMENTS), err
        return
    assert np.isfinite(r.qdot).all() and np.isfinite(r.secondary).all() and np.isfinite(r.avoidance).all()
    assert 0 < r.saturation_scale <= 1 and 0 < r.acceleration_scale <= 1 and 0 <= r.weight <= 1
    if not hostile and projector == "classical":  # the feature velocity of qdot1 kept by the secondary motion
        LJ = L @ Jc
        assert np.abs(LJ @ r.secondary).max() <= 1e-8 * max(1.0, np.abs(LJ).max() * np.abs(r.secondary).max())
