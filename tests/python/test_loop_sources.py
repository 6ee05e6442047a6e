"""Frame sources (ibvs.vision.sources): every frame carries its capture time and index; a source that
stops delivering returns None after its timeout; files and bags end. The videos and bags are made here,
in tmp dirs (cv2.VideoWriter, ibvs.ros.BagWriter)."""

from __future__ import annotations

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2", reason="frame sources read through OpenCV (the vision extra)")

import loop_world as lw  # noqa: E402
from ibvs.loop import SimClock  # noqa: E402
from ibvs.vision.sources import OpenCVCapture, RendererSource, RosImageSource, VideoFile  # noqa: E402


def _video(path, n=12, fps=20.0, size=(64, 48)):
    """A small MJPG video whose frame k is uniformly gray 10 k (its index can be read back from the image)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, size)
    assert writer.isOpened()
    for k in range(n):
        writer.write(np.full((size[1], size[0], 3), 10 * k, np.uint8))
    writer.release()
    return path


def test_opencv_capture_of_a_file_stamps_its_position(tmp_path):
    path = _video(tmp_path / "v.avi")
    src = OpenCVCapture(str(path))
    with src:
        frames = []
        while (f := src.read(0.1)) is not None:
            frames.append(f)
    assert src.ended and len(frames) == 12 and src.rate == pytest.approx(20.0)
    assert [f.index for f in frames] == list(range(12))
    np.testing.assert_allclose([f.stamp for f in frames], np.arange(12) / 20.0, atol=1e-6)
    assert all(f.image.ndim == 2 and f.image.dtype == np.uint8 for f in frames)
    np.testing.assert_allclose([f.image.mean() for f in frames], 10 * np.arange(12), atol=3)


def test_video_file_is_replayed_at_its_rate_on_the_clock(tmp_path):
    path = _video(tmp_path / "v.avi")
    clock = SimClock(5.0)
    src = VideoFile(path, clock=clock)
    src.open()
    f0 = src.read(1.0)
    assert f0.index == 0 and f0.stamp == 5.0 and clock.now() == 5.0
    assert src.read(0.01) is None and clock.now() == pytest.approx(5.01)  # the next is due at 5.05
    f1 = src.read(1.0)
    assert f1.index == 1 and f1.stamp == pytest.approx(5.05) and clock.now() == pytest.approx(5.05)
    n = 2
    while src.read(1.0) is not None:
        n += 1
    assert n == 12 and src.ended
    src.close()
    src.close()  # idempotent


def test_missing_video_and_device_are_clear_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="no video file"):
        VideoFile(tmp_path / "none.avi").open()
    with pytest.raises(OSError, match="cannot open"):
        OpenCVCapture(str(tmp_path / "none.avi")).open()
    with pytest.raises(ValueError, match="device"):
        OpenCVCapture(-1)
    with pytest.raises(ValueError, match="rate"):
        VideoFile(tmp_path / "v.avi", rate=float("nan"))


def test_ros_bag_images_with_their_header_stamps(tmp_path):
    pytest.importorskip("rosbags", reason="bags need rosbags (the ros extra)")
    from ibvs import ros

    w = lw.world()
    ts = ros.types.typestore()
    path = tmp_path / "cam.mcap"
    stamps_ns = [1_000_000_000 + k * 33_000_000 for k in range(5)]
    with ros.BagWriter(path, ts) as bag:
        bag.write(ros.TOPICS["camera_info"], ros.camera_info(w.camera, ts, "cam"), stamps_ns[0])
        for k, ns in enumerate(stamps_ns):
            image = np.full((int(w.camera.height), int(w.camera.width)), 20 * k, np.uint8)
            bag.write(ros.TOPICS["image"], ros.image_msg(image, ts, "cam", ns), ns + 5_000_000)  # logged later
    src = RosImageSource(path)
    src.open()
    assert src.camera == w.camera and src.rate == pytest.approx(1 / 0.033)
    frames = []
    while (f := src.read(0.1)) is not None:
        frames.append(f)
    assert src.ended and [f.index for f in frames] == list(range(5))
    np.testing.assert_allclose([f.stamp for f in frames], np.array(stamps_ns) / 1e9)  # the header, not the log time
    assert [int(f.image[0, 0]) for f in frames] == [0, 20, 40, 60, 80]
    src.close()
    with pytest.raises(ValueError, match="no topic"):
        RosImageSource(path, image_topic="/nope").open()


def test_renderer_source_latency_drops_and_death():
    w = lw.world(latency=0.1)
    robot = lw.RecordingRobot(w.clock, w.q0, w.model)
    src = lw.render_source(w, robot)
    f = src.read(1.0)
    assert f.index == 0 and f.stamp == 0.0 and w.clock.now() == pytest.approx(0.1)  # delivered 100 ms later
    period = 1 / w.camera.fps
    f = src.read(1.0)
    assert f.index == 1 and f.stamp == pytest.approx(period) and w.clock.now() == pytest.approx(0.1 + period)
    # the image is the pose at capture: a frame in flight shows the camera where it was
    before = src.renderer.render(w.model.camera(robot.q))
    robot.dq = np.array([0, 0, 0, 0, 0, 1.0])  # rad/s about the optical axis, from now on
    f2 = src.read(1.0)  # captured at 2 periods, before the motion began at 0.1 + 1 period
    assert f2.stamp == pytest.approx(2 * period) and np.array_equal(f2.image, before)
    while (f := src.read(1.0)).stamp < w.clock.now() - 0.1 - 1e-9 or f.stamp <= 0.1 + period:
        pass  # the first frame captured after the motion began
    assert not np.array_equal(f.image, before)
    # drops: indices skipped, the count near the probability
    w = lw.world(drop=0.5)
    src = lw.render_source(w, lw.RecordingRobot(w.clock, w.q0, w.model))
    idx = [src.read(1.0).index for _ in range(40)]
    gaps = sum(b - a - 1 for a, b in zip(idx, idx[1:]))
    assert 0.3 < gaps / (idx[-1] + 1) < 0.7
    # death: stop_after frames, then None after each timeout (the clock moves on by it)
    w = lw.world(stop_after=2)
    src = lw.render_source(w, lw.RecordingRobot(w.clock, w.q0, w.model))
    assert src.read(1.0) is not None and src.read(1.0) is not None
    t = w.clock.now()
    assert src.read(0.25) is None and w.clock.now() == pytest.approx(t + 0.25)


def test_renderer_source_arguments_are_checked():
    w = lw.world()
    robot = lw.RecordingRobot(w.clock, w.q0, w.model)
    src = lw.render_source(w, robot)
    for kw, match in (({"rate": 0}, "rate"), ({"latency": -1.0}, "latency"), ({"drop": 1.0}, "drop"),
                      ({"stop_after": -1}, "stop_after")):
        with pytest.raises(ValueError, match=match):
            RendererSource(src.renderer, src.pose, **kw)
    with pytest.raises(TypeError, match="pose"):
        RendererSource(src.renderer, np.eye(4))
    with pytest.raises(ValueError, match="timeout"):
        src.read(float("nan"))


def test_a_gstreamer_pipeline_that_cannot_open_is_a_clear_error():
    # OpenCV's GStreamer backend (when built with it) or its absence: either way no such pipeline opens here
    src = OpenCVCapture("nosuchsrc ! appsink")
    assert not src.is_file
    with pytest.raises(OSError, match="cannot open 'nosuchsrc ! appsink'"):
        src.open()
