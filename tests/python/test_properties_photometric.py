"""Property tests of the photometric inputs (issue 36, item 5): LuminanceServo's constructor options, goal and
current images, and photometric_moments, with NaN, infinities and huge values at random positions. Every input
is answered with finite numbers (a status for textureless or saturated images, a zero twist unless ok) or refused
with a ValueError/TypeError naming the argument."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from test_properties_more import ENTRY, refused_by_name

import ibvs

W, H_ = 40, 30
CAM = ibvs.CameraModel(px=40.0, py=40.0, u0=19.5, v0=14.5)
U, V = np.meshgrid(np.arange(W), np.arange(H_))
GOAL = 120 + 50 * np.sin(0.35 * U + 0.15 * V) + 40 * np.cos(0.3 * V - 0.2 * U)


@st.composite
def images(draw) -> np.ndarray:
    """A textured, flat or random image, with a few entries (at random positions) set to any float."""
    kind = draw(st.sampled_from(["texture", "flat", "noise", "saturated"]))
    shift = draw(st.floats(-2.0, 2.0))
    im = {"texture": 120 + 50 * np.sin(0.35 * (U + shift) + 0.15 * V) + 40 * np.cos(0.3 * V - 0.2 * U),
          "flat": np.full((H_, W), draw(st.floats(0.0, 255.0))),
          "noise": np.random.default_rng(draw(st.integers(0, 99))).uniform(0, 255, (H_, W)),
          "saturated": np.where(U > 4, 255.0, GOAL)}[kind]
    for _ in range(draw(st.integers(0, 3))):
        im[draw(st.integers(0, H_ - 1)), draw(st.integers(0, W - 1))] = draw(ENTRY)
    return im


@given(st.sampled_from(["desired", "current", "mean"]), st.sampled_from(["levenberg_marquardt", "gauss_newton"]),
       images(), images(), st.booleans())
@settings(max_examples=120)
def test_luminance_inputs_are_answered_or_refused_by_name(jacobian, law, goal, current, as_u8):
    servo = ibvs.LuminanceServo(CAM, W, H_, jacobian=jacobian, law=law, border=4)
    try:
        servo.set_desired(goal)
    except ValueError as e:
        assert refused_by_name(e, "image"), e
        assert not np.isfinite(goal).all() or np.abs(goal).max() > 1e6 or "texture" in str(e)
        return
    if as_u8:
        current = np.nan_to_num(current, nan=0.0, posinf=255.0, neginf=0.0).clip(0, 255).astype(np.uint8)
    try:
        r = servo.update(current)
    except ValueError as e:
        assert refused_by_name(e, "image"), e
        assert not as_u8 and (not np.isfinite(current).all() or np.abs(current).max() > 1e6)
        return
    assert r.status in ("ok", "textureless", "saturated")
    assert np.isfinite(r.twist).all() and np.isfinite(r.error_rms)
    if r.status != "ok":
        assert np.array_equal(r.twist, np.zeros(6))
        assert jacobian == "current"  # the goal's H is checked once; the mean J keeps the goal's gradients


@given(st.lists(ENTRY, min_size=7, max_size=7), st.integers(0, 12))
def test_luminance_options_are_answered_or_refused_by_name(values, border):
    smoothing, gain, mu, a, b, c, cond = values
    try:
        servo = ibvs.LuminanceServo(CAM, W, H_, border=border, smoothing=smoothing, gain=gain, mu=mu,
                                    plane=(a, b, c), min_conditioning=cond)
    except ValueError as e:
        names = ("border", "smoothing", "gain", "mu", "min_conditioning", "plane", "width", "camera")
        assert refused_by_name(e, *names), e
        return
    try:
        servo.set_desired(GOAL)
    except ValueError as e:
        assert "texture" in str(e), e  # an accepted servo refuses only a goal of too little texture
        return
    r = servo.update(GOAL + 3.0 * np.sin(0.2 * U))
    assert np.isfinite(r.twist).all() and r.status in ("ok", "textureless")


@given(images())
def test_photometric_moments_are_finite_or_refused_by_name(image):
    try:
        m = ibvs.photometric_moments(CAM, image)
    except ValueError as e:
        assert refused_by_name(e, "image"), e
        assert not np.isfinite(image).all() or np.abs(image).max() > 1e6
        return
    assert m.shape == (15,) and np.isfinite(m).all()
