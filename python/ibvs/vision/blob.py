"""Blobs in the loop: the image moments and the ellipse of one white blob measured in the rendered image.

A BlobMeasure renders the target as one white blob (Renderer kind "disc": a 3-D circle, the disc whose
rim holds the target's points; kind "polygon": the planar polygon whose vertices they are) at the pose
the simulator gives and measures the blob's grey-level moments with OpenCV: each pixel weighs its
coverage by the blob, (I - plate) / (blob - plate) clipped to [0, 1] (the renderer's edges are
anti-aliased), the plate's pixels nothing:
  * "ellipse": cv2.moments(weights) -> ibvs.EllipseFeature.measure_moments (centroid and centred
    second-order moments, pixels -> normalised through the camera's px, py, u0, v0);
  * "moments": ibvs.vision.image_moments(weights, weights=True) (cv2.moments to order 3, order 4 summed,
    normalised) -> ibvs.MomentsFeature.measure, with the goal's area a* and depth Z* from the goal's image.
Grey-level moments rather than a thresholded mask's: a binary mask's moments move with the pixel grid,
and the moments task's invariants (its x/y rotation rows, weakly sensitive) then let the camera wander
centimetres along their weak direction (tests/python/test_vision_blobs.py; about 10 times less with
the coverage weights).
The plane (A, B, C) of the blob (the target's z = 0 plane) comes from the pose the depth mode gives
(ibvs.sim.plane_in_camera). blob_source wraps it in an ibvs.sim.FunctionSource for sim.Target(features=...).

Lens distortion: the image is rendered through the camera's lens; before the moments are taken it is
undistorted (cv2.remap onto the pinhole image of the same px, py, u0, v0: each pinhole pixel reads the
sensor at CameraModel.project of its normalised coordinates), so that the moments are those of the
blob's perspective image, whose moments the features' interaction matrices describe. A camera without
pixels (CameraModel.normalized, the paper's free camera) is imaged by ibvs.vision.image_camera's
640x480 pinhole.

The blob is lost (the episode's lost_feature) when it is empty, touches the image border (its moments
would be those of a cut blob; judged on the image thresholded half-way between plate and blob) or the
depth pose is unknown.
"""

from __future__ import annotations

import hashlib
from typing import Optional

import numpy as np

from .._core import CameraModel, EllipseFeature, MomentsFeature
from .._core import sim as _sim
from .images import image_camera, opencv
from .moments import image_moments
from .renderer import Renderer

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["BLOB_FEATURES", "BlobMeasure", "blob_source"]

#: What a blob measures: "ellipse" (ibvs.EllipseFeature, of a disc) or "moments" (ibvs.MomentsFeature
#: "region", of a polygon).
BLOB_FEATURES = ("ellipse", "moments")


class BlobMeasure:
    """The measurement of one blob from the rendered image: the callable of an ibvs.sim.FunctionSource.

    BlobMeasure(camera, target, feature="ellipse", **renderer_options)
      camera    the simulator's ibvs.CameraModel (a normalised one is imaged by image_camera's pinhole)
      target    an ibvs.sim.Target: its points on a circle (feature "ellipse": the disc they are the rim of)
                or the vertices of a polygon, in order (feature "moments"), in its z = 0 plane
      feature   "ellipse" or "moments"
      renderer_options  Renderer's blur, noise, seed (exposure needs the twist, which a source is not given;
                with noise, plate pixels brighter than the plate weigh a little: the moments are biased by it,
                which the tests do not cover)
    Calling it as measure(frame, cMo, depth_pose, goal, uv, depth) renders the blob at cMo and returns the
    block's measurement, or None (lost). image(cMo) and weights(image) give the intermediate steps.
    It pickles by its arguments (so does the FunctionSource of blob_source, and a Target holding it: a
    sweep sends it to worker processes): the copy is the BlobMeasure they build, rendering and
    undistorting anew. Its noise restarts at every episode's goal and start, from the seed and that frame's
    pose, so an episode's images do not depend on the episodes run before it.
    """

    def __init__(self, camera, target, feature: str = "ellipse", **renderer_options):
        if feature not in BLOB_FEATURES:
            raise ValueError(f"feature must be one of {BLOB_FEATURES}, got {feature!r}")
        if "exposure" in renderer_options:
            raise ValueError("exposure: a blob source is not given the camera's twist (no motion blur)")
        self._arguments = dict(camera=camera, target=target, feature=feature, **renderer_options)
        self.feature = feature
        self._setup(camera, target, "disc" if feature == "ellipse" else "polygon", renderer_options)

    def _setup(self, camera, target, kind: str, renderer_options: dict) -> None:
        """The renderer, the undistortion onto the pinhole image and the goal's memory (shared with
        ibvs.vision.dense.PhotometricMeasure)."""
        self.camera = image_camera(camera)
        self.renderer = Renderer(self.camera, target, kind, **renderer_options)
        self._seed = int(renderer_options.get("seed", 0))  # valid: the Renderer checked it
        cam = self.camera
        self._pinhole = cam
        self._undistort = None
        if cam.distortion != "none":
            W, H = self.renderer.size
            self._pinhole = CameraModel(cam.px, cam.py, cam.u0, cam.v0, 0.0, 0.0, W, H, cam.fps)
            uu, vv = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
            xy = np.stack([(uu.ravel() - cam.u0) / cam.px, (vv.ravel() - cam.v0) / cam.py], 1)
            m = cam.project(xy, invalid="nan")
            m[~np.isfinite(m).all(1)] = -1e6
            self._undistort = tuple(m[:, c].reshape(H, W).astype(np.float32) for c in (0, 1))
        self._target_pose = np.asarray(target.pose, dtype=np.float64)
        self._goal: Optional[tuple] = None  # (goal pose, a*, Z*) of the moments

    def _restart_noise(self, cMo) -> None:
        """At the goal (frame -1) and the start (frame 0) of every episode, the noise restarts from the seed and
        that frame's pose: an episode's images depend on them alone, not on the episodes this measure rendered
        before (a sweep's rows are the same on any number of workers, in any order)."""
        digest = hashlib.sha256(np.ascontiguousarray(cMo, dtype=np.float64).tobytes()).digest()
        self.renderer.reseed(self._seed ^ int.from_bytes(digest[:8], "little"))

    def image(self, cMo) -> np.ndarray:
        """The rendered camera image (uint8, through the lens) at camera <- target pose cMo."""
        cMo = np.asarray(cMo, dtype=np.float64)
        return self.renderer.render(self._target_pose @ np.linalg.inv(cMo))

    def undistorted(self, image, border: float) -> np.ndarray:
        """The image (float32) remapped onto the pinhole image of the camera's px, py, u0, v0 (itself when
        the camera has no distortion); `border` fills what the sensor does not see."""
        img = np.asarray(image).astype(np.float32)
        if self._undistort is not None:
            img = opencv().remap(img, *self._undistort, opencv().INTER_LINEAR,
                                 borderMode=opencv().BORDER_CONSTANT, borderValue=float(border))
        return img

    def weights(self, image) -> np.ndarray:
        """Each pixel's coverage by the blob (float32 in [0, 1]) in the undistorted (pinhole) image."""
        img = self.undistorted(image, Renderer.PLATE)
        w = (img - np.float32(Renderer.PLATE)) * np.float32(1.0 / (Renderer.DOT - Renderer.PLATE))
        return np.clip(w, 0.0, 1.0, out=w)

    def __call__(self, frame, cMo, depth_pose, goal, uv, depth):
        cv2 = opencv()
        if frame <= 0:
            self._restart_noise(cMo)
        w = self.weights(self.image(cMo))
        inside = w > 0.5
        border = inside[0].any() or inside[-1].any() or inside[:, 0].any() or inside[:, -1].any()
        if border or not inside.any():
            return None  # no blob, or a blob cut by the image border
        if not np.isfinite(depth_pose).all():
            return None
        try:
            plane = _sim.plane_in_camera(depth_pose)
            if self.feature == "ellipse":
                return EllipseFeature.measure_moments(cv2.moments(w), plane, self._pinhole)
            mo = image_moments(w, self._pinhole, weights=True)
            if frame < 0 or self._goal is None or not np.array_equal(self._goal[0], goal):
                if frame >= 0:  # the goal is taught first (frame -1); without it, no a*, Z*
                    return None
                A, B, C = plane  # at the goal the depth pose is the goal's true pose
                self._goal = (np.array(goal), mo[0], 1.0 / (A * mo[1] / mo[0] + B * mo[2] / mo[0] + C))
            _, a_desired, z_desired = self._goal
            return MomentsFeature.measure(mo, plane, "region", a_desired, z_desired)
        except ValueError:
            return None  # a plane through the camera centre, a refused measurement: cannot measure

    def __repr__(self) -> str:
        return f"BlobMeasure({self.feature}, {self.renderer!r})"

    def __getstate__(self) -> dict:
        # Its arguments, a few hundred bytes (its renderer's textures and the undistortion maps are megabytes).
        return dict(self._arguments)

    def __setstate__(self, state: dict) -> None:
        self.__init__(**state)


def blob_source(camera, target, feature: str = "ellipse", **renderer_options):
    """An ibvs.sim.FunctionSource measuring `feature` ("ellipse": an ibvs.EllipseFeature block; "moments":
    an ibvs.MomentsFeature("region") block) from the images of the target rendered as one blob
    (BlobMeasure(camera, target, feature, **renderer_options))."""
    measure = BlobMeasure(camera, target, feature, **renderer_options)
    kind = EllipseFeature() if feature == "ellipse" else MomentsFeature("region")
    return _sim.FunctionSource(kind, measure)
