"""Property-based tests (hypothesis) of ibvs.robot's limit check, the one path every robot command takes:
whatever is asked, what check_command returns never exceeds the speed limits nor the acceleration over one
period, keeps the direction unless it says it ramped, never takes a joint past its position limits within
the period, and anything non-finite or misshapen is refused with an error naming it; Limits are valid or
refused by name."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from ibvs.robot import JointState, LimitError, Limits, check_command

ANY = st.floats(allow_nan=True, allow_infinity=True, width=64)
SPEED = st.floats(-10.0, 10.0)
POS = st.floats(0.01, 5.0)
TOL = 1e-9


@st.composite
def setups(draw):
    n = draw(st.integers(1, 7))
    half = np.array(draw(st.lists(POS, min_size=n, max_size=n)))
    centre = np.array(draw(st.lists(st.floats(-3, 3), min_size=n, max_size=n)))
    dq_max = np.array(draw(st.lists(st.floats(0.01, 3.0), min_size=n, max_size=n)))
    ddq_max = np.array(draw(st.lists(st.floats(0.1, 50.0), min_size=n, max_size=n)))
    lim = Limits(centre - half, centre + half, dq_max, ddq_max)
    frac = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=n, max_size=n)))
    q = centre + frac * half
    last = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=n, max_size=n))) * dq_max
    dq = np.array(draw(st.lists(st.one_of(SPEED, st.just(0.0)), min_size=n, max_size=n)))
    dt = draw(st.sampled_from([0.001, 0.01, 1 / 30, 0.1]))
    return lim, q, last, dq, dt


_UNIT = Limits([-1.0, -1.0], [1.0, 1.0], [1.0, 1.0], [1.0, 1.0])


@settings(max_examples=150, deadline=None)
@given(setups())
@example((_UNIT, np.zeros(2), np.zeros(2), np.array([1e-281, 0.0]), 0.001))  # its squares underflow
@example((_UNIT, np.zeros(2), np.zeros(2), np.array([1.42141081e-306, 0.0]), 0.001))  # a denormal, sent as 0
def test_command_never_exceeds_the_limits_and_keeps_its_direction(setup):
    lim, q, last, dq, dt = setup
    state = JointState(q, last, 0.0)
    try:
        cmd = check_command(dq, state, lim, dt, last)
    except LimitError as e:
        assert "refused" in str(e)
        # refused only when a joint would pass its limits moving outwards (checked on the unscaled request's
        # direction: the scaled command keeps each joint's sign or is ramped)
        return
    out = cmd.dq
    assert np.isfinite(out).all() and out.shape == dq.shape
    assert (np.abs(out) <= lim.dq_max * (1 + TOL)).all()
    assert (np.abs(out - last) <= lim.ddq_max * dt * (1 + TOL) + 1e-12).all()
    q_next = q + out * dt
    assert not (((q_next > lim.q_max) & (out > 0)) | ((q_next < lim.q_min) & (out < 0))).any()
    if "ramped" not in cmd.reason:
        # out = s dq with 0 <= s <= 1: parallel, same sense, not longer
        # (dq / m: a tiny request, 1e-281, whose squares underflow to 0 is still a direction)
        m = float(np.abs(dq).max())
        s = float((out / m) @ (dq / m)) / float((dq / m) @ (dq / m)) if m > 0 else 0.0
        assert -TOL <= s <= 1 + TOL
        np.testing.assert_allclose(out, s * dq, rtol=0, atol=1e-12 * (1 + np.abs(dq).max()))
    assert cmd.clamped == (not np.array_equal(out, dq))


@settings(max_examples=80, deadline=None)
@given(setups(), st.integers(0, 6), st.sampled_from([np.nan, np.inf, -np.inf]))
def test_non_finite_command_refused_naming_it(setup, j, bad):
    lim, q, last, dq, dt = setup
    dq = dq.copy()
    dq[j % dq.size] = bad
    with pytest.raises(ValueError, match=rf"dq\[{j % dq.size}\]"):
        check_command(dq, JointState(q, last, 0.0), lim, dt, last)


@settings(max_examples=80, deadline=None)
@given(setups(), st.integers(0, 3))
def test_wrong_shape_command_refused_naming_it(setup, extra):
    lim, q, last, dq, dt = setup
    assume(extra != 0)
    with pytest.raises(ValueError, match="dq must have shape"):
        check_command(np.zeros(dq.size + extra), JointState(q, last, 0.0), lim, dt, last)


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 4).flatmap(lambda n: st.tuples(*[st.lists(ANY, min_size=n, max_size=n) for _ in range(4)])))
def test_limits_valid_or_refused_by_name(values):
    q_min, q_max, dq_max, ddq_max = values
    try:
        lim = Limits(q_min, q_max, dq_max, ddq_max)
    except ValueError as e:
        assert any(name in str(e) for name in ("q_min", "q_max", "dq_max", "ddq_max")), e
        return
    assert (lim.q_min < lim.q_max).all() and np.isfinite(lim.dq_max).all() and (lim.dq_max > 0).all()
    assert np.isfinite(lim.ddq_max).all() and (lim.ddq_max > 0).all()
