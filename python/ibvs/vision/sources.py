"""Frame sources: images with their capture time, one interface for cameras, videos, bags and renderers.

    src = VideoFile("run.mp4")                 # or OpenCVCapture(0), RosImageSource("run.mcap"),
    src.open()                                 # RendererSource(renderer, pose, clock, rate=30, latency=0.05)
    frame = src.read(timeout=0.5)              # Frame(image, stamp, index), or None: nothing within timeout
    src.close()

Every Frame carries its capture time (`stamp`, seconds on the source's clock) and its index in the
source's sequence (a gap in the indices is a dropped frame). A source that stops delivering is noticed:
read() returns None once `timeout` seconds pass without a new frame (the servo loop's watchdog counts
them); a source at its end (a video or a bag read to the last frame) returns None at once and says so
in `ended`.

Sources (all open lazily: the constructor checks its arguments and touches nothing):
  OpenCVCapture   cv2.VideoCapture of a device index, a file or a GStreamer pipeline string; stamp: the
                  clock at grab (devices, pipelines) or CAP_PROP_POS_MSEC (files, from 0)
  VideoFile       a video file replayed at its own frame rate on a clock (stamp: start + its position)
  RosImageSource  sensor_msgs/Image messages of a ROS 2 bag (ibvs.ros), stamp: each header's stamp;
                  the camera model from the bag's camera_info topic when it has one
  RendererSource  ibvs.vision.Renderer images at a pose given by a callable, captured every 1/rate s
                  on a clock and delivered `latency` s later, a fraction `drop` of them lost (seeded)

The MuJoCo camera of the physics testbed (ibvs.sim.physics) implements the same interface.
"""

from __future__ import annotations

import abc
import collections
import math
from dataclasses import dataclass
from typing import Callable, Deque, Optional, Tuple, Union

import numpy as np

__all__ = ["Frame", "FrameSource", "OpenCVCapture", "RendererSource", "RosImageSource", "VideoFile"]


@dataclass(frozen=True)
class Frame:
    """One image (uint8, (H, W) gray or (H, W, 3) BGR as OpenCV gives it), its capture time `stamp`
    (seconds, on the source's clock) and its `index` in the source's sequence (0, 1, ...; a gap is a
    dropped frame)."""

    image: np.ndarray
    stamp: float
    index: int


def _positive(x, name: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)) or not (
            math.isfinite(x) and x > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {x!r}")
    return float(x)


def _timeout(x) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)) or not (
            math.isfinite(x) and x >= 0):
        raise ValueError(f"timeout must be a finite number >= 0 (seconds), got {x!r}")
    return float(x)


def _real_clock():
    from ..loop.clock import RealClock

    return RealClock()


class FrameSource(abc.ABC):
    """Images with their capture time (see the module docstring).

    rate     nominal frames per second
    camera   the ibvs.CameraModel of the images when the source knows it (None otherwise)
    ended    True once a finite source (a file, a bag) has delivered its last frame
    """

    rate: float = 30.0
    camera = None
    ended: bool = False

    def open(self) -> None:
        """Start delivering (open the device, the file, the bag). Idempotent."""

    @abc.abstractmethod
    def read(self, timeout: float) -> Optional[Frame]:
        """The next frame, or None when none came within `timeout` seconds (or the source ended)."""

    def close(self) -> None:
        """Release the device or file. Idempotent; never raises."""

    def __enter__(self) -> "FrameSource":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# --------------------------------------------------------------------------- OpenCV


def _cv2():
    try:
        import cv2
    except ImportError as e:
        raise ImportError('frame sources need OpenCV (the vision extra): pip install ".[vision]" from the ibvs '
                          'repository root') from e
    return cv2


class OpenCVCapture(FrameSource):
    """cv2.VideoCapture of `device`: a camera index (int), a video file's path or a GStreamer pipeline
    string (opened with cv2.CAP_GSTREAMER when it contains '!'). Frames are read as fast as the device
    gives them: the stamp is the clock's time at grab for a device or a pipeline, CAP_PROP_POS_MSEC / 1000
    for a file (its position, from 0). read() blocks inside OpenCV up to the device's own timeout; a
    file at its end returns None (ended). width, height, fps: requested from a device (0: its default).
    gray: frames converted to 8-bit gray (what the trackers take)."""

    def __init__(self, device: Union[int, str], clock=None, width: int = 0, height: int = 0, fps: float = 0.0,
                 gray: bool = True, camera=None):
        if isinstance(device, bool) or not isinstance(device, (int, str)) or (isinstance(device, int) and device < 0):
            raise ValueError(f"device must be a camera index >= 0, a file path or a GStreamer pipeline, got "
                             f"{device!r}")
        for name, v in (("width", width), ("height", height)):
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise ValueError(f"{name} must be an integer >= 0 (0: the device's default), got {v!r}")
        if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not (math.isfinite(fps) and fps >= 0):
            raise ValueError(f"fps must be a number >= 0 (0: the device's default), got {fps!r}")
        self.device, self.clock = device, clock if clock is not None else _real_clock()
        self.width, self.height, self.fps, self.gray = width, height, float(fps), bool(gray)
        self.camera = camera
        self.is_file = isinstance(device, str) and "!" not in device
        self.rate = float(fps) if fps else 30.0
        self._cap = None
        self._index = 0
        self.ended = False

    def open(self) -> None:
        if self._cap is not None:
            return
        cv2 = _cv2()
        if isinstance(self.device, str) and "!" in self.device:
            cap = cv2.VideoCapture(self.device, cv2.CAP_GSTREAMER)
        else:
            cap = cv2.VideoCapture(self.device)
        if not cap.isOpened():
            cap.release()
            raise OSError(f"source: cannot open {self.device!r} with OpenCV (no such device or file, or no "
                          f"backend for it)")
        if not self.is_file:
            if self.width:
                cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.width)
            if self.height:
                cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height)
            if self.fps:
                cap.set(cv2.CAP_PROP_FPS, self.fps)
        fps = cap.get(cv2.CAP_PROP_FPS)
        if math.isfinite(fps) and fps > 0:
            self.rate = float(fps)
        self._cap = cap

    def read(self, timeout: float) -> Optional[Frame]:
        _timeout(timeout)
        if self._cap is None:
            self.open()
        cv2 = _cv2()
        if self.ended:
            return None
        t_grab = self.clock.now()
        if not self._cap.grab():
            if self.is_file:
                self.ended = True
            return None
        ok, image = self._cap.retrieve()
        if not ok or image is None:
            return None
        stamp = self._cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0 if self.is_file else t_grab
        if self.gray and image.ndim == 3:
            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        frame = Frame(image, float(stamp), self._index)
        self._index += 1
        return frame

    def close(self) -> None:
        cap, self._cap = self._cap, None
        if cap is not None:
            try:
                cap.release()
            except Exception:  # noqa: BLE001 - closing never raises
                pass


class VideoFile(FrameSource):
    """A video file replayed at its own frame rate (or `rate`) on `clock`: frame k is delivered at
    start + k / rate (start: the clock's time at open) and stamped so; read() sleeps on the clock until
    then, or returns None when that is more than `timeout` away. At the end: None, ended."""

    def __init__(self, path, clock=None, rate: Optional[float] = None, gray: bool = True, camera=None):
        from pathlib import Path

        self.path = Path(path)
        if rate is not None:
            _positive(rate, "rate")
        self.clock = clock if clock is not None else _real_clock()
        self._rate, self.camera = rate, camera
        self._capture = OpenCVCapture(str(self.path), clock=self.clock, gray=gray, camera=camera)
        self._start: Optional[float] = None
        self._next: Optional[Frame] = None
        self.rate = float(rate) if rate is not None else 30.0

    def open(self) -> None:
        if self._start is not None:
            return
        if not self.path.is_file():
            raise FileNotFoundError(f"source: no video file {str(self.path)!r}")
        self._capture.open()
        self.rate = float(self._rate) if self._rate is not None else self._capture.rate
        self._start = self.clock.now()

    @property
    def ended(self) -> bool:  # type: ignore[override]
        return self._capture.ended and self._next is None

    def read(self, timeout: float) -> Optional[Frame]:
        timeout = _timeout(timeout)
        if self._start is None:
            self.open()
        if self._next is None:
            self._next = self._capture.read(timeout)
            if self._next is None:
                return None
        due = self._start + self._next.index / self.rate
        now = self.clock.now()
        if due > now + timeout:
            self.clock.sleep_until(now + timeout)
            return None
        self.clock.sleep_until(due)
        frame, self._next = Frame(self._next.image, due, self._next.index), None
        return frame

    def close(self) -> None:
        self._capture.close()


# --------------------------------------------------------------------------- ROS 2 bags


class RosImageSource(FrameSource):
    """The sensor_msgs/Image messages of `image_topic` in a ROS 2 bag (a rosbag2 directory or an .mcap
    file, read through ibvs.ros), as 8-bit gray, stamped with each message's header stamp (seconds).
    camera: the ibvs.CameraModel of the first message of camera_info_topic when the bag has that topic.
    Frames are delivered as fast as they are asked for; with replay = True at the pace of their stamps on
    `clock` (default the real one), re-stamped onto it (the first at the time it is read), so that the
    loop's latencies are on one clock. At the end: None, ended."""

    def __init__(self, path, image_topic: str = "/camera/image_raw", camera_info_topic: str = "/camera/camera_info",
                 clock=None, replay: bool = False):
        from pathlib import Path

        self.path, self.image_topic, self.camera_info_topic = Path(path), str(image_topic), str(camera_info_topic)
        self.clock, self.replay = clock, bool(replay)
        self._messages = None
        self._index = 0
        self._t0: Optional[Tuple[float, float]] = None
        self.ended = False

    def open(self) -> None:
        if self._messages is not None:
            return
        from .. import ros

        have = ros.topics(self.path)  # FileNotFoundError / ValueError naming the bag
        if self.image_topic not in have:
            raise ValueError(f"bag {str(self.path)!r} has no topic {self.image_topic!r} (its topics: "
                             f"{', '.join(sorted(have))})")
        if self.camera_info_topic in have:
            for _, _, msg in ros.messages(self.path, [self.camera_info_topic]):
                self.camera = ros.camera_model(msg)
                break
        n = have[self.image_topic][1]
        if n > 1:  # the nominal rate: the bag's images over its span
            stamps = [ns for _, ns, _ in _first_and_last(ros.messages(self.path, [self.image_topic]))]
            span = (stamps[-1] - stamps[0]) / 1e9
            self.rate = (n - 1) / span if span > 0 else 30.0
        self._messages = ros.messages(self.path, [self.image_topic])
        if self.replay and self.clock is None:
            self.clock = _real_clock()

    def read(self, timeout: float) -> Optional[Frame]:
        timeout = _timeout(timeout)
        if self._messages is None:
            self.open()
        from .. import ros

        if self.ended:
            return None
        try:
            _, _, msg = next(self._messages)
        except StopIteration:
            self.ended = True
            return None
        stamp = ros.types.stamp_ns(msg, "image") / 1e9
        if self.replay:  # at the pace of the stamps, re-stamped onto the clock (the first at its time of read)
            if self._t0 is None:
                self._t0 = (self.clock.now(), stamp)
            stamp = self._t0[0] + (stamp - self._t0[1])
            self.clock.sleep_until(stamp)
        frame = Frame(ros.gray8(msg), float(stamp), self._index)
        self._index += 1
        return frame

    def close(self) -> None:
        messages, self._messages = self._messages, None
        if messages is not None:
            try:
                messages.close()
            except Exception:  # noqa: BLE001 - closing never raises
                pass


def _first_and_last(iterator):
    """The first and last items of an iterator (one pass, closing it)."""
    first = last = None
    try:
        for item in iterator:
            if first is None:
                first = item
            last = item
    finally:
        iterator.close()
    return [x for x in (first, last) if x is not None]


# --------------------------------------------------------------------------- the simulator's renderer


class RendererSource(FrameSource):
    """Images of ibvs.vision.Renderer (a simulated target) at the camera pose pose() (world <- camera,
    4x4, asked at each capture), captured every 1 / rate seconds on `clock` from the time of open() and
    delivered `latency` seconds after capture (several frames may be in flight when latency > 1 / rate),
    stamped with their capture time. drop: the probability that a frame is lost (its index skipped;
    numpy's default_rng(seed)). stop_after: deliver that many frames, then none (a camera that dies).

    On a simulated clock (ibvs.loop.SimClock, the physics testbed's) read() advances the world to each
    capture and delivery, so the image shows the pose at its capture time and the loop sees it `latency`
    later: an injected delay. On the real clock it sleeps."""

    def __init__(self, renderer, pose: Callable[[], np.ndarray], clock=None, rate: float = 30.0,
                 latency: float = 0.0, drop: float = 0.0, seed: int = 0, stop_after: Optional[int] = None):
        if not callable(pose):
            raise TypeError(f"pose must be a callable returning the camera's 4x4 pose, got {type(pose).__name__}")
        self.rate = _positive(rate, "rate")
        if isinstance(latency, bool) or not isinstance(latency, (int, float)) or not (
                math.isfinite(latency) and latency >= 0):
            raise ValueError(f"latency must be a finite number >= 0 (seconds), got {latency!r}")
        if isinstance(drop, bool) or not isinstance(drop, (int, float)) or not (0 <= drop < 1):
            raise ValueError(f"drop must be a probability in [0, 1), got {drop!r}")
        if stop_after is not None and (isinstance(stop_after, bool) or not isinstance(stop_after, int)
                                       or stop_after < 0):
            raise ValueError(f"stop_after must be None or an integer >= 0, got {stop_after!r}")
        self.renderer, self.pose, self.latency, self.drop = renderer, pose, float(latency), float(drop)
        self.camera = renderer.camera
        self.clock = clock if clock is not None else _real_clock()
        self.seed, self.stop_after = seed, stop_after
        self._rng = np.random.default_rng(seed)
        self._t0: Optional[float] = None
        self._k = 0  # the next capture's index
        self._queue: Deque[Frame] = collections.deque()
        self._delivered = 0

    def open(self) -> None:
        if self._t0 is None:
            self._t0 = self.clock.now()

    def _capture(self) -> None:
        k, self._k = self._k, self._k + 1
        stamp = self._t0 + k / self.rate
        if self.drop and self._rng.random() < self.drop:
            return
        image = self.renderer.render(np.asarray(self.pose(), dtype=np.float64))
        self._queue.append(Frame(image, stamp, k))

    def read(self, timeout: float) -> Optional[Frame]:
        timeout = _timeout(timeout)
        if self._t0 is None:
            self.open()
        deadline = self.clock.now() + timeout
        if self.stop_after is not None and self._delivered >= self.stop_after:  # a dead camera: nothing comes
            self.clock.sleep_until(deadline)
            return None
        while True:
            next_capture = self._t0 + self._k / self.rate
            next_delivery = self._queue[0].stamp + self.latency if self._queue else math.inf
            t = min(next_capture, next_delivery)
            if t > deadline:
                self.clock.sleep_until(deadline)
                return None
            self.clock.sleep_until(t)
            if next_delivery <= next_capture:
                self._delivered += 1
                return self._queue.popleft()
            self._capture()

    def close(self) -> None:
        self._queue.clear()
