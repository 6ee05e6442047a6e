"""Dense features in the loop: photometric servoing and photometric moments measured in rendered images of
a textured plate, as feature blocks of an ordinary ibvs.Servo, so that ibvs.sim.run (its statuses, depth
modes, latency, robots, metrics), the sweeps and `ibvs run` run them as any other scheme.

"luminance" (Collewet & Marchand, IEEE T-RO 2011): the law is ibvs.LuminanceServo's (the core's, gain 1):
each frame's image gives its Levenberg-Marquardt step d = (H + mu diag H)^-1 L_I^T (I - I*), and the
block is s = d with interaction matrix L = I (6 rows, ibvs.FunctionFeature), s* = 0: the Servo's law
v = -gain L^+ (s - s*) = -gain d is then exactly the photometric law at the Servo's gain. The goal image
(frame -1) is I*, with L_I at it (jacobian "desired") and its depth plane from the goal's depth pose.
A textureless or saturated image (H singular), or a step refused, is a lost feature (the episode's
lost_feature; never a NaN twist).

"moments" (Bakthavatchalam, Tahri & Chaumette, IEEE T-RO 2018): ibvs.photometric_moments of the
undistorted image (each pixel weighs its intensity; the plate must be seen whole on a black background:
the renderer's background is 0, and pixels farther than 2 px from the plate (darker than half its darkest
level, 20) are set to 0: the sensor noise on the background would otherwise bias the moments) -> ibvs.MomentsFeature.measure
("region"), as a polygon's moments (ibvs.vision.blob, feature "moments", with a* and Z* from the goal's
image). A plate touching the image border is lost. A lighting change scales the moments: a gain g moves
the depth feature an = Z* sqrt(a*/a) by 1/sqrt(g) (no invariance to lighting).

Both render through the camera's lens and undistort onto the pinhole image of its px, py, u0, v0 before
measuring (ibvs.vision.blob.BlobMeasure, whose set-up, noise restarts and pickling they share).
"""

from __future__ import annotations

import numpy as np

from .._core import FunctionFeature, LuminanceServo, MomentsFeature, photometric_moments
from .._core import sim as _sim
from .blob import BlobMeasure
from .images import check_real, opencv
from .renderer import lighting_pair

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["DENSE_FEATURES", "PhotometricMeasure", "photometric_source", "luminance_block"]

#: The dense features: "luminance" (photometric servoing) and "moments" (photometric moments).
DENSE_FEATURES = ("luminance", "moments")


def _step_block(measurement):
    """FunctionFeature fn of the luminance block: s = the photometric step, L = the identity."""
    return np.asarray(measurement, dtype=np.float64), np.eye(6)


def luminance_block() -> FunctionFeature:
    """The 6-row feature block of photometric servoing (s = the LuminanceServo step, L = I): stack it in a
    Task whose target carries photometric_source(..., "luminance")."""
    return FunctionFeature(6, 6, _step_block, "luminance")


class PhotometricMeasure(BlobMeasure):
    """The measurement of a dense feature from the rendered image: the callable of an ibvs.sim.FunctionSource.

    PhotometricMeasure(camera, target, feature="luminance", border=10, smoothing=0.0, mu=0.01,
                       jacobian="desired", **renderer_options)
      camera, target  as BlobMeasure (a normalised camera is imaged by image_camera's 640x480 pinhole); the
                      target's points span the textured plate (Renderer kind "texture")
      feature         "luminance" or "moments"
      border, smoothing, mu, jacobian  ibvs.LuminanceServo's options (luminance)
      renderer_options  Renderer's texture, noise, seed, blur, gain, offset (a lighting change since the
                      goal: gain/offset here hold for the goal and the episode alike)
      lighting        None, or (gain, offset): the lighting of the episode's frames (0, 1, ...) when it
                      changed since the goal was taught (ibvs.vision.ImageSensor's option)
    """

    def __init__(self, camera, target, feature: str = "luminance", border: int = 10, smoothing: float = 0.0,
                 mu: float = 0.01, jacobian: str = "desired", lighting=None, **renderer_options):
        if feature not in DENSE_FEATURES:
            raise ValueError(f"feature must be one of {DENSE_FEATURES}, got {feature!r}")
        if "exposure" in renderer_options:
            raise ValueError("exposure: a feature source is not given the camera's twist (no motion blur)")
        self._arguments = dict(camera=camera, target=target, feature=feature, border=border, smoothing=smoothing,
                               mu=mu, jacobian=jacobian, lighting=lighting, **renderer_options)
        self.feature = feature
        if feature == "moments":
            renderer_options = {"background": 0.0, **renderer_options}
        self._setup(camera, target, "texture", renderer_options)
        self._lighting = lighting_pair(self.renderer, lighting)
        self._options = dict(border=border, smoothing=check_real(smoothing, "smoothing", 0.0, 100.0),
                             mu=check_real(mu, "mu", 0.0, 1e6), jacobian=jacobian)
        LuminanceServo(self._pinhole, *self.renderer.size, **self._options)  # the options checked now
        self._servo = None

    def _luminance(self, frame, image, depth_pose, goal):
        if frame < 0:  # the goal: I*, L_I at it with the goal's plane
            plane = _sim.plane_in_camera(depth_pose)
            self._servo = LuminanceServo(self._pinhole, *self.renderer.size, plane=plane, **self._options)
            self._servo.set_desired(image)
            self._goal = (np.array(goal),)
            return np.zeros(6)
        if self._servo is None or not np.array_equal(self._goal[0], goal):
            return None  # the goal is taught first (frame -1)
        r = self._servo.update(image)
        return -np.asarray(r.twist) if r.ok else None

    def _moments(self, frame, image, depth_pose, goal):
        inside = image > 0.5 * max(self.renderer.gain * 20.0 + self.renderer.offset, 1.0)
        if inside[0].any() or inside[-1].any() or inside[:, 0].any() or inside[:, -1].any() or not inside.any():
            return None  # a plate cut by the image border, or none
        plane = _sim.plane_in_camera(depth_pose)
        # the background's noise is left out beyond 2 px of the plate (pixels above half its darkest level,
        # grown by 2 px so that its anti-aliased rim stays whole): over the whole image the noise would
        # outweigh the plate's far corners in the higher-order moments
        near = opencv().dilate(inside.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
        mo = photometric_moments(self._pinhole, np.where(near, image, 0.0).astype(np.float64))
        if frame < 0 or self._goal is None or not np.array_equal(self._goal[0], goal):
            if frame >= 0:
                return None
            A, B, C = plane
            self._goal = (np.array(goal), mo[0], 1.0 / (A * mo[1] / mo[0] + B * mo[2] / mo[0] + C))
        _, a_desired, z_desired = self._goal
        return MomentsFeature.measure(mo, plane, "region", a_desired, z_desired)

    def __call__(self, frame, cMo, depth_pose, goal, uv, depth):
        if frame <= 0:
            self._restart_noise(cMo)
        if not np.isfinite(depth_pose).all():
            return None
        self.renderer.set_lighting(*self._lighting[frame >= 0])
        image = self.undistorted(self.image(cMo), self.renderer.background)
        try:
            if self.feature == "luminance":
                return self._luminance(frame, image, depth_pose, goal)
            return self._moments(frame, image, depth_pose, goal)
        except ValueError:
            return None  # a plane through the camera centre, too little texture at the goal: cannot measure

    def __repr__(self) -> str:
        return f"PhotometricMeasure({self.feature}, {self.renderer!r})"


def photometric_source(camera, target, feature: str = "luminance", **options):
    """An ibvs.sim.FunctionSource measuring `feature` ("luminance": the luminance_block(); "moments": an
    ibvs.MomentsFeature("region") block) from rendered images of the textured plate
    (PhotometricMeasure(camera, target, feature, **options))."""
    measure = PhotometricMeasure(camera, target, feature, **options)
    kind = luminance_block() if feature == "luminance" else MomentsFeature("region")
    return _sim.FunctionSource(kind, measure)
