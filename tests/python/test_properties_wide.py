"""Property-based tests (hypothesis) of the wide-field-of-view inputs: CameraModel.from_omnidir,
to_bearing, from_bearing, spherical_measurements and the spherical feature blocks. Every input is
answered with finite numbers (unit bearings) or refused with ValueError/TypeError naming the
argument."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import ibvs
from test_properties import hostile_arrays

from test_properties_more import ENTRY


def refused_by_name(e: Exception, *names: str) -> bool:
    """A ValueError/TypeError whose message names one of the arguments or entries (e.g. "pixels[1]")."""
    return isinstance(e, (ValueError, TypeError)) and any(n in str(e) for n in names)

COEF = st.one_of(st.floats(-0.3, 0.3), ENTRY)
PIXEL = st.one_of(st.floats(-500.0, 2000.0), ENTRY)
K = np.array([[300.0, 0.0, 640.0], [0.0, 300.5, 512.0], [0.0, 0.0, 1.0]])


def camera(kind, xi, d):
    if kind == "omnidir":
        return ibvs.CameraModel.from_omnidir(K, xi, d, 1280, 1024)
    return ibvs.CameraModel.from_opencv(K, d, 1280, 1024, fisheye=True)


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(["omnidir", "fisheye"]), st.one_of(st.floats(0.0, 3.0), ENTRY), st.lists(COEF, min_size=4, max_size=4),
       hostile_arrays(np.float64, (3, 2), elements=PIXEL), hostile_arrays(np.float64, (3, 3), elements=ENTRY))
def test_bearings_finite_or_refused(kind, xi, d, px, b):
    try:
        cam = camera(kind, xi, d)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "xi", "D", "dist", "dist[0]", "dist[1]", "dist[2]", "dist[3]", "D[0]", "D[1]",
                               "D[2]", "D[3]"), e
        return
    assert 0 < cam.max_angle <= np.pi and cam.field_of_view > 0
    try:
        out = cam.to_bearing(px)
        assert np.isfinite(out).all() and np.allclose(np.linalg.norm(out, axis=1), 1.0, atol=1e-12)
    except ValueError as e:
        assert refused_by_name(e, "pixels[0]", "pixels[1]", "pixels[2]"), e
    nan = cam.to_bearing(px, invalid="nan")
    assert all(np.isfinite(r).all() or np.isnan(r).all() for r in nan)
    try:
        out = cam.from_bearing(b)
        assert np.isfinite(out).all()
    except ValueError as e:
        assert refused_by_name(e, "bearings[0]", "bearings[1]", "bearings[2]"), e


@settings(max_examples=150, deadline=None)
@given(hostile_arrays(np.float64, 4, elements=ENTRY), hostile_arrays(np.float64, 4, elements=ENTRY),
       st.sampled_from([ibvs.SphericalPointFeature(), ibvs.SphericalPolarFeature()]), st.booleans())
def test_spherical_blocks_finite_or_refused(m, md, f, unit):
    if unit:  # a valid bearing most of the time: the evaluation itself is exercised
        with np.errstate(all="ignore"):
            for v in (m, md):
                n = np.linalg.norm(v[:3])
                if np.isfinite(n) and n > 0:
                    v[:3] /= n
    try:
        s, e, L = f.value(m), f.error(m, md), f.interaction(m)
        assert np.isfinite(s).all() and np.isfinite(e).all() and np.isfinite(L).all()
        rows = f.axis_angle_rows(m, md)  # the azimuth row of a spherical-polar block off the axis, else none
        assert rows in ([], [1]) and (rows == [] or isinstance(f, ibvs.SphericalPolarFeature))
    except ValueError as err:
        assert refused_by_name(err, *(f"measurement[{i}]" for i in range(4)),
                               *(f"measurement_desired[{i}]" for i in range(4)), "measurement",
                               "measurement_desired"), err


@settings(max_examples=80, deadline=None)
@given(hostile_arrays(np.float64, (2, 2), elements=PIXEL), hostile_arrays(np.float64, 2, elements=ENTRY))
def test_spherical_measurements_finite_or_refused(px, R):
    cam = camera("fisheye", 0.0, [-0.013, 0.02, -0.012, 0.002])
    try:
        m = ibvs.spherical_measurements(cam, px, R)
        assert np.isfinite(m).all()
    except ValueError as e:
        assert refused_by_name(e, "pixels[0]", "pixels[1]", "distance[0]", "distance[1]"), e


@settings(max_examples=60, deadline=None)
@given(hnp.arrays(np.float64, 3, elements=st.floats(-4.0, 4.0)),
       hnp.arrays(np.float64, 3, elements=st.floats(-3.0, 3.0)),
       st.sampled_from(["cartesian", "polar_per_point", "spherical", "spherical_stacked"]),
       hostile_arrays(np.float64, (4, 4), elements=ENTRY))
def test_wide_study_runs_finite_or_refused(rotation, translation, scheme, junk):
    """ibvs.study.wide.run: any rigid start ends in one of its outcomes with finite metrics; a start that is
    not a finite rigid transform is refused, naming it."""
    from ibvs import sim
    from ibvs.study import wide

    T = ibvs.se3_exp(np.r_[translation, rotation])
    o, _ = wide.run(scheme, T, duration=0.2)
    assert o.outcome in sim.OUTCOMES + ("cannot_see", "left_perspective")
    assert all(np.isfinite([o.camera_retreat, o.path_length, o.peak_linear_speed, o.peak_angular_speed,
                            o.final_translation_error, o.final_rotation_error]))
    try:
        wide.run(scheme, junk, duration=0.2)
    except ValueError as e:
        assert "start" in str(e)


@settings(max_examples=60, deadline=None)
@given(st.one_of(st.floats(80.0, 310.0), ENTRY), hnp.arrays(np.float64, 3, elements=st.floats(-2.0, 2.0)))
def test_wide_study_lens_of_any_fov_finite_or_refused(fov, rotation):
    """ibvs.study.wide's lens of full field of view fov: in [90, 300] degrees a camera whose image circle is
    fov/2 off the axis and a run with finite metrics from any start; otherwise ValueError naming fov."""
    import math

    from ibvs.study import wide

    try:
        cam = wide.camera(fov)
    except ValueError as e:
        assert "fov" in str(e) and not 90.0 <= fov <= 300.0
        return
    assert 90.0 <= fov <= 300.0
    assert abs(cam.px * math.radians(fov / 2) - wide.SENSOR / 2) < 1e-9
    o, _ = wide.run("spherical", ibvs.se3_exp(np.r_[0.0, 0.0, 0.0, rotation]), cam, duration=0.1)
    assert np.isfinite([o.camera_retreat, o.path_length, o.final_translation_error]).all()
