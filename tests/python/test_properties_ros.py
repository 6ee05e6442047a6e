"""Property-based tests (hypothesis) of ibvs.ros's input paths, as test_properties*.py do for the core:
every CameraInfo, Image, JointState and TFMessage, however malformed, gives finite numbers (a camera
model, an image) or is refused with a ValueError/TypeError naming the field; what is accepted round-trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("rosbags", reason='the ros extra is not installed (pip install ".[ros]")')
from ibvs import ros  # noqa: E402

TS = ros.types.typestore()
T = TS.types
ANY = st.floats(allow_nan=True, allow_infinity=True, width=64)
PLAUSIBLE = st.one_of(st.floats(-2000.0, 2000.0), ANY, st.sampled_from([0.0, 1.0, -1.0, 1e-300, 1e300]))
MODELS = st.sampled_from(["plumb_bob", "rational_polynomial", "equidistant", "visp", "", "none", "fisheye", "PLUMB"])


def _named(e: Exception, prefix: str) -> bool:
    return isinstance(e, (ValueError, TypeError)) and prefix in str(e)


@settings(max_examples=300)
@given(st.integers(0, 5000), st.integers(0, 5000), MODELS, st.lists(PLAUSIBLE, max_size=9),
       st.lists(PLAUSIBLE, min_size=9, max_size=9), st.integers(0, 5), st.integers(0, 5),
       st.tuples(st.integers(0, 700), st.integers(0, 700), st.integers(0, 700), st.integers(0, 700)), st.booleans())
def test_camera_info_finite_or_refused_by_field(width, height, model, d, k, bx, by, roi, rectify):
    roi_msg = T["sensor_msgs/msg/RegionOfInterest"](x_offset=roi[0], y_offset=roi[1], width=roi[2], height=roi[3],
                                                    do_rectify=rectify)
    msg = T["sensor_msgs/msg/CameraInfo"](header=ros.types.header(TS, 0, "c"), height=height, width=width,
                                          distortion_model=model, d=np.array(d, dtype=np.float64),
                                          k=np.array(k, dtype=np.float64), r=np.zeros(9), p=np.zeros(12),
                                          binning_x=bx, binning_y=by, roi=roi_msg)
    try:
        cam = ros.camera_model(msg)
    except (ValueError, TypeError) as e:
        assert _named(e, "camera_info"), e
        return
    assert np.isfinite([cam.px, cam.py, cam.u0, cam.v0, *cam.coefficients]).all()
    assert cam.px > 0 and cam.py > 0 and cam.width >= 1 and cam.height >= 1
    # what is accepted is a camera whose own CameraInfo reads back as the same camera
    back = ros.camera_model(ros.camera_info(cam, TS))
    assert back == cam


ENCODINGS = st.sampled_from(sorted(ros.ENCODINGS) + ["yuv422", "32FC1", "", "MONO8"])


@settings(max_examples=300)
@given(ENCODINGS, st.integers(0, 6), st.integers(0, 6), st.integers(0, 40), st.integers(0, 3),
       st.binary(max_size=200))
def test_image_finite_or_refused_by_field(encoding, height, width, step, big, data):
    msg = T["sensor_msgs/msg/Image"](header=ros.types.header(TS, 0, "c"), height=height, width=width,
                                     encoding=encoding, is_bigendian=big, step=step,
                                     data=np.frombuffer(data, dtype=np.uint8))
    try:
        a = ros.image(msg)
        g = ros.gray8(msg)
    except (ValueError, TypeError) as e:
        assert _named(e, "image"), e
        return
    channels, size = ros.ENCODINGS[encoding]
    assert a.shape[:2] == (height, width) and g.shape == (height, width) and g.dtype == np.uint8
    assert step >= width * channels * size and len(data) >= step * (height - 1) + width * channels * size
    # round trip: the array written as a message reads back the same (mono8 / mono16 / rgb8 / rgba8)
    if encoding in ("mono8", "mono16", "rgb8", "rgba8", "8UC1", "16UC1"):
        np.testing.assert_array_equal(ros.image(ros.image_msg(a, TS)), a)


@settings(max_examples=150)
@given(st.lists(st.text(min_size=1, max_size=3), max_size=5), st.lists(ANY, max_size=6),
       st.lists(st.text(min_size=1, max_size=3), max_size=4))
def test_joint_state_finite_or_refused_by_field(names, positions, asked):
    msg = T["sensor_msgs/msg/JointState"](header=ros.types.header(TS, 0, ""), name=names,
                                          position=np.array(positions, dtype=np.float64), velocity=np.zeros(0),
                                          effort=np.zeros(0))
    try:
        q = ros.joint_positions(msg, asked or None)
    except (ValueError, TypeError) as e:
        assert _named(e, "joint_states"), e
        return
    assert np.isfinite(q).all() and len(q) == len(asked or names)


@settings(max_examples=150)
@given(st.lists(PLAUSIBLE, min_size=7, max_size=7))
def test_tf_finite_or_refused_by_field(x):
    msg = ros.tf_message({("w", "c"): np.eye(4)}, TS)
    tr = msg.transforms[0].transform
    tr.translation.x, tr.translation.y, tr.translation.z = x[:3]
    tr.rotation.x, tr.rotation.y, tr.rotation.z, tr.rotation.w = x[3:]
    try:
        T4 = ros.transforms(msg)[("w", "c")]
    except (ValueError, TypeError) as e:
        assert _named(e, "tf.transforms[0].transform"), e
        return
    assert np.isfinite(T4).all()
    R = T4[:3, :3]
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-9)
