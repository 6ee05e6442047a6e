"""ibvs.ros conversions, with rosbags' ROS 2 message classes (no ROS installation): round trips
message -> ibvs -> message, known values, and malformed messages refused with an error naming the field."""

from __future__ import annotations

import dataclasses
import sys
from types import SimpleNamespace

import numpy as np
import pytest

import ibvs

pytest.importorskip("rosbags", reason='the ros extra is not installed (pip install ".[ros]")')
from ibvs import ros  # noqa: E402

TS = ros.types.typestore()
T = TS.types


def info_msg(**over):
    """A 640x480 plumb_bob CameraInfo (the fields a camera driver publishes), with fields replaced."""
    fields = dict(header=ros.types.header(TS, 0, "cam"), height=480, width=640, distortion_model="plumb_bob",
                  d=np.array([-0.1, 0.02, 0.001, -0.002, 0.003]),
                  k=np.array([600.0, 0.0, 320.5, 0.0, 601.0, 239.5, 0.0, 0.0, 1.0]), r=np.eye(3).reshape(-1),
                  p=np.zeros(12), binning_x=0, binning_y=0,
                  roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0,
                                                            do_rectify=False))
    fields.update(over)
    return T["sensor_msgs/msg/CameraInfo"](**fields)


def roundtrip(msg):
    """A message serialised to CDR and read back, as a bag or a subscription delivers it."""
    return TS.deserialize_cdr(TS.serialize_cdr(msg, msg.__msgtype__), msg.__msgtype__)


# ---------------------------------------------------------------------------- CameraInfo

def test_camera_info_to_model_known_values():
    cam = ros.camera_model(info_msg(), fps=30.0)
    assert (cam.px, cam.py, cam.u0, cam.v0) == (600.0, 601.0, 320.5, 239.5)
    assert cam.distortion == "plumb_bob" and cam.coefficients == (-0.1, 0.02, 0.001, -0.002, 0.003)
    assert cam.bounds == (0.0, 640.0, 0.0, 480.0) and cam.fps == 30.0
    # the same camera as OpenCV's K and dist give
    ref = ibvs.CameraModel.from_opencv([[600.0, 0, 320.5], [0, 601.0, 239.5], [0, 0, 1]],
                                       [-0.1, 0.02, 0.001, -0.002, 0.003], 640, 480, fps=30.0)
    assert cam == ref


@pytest.mark.parametrize("model", [
    ibvs.CameraModel.from_opencv([[600.0, 0, 320.5], [0, 601.0, 239.5], [0, 0, 1]], [-0.1, 0.02, 0.001, -0.002, 0.003],
                                 640, 480),
    ibvs.CameraModel.from_opencv([[300.0, 0, 160], [0, 300.0, 120], [0, 0, 1]], [0.1, -0.01, 0.002, -0.001], 320, 240,
                                 fisheye=True),
    ibvs.CameraModel(800.0, 800.0, 320.0, 240.0, 0.0, 0.0, 640.0, 480.0),
    ibvs.CameraModel.afma6(),
], ids=["plumb_bob", "equidistant", "none", "visp"])
def test_model_to_camera_info_and_back_is_exact(model):
    msg = roundtrip(ros.camera_info(model, TS, "cam", 1_500_000_000))
    assert msg.header.stamp.sec == 1 and msg.header.stamp.nanosec == 500_000_000 and msg.header.frame_id == "cam"
    back = ros.camera_model(msg, fps=model.fps)
    assert back == model
    assert back.distortion == model.distortion and back.coefficients == model.coefficients
    # and the message of the model read back is the same message
    again = ros.camera_info(back, TS, "cam", 1_500_000_000)
    for f in ("distortion_model", "width", "height"):
        assert getattr(again, f) == getattr(msg, f)
    for f in ("d", "k", "r", "p"):
        np.testing.assert_array_equal(getattr(again, f), getattr(msg, f))
    u = np.array([[10.5, 20.25], [600.0, 400.0]])
    np.testing.assert_array_equal(back.normalize(u), model.normalize(u))


def test_no_distortion_is_written_as_plumb_bob_zeros():
    msg = ros.camera_info(ibvs.CameraModel(800.0, 800.0, 320.0, 240.0, 0.0, 0.0, 640.0, 480.0), TS)
    assert msg.distortion_model == "plumb_bob" and list(msg.d) == [0.0] * 5
    assert list(msg.p) == [800.0, 0, 320.0, 0, 0, 800.0, 240.0, 0, 0, 0, 1.0, 0]


def test_rational_polynomial_with_zero_k4_k5_k6_is_plumb_bob():
    d = np.array([-0.1, 0.02, 0.001, -0.002, 0.003, 0.0, 0.0, 0.0])
    cam = ros.camera_model(info_msg(distortion_model="rational_polynomial", d=d))
    assert cam.distortion == "plumb_bob" and cam.coefficients == tuple(d[:5])
    with pytest.raises(ValueError, match=r"camera_info\.d: rational_polynomial with k4, k5, k6"):
        ros.camera_model(info_msg(distortion_model="rational_polynomial", d=np.r_[d[:5], 0.1, 0, 0]))


def test_binning_and_roi_as_image_geometry():
    roi = T["sensor_msgs/msg/RegionOfInterest"](x_offset=100, y_offset=40, height=400, width=320, do_rectify=False)
    cam = ros.camera_model(info_msg(binning_x=2, binning_y=2, roi=roi))
    assert (cam.px, cam.py) == (300.0, 300.5)
    assert (cam.u0, cam.v0) == ((320.5 - 100) / 2, (239.5 - 40) / 2)
    assert cam.bounds == (0.0, 160.0, 0.0, 200.0)
    # a pixel of the binned ROI image sees what the full-resolution pixel it came from sees
    full = ros.camera_model(info_msg())
    p = np.array([[50.0, 70.0]])
    np.testing.assert_allclose(cam.normalize(p), full.normalize(p * 2 + [100, 40]), rtol=0, atol=1e-12)


@pytest.mark.parametrize("change, field", [
    (dict(d=np.zeros(4)), r"camera_info\.d: distortion_model 'plumb_bob' has 5 coefficients, got 4"),
    (dict(distortion_model="equidistant"), r"camera_info\.d: .*'equidistant' has 4 coefficients, got 5"),
    (dict(distortion_model="fisheye62"), r"camera_info\.distortion_model: 'fisheye62'"),
    (dict(k=np.array([600.0, 0, 320, 0, np.nan, 240, 0, 0, 1])), r"camera_info\.k must be finite"),
    (dict(k=np.array([600.0, 0, 320, 0, 600, 240, 0, 0])), r"camera_info\.k must have 9 elements"),
    (dict(k=np.array([0.0, 0, 320, 0, 600, 240, 0, 0, 1])), r"camera_info\.k must be \[fx, 0, cx"),
    (dict(k=np.array([600.0, 2, 320, 0, 600, 240, 0, 0, 1])), r"camera_info\.k: skew"),
    (dict(d=np.array([0.1, np.inf, 0, 0, 0])), r"camera_info\.d must be finite"),
    (dict(width=0), r"camera_info\.width must be in \[1, "),
    (dict(binning_x=3), r"camera_info\.binning_x/binning_y: the 640 x 480 image is not divisible by 3 x 1"),
    (dict(distortion_model="", d=np.array([0.1])), r"camera_info\.d: distortion_model '' has no coefficients"),
])
def test_malformed_camera_info_names_the_field(change, field):
    with pytest.raises(ValueError, match=field):
        ros.camera_model(info_msg(**change))


def test_camera_info_roi_refusals():
    roi = T["sensor_msgs/msg/RegionOfInterest"]
    with pytest.raises(ValueError, match=r"camera_info\.roi\.do_rectify"):
        ros.camera_model(info_msg(roi=roi(x_offset=0, y_offset=0, height=10, width=10, do_rectify=True)))
    with pytest.raises(ValueError, match=r"camera_info\.roi: \(600, 0\) \+ 100 x 10 does not fit"):
        ros.camera_model(info_msg(roi=roi(x_offset=600, y_offset=0, height=10, width=100, do_rectify=False)))


def test_not_a_camera_info_names_the_missing_field():
    with pytest.raises(TypeError, match=r"camera_info\.width: the message has no field 'width'"):
        ros.camera_model(T["std_msgs/msg/String"](data="x"))


def test_camera_info_refuses_a_normalised_camera():
    with pytest.raises(ValueError, match="model: a CameraInfo describes a pixel sensor"):
        ros.camera_info(ibvs.CameraModel.normalized(), TS)


def test_duck_typed_on_fields_any_class_works():
    """An rclpy-like message: plain attributes, lists for arrays (SimpleNamespace stands in for rclpy)."""
    ns = SimpleNamespace
    msg = ns(header=ns(stamp=ns(sec=1, nanosec=2), frame_id="c"), height=480, width=640, distortion_model="plumb_bob",
             d=[0.0] * 5, k=[600.0, 0.0, 320.0, 0.0, 600.0, 240.0, 0.0, 0.0, 1.0], r=[0.0] * 9, p=[0.0] * 12,
             binning_x=0, binning_y=0, roi=ns(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
    assert ros.camera_model(msg) == ibvs.CameraModel(600.0, 600.0, 320.0, 240.0, 0.0, 0.0, 640.0, 480.0)


def test_building_with_non_rosbags_classes_gives_lists():
    """Classes other than rosbags' (rclpy's) get Python lists for numeric arrays, bytes for uint8 data."""

    def cls_of(name):
        fields = [f.name for f in dataclasses.fields(T[name]) if not f.name.startswith("__")]
        return type(name.replace("/", "_"), (SimpleNamespace,), {"_fields": fields})

    msg = ros.image_msg(np.arange(6, dtype=np.uint8).reshape(2, 3), types=cls_of)
    assert msg.data == bytes(range(6)) and msg.encoding == "mono8" and msg.step == 3
    info = ros.camera_info(ibvs.CameraModel(800.0, 800.0, 320.0, 240.0, 0.0, 0.0, 640.0, 480.0), types=cls_of)
    assert isinstance(info.k, list) and info.k[0] == 800.0 and ros.camera_model(info).px == 800.0


# ---------------------------------------------------------------------------- Image

def img_msg(data, height, width, encoding, step, big=0):
    return T["sensor_msgs/msg/Image"](header=ros.types.header(TS, 0, "c"), height=height, width=width,
                                      encoding=encoding, is_bigendian=big, step=step,
                                      data=np.frombuffer(bytes(data), dtype=np.uint8))


@pytest.mark.parametrize("array", [
    np.arange(12, dtype=np.uint8).reshape(3, 4),
    (np.arange(12, dtype=np.uint16) * 5000).reshape(3, 4),
    np.arange(36, dtype=np.uint8).reshape(3, 4, 3),
    np.arange(48, dtype=np.uint8).reshape(3, 4, 4),
], ids=["mono8", "mono16", "rgb8", "rgba8"])
def test_image_round_trip(array):
    msg = roundtrip(ros.image_msg(array, TS))
    out = ros.image(msg)
    assert out.dtype == array.dtype
    np.testing.assert_array_equal(out, array)


def test_image_step_padding_and_big_endian():
    # 3 x 2 mono16, big-endian, rows padded to 8 bytes: values 1, 2, 3 / 256, 257, 65535
    rows = [b"\x00\x01\x00\x02\x00\x03\xee\xee", b"\x01\x00\x01\x01\xff\xff\xee\xee"]
    out = ros.image(img_msg(b"".join(rows), 2, 3, "mono16", 8, big=1))
    np.testing.assert_array_equal(out, [[1, 2, 3], [256, 257, 65535]])
    little = ros.image(img_msg(b"\x01\x00\x02\x00", 1, 2, "mono16", 4, big=0))
    np.testing.assert_array_equal(little, [[1, 2]])
    # the last row may come without its padding
    out8 = ros.image(img_msg(b"\x01\x02\x09\x03\x04", 2, 2, "mono8", 3))
    np.testing.assert_array_equal(out8, [[1, 2], [3, 4]])


def test_gray8_of_each_encoding():
    px = np.array([[10, 100, 200]], dtype=np.uint8)  # R, G, B of one pixel
    y = round(0.299 * 10 + 0.587 * 100 + 0.114 * 200)
    assert ros.gray8(img_msg(px.tobytes(), 1, 1, "rgb8", 3))[0, 0] == y
    assert ros.gray8(img_msg(px[:, ::-1].tobytes(), 1, 1, "bgr8", 3))[0, 0] == y
    assert ros.gray8(img_msg(bytes([10, 100, 200, 7]), 1, 1, "rgba8", 4))[0, 0] == y
    assert ros.gray8(img_msg(bytes([200, 100, 10, 7]), 1, 1, "bgra8", 4))[0, 0] == y
    assert ros.gray8(img_msg(b"\xff\xff\x01\x01", 1, 2, "mono16", 4, big=1)).tolist() == [[255, 1]]
    mono = ros.gray8(img_msg(b"\x05\x06", 1, 2, "mono8", 2))
    assert mono.dtype == np.uint8 and mono.tolist() == [[5, 6]]


@pytest.mark.parametrize("data, h, w, enc, step, big, match", [
    (b"\x00" * 12, 2, 2, "yuv422", 4, 0, r"image\.encoding: 'yuv422' is not one of"),
    (b"\x00" * 12, 2, 3, "rgb8", 6, 0, r"image\.step: 6 bytes is shorter than a row of 3 rgb8 pixels \(9 bytes\)"),
    (b"\x00" * 5, 2, 3, "mono8", 3, 0, r"image\.data: 5 bytes, fewer than the 6 of 2 rows of step 3"),
    (b"\x00" * 4, 0, 4, "mono8", 4, 0, r"image\.height must be in \[1, "),
    (b"\x00" * 4, 1, 2, "mono16", 4, 2, r"image\.is_bigendian must be 0 or 1"),
])
def test_malformed_image_names_the_field(data, h, w, enc, step, big, match):
    with pytest.raises(ValueError, match=match):
        ros.image(img_msg(data, h, w, enc, step, big))


def test_image_msg_refusals():
    with pytest.raises(ValueError, match="array must be"):
        ros.image_msg(np.zeros((2, 2), dtype=np.float32), TS)
    with pytest.raises(ValueError, match="encoding: 'bgr8' does not fit"):
        ros.image_msg(np.zeros((2, 2), dtype=np.uint8), TS, encoding="bgr8")


def test_image_msg_stamp_and_byte_order():
    msg = ros.image_msg(np.zeros((2, 2), dtype=np.uint16), TS, "cam", 3 * 10**9 + 7)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (3, 7)
    assert msg.is_bigendian == int(sys.byteorder == "big") and msg.step == 4


# ---------------------------------------------------------------------------- Twist, joints, tf

def test_twist_round_trip_and_base_frame():
    v = np.array([0.1, -0.2, 0.3, 0.01, 0.02, -0.03])
    msg = roundtrip(ros.twist_msg(v, TS, "camera_optical_frame", 42))
    assert msg.__msgtype__ == "geometry_msgs/msg/TwistStamped" and msg.header.frame_id == "camera_optical_frame"
    np.testing.assert_array_equal(ros.twist_of(msg), v)
    np.testing.assert_array_equal(ros.twist_of(ros.twist_msg(v, TS, stamped=False)), v)
    bTc = np.eye(4)
    bTc[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]  # camera z forward = base x (a camera looking ahead)
    vb = ros.twist_of(ros.twist_msg(v, TS, base_T_camera=bTc))
    np.testing.assert_allclose(vb, [0.3, -0.1, 0.2, -0.03, -0.01, -0.02], atol=1e-15)
    with pytest.raises(ValueError, match="twist must be 6 finite numbers"):
        ros.twist_msg([0, 0, np.nan, 0, 0, 0], TS)
    with pytest.raises(ValueError, match="base_T_camera: its rotation is not orthonormal"):
        ros.twist_msg(v, TS, base_T_camera=np.diag([2.0, 1, 1, 1]))


def test_joint_state_in_any_order_and_missing_joint():
    js = T["sensor_msgs/msg/JointState"](header=ros.types.header(TS, 0, ""), name=["b", "a", "c"],
                                         position=np.array([2.0, 1.0, 3.0]), velocity=np.zeros(0), effort=np.zeros(0))
    js = roundtrip(js)
    np.testing.assert_array_equal(ros.joint_positions(js, ["a", "b", "c"]), [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(ros.joint_positions(js), [2.0, 1.0, 3.0])
    with pytest.raises(ValueError, match=r"joint_states\.name: joint 'd' is not in the message"):
        ros.joint_positions(js, ["a", "d"])
    bad = T["sensor_msgs/msg/JointState"](header=js.header, name=["a"], position=np.array([1.0, 2.0]),
                                          velocity=np.zeros(0), effort=np.zeros(0))
    with pytest.raises(ValueError, match=r"joint_states\.position: 2 positions for 1 names"):
        ros.joint_positions(bad)


def test_joint_velocities_out():
    qdot = np.array([0.1, -0.2, 0.3])
    jt = roundtrip(ros.joint_trajectory(qdot, ["j1", "j2", "j3"], TS, 5, time_from_start=0.02))
    assert list(jt.joint_names) == ["j1", "j2", "j3"] and len(jt.points) == 1
    np.testing.assert_array_equal(jt.points[0].velocities, qdot)
    assert jt.points[0].time_from_start.nanosec == 20_000_000
    arr = roundtrip(ros.float64_array(qdot, TS))
    np.testing.assert_array_equal(ros.array_of(arr), qdot)
    pts = np.arange(8.0).reshape(4, 2)
    np.testing.assert_array_equal(ros.array_of(roundtrip(ros.float64_array(pts, TS, "points"))), pts)
    with pytest.raises(ValueError, match="names: 2 joint names for 3 velocities"):
        ros.joint_trajectory(qdot, ["a", "b"], TS)


def test_tf_round_trip():
    rng = np.random.default_rng(3)
    poses = {}
    for i, angle in enumerate([0.0, 1.0, np.pi, np.pi - 1e-9, 3.0]):
        axis = rng.normal(size=3)
        T4 = ibvs.se3_exp(np.r_[rng.normal(size=3), angle * axis / np.linalg.norm(axis)])
        poses[("world", f"f{i}")] = T4
    back = ros.transforms(roundtrip(ros.tf_message(poses, TS, 9)))
    assert set(back) == set(poses)
    for k, T4 in poses.items():
        np.testing.assert_allclose(back[k], T4, rtol=0, atol=2e-15)
    bad = ros.tf_message({("w", "c"): np.eye(4)}, TS)
    bad.transforms[0].transform.rotation.w = 0.0
    with pytest.raises(ValueError, match=r"tf\.transforms\[0\]\.transform\.rotation: quaternion must be finite and"):
        ros.transforms(bad)
