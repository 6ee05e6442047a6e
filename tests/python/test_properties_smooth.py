"""Property-based tests (hypothesis) of the smooth law and lost points: every option value and every
validity mask is answered with finite numbers or refused with ValueError/TypeError naming the
argument (decay_rate, max_linear_acceleration, max_angular_acceleration, period, cartesian_near_goal,
stop_time, valid, uv, depth); accepted twists respect the acceleration limits."""

from __future__ import annotations

import re

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import ibvs

ANY = st.one_of(st.floats(-3.0, 30.0), st.floats(allow_nan=True, allow_infinity=True, width=64),
                st.sampled_from([0.0, 5e-324, 1e-300, 1e300, float("inf")]))
OPTIONS = ("decay_rate", "max_linear_acceleration", "max_angular_acceleration", "period", "cartesian_near_goal",
           "stop_time")


def names(e: Exception, *words: str) -> bool:
    return isinstance(e, (ValueError, TypeError)) and any(re.search(rf"(?<![\w.]){re.escape(w)}\b", str(e))
                                                          for w in words)


@settings(max_examples=150, deadline=None)
@given(st.fixed_dictionaries({k: ANY for k in OPTIONS}),
       hnp.arrays(np.float64, (6, 4, 2), elements=st.floats(-0.3, 0.3)),
       hnp.arrays(np.bool_, (6, 4)), st.sampled_from(["cartesian", "polar", "stacked"]))
def test_smooth_servo_finite_or_refused(opts, frames, masks, kind):
    layout = getattr(ibvs.Layout, kind)(4)
    try:
        servo = ibvs.Servo(layout, gain=1.0, **opts)
    except (ValueError, TypeError) as e:
        assert names(e, *OPTIONS, "smoothing.period", "smoothing.decay_rate", "smoothing.max_linear_acceleration",
                     "smoothing.max_angular_acceleration"), e
        return
    uvd = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])
    prev = np.zeros(6)
    for uv, valid in zip(frames, masks):
        uv = uv.copy()
        uv[~valid] = np.nan  # a lost point's values are not read
        r = servo.update(uv, 1.0, uvd, valid=valid)
        assert np.isfinite(r.velocity).all() and np.isfinite(r.error).all() and np.isfinite(r.jacobian).all()
        assert r.lost_points == int((~valid).sum())
        if r.status == ibvs.Status.features_lost:
            assert np.linalg.norm(r.velocity) <= np.linalg.norm(prev) * (1 + 1e-12)
        else:
            dv = r.velocity - prev
            for part, a in ((dv[:3], servo.max_linear_acceleration), (dv[3:], servo.max_angular_acceleration)):
                if np.isfinite(a):  # then period > 0
                    assert np.linalg.norm(part) <= a * servo.period * (1 + 1e-9) + 1e-300
        prev = r.velocity


@settings(max_examples=100, deadline=None)
@given(st.one_of(hnp.arrays(st.sampled_from([np.bool_, np.int64, np.float64]), st.integers(0, 6)),
                 st.lists(st.booleans(), max_size=6), st.none()),
       hnp.arrays(np.float64, (4, 2), elements=st.floats(allow_nan=True, allow_infinity=True, width=64)))
def test_valid_argument_finite_or_refused(valid, uv):
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0)
    uvd = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])
    try:
        r = servo.update(uv, 1.0, uvd, valid=valid)
    except (ValueError, TypeError) as e:
        assert names(e, "valid", "uv") or re.search(r"uv\[\d\]", str(e)), e
        return
    assert np.isfinite(r.velocity).all()
