"""Property-based tests (hypothesis) of the 3-D, 2.5-D and user-defined feature blocks: any measurement
of a PbvsFeature or a Point25DFeature (every interaction-matrix mode) and any output of a FunctionFeature's
callable (values, exceptions, wrong shapes) is answered with finite numbers or refused with ValueError."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import ibvs
from test_properties import hostile_arrays

KINDS = {"desired_camera": ibvs.PbvsFeature("desired_camera"), "object": ibvs.PbvsFeature("object"),
         "2.5-D": ibvs.Point25DFeature()}

_any = st.one_of(st.floats(-10, 10), st.floats(allow_nan=True, allow_infinity=True),
                 st.sampled_from([0.0, np.pi, -np.pi, 2 * np.pi, 1e6, 1e-300]))


@settings(max_examples=150)
@given(st.sampled_from(list(KINDS)), hostile_arrays(np.float64, 6, elements=_any),
       hostile_arrays(np.float64, 6, elements=_any), st.sampled_from(["current", "desired", "mean"]))
def test_pose_measurements_finite_or_refused(kind, m, md, jacobian):
    f = KINDS[kind]
    servo = ibvs.Servo(ibvs.Task().add(f), gain=1.0, damping=0.01, jacobian=jacobian)
    none, none_z = np.zeros((0, 2)), np.zeros(0)
    try:
        r = servo.update(none, none_z, none, none_z, measurements=[m], measurements_desired=[md])
    except ValueError as e:
        assert "measurements" in str(e)
        return
    assert np.isfinite(r.velocity).all() and np.isfinite(r.error).all() and np.isfinite(r.jacobian).all()


@settings(max_examples=100)
@given(hostile_arrays(np.float64, 2, elements=_any), hostile_arrays(np.float64, (2, 6), elements=_any),
       st.sampled_from(["ok", "raise", "shape", "none"]))
def test_function_outputs_finite_or_refused(s, L, mode):
    def fn(m):
        if mode == "raise":
            raise RuntimeError("boom")
        if mode == "none":
            return None
        return (s, L) if mode == "ok" else (s, L[:1])

    servo = ibvs.Servo(ibvs.Task().add(ibvs.FunctionFeature(2, 1, fn)), gain=1.0)
    none, none_z = np.zeros((0, 2)), np.zeros(0)
    try:
        r = servo.update(none, none_z, none, measurements=[[0.5]], measurements_desired=[[0.5]])
    except ValueError as e:
        assert "fn" in str(e)
        return
    assert mode == "ok" and np.isfinite(r.velocity).all()
