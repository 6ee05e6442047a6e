"""Property-based tests (hypothesis) of the segment and ellipse blocks of a Task (ibvs.SegmentFeature,
ibvs.EllipseFeature): every input of their measurement functions and of a Servo holding them is answered
with finite numbers or refused with ValueError/TypeError naming the argument; what a measurement function
returns is always accepted by its block; a refusal of the servo is exactly a refusal of the block."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import ibvs

from test_properties import COORD, DEPTH, finite, hostile_arrays
from test_properties_more import ENTRY, assert_finite_episode, refused_by_name

# Measurement entries: anything near the limits or beyond them ...
ANY_SEGMENT = st.tuples(COORD, COORD, st.one_of(st.floats(0.0, 0.5), ENTRY), st.one_of(st.floats(-7, 7), ENTRY),
                        DEPTH, DEPTH)
ANY_ELLIPSE = st.tuples(COORD, COORD, st.one_of(st.floats(0.0, 0.05), ENTRY),
                        st.one_of(st.floats(-0.05, 0.05), ENTRY), st.one_of(st.floats(0.0, 0.05), ENTRY),
                        st.one_of(st.floats(-2, 2), ENTRY), st.one_of(st.floats(-2, 2), ENTRY),
                        st.one_of(st.floats(-1, 3), ENTRY))
HALF = st.floats(-0.5, 0.5)


@st.composite
def plausible(draw, kind):
    """... or a segment / an ellipse on a plane in front of the camera, one entry sometimes replaced by ENTRY."""
    if kind == "segment":
        m = [draw(HALF), draw(HALF), draw(st.floats(1e-9, 1.0)), draw(st.floats(-np.pi, np.pi)),
             draw(st.floats(0.2, 5.0)), draw(st.floats(0.2, 5.0))]
    else:
        a, b, t = draw(st.floats(1e-4, 0.3)), draw(st.floats(1e-4, 0.3)), draw(st.floats(-np.pi, np.pi))
        R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
        N = R @ np.diag([a * a, b * b]) @ R.T / 4
        m = [draw(HALF), draw(HALF), N[0, 0], N[0, 1], N[1, 1], draw(HALF), draw(HALF), draw(st.floats(0.5, 5.0))]
    if draw(st.booleans()):
        m[draw(st.integers(0, len(m) - 1))] = draw(ENTRY)
    return tuple(m)


SEGMENT = st.one_of(plausible("segment"), ANY_SEGMENT)
ELLIPSE = st.one_of(plausible("ellipse"), ANY_ELLIPSE)
VEC3 = hostile_arrays(np.float64, 3, elements=st.one_of(st.floats(-2.0, 5.0), ENTRY))
# A circle's centre in front of the camera, or anything.
CENTRE = st.one_of(st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(0.3, 5.0)).map(np.array), VEC3)


def block_accepts(feature, m) -> bool:
    try:
        feature.value(m)
        return True
    except ValueError:
        return False


@given(st.booleans(), SEGMENT, SEGMENT, st.sampled_from(["current", "desired", "mean"]))
def test_segment_measurements_finite_or_refused(normalized, m, md, jacobian):
    seg = ibvs.SegmentFeature(normalized)
    servo = ibvs.Servo(ibvs.Task(ibvs.Layout.cartesian(1)).add(seg), gain=1.0, jacobian=jacobian)
    try:
        r = servo.update([[0.1, 0.0]], 1.0, [[0.0, 0.1]], 1.0, measurements=[m], measurements_desired=[md])
    except ValueError as e:
        assert refused_by_name(e, "measurements", "measurements_desired")
        assert not (block_accepts(seg, m) and block_accepts(seg, md))
        return
    assert finite(r.velocity, r.error, r.jacobian, seg.value(m), seg.interaction(m), seg.error(m, md))
    assert abs(r.error[5]) <= np.pi / 2 + 1e-12  # alpha's error, the segment taken in its nearest direction


@given(ELLIPSE, ELLIPSE, st.floats(0.1, 100.0))
def test_ellipse_measurements_finite_or_refused(m, md, weight):
    ellipse = ibvs.EllipseFeature()
    servo = ibvs.Servo(ibvs.Task().add(ellipse, weight=weight), gain=1.0, damping=0.01)
    none, none_z = np.zeros((0, 2)), np.zeros(0)
    try:
        r = servo.update(none, none_z, none, measurements=[m], measurements_desired=[md])
    except ValueError as e:
        assert refused_by_name(e, "measurements", "measurements_desired")
        assert not (block_accepts(ellipse, m) and block_accepts(ellipse, md))
        return
    assert finite(r.velocity, r.error, r.jacobian, ellipse.interaction(m))
    n20, n11, n02 = m[2:5]
    assert n20 * n02 - n11 * n11 > 0  # accepted: an ellipse of positive area


@given(hostile_arrays(np.float64, 2, elements=COORD), hostile_arrays(np.float64, 2, elements=COORD), DEPTH, DEPTH,
       VEC3, VEC3)
def test_segment_measure_and_project_finite_or_refused(p1, p2, z1, z2, P1, P2):
    for call, names in [(lambda: ibvs.SegmentFeature.measure(p1, p2, z1, z2), ("p1", "p2", "Z1", "Z2")),
                        (lambda: ibvs.SegmentFeature.project(P1, P2), ("P1", "P2", "P1.z", "P2.z", "p1", "p2"))]:
        try:
            m = call()
        except ValueError as e:
            assert refused_by_name(e, *names) or "distinct" in str(e)
            continue
        assert finite(m) and block_accepts(ibvs.SegmentFeature(), m) and m[2] > 0


@given(CENTRE, VEC3, st.one_of(st.floats(0.0, 0.5), ENTRY))
def test_project_circle_finite_or_refused(centre, normal, radius):
    try:
        m = ibvs.EllipseFeature.project_circle(centre, normal, radius)
    except ValueError as e:
        assert refused_by_name(e, "centre", "normal", "radius") or "circle" in str(e)
        return
    assert finite(m) and block_accepts(ibvs.EllipseFeature(), m)


@given(hostile_arrays(np.float64, 6, elements=st.one_of(st.floats(-1e3, 1e5), ENTRY)),
       hostile_arrays(np.float64, 3, elements=st.one_of(st.floats(-2, 2), ENTRY)), st.booleans())
def test_measure_moments_finite_or_refused(moments, plane, pixels):
    camera = ibvs.CameraModel(600.0, 600.0, 320.0, 240.0) if pixels else None
    try:
        m = ibvs.EllipseFeature.measure_moments(moments, plane, camera)
    except ValueError as e:
        assert refused_by_name(e, "moments", "m00", "mu20", "mu11", "mu02", "m10", "m01") or "the moments" in str(e)
        return
    assert finite(m) and block_accepts(ibvs.EllipseFeature(), m)


# ---- the simulator's segment and circle sources (sim.SegmentSource, sim.EllipseSource)

def _rim_target(n=8, radius=0.3):
    a = 2 * np.pi * np.arange(n) / n
    T = np.eye(4)
    T[2, 3] = 3.0
    return ibvs.sim.Target(np.column_stack([radius * np.cos(a), radius * np.sin(a), np.zeros(n)]), T)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(["segment", "circle"]), st.integers(-2, 5), st.integers(-2, 5),
       hostile_arrays(np.float64, 3, elements=st.one_of(st.floats(-0.3, 0.3), ENTRY)),
       hnp.arrays(np.float64, 3, elements=st.one_of(st.sampled_from([0.0, 1.0]), ENTRY)),
       st.one_of(st.floats(-0.5, 0.5), ENTRY), hnp.arrays(np.float64, 6, elements=st.floats(-1.0, 1.0)),
       st.sampled_from(["exact", "pose", "estimated", "desired"]))
def test_segment_and_circle_sources_finite_or_refused(kind, i, j, centre, normal, radius, twist, depth):
    """A SegmentSource(i, j) on the paper's square or an EllipseSource(centre, normal, radius) on a rim target,
    any arguments (coincident or missing points, a zero or negative radius, a zero normal, a circle seen
    edge-on), then a short episode from any start and depth mode: refused with ValueError / TypeError naming
    the argument (or the goal it cannot be measured at), or finite measurements and errors."""
    sim = ibvs.sim
    try:
        if kind == "segment":
            target = sim.Target.paper().with_features([sim.SegmentSource(i, j)])
            block = ibvs.SegmentFeature()
        else:
            target = _rim_target().with_features([sim.EllipseSource(centre, normal, radius)])
            block = ibvs.EllipseFeature()
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "i", "j", "centre", "normal", "radius", "sources"), e
        return
    try:
        r = sim.run(ibvs.Servo(ibvs.Task().add(block), gain=1.0), sim.Camera.normalized(0.3), target,
                    ibvs.se3_exp(0.3 * twist), np.eye(4), duration=0.1, depth=depth, stop_on_singular=False)
    except ValueError as e:
        assert refused_by_name(e, "goal"), e
        return
    assert_finite_episode(r)
