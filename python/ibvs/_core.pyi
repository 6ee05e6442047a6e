"""Type stubs of the native module ibvs._core (the control-law core and the simulator's native part).

tests/python/test_stub.py checks that they are the module's: mypy.stubtest (what it cannot express is in
tests/python/stubtest_allowlist.txt) and the parameter names of every function, which stubtest cannot read
from pybind11's functions.
"""

from __future__ import annotations

import os
from typing import Any, ClassVar, List, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
"""The package version: CMakeLists.txt's project(ibvs VERSION ...)."""

# Stub-only aliases (private: the module has no such names).
_ArrayLike = npt.ArrayLike
_FloatArray = npt.NDArray[np.float64]
_Depth = Union[float, npt.ArrayLike]

# Representation and Status are pybind11 enums, not enum.Enum: members are class attributes compared
# with ==, int(x) and x.value give the number, x.name the name, and the class is not iterable
# (Status.__members__ maps the names to the members).

class Representation:
    """How a block of a Layout measures one point: cartesian (u, v) = 0, polar (r, theta) = 1,
    cylindrical (r, r theta) = 2."""

    cartesian: ClassVar[Representation]
    polar: ClassVar[Representation]
    cylindrical: ClassVar[Representation]
    __members__: ClassVar[dict[str, Representation]]
    def __init__(self, value: int) -> None: ...
    def __int__(self) -> int: ...
    def __index__(self) -> int: ...
    def __eq__(self, other: object) -> bool: ...
    def __ne__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class Status:
    """What an update() returns: ok = 0, singular = 1 (rank-deficient Jacobian), features_lost = 2 (too
    few valid points: the twist ramps to zero), invalid_input = -1."""

    ok: ClassVar[Status]
    singular: ClassVar[Status]
    invalid_input: ClassVar[Status]
    features_lost: ClassVar[Status]
    __members__: ClassVar[dict[str, Status]]
    def __init__(self, value: int) -> None: ...
    def __int__(self) -> int: ...
    def __index__(self) -> int: ...
    def __eq__(self, other: object) -> bool: ...
    def __ne__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class Layout:
    """Which feature blocks are stacked, in which row order.

    Layout(blocks, n_points=None): blocks is a sequence of (point_index, "cartesian" | "polar" | "cylindrical");
    block k fills rows 2k and 2k+1 of the feature vector and the Jacobian.
    n_points defaults to the largest point index + 1.
    """

    def __init__(
        self, blocks: Sequence[Tuple[int, Union[str, Representation]]], n_points: int | None = None
    ) -> None: ...
    @staticmethod
    def cartesian(n: int) -> Layout:
        """Classic IBVS: (u_i, v_i) for each of n points, 2n x 6."""
    @staticmethod
    def polar(n: int) -> Layout:
        """IBVS-P: (r_i, theta_i) for each of n points, 2n x 6."""
    @staticmethod
    def stacked(n: int) -> Layout:
        """Stacked hybrid: (u_i, v_i, r_i, theta_i) for each of n points, 4n x 6."""
    @staticmethod
    def cylindrical(n: int) -> Layout:
        """(r_i, r_i theta_i) for each of n points (Iwatsuki & Okiyama), 2n x 6. Servo error per point:
        (r - r*, r wrap(theta - theta*)); rows bounded at r = 0, so no Cartesian fallback.
        """
    @property
    def rows(self) -> int:
        """M, the number of feature rows (2 per block)."""
    @property
    def n_points(self) -> int:
        """N, the number of image points."""
    @property
    def blocks(self) -> list[tuple[int, str]]:
        """List of (point_index, representation) in row order."""
    def __eq__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...

def features(uv: _ArrayLike, layout: Layout) -> _FloatArray:
    """(M,) stacked features of uv (N, 2)."""

def jacobian(uv: _ArrayLike, depth: _Depth, layout: Layout, polar_min_radius: float = 1e-3) -> _FloatArray:
    """(M, 6) stacked image Jacobian."""

def feature_error(
    f: _ArrayLike, f_desired: _ArrayLike, layout: Layout, angle_wrap: str = "consistent"
) -> _FloatArray:
    """(M,) f (-) f*, theta rows wrapped as one rotation ("consistent") or each into (-pi, pi]
    ("per_point")."""

def damped_pinv(J: _ArrayLike, damping: float = 0.0) -> _FloatArray:
    """(6, M) pseudoinverse of J (M, 6)."""

def singular_values(J: _ArrayLike) -> _FloatArray:
    """Singular values of J (M, 6), decreasing (entries at most 1e150 in magnitude)."""
def wrap_angle(angle: Union[float, _ArrayLike]) -> Union[float, _FloatArray]:
    """Wrap angles (radians, any finite value) into (-pi, pi]; exactly -pi maps to +pi."""
def se3_exp(twist: _ArrayLike) -> _FloatArray:
    """(4, 4) rigid motion of a twist applied for unit time."""

class AdaptiveGain:
    """gain(x) = (at_zero - at_infinity) * exp(-(slope_at_zero / (at_zero - at_infinity)) * x) + at_infinity."""

    def __init__(self, at_zero: float, at_infinity: float, slope_at_zero: float) -> None: ...
    @property
    def at_zero(self) -> float:
        """g0: the gain at zero error norm (used near convergence), 1/s."""
    @property
    def at_infinity(self) -> float:
        """g_inf: the gain for large error norms, 1/s (0 < g_inf <= g0)."""
    @property
    def slope_at_zero(self) -> float:
        """g0': minus the slope of the gain at zero error, 1/s per unit of error norm."""
    def __call__(self, x: Union[float, _ArrayLike]) -> Union[float, _FloatArray]: ...

class CameraModel:
    """Pinhole camera with lens distortion: normalised image coordinates (x, y) = (X/Z, Y/Z) in the
    camera frame (x right, y down, z forward) <-> pixels u = u0 + px xd, v = v0 + py yd.
    distortion: "none", "visp" (kud, kdu), "plumb_bob" (k1, k2, p1, p2, k3), "equidistant" (k1..k4),
    "omnidir" (Mei's unified model: xi, k1, k2, p1, p2). Pixels <-> unit bearings over the whole field
    of view: to_bearing, from_bearing. Also ibvs.sim.Camera (the simulator's camera)."""

    def __init__(
        self,
        px: float,
        py: float,
        u0: float,
        v0: float,
        kud: float = 0.0,
        kdu: float = 0.0,
        width: float = 640.0,
        height: float = 480.0,
        fps: float = 60.0,
    ) -> None: ...
    @staticmethod
    def from_visp(
        px: float, py: float, u0: float, v0: float, kud: float, kdu: float, width: float, height: float,
        fps: float = 60.0,
    ) -> CameraModel:
        """ViSP's vpCameraParameters with distortion: focal lengths px, py and principal point u0, v0
        (pixels); project with kud, normalize with kdu (separate calibrations: the round trip is close,
        not exact). kud = kdu = 0 gives distortion "none".
        """
    @staticmethod
    def from_opencv(
        K: _ArrayLike, dist: _ArrayLike | None, width: float, height: float, fisheye: bool = False, fps: float = 60.0
    ) -> CameraModel:
        """K (3, 3) pixels; dist (k1, k2, p1, p2[, k3]) or with fisheye (k1, k2, k3, k4)."""
    @staticmethod
    def from_omnidir(
        K: _ArrayLike, xi: Union[float, _ArrayLike], D: _ArrayLike, width: float, height: float, fps: float = 60.0
    ) -> CameraModel:
        """Mei's unified omnidirectional model as cv2.omnidir.calibrate returns it: K (no skew), xi >= 0,
        D = (k1, k2, p1, p2)."""
    @staticmethod
    def from_yaml(path: Union[str, os.PathLike[str]], fps: float | None = None) -> CameraModel:
        """ROS camera_info or OpenCV calibration file (needs the vision extra: pip install ".[vision]").

        fps: the given one, else the file's fps or frame_rate, else 60 with a UserWarning."""
    @staticmethod
    def normalized(bounds: float = 0.3, fps: float = 60.0) -> CameraModel:
        """Paper Table I: unit focal length (pixels = normalised coordinates), sensor +-bounds, no
        distortion."""
    @staticmethod
    def afma6() -> CameraModel:
        """Paper Section III-B / ViSP's Afma6 camera: 640x480, px 1090.6, py 1090.0, u0 310.1, v0 260.8,
        kud -0.2114, kdu 0.2217, 60 fps."""
    @property
    def px(self) -> float:
        """Focal length along u, pixels (OpenCV fx)."""
    @property
    def py(self) -> float:
        """Focal length along v, pixels (OpenCV fy)."""
    @property
    def u0(self) -> float:
        """Principal point, pixels (OpenCV cx)."""
    @property
    def v0(self) -> float:
        """Principal point v, pixels (OpenCV cy)."""
    @property
    def distortion(self) -> str:
        """'none', 'visp', 'plumb_bob', 'equidistant' or 'omnidir'."""
    @property
    def coefficients(self) -> Tuple[float, ...]:
        """The distortion coefficients: () none, (kud, kdu) visp, (k1, k2, p1, p2, k3) plumb_bob,
        (k1, k2, k3, k4) equidistant, (xi, k1, k2, p1, p2) omnidir."""
    @property
    def xi(self) -> float:
        """Mei's xi (omnidir; 0 for the other models)."""
    @property
    def max_angle(self) -> float:
        """Angle off the optical axis (radians) below which to_bearing / from_bearing are one-to-one."""
    @property
    def fold_radius(self) -> float:
        """Distorted normalised radius of max_angle: the image circle (inf when none)."""
    @property
    def field_of_view(self) -> float:
        """Full angle (radians) the sensor sees."""
    @property
    def K(self) -> _FloatArray:
        """(3, 3) camera matrix, pixels."""
    @property
    def width(self) -> float:
        """u_max - u_min, pixels."""
    @property
    def height(self) -> float:
        """v_max - v_min, pixels."""
    @property
    def bounds(self) -> Tuple[float, float, float, float]:
        """(u_min, u_max, v_min, v_max), pixels."""
    @property
    def fps(self) -> float:
        """Frames per second."""
    @property
    def max_radius(self) -> float:
        """Normalised radius up to which the distortion is one-to-one (inf: everywhere)."""
    def project(self, uv: _ArrayLike, invalid: str = "raise") -> _FloatArray:
        """Normalised (N, 2), (N, 1, 2) or (2,) -> pixels of the same shape."""
    def normalize(self, pixels: _ArrayLike, invalid: str = "raise") -> _FloatArray:
        """Pixels (N, 2), (N, 1, 2) or (2,) -> normalised of the same shape."""
    def to_bearing(self, pixels: _ArrayLike, invalid: str = "raise") -> _FloatArray:
        """Pixels (N, 2), (N, 1, 2) or (2,) -> unit bearings (N, 3) or (3,), the whole field of view."""
    def from_bearing(self, bearings: _ArrayLike, invalid: str = "raise") -> _FloatArray:
        """Directions (N, 3) or (3,) (finite, non-zero) -> pixels (N, 2) or (2,)."""
    def contains(self, pixels: _ArrayLike) -> Union[bool, npt.NDArray[np.bool_]]:
        """Whether each pixel lies inside the sensor bounds (inclusive): bool (N,), or a bool for one
        point (2,)."""
    def to_opencv(self) -> Tuple[Any, ...]:
        """(K, dist) for OpenCV (cv2.fisheye for equidistant); omnidir: (K, xi, D) for cv2.omnidir."""
    def __eq__(self, other: object) -> bool: ...

class DepthEstimator:
    """Online depth per point from successive frames and the camera's motion (an EKF on (x, y, 1/z)).
    Normalised points, depths in metres, motion = pose of the current camera in the previous camera
    frame (4x4, metres) or twist * dt (6,)."""

    def __init__(
        self,
        prior: _ArrayLike,
        point_noise: float = 0.0,
        prior_uncertainty: float = 1.0,
        process_noise: float = 1e-4,
        position_noise: float = 1e-6,
        min_depth: float = 1e-3,
        max_depth_ratio: float = 100.0,
    ) -> None: ...
    def update(self, uv: _ArrayLike, motion: _ArrayLike) -> Tuple[_FloatArray, _FloatArray]:
        """-> (depth (N,) m, variance (N,) m^2)."""
    def reset(self, prior: _ArrayLike | None = None) -> None:
        """Forget the state (and take a new prior (N,) if given): the next update() starts from the prior."""
    @property
    def depth(self) -> _FloatArray:
        """Current depth estimate (N,), metres (the prior before the first update)."""
    @property
    def variance(self) -> _FloatArray:
        """Its variance (N,), m^2 (first order in 1/z)."""
    @property
    def prior(self) -> _FloatArray:
        """The prior depths (N,), metres."""
    @property
    def initialized(self) -> bool:
        """False until the first update() after construction or reset()."""
    @property
    def restarts(self) -> int:
        """Points restarted from the prior by the last update() (a prediction behind the camera)."""
    @property
    def n_points(self) -> int:
        """N, the number of points."""

class PlanarPose:
    """Camera <- target pose and depths of a planar target (points (N, 3), z = 0, metres), from normalised
    image points (estimate) or from bearings at any angle off the axis (estimate_bearings)."""

    def __init__(self, points: _ArrayLike, iterations: int = 5) -> None: ...
    def estimate(self, uv: _ArrayLike) -> Tuple[_FloatArray, _FloatArray, bool]:
        """Normalised uv -> (pose 4x4 camera <- target, depth (N,), degenerate)."""
    def estimate_bearings(self, bearings: _ArrayLike) -> Tuple[_FloatArray, _FloatArray, bool]:
        """Bearings (N, 3), any angle off the axis -> (pose 4x4 camera <- target, range |P| (N,), degenerate)."""
    @property
    def points(self) -> _FloatArray:
        """(N, 3), target frame, metres."""
    @property
    def iterations(self) -> int:
        """Gauss-Newton steps after the linear (homography) start."""

class ServoResult:
    """Result of one update(): a snapshot owning its buffer; error, jacobian and velocity are
    read-only views of it (no copy), never changed by later updates."""

    @property
    def status(self) -> Status:
        """Status.ok, Status.singular (rank-deficient Jacobian; diagnostics on) or Status.invalid_input."""
    @property
    def velocity(self) -> _FloatArray:
        """(6,) camera twist: Tx, Ty, Tz (m/s), wx, wy, wz (rad/s)."""
    @property
    def error(self) -> _FloatArray:
        """Feature error f (-) f* (M,). Read-only view."""
    @property
    def error_norm(self) -> float:
        """Euclidean norm of error."""
    @property
    def jacobian(self) -> _FloatArray:
        """Interaction matrix used (M, 6). Read-only view."""
    @property
    def sigma_min(self) -> float:
        """Smallest singular value of jacobian; NaN if not computed (diagnostics=False, or a refused
        input). Computed when first read (exact eigenvalues of J^T J, ~0.5 us; relative error
        ~eps cond(J)^2) unless the step had it anyway (exact_diagnostics, QR + SVD route).
        """
    @property
    def sigma_max(self) -> float:
        """Largest singular value of jacobian (to rounding); NaN if not computed. Computed when read."""
    @property
    def condition(self) -> float:
        """sigma_max / sigma_min (inf when sigma_min = 0; NaN if not computed)."""
    @property
    def polar_fallbacks(self) -> int:
        """Polar blocks computed as Cartesian this step (point within polar_min_radius of the centre)."""
    @property
    def gain(self) -> float:
        """The gain applied this step."""
    @property
    def saturated(self) -> bool:
        """True when the twist was scaled down to the speed limits."""
    @property
    def saturation_scale(self) -> float:
        """The uniform factor in (0, 1] applied to the twist (1 when not saturated)."""
    @property
    def pixel_error(self) -> float:
        """update_pixels: largest point-to-goal distance in pixels; NaN after update."""
    @property
    def lost_points(self) -> int:
        """Points marked invalid this step (update(valid=...))."""
    @property
    def law_switched(self) -> bool:
        """The continuous law (decay_rate > 0) started a transition this step."""
    @property
    def acceleration_limited(self) -> bool:
        """The change of twist was scaled down to the acceleration limits this step."""

class Feature:
    """A block of feature rows of a Task beside its points.

    Each kind documents its measurement: the values a frame gives it (e.g. a line: rho, theta and
    the plane A, B, C with 1/Z = A x + B y + C), in normalised coordinates and metres. value(),
    error() and interaction() evaluate it (they check the measurement first: ValueError naming
    the entry).
    """

    @property
    def rows(self) -> int:
        """Rows of the block (size of its value)."""
    @property
    def size(self) -> int:
        """Values in one measurement."""
    def value(self, measurement: _ArrayLike) -> _FloatArray:
        """The block's feature values s (rows,)."""
    def error(self, measurement: _ArrayLike, measurement_desired: _ArrayLike) -> _FloatArray:
        """s (-) s*: the measurement aligned to the goal's, angles wrapped (rows,)."""
    def axis_angle_rows(self, measurement: _ArrayLike, measurement_desired: _ArrayLike) -> list[int]:
        """The error rows that are angles about the optical axis at these measurements: they join a Servo's
        consistent angle wrap (angle_wrap="consistent") with the polar points' theta rows. [] for most kinds;
        [1] (the azimuth) for a SphericalPolarFeature off the axis."""
    def interaction(self, measurement: _ArrayLike) -> _FloatArray:
        """The interaction matrix L (rows, 6): ds/dt = L v for the camera twist v."""

class LineFeature(Feature):
    """An image line (rho, theta).

    The line x cos(theta) + y sin(theta) = rho (normalised coordinates), projection of a 3-D line
    in the plane 1/Z = A x + B y + C (one through the line, not through the camera centre).
    Measurement (5): rho, theta, A, B, C; LineFeature.measure(p1, p2, plane) builds it from two
    image points. Interaction matrix: Espiau, Chaumette & Rives 1992 (ViSP's vpFeatureLine with
    A = -A'/D', B = -B'/D', C = -C'/D'). The line is also (-rho, theta + pi): the error uses the
    form nearest the goal's, theta's difference wrapped into (-pi, pi].
    """

    def __init__(self) -> None: ...
    @staticmethod
    def measure(p1: _ArrayLike, p2: _ArrayLike, plane: _ArrayLike) -> _FloatArray:
        """The measurement (rho >= 0, theta, A, B, C) of the line through two distinct image points."""

class SegmentFeature(Feature):
    """An image segment (ViSP's vpFeatureSegment).

    The segment from image point p1 (depth Z1) to p2 (depth Z2): centre (xc, yc), length l and
    orientation alpha = atan2(y2 - y1, x2 - x1). Features: (xc/l, yc/l, 1/l, alpha) when
    normalized (default; 1/l is proportional to the depth of a fronto-parallel segment), else
    (xc, yc, l, alpha). Measurement (6): xc, yc, l, alpha, Z1, Z2, from
    SegmentFeature.measure(p1, p2, Z1, Z2) or from two 3-D points by SegmentFeature.project(P1, P2).
    The segment is unoriented: it is also its reverse (alpha + pi, Z1 and Z2 exchanged), and the
    error uses the form whose alpha is nearest the goal's (alpha's difference wrapped into
    (-pi, pi], at most pi/2). Interaction matrix: the end points' point rows composed (equal to
    ViSP's closed form). Refused: a segment shorter than 1e-9 (zero length), depths outside
    [1e-6, 1e6] m, a centre beyond 10 (normalised), non-finite values.
    """

    def __init__(self, normalized: bool = True) -> None: ...
    @property
    def normalized(self) -> bool:
        """True: features (xc/l, yc/l, 1/l, alpha); False: (xc, yc, l, alpha)."""
    @staticmethod
    def measure(p1: _ArrayLike, p2: _ArrayLike, Z1: float, Z2: float) -> _FloatArray:
        """The measurement (xc, yc, l, alpha, Z1, Z2) of the segment from image point p1 at depth Z1
        to p2 at depth Z2 (normalised coordinates, metres)."""
    @staticmethod
    def project(P1: _ArrayLike, P2: _ArrayLike) -> _FloatArray:
        """The measurement of the segment between two 3-D points of the camera frame (in front of
        the camera)."""

class EllipseFeature(Feature):
    """An image ellipse or planar blob by its moments (ViSP's vpFeatureEllipse).

    Features (xg, yg, n20, n11, n02): the centroid and the centred second-order moments divided by
    the area (normalised coordinates; a disc of radius R has n20 = n02 = R^2 / 4). Measurement (8):
    xg, yg, n20, n11, n02 and the plane A, B, C (1/Z = A x + B y + C) of the 3-D circle or planar
    blob; from a 3-D circle by EllipseFeature.project_circle(centre, normal, radius), from an image
    blob by EllipseFeature.measure_moments(cv2.moments(mask), plane, camera). Interaction matrix:
    Chaumette 2004 (IEEE T-RO), eqs. (14) and (26). Refused: zero or negative area
    (n20 n02 - n11^2 <= 0), a plane seen edge-on or behind the camera over the ellipse, a centroid
    beyond 10 (normalised), non-finite values. A circle seen fronto-parallel and centred is a
    singular configuration (the five rows have rank 3).
    """

    def __init__(self) -> None: ...
    @staticmethod
    def project_circle(centre: _ArrayLike, normal: _ArrayLike, radius: float) -> _FloatArray:
        """The measurement of the image of a 3-D circle (camera frame, metres): its centre, the
        normal of its plane (any length, either sign) and its radius."""
    @staticmethod
    def measure_moments(
        moments: Union[dict[str, float], _ArrayLike], plane: _ArrayLike, camera: CameraModel | None = None
    ) -> _FloatArray:
        """The measurement of a planar blob from its image moments: cv2.moments' dict (or the 6
        values m00, m10, m01, mu20, mu11, mu02), in pixels of `camera` (without lens distortion:
        undistort first) or, camera None, in normalised coordinates; plane (A, B, C) of
        1/Z = A x + B y + C."""

class MomentsFeature(Feature):
    """Image moments of a planar object.

    Tahri & Chaumette (IEEE T-RO 2005): rows xn, yn, an, r1, r2 (invariants "p": px, py, or "s":
    sx, sy) and alpha ("second_order": modulo pi; "third_order": over the full turn). source
    "region" (integrals) or "points" (sums). Measurement (20): m00..m04, a*, Z*, A, B, C.
    """

    def __init__(
        self,
        source: str = "region",
        invariants: str = "p",
        alpha: str = "third_order",
        rows: Sequence[str] | None = None,
    ) -> None: ...
    @property
    def source(self) -> str:
        """"region" (moments are integrals over the object) or "points" (sums over discrete points)."""
    @property
    def invariants(self) -> str:
        """The pair of invariants for wx, wy: "p" (px, py) or "s" (sx, sy)."""
    @property
    def alpha(self) -> str:
        """The orientation: "second_order" (modulo pi) or "third_order" (over the full turn)."""
    @property
    def row_names(self) -> List[str]:
        """The selected rows, in order."""
    @staticmethod
    def of_points(xy: _ArrayLike) -> _FloatArray:
        """Moments m00..m04 (15,) of discrete image points (N, 2): sums of x^i y^j."""
    @staticmethod
    def of_polygon(xy: _ArrayLike) -> _FloatArray:
        """Moments m00..m04 (15,) of the region inside a simple polygon (N, 2), either orientation."""
    @staticmethod
    def measure(
        moments: _ArrayLike, plane: _ArrayLike, source: str = "region", area_desired: float = 0.0,
        depth_desired: float = 1.0,
    ) -> _FloatArray:
        """The measurement (20,): moments, a*, Z*, plane. area_desired=0: the object's own area."""
    @staticmethod
    def project(
        points: _ArrayLike, source: str = "region", area_desired: float = 0.0, depth_desired: float = 1.0
    ) -> _FloatArray:
        """The measurement (20,) of a 3-D planar polygon or point set (N, 3) in the camera frame."""
    @staticmethod
    def area(measurement: _ArrayLike, source: str = "region") -> float:
        """The object's area a: m00 (region) or mu20 + mu02 (points)."""

class SphericalPointFeature(Feature):
    """A point on the unit sphere: its bearing b = P / |P| (3 rows).

    Measurement (4): bx, by, bz (unit) and the distance R = |P|. Interaction matrix
    [-(I - b b^T) / R, [b]_x] (Hamel & Mahony 2002, eq. 9).
    """

    def __init__(self) -> None: ...
    @staticmethod
    def measure(P: _ArrayLike) -> _FloatArray:
        """The measurement (bx, by, bz, R) of the camera-frame point P."""

class SphericalPolarFeature(Feature):
    """A point on the unit sphere as (colatitude, azimuth) (2 rows); measurement (bx, by, bz, R).

    Interaction matrix: Corke, ICRA 2010; the azimuth error wrapped into (-pi, pi]; (bx, by) rows
    near the axis (sin beta < min_sin).
    """

    def __init__(self, min_sin: float = 0.001) -> None: ...
    @property
    def min_sin(self) -> float:
        """sin(colatitude) below which the current point uses its (bx, by) rows."""

def spherical_measurements(
    camera: CameraModel, pixels: _ArrayLike, distance: _ArrayLike, invalid: str = "raise"
) -> _FloatArray:
    """(N, 4) measurements (bx, by, bz, R) of spherical feature blocks from pixels (through
    camera.to_bearing) and distances |P| (metres)."""

class Task:
    """What a Servo drives to zero: the points of a Layout, then feature blocks.

    Task(layout=None): the image points of `layout` (a Servo of a Task of points only is the Servo
    of the Layout, bit for bit), then add(feature, weight) appends blocks of other kinds. Each
    block's rows (of J and of the error) are multiplied by its weight; point_weights gives one
    weight per block of the Layout. dof: the camera twist components the law may use (ViSP's
    setCameraDoF): six bools, or names among "Tx", "Ty", "Tz", "wx", "wy", "wz"; the others are 0
    and the law is solved on the remaining columns of J.
    """

    point_weights: List[float]
    """One weight per Layout block ([] = all 1); settable."""
    dof: List[bool]
    """The controlled twist components (6 bools); settable (bools or names)."""
    def __init__(self, layout: Layout | None = None) -> None: ...
    def add(self, feature: Feature, weight: float = 1.0) -> Task:
        """Append a copy of a feature block (rows multiplied by weight > 0); returns the task."""
    @property
    def layout(self) -> Layout | None:
        """The task's point Layout, or None."""
    @property
    def rows(self) -> int:
        """Rows of the whole task (points, then feature blocks)."""
    @property
    def measurement_size(self) -> int:
        """Values in one measurement of all feature blocks, concatenated."""
    @property
    def features(self) -> List[Feature]:
        """Copies of the feature blocks, in row order."""
    @property
    def weights(self) -> List[float]:
        """The feature blocks' weights."""

class Servo:
    """The IBVS control law v = -gain * J+ (f (-) f*) for a Layout or a Task.

    Servo(layout, gain, damping=0.0, jacobian="current", polar_min_radius=1e-3, diagnostics=True,
          max_linear_speed=inf, max_angular_speed=inf, camera=None, angle_wrap="consistent",
          exact_diagnostics=False)
      gain      gamma in (0, 1e250] (1/s), or an AdaptiveGain (gain as a function of the error norm)
      damping   lambda >= 0: 0 = Moore-Penrose, > 0 = damped least squares; the twist equals
                -gain * damped_pinv(jacobian, damping) @ error (to ~1e-10 relative) either way
      jacobian  "current" J(f, z), "desired" J(f*, z*) or "mean" of the two
      diagnostics  Status.singular every step (exact, from the full-rank test of the solve,
                nearly free) and ServoResult.sigma_min / sigma_max / condition, computed when
                read; False: NaN, never singular
      exact_diagnostics  compute sigma_min / sigma_max every step by QR + SVD (~4 us)
      max_linear_speed, max_angular_speed  > 0 (m/s, rad/s): the whole twist is scaled by one
                factor so that |T| and |w| stay within them (direction kept); inf = no limit
      camera    an ibvs.CameraModel for update_pixels (pixels in, twist out), or None
      angle_wrap  "consistent" (default): the theta differences of one frame (and the feature blocks'
                angles about the axis, Feature.axis_angle_rows) are wrapped as one
                rotation about their circular mean (see feature_error), the mean kept on the
                previous frame's side of the half-turn while within pi + pi/4 of 0 (reset()
                forgets it); "per_point": eq. (13) point by point, no memory
      decay_rate  mu >= 0 (1/s): the continuous law of Mansard & Chaumette 2007 (eq. 17) from the
                first update, reset(twist) and every change of law, of the Cartesian / polar
                choices or of the valid points; 0 = off
      max_linear_acceleration, max_angular_acceleration  > 0 (m/s^2, rad/s^2), direction kept
      period    the control period (s) the above and stop_time need; ibvs.sim.run uses 1/fps
      cartesian_near_goal  > 0: every polar block Cartesian while every valid point lies within
                this distance (normalised) of its goal (polar again beyond 1.5 times it)
      stop_time  >= 0 (s): with too few valid points the twist ramps to zero over this time
    """

    gain: Union[float, AdaptiveGain]
    """The constant gain (float, 1/s) or the AdaptiveGain; settable."""
    damping: float
    """lambda >= 0 of the damped least squares; settable."""
    max_linear_speed: float
    """Limit on |T| (m/s), inf = none; settable."""
    max_angular_speed: float
    """Limit on |w| (rad/s), inf = none; settable."""
    angle_wrap: str
    """'consistent' or 'per_point' (see the class doc); setting it also forgets the previous frame."""
    def __init__(
        self,
        layout: Union[Layout, Task],
        gain: Union[float, AdaptiveGain],
        damping: float = 0.0,
        jacobian: str = "current",
        polar_min_radius: float = 1e-3,
        diagnostics: bool = True,
        max_linear_speed: float = ...,
        max_angular_speed: float = ...,
        camera: CameraModel | None = None,
        angle_wrap: str = "consistent",
        exact_diagnostics: bool = False,
        decay_rate: float = 0.0,
        max_linear_acceleration: float = ...,
        max_angular_acceleration: float = ...,
        period: float = 0.0,
        cartesian_near_goal: float = 0.0,
        stop_time: float = 0.0,
    ) -> None: ...
    @staticmethod
    def automatic_hybrid(
        n_points: int,
        gain: Union[float, AdaptiveGain],
        switch_radius: float = 0.05,
        damping: float = 0.0,
        jacobian: str = "current",
        diagnostics: bool = True,
        max_linear_speed: float = ...,
        max_angular_speed: float = ...,
        camera: CameraModel | None = None,
        angle_wrap: str = "consistent",
    ) -> Servo:
        """Automatic hybrid: each point polar while it and its desired point lie at least switch_radius
        (normalised units) from the principal point, Cartesian otherwise, re-decided every step. It is
        Servo(Layout.polar(n_points), gain, polar_min_radius=switch_radius, ...); ServoResult.polar_fallbacks
        counts the points computed as Cartesian.
        """
    def update(
        self,
        uv: _ArrayLike,
        depth: _Depth,
        uv_desired: _ArrayLike,
        depth_desired: _Depth | None = None,
        measurements: _ArrayLike | Sequence[_ArrayLike] | None = None,
        measurements_desired: _ArrayLike | Sequence[_ArrayLike] | None = None,
        valid: _ArrayLike | None = None,
    ) -> ServoResult:
        """uv, uv_desired (N, 2) or (N, 1, 2) normalised; depth metres; measurements of a Task's feature
        blocks: one array per block or all of them concatenated; valid: None or N bools (False: a lost
        point, left out of the law; its uv and depth may be NaN)."""
    def update_pixels(
        self, pixels: _ArrayLike, depth: _Depth, pixels_desired: _ArrayLike, depth_desired: _Depth | None = None
    ) -> ServoResult:
        """pixels, pixels_desired (N, 2) or (N, 1, 2) as measured; normalised with the servo's camera."""
    def reset(self, twist: _ArrayLike | None = None) -> None:
        """Forget the previous frame's angle-wrap branch; with decay_rate > 0 start from twist (None: rest)."""
    def continue_turn(self, centre: float) -> None:
        """Choose the angle wrap's branch for the next frame as if the previous mean polar angle error had been
        centre (radians): +pi or -pi picks a half-turn's direction. NaN forgets it (as reset() and a change of
        angle_wrap do; ibvs.sim.run resets the servo: use its turn); ValueError unless NaN or |centre| <= pi + pi/4."""
    @property
    def decay_rate(self) -> float:
        """mu >= 0 (1/s) of the continuous law (Mansard & Chaumette 2007, eq. 17); 0: off."""
    @property
    def max_linear_acceleration(self) -> float:
        """Limit on the change of T per second (m/s^2), direction kept; inf: none."""
    @property
    def max_angular_acceleration(self) -> float:
        """Limit on the change of w per second (rad/s^2), direction kept; inf: none."""
    @property
    def period(self) -> float:
        """The control period (s) that decay_rate, the acceleration limits and stop_time use."""
    @property
    def cartesian_near_goal(self) -> float:
        """> 0: polar blocks Cartesian while every valid point is within this of its goal; 0: off."""
    @property
    def stop_time(self) -> float:
        """With too few valid points, the time (s) over which the twist ramps to zero."""
    @property
    def camera(self) -> CameraModel | None:
        """The CameraModel used by update_pixels (None if not given)."""
    @property
    def layout(self) -> Layout:
        """The Layout this servo was built for (a Task's points)."""
    @property
    def task(self) -> Task:
        """The Task this servo was built for (a Layout's is its points only)."""
    @property
    def jacobian_mode(self) -> str:
        """Where the interaction matrix is evaluated: "current", "desired" or "mean"."""
    @property
    def polar_min_radius(self) -> float:
        """Radius below which a polar block uses its Cartesian rows for the step (normalised units)."""

class PartitionedServo:
    """Partitioned IBVS (Corke & Hutchinson 2001): wz from a segment angle, Tz from sqrt(area)."""

    gain: float
    """gamma > 0, 1/s, for all three parts; settable."""
    def __init__(
        self,
        n_points: int,
        gain: float,
        damping: float = 0.0,
        segment: Tuple[int, int] = (0, 1),
        max_linear_speed: float = ...,
        max_angular_speed: float = ...,
        camera: CameraModel | None = None,
    ) -> None: ...
    def update(
        self, uv: _ArrayLike, depth: _Depth, uv_desired: _ArrayLike, depth_desired: _Depth | None = None
    ) -> ServoResult:
        """One control step (depth_desired is accepted and unused)."""
    def update_pixels(
        self, pixels: _ArrayLike, depth: _Depth, pixels_desired: _ArrayLike, depth_desired: _Depth | None = None
    ) -> ServoResult:
        """One control step from pixels (N, 2) or (N, 1, 2) with the servo's camera model, as Servo.update_pixels."""
    @property
    def camera(self) -> CameraModel | None:
        """The CameraModel used by update_pixels (None if not given)."""
    @property
    def layout(self) -> Layout:
        """Layout.cartesian(N): the layout of its error and Jacobian."""
    @property
    def n_points(self) -> int:
        """N, the number of points (at least 3)."""
    @property
    def damping(self) -> float:
        """lambda >= 0 of the least squares on the four (Tx, Ty, wx, wy) columns."""
    @property
    def max_linear_speed(self) -> float:
        """Limit on |(Tx, Ty, Tz)| (m/s); inf = none."""
    @property
    def max_angular_speed(self) -> float:
        """Limit on |(wx, wy, wz)| (rad/s); inf = none."""
    @property
    def segment(self) -> Tuple[int, int]:
        """(i, j): the points whose image segment gives theta_z."""

class JointMappingResult:
    """Result of JointMapping.update()."""

    @property
    def status(self) -> Status:
        """ok, or singular when the camera Jacobian has rank < min(6, n)."""
    @property
    def qdot(self) -> _FloatArray:
        """(n,) joint velocities, m/s or rad/s per joint."""
    @property
    def camera_jacobian(self) -> _FloatArray:
        """(6, n): camera twist (camera frame) = camera_jacobian @ qdot."""
    @property
    def sigma_min(self) -> float:
        """Smallest of the min(6, n) singular values of camera_jacobian."""
    @property
    def sigma_max(self) -> float:
        """Largest singular value of camera_jacobian."""
    @property
    def manipulability(self) -> float:
        """Product of the min(6, n) singular values of camera_jacobian (|det| for 6 joints)."""
    @property
    def damping(self) -> float:
        """The damping applied this step."""
    @property
    def rank(self) -> int:
        """Numerical rank of camera_jacobian."""
    @property
    def saturated(self) -> bool:
        """True when qdot was scaled down to max_joint_speed."""
    @property
    def saturation_scale(self) -> float:
        """The uniform factor in (0, 1] applied to qdot (1 when not saturated)."""

class JointMapping:
    """Camera twist -> joint velocities of the arm carrying the camera (damped least squares,
    speed limits, null-space task). Frames: base b, end effector e, camera c; eMc = e <- c."""

    def __init__(
        self,
        n_joints: int,
        eMc: _ArrayLike,
        frame: str = "end_effector",
        damping: float = 0.0,
        singular_region: float = 0.0,
        max_joint_speed: Union[float, _ArrayLike, None] = None,
        mounting: str = "eye_in_hand",
    ) -> None: ...
    def update(
        self,
        twist: _ArrayLike,
        jacobian: _ArrayLike,
        bRe: _ArrayLike | None = None,
        secondary: _ArrayLike | None = None,
        bMe: _ArrayLike | None = None,
    ) -> JointMappingResult:
        """twist (6,) camera frame; jacobian (6, n) end-effector Jacobian in `frame`; bRe (3, 3) for
        frame='base'; secondary (n,) joint velocities projected into the null space; bMe (4, 4) base <-
        end effector, required with mounting='eye_to_hand' (then eMc is the fixed camera's bMc)."""
    @property
    def mounting(self) -> str:
        """'eye_in_hand' or 'eye_to_hand'."""
    @property
    def n_joints(self) -> int:
        """n, the number of joints."""
    @property
    def eMc(self) -> _FloatArray:
        """end-effector <- camera, 4x4."""
    @property
    def frame(self) -> str:
        """"end_effector" (ViSP eJe, Pinocchio LOCAL) or "base" (Pinocchio LOCAL_WORLD_ALIGNED): the frame of
        the Jacobians given to update().
        """
    @property
    def damping(self) -> float:
        """lambda >= 0 (or its largest value, with singular_region > 0)."""
    @property
    def singular_region(self) -> float:
        """Manipulability below which the damping applies (0: constant damping)."""
    @property
    def max_joint_speed(self) -> _FloatArray | None:
        """(n,) joint-speed limits, or None."""

def joint_velocities(
    twist: _ArrayLike,
    eMc: _ArrayLike,
    jacobian: _ArrayLike,
    frame: str = "end_effector",
    bRe: _ArrayLike | None = None,
    damping: float = 0.0,
    singular_region: float = 0.0,
    max_joint_speed: Union[float, _ArrayLike, None] = None,
    secondary: _ArrayLike | None = None,
    mounting: str = "eye_in_hand",
    bMe: _ArrayLike | None = None,
) -> _FloatArray:
    """(n,) joint velocities moving the camera with `twist` (JointMapping(...).update(...).qdot)."""

class SecondaryTaskResult:
    """Result of SecondaryTask.update()."""

    @property
    def status(self) -> Status:
        """ok."""
    @property
    def qdot(self) -> _FloatArray:
        """(n,) the joint velocities to command."""
    @property
    def secondary(self) -> _FloatArray:
        """(n,) the projected secondary motion P (joints + Jc^+ twist)."""
    @property
    def avoidance(self) -> _FloatArray:
        """(n,) the joint-limit avoidance term."""
    @property
    def weight(self) -> float:
        """s of the large projector's switch (0 with the classical projector)."""
    @property
    def rank(self) -> int:
        """Rank of the primary task's joint Jacobian L Jc."""
    @property
    def active(self) -> int:
        """Joints beyond their activation threshold."""
    @property
    def saturation_scale(self) -> float:
        """Speed-cap factor in (0, 1]."""
    @property
    def acceleration_scale(self) -> float:
        """Acceleration-cap factor in (0, 1]."""

class SecondaryTask:
    """Secondary motions in the null space of a servo's task (classical or large projector), joint-limit
    avoidance (Marey & Chaumette 2010, ViSP's thresholds) and joint speed / acceleration caps."""

    def __init__(
        self,
        n_joints: int,
        projector: str = "classical",
        q_min: _ArrayLike | None = None,
        q_max: _ArrayLike | None = None,
        rho: float = 0.1,
        rho1: float = 0.3,
        lambda_tune: float = 0.7,
        max_joint_speed: Union[float, _ArrayLike, None] = None,
        max_joint_acceleration: Union[float, _ArrayLike, None] = None,
        period: float = 0.0,
        switch_low: float = 0.1,
        switch_high: float = 0.7,
    ) -> None: ...
    def update(
        self,
        qdot: _ArrayLike,
        camera_jacobian: _ArrayLike,
        interaction: _ArrayLike | None = None,
        error: _ArrayLike | None = None,
        q: _ArrayLike | None = None,
        qdot_previous: _ArrayLike | None = None,
        twist: _ArrayLike | None = None,
        joints: _ArrayLike | None = None,
    ) -> SecondaryTaskResult:
        """qdot (n,) primary joint velocities, camera_jacobian (6, n), interaction (M, 6) and error (M,) of the
        servo, q (n,) joint positions, qdot_previous (n,) last command, twist (6,) task-space and joints (n,)
        joint-space secondary motions."""
    @property
    def n_joints(self) -> int:
        """n, the number of joints."""
    @property
    def projector(self) -> str:
        """'classical' or 'large'."""
    @property
    def avoids_joint_limits(self) -> bool:
        """True when q_min and q_max were given."""

def segment_angle(uv: _ArrayLike, i: int, j: int) -> float:
    """theta_z: angle of the image segment from point i to point j."""
def segment_angle_jacobian(uv: _ArrayLike, depth: _Depth, i: int, j: int) -> _FloatArray:
    """(6,) d theta_z/dt = J @ v."""
def area_scale(uv: _ArrayLike) -> float:
    """sigma = sqrt(|area|) of the polygon of the points in order."""
def area_scale_jacobian(uv: _ArrayLike, depth: _Depth) -> _FloatArray:
    """(6,) d sigma/dt = J @ v."""

class sim:
    """The simulator's native part. At runtime ibvs._core.sim is a submodule (pybind11
    def_submodule); a single-file stub cannot declare a submodule, so its contents are
    declared in this namespace class: attribute access and annotations such as
    _core.sim.Camera type-check the same. Use ibvs.sim, not this."""

    class FeatureSource:
        """How the simulator measures one feature block of a Task on the target (one per block,
        in the Task's order: Target(points, pose, features=[...]))."""

        @property
        def size(self) -> int:
            """Values in one measurement (its Feature's size)."""

    class LineSource(FeatureSource):
        """An image line (ibvs.LineFeature) through target points i and j; its plane: the target's
        z = 0 plane (k None) or the plane through points i, j and k."""

        def __init__(self, i: int, j: int, k: int | None = None) -> None: ...
        @property
        def i(self) -> int:
            """The line's first target point."""
        @property
        def j(self) -> int:
            """The line's second target point."""
        @property
        def k(self) -> int | None:
            """The plane's third point, or None: the target's z = 0 plane."""

    class MomentsSource(FeatureSource):
        """Image moments (ibvs.MomentsFeature) of the target's points as one planar object: the
        moments of the controller's points, the target's z = 0 plane from the depth mode's pose, the
        goal's area a* and depth Z*."""

        def __init__(self, source: str = "region") -> None: ...
        @property
        def source(self) -> str:
            """'region' or 'points'."""

    class PbvsSource(FeatureSource):
        """PBVS (ibvs.PbvsFeature) on the pose the depth mode gives against the goal's pose as the same mode
        knew it at the goal (exact: the true one; "pose": the estimate from the goal's image)."""

        def __init__(self, target: str = "desired_camera") -> None: ...
        @property
        def target(self) -> str:
            """'desired_camera' or 'object'."""

    class Point25DSource(FeatureSource):
        """2.5-D (ibvs.Point25DFeature) with target point i as the reference point; its goal (c*R, Z*) as the
        depth mode knew it at the goal (exact: the true one; "pose": estimated from the goal's image)."""

        def __init__(self, i: int = 0) -> None: ...
        @property
        def i(self) -> int:
            """The reference point (a target point's index)."""

    class SphericalSource(FeatureSource):
        """A point on the sphere (ibvs.SphericalPointFeature or SphericalPolarFeature) of target point i."""

        def __init__(self, i: int = 0) -> None: ...
        @property
        def i(self) -> int:
            """The target point's index."""

    class SegmentSource(FeatureSource):
        """An image segment (ibvs.SegmentFeature) between target points i and j: the controller's
        points and the depths the depth mode gives them."""

        def __init__(self, i: int, j: int) -> None: ...
        @property
        def i(self) -> int:
            """The segment's first target point (p1)."""
        @property
        def j(self) -> int:
            """The segment's second target point (p2)."""

    class EllipseSource(FeatureSource):
        """The image ellipse (ibvs.EllipseFeature) of a 3-D circle fixed to the target (target frame:
        centre, normal, radius); its plane from the depth mode's pose."""

        def __init__(self, centre: _ArrayLike, normal: _ArrayLike, radius: float) -> None: ...
        @property
        def centre(self) -> _FloatArray:
            """The circle's centre (3,), target frame, metres."""
        @property
        def normal(self) -> _FloatArray:
            """The unit normal of the circle's plane (3,), target frame."""
        @property
        def radius(self) -> float:
            """The circle's radius, metres."""

    class FunctionSource(FeatureSource):
        """A feature source whose measurement a Python callable gives:
        measure(frame, cMo, depth_pose, goal, uv, depth) -> the block's measurement or None."""

        def __init__(self, feature: Feature, measure: Any) -> None: ...
        @property
        def measure(self) -> Any:
            """The callable."""

    @staticmethod
    def plane_in_camera(pose: _ArrayLike, normal: _ArrayLike = ..., d: float = 0.0) -> _FloatArray:
        """(A, B, C) of 1/Z = A x + B y + C for the plane {X : normal . X = d} of the target frame
        seen with pose (camera <- target)."""

    class Target:
        """Points (N, 3) in the target frame, the target's world pose (4x4) and its feature sources."""

        def __init__(
            self, points: _ArrayLike, pose: _ArrayLike | None = None, features: Sequence[sim.FeatureSource] | None = None
        ) -> None: ...
        @property
        def features(self) -> list[sim.FeatureSource]:
            """The feature sources, in the order of the Task's feature blocks."""
        def with_features(self, features: Sequence[sim.FeatureSource]) -> sim.Target:
            """A copy of the target (points, pose) with these feature sources instead."""
        @staticmethod
        def paper() -> sim.Target:
            """Paper Table I: the points (+-0.25, +-0.25, 3) in the world."""
        @staticmethod
        def square(side: float = 0.1, pose: _ArrayLike | None = None) -> sim.Target:
            """Four dots at the corners of a square (side in metres) in the target's z = 0 plane."""
        @property
        def points(self) -> _FloatArray:
            """(N, 3), target frame."""
        @property
        def pose(self) -> _FloatArray:
            """world <- target, 4x4."""
        def world_points(self) -> _FloatArray:
            """(N, 3), world frame."""
        @property
        def planar(self) -> bool:
            """True when every point lies in the target frame's z = 0 plane (a plate with a front side)."""
        def __len__(self) -> int: ...

    class Robot:
        """A robot carrying the camera (subclass it and define kinematics(q) -> (T_we, J)).
        world = base frame; mount = eMc (end-effector <- camera)."""

        def __init__(
            self,
            q_min: _ArrayLike,
            q_max: _ArrayLike,
            qdot_max: _ArrayLike,
            mount: _ArrayLike,
            frame: str = "end_effector",
            damping: float = 0.0,
            singular_region: float = 0.0,
            mounting: str = "eye_in_hand",
        ) -> None: ...
        @property
        def mounting(self) -> str:
            """'eye_in_hand' or 'eye_to_hand' (the camera fixed at mount = bMc, the target on the end effector)."""
        @property
        def secondary_task(self) -> dict[str, Any] | None:
            """None, or the settings of set_secondary_task()."""
        def set_secondary_task(
            self,
            projector: str = "classical",
            avoid_joint_limits: bool = True,
            rho: float = 0.1,
            rho1: float = 0.3,
            lambda_tune: float = 0.7,
            qddot_max: Union[float, _ArrayLike, None] = None,
            switch_low: float = 0.1,
            switch_high: float = 0.7,
        ) -> None:
            """Run a SecondaryTask (joint-limit avoidance, caps) after the joint mapping in every episode."""
        def clear_secondary_task(self) -> None:
            """Back to the joint mapping alone."""
        @property
        def dof(self) -> int:
            """Number of joints n."""
        @property
        def q_min(self) -> _FloatArray:
            """(n,) lower joint limits."""
        @property
        def q_max(self) -> _FloatArray:
            """(n,) upper joint limits."""
        @property
        def qdot_max(self) -> _FloatArray:
            """(n,) joint speed limits."""
        @property
        def mount(self) -> _FloatArray:
            """end-effector <- camera, 4x4."""
        @property
        def frame(self) -> str:
            """Frame of the Jacobian kinematics() returns: 'end_effector' or 'base'."""
        @property
        def damping(self) -> float:
            """Damping of the robot's JointMapping (see ibvs.JointMapping)."""
        @property
        def singular_region(self) -> float:
            """Singular region of the robot's JointMapping (see ibvs.JointMapping)."""
        def kinematics(self, q: _ArrayLike) -> Tuple[_FloatArray, _FloatArray]:
            """(T_we (4, 4) world <- end effector, J (6, n) end-effector Jacobian in `frame`)."""
        def camera(self, q: _ArrayLike) -> _FloatArray:
            """world <- camera, 4x4."""
        def jacobian(self, q: _ArrayLike) -> _FloatArray:
            """(6, n) camera Jacobian."""
        def joint_velocity(self, q: _ArrayLike, twist: _ArrayLike) -> _FloatArray:
            """Joint velocities (n,) for the camera twist at q, by the robot's JointMapping (before the speed
            limits)."""
        def outside_limits(self, q: _ArrayLike) -> int:
            """Index of the first joint outside its range, or -1."""

    class Gantry(Robot):
        """Afma6-like gantry: 3 prismatic joints + 3-revolute wrist, camera on the flange."""

        @staticmethod
        def afma6() -> sim.Gantry:
            """ViSP vpAfma6 defaults with the distorted-camera mount."""
        @property
        def coupling(self) -> float:
            """Wrist coupling c: q6' = q6 - c q5 (ViSP's vpAfma6)."""
        @property
        def offset(self) -> float:
            """l, metres, between joints 5 and 6 (ViSP's vpAfma6)."""
        def with_limits(
            self,
            q_min: _ArrayLike | None = None,
            q_max: _ArrayLike | None = None,
            qdot_max: _ArrayLike | None = None,
        ) -> sim.Gantry:
            """A copy with other joint position / speed limits."""
        def with_mount(self, mount: _ArrayLike, mounting: str = "eye_in_hand") -> sim.Gantry:
            """A copy with another camera mount (eMc, or the fixed camera's world <- camera with 'eye_to_hand')."""
        def end_effector(self, q: _ArrayLike) -> _FloatArray:
            """world <- end-effector, 4x4."""
        def manipulability(self, q: _ArrayLike) -> float:
            """|det jacobian(q)| = |cos q5|."""

    class Sensor:
        """What the simulated camera reports each frame (ibvs.sim.run(..., vision=...)). Subclass it and
        define measure(frame, pose, projected, twist) -> (N, 2) pixels (NaN row = lost point) and
        optionally reset(seed); ibvs.vision.ImageSensor is one."""

        def __init__(self) -> None: ...

    @staticmethod
    def _run(
        servo: Union[Servo, PartitionedServo],
        camera: CameraModel,
        target: sim.Target,
        start: _ArrayLike,
        goal: _ArrayLike,
        robot: sim.Robot | None = None,
        duration: float = 10.0,
        noise: float = 0.0,
        latency: int = 0,
        depth: str = "exact",
        seed: int = 0,
        tolerance: float = 1e-4,
        tolerance_px: float = 0.0,
        max_depth_ratio: float = 10.0,
        max_error_ratio: float = 100.0,
        stop_on_singular: bool = True,
        depth_scale: float = 1.0,
        boundary_margin: float = 0.0,
        boundary_gain: float = 0.1,
        standoff_ratio: float = 0.05,
        sensor: sim.Sensor | None = None,
        keep_lost: bool = False,
        goal_pose: str = "taught",
        turn: float = ...,
    ) -> dict[str, Any]:
        """One episode; a dict of arrays and scalars (ibvs.sim.run builds its Result from it)."""

# ---- 3-D (PBVS), 2.5-D and user-defined feature blocks (features/pose.hpp, bind_pose.cpp) ----

def theta_u(R: _ArrayLike) -> _FloatArray:
    """The rotation vector theta u (3,) of a rotation matrix, theta in [0, pi] (at pi, the axis' sign
    with its largest component positive)."""

def theta_u_interaction(tu: _ArrayLike) -> _FloatArray:
    """L_tu (3, 3): d(theta u)/dt = L_tu w for theta u of c*Rc and the camera's angular velocity w:
    I + (theta/2)[u]x + (1 - sinc(theta)/sinc^2(theta/2))[u]x^2 (Malis et al. 1999; ViSP cdRc)."""

class PbvsFeature(Feature):
    """Position-based visual servoing: (translation, theta u), 6 rows.

    target="desired_camera": s = (c*t_c, theta u), the current camera's centre in the desired
    camera's frame (goal 0), L = [c*Rc 0; 0 L_tu]: the camera centre moves on a straight line.
    target="object": s = (c t_o, theta u), the object origin in the camera frame (goal c*t_o),
    L = [-I [c t_o]x; 0 L_tu]: the object origin's image moves on a straight line.
    theta u is that of c*Rc (the current camera's orientation in the desired one), goal 0
    (Chaumette & Hutchinson, IEEE RAM 2006, Sec. IV; ViSP's vpFeatureTranslation cdMc / cMo and
    vpFeatureThetaU cdRc). Measurement (6): t (3, metres), theta u (3, radians); measure(pose,
    pose_desired) builds it from camera <- object poses (e.g. ibvs.PlanarPose's). theta u of angle
    in (pi, 2 pi] is used in its principal form; beyond 2 pi, refused.
    """

    def __init__(self, target: str = "desired_camera") -> None: ...
    @property
    def target(self) -> str:
        """'desired_camera' or 'object'."""
    @staticmethod
    def measure(pose: _ArrayLike, pose_desired: _ArrayLike, target: str = "desired_camera") -> _FloatArray:
        """The measurement (6,) from the current and desired camera <- object poses (4x4)."""

class Point25DFeature(Feature):
    """2.5-D visual servoing (Malis, Chaumette & Boudet, IEEE T-RA 1999): 6 rows.

    s = (x, y, log Z, theta u) of a reference point: its normalised image point, its depth and
    theta u of c*Rc; the error is (x - x*, y - y*, log(Z/Z*), theta u). L: the point's rows (paper
    eq. 3), [0, 0, -1/Z, -y, x, 0] for log Z, [0 L_tu] for theta u; the reference point's image
    moves on a straight line. Measurement (6): x, y, Z (> 0, metres), theta u (3); measure(pose,
    pose_desired, point) builds it from camera <- object poses and the point in the object frame.
    """

    def __init__(self) -> None: ...
    @staticmethod
    def measure(
        pose: _ArrayLike, pose_desired: _ArrayLike, point: _ArrayLike = (0.0, 0.0, 0.0)
    ) -> _FloatArray:
        """The measurement (6,) of `point` (object frame) from the current and desired camera <- object
        poses."""

class FunctionFeature(Feature):
    """A feature block of your own: fn(measurement) -> (s, L).

    rows: the block's rows (1 to 64); size: values in one measurement; fn receives the measurement
    (a (size,) array) and returns s (rows,) and L (rows, 6), the interaction matrix (ds/dt = L v for
    the camera twist v). It must be a pure function of the measurement. A measurement for which fn
    raises or returns a non-finite value is refused (ValueError with fn's message, from validate()
    and update() alike). Stack it with any other block in a Task.
    """

    def __init__(self, rows: int, size: int, fn: Any, name: str = "function") -> None: ...
    @property
    def fn(self) -> Any:
        """The callable."""
    @property
    def name(self) -> str:
        """The block's name in describe() and repr (default "function")."""

# Photometric visual servoing (cpp/include/ibvs/features/luminance.hpp; docs/photometric.md)

class LuminanceResult:
    """Result of one LuminanceServo.update()."""

    @property
    def twist(self) -> _FloatArray:
        """Camera twist (vx, vy, vz, wx, wy, wz), (6,); zeros unless status is 'ok'."""
    @property
    def status(self) -> str:
        """'ok', 'textureless' or 'saturated' (H singular: zero twist), 'invalid_input'."""
    @property
    def ok(self) -> bool:
        """status == 'ok'."""
    @property
    def error_rms(self) -> float:
        """sqrt(|I - I*|^2 / N) over the grid, intensity units."""
    @property
    def pixels(self) -> int:
        """N, the grid's pixels."""

class LuminanceServo:
    """Photometric visual servoing (Collewet & Marchand, IEEE T-RO 2011): the feature is the image.

    L_I = -(I_x L_x + I_y L_y) per pixel of the grid (the image but a border), the gradient from ViSP's
    7-tap filter; law v = -gain (H + mu diag H)^-1 L_I^T (I - I*), H = L_I^T L_I ("levenberg_marquardt")
    or "gauss_newton", L_I at the desired image (once), the current one or their mean. Images: 2-D
    arrays, uint8 (no copy) or real (float64). See docs/photometric.md.
    """

    def __init__(
        self,
        camera: CameraModel,
        width: int,
        height: int,
        border: int = 10,
        smoothing: float = 0.0,
        jacobian: str = "desired",
        law: str = "levenberg_marquardt",
        gain: float = 1.0,
        mu: float = 0.01,
        plane: _ArrayLike = [0.0, 0.0, 1.0],
        min_conditioning: float = 1e-9,
    ) -> None: ...
    def set_desired(self, image: _ArrayLike) -> None:
        """The goal image (ValueError for a wrong size, a non-finite pixel or too little texture)."""
    def update(self, image: _ArrayLike) -> LuminanceResult:
        """One control step on the current image: a LuminanceResult (ValueError for a bad image)."""
    def interaction(self, image: _ArrayLike) -> _FloatArray:
        """L_I over the grid (N, 6) of an image, grid rows in order (double precision)."""
    def intensities(self, image: _ArrayLike) -> _FloatArray:
        """The feature s (N,) of an image: its (smoothed) intensities over the grid."""
    @property
    def width(self) -> int:
        """Image width, pixels (columns)."""
    @property
    def height(self) -> int:
        """Image height, pixels (rows)."""
    @property
    def pixels(self) -> int:
        """N, the grid's pixels."""
    def set_mu(self, mu: float) -> None:
        """Changes the Levenberg-Marquardt mu (in [0, 1e6]), e.g. to 0 (Gauss-Newton) once near the goal."""
    @property
    def mu(self) -> float:
        """The Levenberg-Marquardt mu."""
    @property
    def has_desired(self) -> bool:
        """Whether set_desired() was called."""
    @property
    def border(self) -> int:
        """Pixels left out on each side."""
    @property
    def jacobian(self) -> str:
        """Where L_I is evaluated: "desired", "current" or "mean"."""
    @property
    def law(self) -> str:
        """"levenberg_marquardt" or "gauss_newton"."""

def photometric_moments(camera: CameraModel, image: _ArrayLike) -> _FloatArray:
    """Moments m00..m04 (15,) of an intensity image in normalised coordinates (Bakthavatchalam et al. 2018).

    m_pq = sum of x^p y^q I(u, v) / (p_x p_y) over the pixels. For a planar Lambertian object seen whole on
    a zero-intensity background, MomentsFeature(source="region") gives their interaction matrix.
    """
