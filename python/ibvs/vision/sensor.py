"""The image sensor: the simulator's measurement through rendered images and a tracker or detector."""

from __future__ import annotations

import time

import numpy as np

from .._core import sim as _sim
from .dots import DotTracker
from .keypoints import KeypointTracker
from .klt import KltTracker
from .renderer import Renderer, lighting_pair
from .tag import TagDetector

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["ImageSensor", "SENSOR_KINDS"]

#: What ImageSensor.for_target (and sim.run's vision=) can see and measure: sensor kind -> (Renderer kind,
#: detector). "klt" and "keypoints" see a textured plate (the procedural texture unless a texture is given).
SENSOR_KINDS = {
    "dots": ("dots", "DotTracker"),
    "tag": ("tag", "TagDetector"),
    "klt": ("texture", "KltTracker"),
    "keypoints": ("texture", "KeypointTracker"),
}


class ImageSensor(_sim.Sensor):
    """The simulator's measurement through images: ibvs.sim.run(..., vision=ImageSensor(renderer, detector)).

    Each frame: renderer.render(pose, twist) -> detector (a DotTracker or a KltTracker, started at frames
    -1 (goal) and 0 from the true projections, as a user clicks on the dots or the plate's corners; a
    TagDetector; or a KeypointTracker whose reference is the goal image (frame -1), its points the goal's
    true projections: teach by showing) -> pixels, NaN
    for a lost point (the episode then ends as lost_feature). The renderer's noise is reseeded with
    the run's seed. keep_frames=True keeps every image (frames[k] is frame k; goal_image the goal's)
    for a video; render_seconds and detect_seconds hold each frame's times. With a fisheye or
    omnidirectional lens (Renderer.wide) the default DotTracker (for_target) loses a dot cut by the edge
    of the image circle (Renderer.mask). lighting: None, or (gain, offset): the lighting of the episode's
    frames (0, 1, ...) when it changed since the goal was taught (the goal's is the renderer's own; see
    Renderer.set_lighting).
    """

    def __init__(self, renderer: Renderer, detector, keep_frames: bool = False, lighting=None):
        super().__init__()
        if not isinstance(renderer, Renderer):
            raise TypeError(f"renderer must be an ibvs.vision.Renderer, got {type(renderer).__name__}")
        if not isinstance(detector, (DotTracker, TagDetector, KltTracker, KeypointTracker)):
            raise TypeError(
                "detector must be an ibvs.vision.DotTracker, TagDetector, KltTracker or KeypointTracker, got "
                f"{type(detector).__name__}"
            )
        if isinstance(detector, (DotTracker, TagDetector)):
            n = detector.n if isinstance(detector, DotTracker) else detector.n_points
            if n != len(renderer.target):
                raise ValueError(f"detector: it measures {n} points but the target has {len(renderer.target)}")
        if isinstance(detector, (DotTracker, KltTracker)) and detector.size != renderer.size:
            raise ValueError(
                f"detector: image_size {detector.size} differs from the camera's {renderer.size}"
            )
        self.renderer, self.detector, self.keep_frames = renderer, detector, bool(keep_frames)
        self._lighting = lighting_pair(renderer, lighting)
        self.frames: list = []
        self.goal_image = None
        self.render_seconds: list = []
        self.detect_seconds: list = []

    @classmethod
    def for_target(cls, camera, target, kind: str = "dots", keep_frames: bool = False, lighting=None,
                   **renderer_options):
        """The default image sensor of a kind in SENSOR_KINDS: Renderer(camera, target, its renderer kind,
        **renderer_options) and a DotTracker (dots), a TagDetector of tag 0 (tag), a KltTracker (klt) or a
        KeypointTracker (keypoints; "texture": the plate's)."""
        if kind not in SENSOR_KINDS:
            raise ValueError(f"kind must be one of {tuple(SENSOR_KINDS)}, got {kind!r}")
        r = Renderer(camera, target, SENSOR_KINDS[kind][0], **renderer_options)
        if kind == "dots":
            det = DotTracker(len(target), r.size, mask=r.mask)
        elif kind == "tag":
            det = TagDetector((r.tag_id,), r.dictionary, image_size=r.size)
        elif kind == "klt":
            det = KltTracker(r.size)
        else:
            det = KeypointTracker(image_size=r.size)
        return cls(r, det, keep_frames, lighting)

    def reset(self, seed: int) -> None:
        self.renderer.reseed(seed)
        self.frames, self.goal_image = [], None
        self.render_seconds, self.detect_seconds = [], []

    def measure(self, frame: int, pose, projected, twist) -> np.ndarray:
        self.renderer.set_lighting(*self._lighting[frame >= 0])
        t0 = time.perf_counter()
        image = self.renderer.render(pose, twist)
        self.render_seconds.append(time.perf_counter() - t0)
        if isinstance(self.detector, DotTracker):
            if frame <= 0:
                self.detector.reset(projected)
            track = self.detector.track(image)
        elif isinstance(self.detector, KltTracker):
            if frame <= 0:
                self.detector.reset(image, projected)
            track = self.detector.track(image)
        elif isinstance(self.detector, KeypointTracker):
            if frame < 0:
                self.detector.set_reference(image, projected)
            track = self.detector.detect(image)
        else:
            track = self.detector.detect(image)
        self.detect_seconds.append(track.seconds)
        if self.keep_frames:
            if frame < 0:
                self.goal_image = image
            else:
                self.frames.append(image)
        return track.pixels

