"""ibvs.SegmentFeature from Python: its interaction matrix against central differences of its own
projection (both feature sets), the unoriented segment (its reverse is the same segment), a task of
two segments closing the loop from a general start, and the refusals (ValueError naming the entry).
tests/cpp/test_segment.cpp checks the same rows against ViSP's closed form."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs


def moved(P, xi):
    """Camera-frame point P seen from the camera moved by twist xi."""
    T = np.linalg.inv(ibvs.se3_exp(xi))
    return T[:3, :3] @ P + T[:3, 3]


@pytest.mark.parametrize("normalized", [True, False])
def test_segment_interaction_is_the_derivative_of_its_projection(rng, normalized):
    seg = ibvs.SegmentFeature(normalized)
    checked = 0
    for _ in range(100):
        P1, P2 = (np.append(rng.uniform(-0.5, 0.5, 2), 1.0) * rng.uniform(0.3, 5.0) for _ in range(2))
        m = ibvs.SegmentFeature.project(P1, P2)
        if m[2] < 0.02:  # short: the 1/l rows are steep for a step of 1e-6
            continue
        L, h, Ln = seg.interaction(m), 1e-6, np.zeros((4, 6))
        for k in range(6):
            xi = np.zeros(6)
            xi[k] = h
            a = seg.value(ibvs.SegmentFeature.project(moved(P1, xi), moved(P2, xi)))
            b = seg.value(ibvs.SegmentFeature.project(moved(P1, -xi), moved(P2, -xi)))
            Ln[:, k] = np.append((a[:3] - b[:3]) / (2 * h), ibvs.wrap_angle(a[3] - b[3]) / (2 * h))
        assert np.allclose(L, Ln, rtol=0, atol=1e-6 * max(1.0, np.abs(L).max()))
        checked += 1
    assert checked > 80


def test_measure_values_and_the_reverse_segment():
    m = ibvs.SegmentFeature.measure([0.1, 0.2], [0.1, -0.2], 1.0, 2.0)
    assert np.allclose(m, [0.1, 0.0, 0.4, -np.pi / 2, 1.0, 2.0], rtol=0, atol=1e-15)
    assert np.allclose(ibvs.SegmentFeature().value(m), [0.25, 0.0, 2.5, -np.pi / 2], rtol=0, atol=1e-15)
    assert np.allclose(ibvs.SegmentFeature(normalized=False).value(m), m[:4], rtol=0, atol=0)
    assert np.array_equal(ibvs.SegmentFeature.project([0.1, 0.2, 1.0], [0.2, -0.4, 2.0]), m)
    # The same segment taken from its other end: no error (it is unoriented), whatever the feature set.
    r = ibvs.SegmentFeature.measure([0.1, -0.2], [0.1, 0.2], 2.0, 1.0)
    for normalized in (True, False):
        assert np.abs(ibvs.SegmentFeature(normalized).error(r, m)).max() < 1e-14
    # A goal turned by 100 degrees about the segment's centre: the error is the 80 degrees the other way.
    g = m.copy()
    g[3] = ibvs.wrap_angle(m[3] + np.radians(100))
    assert ibvs.SegmentFeature().error(m, g)[3] == pytest.approx(np.radians(80), abs=1e-12)
    assert repr(ibvs.SegmentFeature()) == "<ibvs feature segment>"
    assert repr(ibvs.SegmentFeature(False)) == "<ibvs feature segment(plain)>"


def segments_seen(T_wc, corners):
    """Measurements of the segments between consecutive corners (world frame) seen from pose T_wc."""
    T = np.linalg.inv(T_wc)
    P = corners @ T[:3, :3].T + T[:3, 3]
    return [ibvs.SegmentFeature.project(P[i], P[(i + 1) % len(P)]) for i in range(len(P))]


@pytest.mark.parametrize("normalized", [True, False])
def test_segments_close_the_loop(normalized):
    """Two edges of the paper's square (8 rows), integrated pose: the camera reaches the goal pose."""
    corners = np.array([[0.25, 0.25, 3.0], [-0.25, 0.25, 3.0], [-0.25, -0.25, 3.0]])
    task = ibvs.Task().add(ibvs.SegmentFeature(normalized)).add(ibvs.SegmentFeature(normalized))
    servo = ibvs.Servo(task, gain=1.0)
    goal = segments_seen(np.eye(4), corners)[:2]
    T, none, none_z = ibvs.se3_exp([0.1, -0.08, -0.4, 0.1, -0.12, 0.5]), np.zeros((0, 2)), np.zeros(0)
    for _ in range(3000):
        r = servo.update(none, none_z, none, measurements=segments_seen(T, corners)[:2], measurements_desired=goal)
        if r.error_norm < 1e-9:
            break
        T = T @ ibvs.se3_exp(r.velocity / 60)
    assert r.error_norm < 1e-9
    assert np.abs(T - np.eye(4)).max() < 1e-7


def test_refusals_name_the_entry():
    seg = ibvs.SegmentFeature()
    good = [0.1, -0.1, 0.3, 0.5, 1.0, 2.0]
    assert np.isfinite(seg.interaction(good)).all()
    for entry, bad, why in [(0, np.nan, "not finite"), (2, 0.0, "length is zero"), (2, 1e-12, "length is zero"),
                            (3, 7.0, "alpha"), (5, -2.0, "depth"), (0, 11.0, "normalised-coordinate")]:
        m = list(good)
        m[entry] = bad
        with pytest.raises(ValueError, match=rf"measurement\[{entry}\]: .*{why}"):
            seg.value(m)
    with pytest.raises(ValueError, match="distinct"):
        ibvs.SegmentFeature.measure([0.1, 0.1], [0.1, 0.1], 1.0, 1.0)
    with pytest.raises(ValueError, match="Z2"):
        ibvs.SegmentFeature.measure([0.1, 0.1], [0.2, 0.1], 1.0, -1.0)
    with pytest.raises(ValueError, match="P1.z"):
        ibvs.SegmentFeature.project([0.1, 0.1, -1.0], [0.2, 0.1, 1.0])
    with pytest.raises(ValueError, match="p2"):
        ibvs.SegmentFeature.measure([0.1, 0.1], [320.0, 240.0], 1.0, 1.0)  # pixels
    with pytest.raises(TypeError, match="normalized"):
        ibvs.SegmentFeature("yes")
    # The servo refuses the same measurement, naming the block.
    servo = ibvs.Servo(ibvs.Task(ibvs.Layout.cartesian(1)).add(ibvs.SegmentFeature()), gain=1.0)
    zero = list(good)
    zero[2] = 0.0
    with pytest.raises(ValueError, match=r"measurements_desired\[0\]\[2\]"):
        servo.update([[0.1, 0.0]], 1.0, [[0.0, 0.1]], measurements=[good], measurements_desired=[zero])
