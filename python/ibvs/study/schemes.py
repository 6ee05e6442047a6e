"""The control laws by name: what `ibvs run`, `ibvs sweep`, ibvs.study.sweep and
ibvs.study.reproduce mean by a scheme.

SCHEMES maps a name to a factory(gain, n_points) returning a servo for n_points image
points: an ibvs.Servo or an ibvs.PartitionedServo, anything ibvs.sim.run accepts. The
factories are module-level functions so that process pools and Dask can pickle them;
register_scheme adds more.

A scheme whose task has feature blocks beyond points (image moments, PBVS, 2.5-D) also needs
the target to carry their feature sources: TARGETS maps its name to a function fn(target)
returning the target with them (ibvs.sim.Target.with_features), which ibvs.study.sweep and
ibvs.study.reproduce apply before each run (target_for). The schemes on a pose (pbvs,
pbvs_object, 2.5d) measure it with the run's depth mode: "exact" (the true pose), "pose"
(ibvs.PlanarPose's estimate) or "estimated"; "desired" gives them the goal's pose, i.e. no error.

A scheme that measures its points in rendered images of a textured plate (klt, keypoints: classic IBVS on
the plate's four corners as ibvs.vision.KltTracker or KeypointTracker finds them) names its image sensor
in VISION; run_one and the sweeps then run it through ibvs.vision.ImageSensor.for_target (sensor_for).
A dense scheme (photometric: the luminance law; photometric_moments) measures its feature block in rendered
images of the textured plate by a feature source that needs the camera (DENSE, dense_target; the run's
camera is then ibvs.vision.image_camera(camera)).
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from typing import Any, Callable, Optional

import numpy as np

from ..finite import finite_within

import ibvs


def cartesian(gain: float, n_points: int = 4):
    """Classic IBVS, eq. (3): (u, v) per point."""
    return ibvs.Servo(ibvs.Layout.cartesian(n_points), gain=gain, damping=0.0)


def polar(gain: float, n_points: int = 4):
    """IBVS-P, -(eq. 7): (r, theta) per point."""
    return ibvs.Servo(ibvs.Layout.polar(n_points), gain=gain, damping=0.0)


def hybrid(gain: float, n_points: int = 4):
    """Per-point hybrid (Section V, Fig. 5): the first half of the points Cartesian, the rest polar."""
    half = n_points // 2
    blocks = [(i, "cartesian" if i < half else "polar") for i in range(n_points)]
    return ibvs.Servo(ibvs.Layout(blocks), gain=gain, damping=0.0)


def stacked(gain: float, n_points: int = 4):
    """Both blocks for every point (u, v, r, theta): 4N x 6 (Fig. 8)."""
    return ibvs.Servo(ibvs.Layout.stacked(n_points), gain=gain, damping=0.0)


def cylindrical(gain: float, n_points: int = 4):
    """The (r, r theta) features of Iwatsuki & Okiyama."""
    return ibvs.Servo(ibvs.Layout.cylindrical(n_points), gain=gain, damping=0.0)


def automatic(gain: float, n_points: int = 4):
    """IBVS-P with a point's rows Cartesian while it or its goal is near the principal point."""
    return ibvs.Servo.automatic_hybrid(n_points, gain=gain)


def partitioned(gain: float, n_points: int = 4):
    """Partitioned IBVS (Corke & Hutchinson 2001): wz from the angle of the segment from point 0
    to point 1, Tz from the square root of the polygon's area, the other four DOF Cartesian."""
    return ibvs.PartitionedServo(n_points, gain=gain)


def moments(gain: float, n_points: int = 4):
    """Image moments of the target as a planar polygon (Tahri & Chaumette 2005): xn, yn, an, the
    rotation invariants p and the orientation alpha over the full turn (third-order moments; a
    target without central symmetry)."""
    return ibvs.Servo(ibvs.Task().add(ibvs.MomentsFeature("region", "p", "third_order")), gain=gain, damping=0.0)


def moments_pi(gain: float, n_points: int = 4):
    """Image moments as `moments` with the orientation alpha of the second-order moments (the
    principal axis, defined modulo pi)."""
    return ibvs.Servo(ibvs.Task().add(ibvs.MomentsFeature("region", "p", "second_order")), gain=gain, damping=0.0)


def pbvs(gain: float, n_points: int = 4):
    """PBVS, camera to desired camera: s = (c*t_c, theta u) (Chaumette & Hutchinson 2006, Sec. IV)."""
    return ibvs.Servo(ibvs.Task().add(ibvs.PbvsFeature("desired_camera")), gain=gain, damping=0.0)


def pbvs_object(gain: float, n_points: int = 4):
    """PBVS, camera to object: s = (c t_o, theta u) (Chaumette & Hutchinson 2006, Sec. IV)."""
    return ibvs.Servo(ibvs.Task().add(ibvs.PbvsFeature("object")), gain=gain, damping=0.0)


def point25d(gain: float, n_points: int = 4):
    """2.5-D visual servoing (Malis, Chaumette & Boudet 1999): (x, y, log Z, theta u) of target point 0."""
    return ibvs.Servo(ibvs.Task().add(ibvs.Point25DFeature()), gain=gain, damping=0.0)


def klt(gain: float, n_points: int = 4):
    """Classic IBVS, eq. (3), on the target's points as a KLT tracker finds them in rendered images of the
    textured plate (ibvs.vision.KltTracker; VISION)."""
    return cartesian(gain, n_points)


def keypoints(gain: float, n_points: int = 4):
    """Classic IBVS, eq. (3), on the target's points as keypoints matched to the goal image and a RANSAC
    homography find them in rendered images of the textured plate (ibvs.vision.KeypointTracker; VISION)."""
    return cartesian(gain, n_points)


def photometric(gain: float, n_points: int = 4):
    """Photometric servoing (Collewet & Marchand 2011): the image is the feature, the Levenberg-Marquardt
    law of ibvs.LuminanceServo (J at the goal image) at this gain (ibvs.vision.dense; DENSE)."""
    from ..vision.dense import luminance_block

    return ibvs.Servo(ibvs.Task().add(luminance_block()), gain=gain, damping=0.0)


def photometric_moments(gain: float, n_points: int = 4):
    """Photometric moments (Bakthavatchalam, Tahri & Chaumette 2018): the moments task of `moments` on the
    image's intensity moments of the textured plate on a black background (ibvs.vision.dense; DENSE)."""
    return ibvs.Servo(ibvs.Task().add(ibvs.MomentsFeature("region", "p", "third_order")), gain=gain, damping=0.0)


def _planar_polygon(target, name: str):
    """Refuse a target the moments schemes cannot use, naming why."""
    P = np.asarray(target.points, dtype=float)
    if len(P) < 3 or not finite_within(P, np.inf) \
            or not finite_within(P[:, 2], 1e-12 * max(1.0, float(np.abs(P).max()))):
        raise ValueError(f"scheme {name}: the target must be a planar polygon (>= 3 points in its z = 0 plane)")
    return P


def moments_target(target):
    """The target with a MomentsSource("region"): its points are the polygon's vertices, in order.
    Raises ValueError for a centrally symmetric target (the paper's square), whose third-order
    orientation is undefined."""
    P = _planar_polygon(target, "moments")
    c = P.mean(axis=0)
    scale = max(float(np.ptp(P)), 1e-300)
    if all(np.min(np.linalg.norm(P - q, axis=1)) < 1e-9 * scale for q in 2 * c - P):
        raise ValueError("scheme moments: the target is centrally symmetric (e.g. the paper's square): its "
                         "orientation alpha from third-order moments is undefined; use an asymmetric polygon")
    return target.with_features([ibvs.sim.MomentsSource("region")])


def moments_pi_target(target):
    """The target with a MomentsSource("region") (alpha from second-order moments, modulo pi)."""
    _planar_polygon(target, "moments_pi")
    return target.with_features([ibvs.sim.MomentsSource("region")])


def pbvs_target(target):
    """The target with a PbvsSource("desired_camera")."""
    return target.with_features([ibvs.sim.PbvsSource("desired_camera")])


def pbvs_object_target(target):
    """The target with a PbvsSource("object")."""
    return target.with_features([ibvs.sim.PbvsSource("object")])


def point25d_target(target):
    """The target with a Point25DSource(0): its point 0 is the reference point."""
    return target.with_features([ibvs.sim.Point25DSource(0)])


#: Scheme name -> factory(gain, n_points) -> servo.
SCHEMES: dict[str, Callable[..., Any]] = {
    "cartesian": cartesian,
    "polar": polar,
    "hybrid": hybrid,
    "stacked": stacked,
    "cylindrical": cylindrical,
    "automatic": automatic,
    "partitioned": partitioned,
    "moments": moments,
    "moments_pi": moments_pi,
    "pbvs": pbvs,
    "pbvs_object": pbvs_object,
    "2.5d": point25d,
    "klt": klt,
    "keypoints": keypoints,
    "photometric": photometric,
    "photometric_moments": photometric_moments,
}

#: Scheme name -> the ibvs.vision.DENSE_FEATURES feature its block measures in rendered images.
DENSE: dict[str, str] = {"photometric": "luminance", "photometric_moments": "moments"}

#: Scheme name -> the ibvs.vision.SENSOR_KINDS kind its points are measured with (image episodes).
VISION: dict[str, str] = {"klt": "klt", "keypoints": "keypoints"}

#: Scheme name -> fn(target) -> the target carrying the scheme's feature sources (schemes whose
#: task has blocks beyond points).
TARGETS: dict[str, Callable[..., Any]] = {
    "moments": moments_target,
    "moments_pi": moments_pi_target,
    "pbvs": pbvs_target,
    "pbvs_object": pbvs_object_target,
    "2.5d": point25d_target,
}

#: What each built-in scheme is, for titles and --help.
TITLES = {
    "cartesian": "IBVS (Cartesian)",
    "polar": "IBVS-P (polar)",
    "hybrid": "per-point hybrid (Cartesian / polar)",
    "stacked": "stacked hybrid (u, v, r, θ)",
    "cylindrical": "cylindrical (r, rθ)",
    "automatic": "automatic hybrid",
    "partitioned": "partitioned (Corke & Hutchinson)",
    "moments": "image moments (Tahri & Chaumette), α from 3rd-order moments",
    "moments_pi": "image moments, α from 2nd-order moments (mod π)",
    "pbvs": "PBVS, camera to desired camera",
    "pbvs_object": "PBVS, camera to object",
    "2.5d": "2.5-D (Malis et al.), reference point 0",
    "klt": "IBVS on KLT-tracked plate corners (rendered texture)",
    "keypoints": "IBVS on keypoint-homography plate corners (rendered texture)",
    "photometric": "photometric servoing (Collewet & Marchand), rendered texture",
    "photometric_moments": "photometric moments (Bakthavatchalam et al.), rendered texture",
}

def points_only() -> tuple:
    """The registered schemes on image points only (no target function, no image sensor): what a sweep
    runs by default."""
    return tuple(s for s in SCHEMES if s not in TARGETS and s not in VISION and s not in DENSE)


def dense_target(scheme, camera, target, **options):
    """(camera, target) of a run of a dense scheme (a name in DENSE, or a Scheme with its dense feature): ibvs.vision.image_camera(camera) and the target
    with the scheme's ibvs.vision.photometric_source (options: its renderer's and LuminanceServo's); the
    camera and the target themselves for any other scheme."""
    feature = DENSE.get(scheme) if isinstance(scheme, str) else getattr(scheme, "dense", None)
    if feature is None:
        return camera, target
    from .. import vision

    cam = vision.image_camera(camera)
    return cam, target.with_features([vision.photometric_source(cam, target, feature, **options)])


def sensor_for(scheme, camera, target, **renderer_options):
    """The image sensor a run of `scheme` (a name or a Scheme) needs (VISION; None for the others): an ibvs.vision.ImageSensor
    of its kind for the target, its camera ibvs.vision.image_camera(camera) (a normalised camera gets a
    640x480 pinhole): use sensor.renderer.camera as the run's camera."""
    kind = VISION.get(scheme) if isinstance(scheme, str) else getattr(scheme, "vision", None)
    if kind is None:
        return None
    from .. import vision

    return vision.ImageSensor.for_target(vision.image_camera(camera), target, kind, **renderer_options)


#: The four schemes of the paper.
PAPER = ("cartesian", "polar", "hybrid", "stacked")


@functools.lru_cache(maxsize=None)
def _takes_points(factory) -> bool:
    try:
        params = list(inspect.signature(factory).parameters.values())
    except (TypeError, ValueError):
        return True
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 2 or any(p.kind == p.VAR_POSITIONAL for p in params)


@dataclasses.dataclass(frozen=True)
class Scheme:
    """A scheme as a worker process receives it: its factory and its target function (None: the
    target as it is), its image sensor kind (VISION) and dense feature (DENSE), None for neither.
    Picklable when both functions are module-level functions."""

    factory: Callable[..., Any]
    target: Optional[Callable[..., Any]] = None
    vision: Optional[str] = None
    dense: Optional[str] = None


def entry(name: str) -> Scheme:
    """The registered scheme `name` as a Scheme (factory and target function)."""
    return Scheme(SCHEMES[name], TARGETS.get(name), VISION.get(name), DENSE.get(name))


def target_for(scheme, target):
    """The target a run of `scheme` (a name, a Scheme or a factory) uses: target itself, or
    with the scheme's feature sources (TARGETS)."""
    fn = TARGETS.get(scheme) if isinstance(scheme, str) else getattr(scheme, "target", None)
    return target if fn is None else fn(target)


def make(scheme, gain: float, n_points: int = 4):
    """A servo of `scheme` (a name in SCHEMES, a Scheme, or a factory) for n_points points. Factories
    written for the paper's four points, factory(gain), are accepted when n_points is 4."""
    factory = SCHEMES[scheme] if isinstance(scheme, str) else scheme
    if isinstance(factory, Scheme):
        factory = factory.factory
    if _takes_points(factory):
        return factory(gain, n_points)
    servo = factory(gain)
    if servo.layout is not None and servo.layout.n_points != n_points:
        raise ValueError(f"scheme: its factory makes a servo for {servo.layout.n_points} points, the target has "
                         f"{n_points}; write it as factory(gain, n_points)")
    return servo


def register_scheme(name: str, factory: Callable[..., Any], *, target: Optional[Callable[..., Any]] = None,
                    replace: bool = False) -> None:
    """Add a scheme: factory(gain, n_points) returns a servo for n_points points (anything
    ibvs.sim.run accepts as servo; factory(gain) is accepted for four-point targets). target:
    fn(target) returning the target with the feature sources of the servo's task's blocks beyond
    points (ibvs.sim.Target.with_features), None for a servo on points only. Module-level functions
    keep the scheme usable by process pools and Dask. Raises ValueError if the name exists (unless
    replace)."""
    if not isinstance(name, str) or not name or any(c in name for c in ",: \t\n"):
        raise ValueError(f"name must be a non-empty string without ',', ':' or spaces, got {name!r}")
    if not callable(factory):
        raise TypeError(f"factory must be callable (gain, n_points -> servo), got {type(factory).__name__}")
    if name in SCHEMES and not replace:
        raise ValueError(f"name: scheme {name!r} is already registered (pass replace=True)")
    if target is not None and not callable(target):
        raise TypeError(f"target must be None or callable (target -> target with feature sources), got "
                        f"{type(target).__name__}")
    SCHEMES[name] = factory
    if target is None:
        TARGETS.pop(name, None)
    else:
        TARGETS[name] = target
