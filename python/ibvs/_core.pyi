"""Type stubs of the native module ibvs._core (the control-law core)."""

from __future__ import annotations

import enum
from typing import Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike
FloatArray = npt.NDArray[np.float64]
Depth = Union[float, npt.ArrayLike]

class Representation(enum.Enum):
    cartesian = 0
    polar = 1
    cylindrical = 2

class Status(enum.Enum):
    ok = 0
    singular = 1
    invalid_input = -1

class Layout:
    def __init__(
        self, blocks: Sequence[Tuple[int, Union[str, Representation]]], n_points: int | None = None
    ) -> None: ...
    @staticmethod
    def cartesian(n: int) -> Layout: ...
    @staticmethod
    def polar(n: int) -> Layout: ...
    @staticmethod
    def stacked(n: int) -> Layout: ...
    @staticmethod
    def cylindrical(n: int) -> Layout: ...
    @property
    def rows(self) -> int: ...
    @property
    def n_points(self) -> int: ...
    @property
    def blocks(self) -> list[tuple[int, str]]: ...
    def __eq__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...

def features(uv: ArrayLike, layout: Layout) -> FloatArray:
    """(M,) stacked features of uv (N, 2)."""

def jacobian(uv: ArrayLike, depth: Depth, layout: Layout, polar_min_radius: float = 1e-3) -> FloatArray:
    """(M, 6) stacked image Jacobian."""

def feature_error(f: ArrayLike, f_desired: ArrayLike, layout: Layout) -> FloatArray:
    """(M,) f (-) f*, theta rows wrapped into (-pi, pi]."""

def damped_pinv(J: ArrayLike, damping: float = 0.0) -> FloatArray:
    """(6, M) pseudoinverse of J (M, 6)."""

def singular_values(J: ArrayLike) -> FloatArray: ...
def wrap_angle(angle: Union[float, ArrayLike]) -> Union[float, FloatArray]: ...
def se3_exp(twist: ArrayLike) -> FloatArray:
    """(4, 4) rigid motion of a twist applied for unit time."""

class AdaptiveGain:
    """gain(x) = (at_zero - at_infinity) * exp(-(slope_at_zero / (at_zero - at_infinity)) * x) + at_infinity."""

    def __init__(self, at_zero: float, at_infinity: float, slope_at_zero: float) -> None: ...
    @property
    def at_zero(self) -> float: ...
    @property
    def at_infinity(self) -> float: ...
    @property
    def slope_at_zero(self) -> float: ...
    def __call__(self, x: Union[float, ArrayLike]) -> Union[float, FloatArray]: ...

class ServoResult:
    @property
    def status(self) -> Status: ...
    @property
    def velocity(self) -> FloatArray:
        """(6,) camera twist: Tx, Ty, Tz (m/s), wx, wy, wz (rad/s)."""
    @property
    def error(self) -> FloatArray: ...
    @property
    def error_norm(self) -> float: ...
    @property
    def jacobian(self) -> FloatArray: ...
    @property
    def sigma_min(self) -> float: ...
    @property
    def sigma_max(self) -> float: ...
    @property
    def condition(self) -> float: ...
    @property
    def polar_fallbacks(self) -> int: ...
    @property
    def gain(self) -> float:
        """The gain applied this step."""
    @property
    def saturated(self) -> bool: ...
    @property
    def saturation_scale(self) -> float: ...

class Servo:
    gain: Union[float, AdaptiveGain]
    damping: float
    max_linear_speed: float
    max_angular_speed: float
    def __init__(
        self,
        layout: Layout,
        gain: Union[float, AdaptiveGain],
        damping: float = 0.0,
        jacobian: str = "current",
        polar_min_radius: float = 1e-3,
        diagnostics: bool = True,
        max_linear_speed: float = ...,
        max_angular_speed: float = ...,
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
    ) -> Servo: ...
    def update(
        self, uv: ArrayLike, depth: Depth, uv_desired: ArrayLike, depth_desired: Depth | None = None
    ) -> ServoResult: ...
    @property
    def layout(self) -> Layout: ...
    @property
    def jacobian_mode(self) -> str: ...
    @property
    def polar_min_radius(self) -> float: ...

class PartitionedServo:
    """Partitioned IBVS (Corke & Hutchinson 2001): wz from a segment angle, Tz from sqrt(area)."""

    gain: float
    def __init__(
        self,
        n_points: int,
        gain: float,
        damping: float = 0.0,
        segment: Tuple[int, int] = (0, 1),
        max_linear_speed: float = ...,
        max_angular_speed: float = ...,
    ) -> None: ...
    def update(
        self, uv: ArrayLike, depth: Depth, uv_desired: ArrayLike, depth_desired: Depth | None = None
    ) -> ServoResult: ...
    @property
    def layout(self) -> Layout: ...
    @property
    def n_points(self) -> int: ...
    @property
    def damping(self) -> float: ...
    @property
    def segment(self) -> Tuple[int, int]: ...

def segment_angle(uv: ArrayLike, i: int, j: int) -> float: ...
def segment_angle_jacobian(uv: ArrayLike, depth: Depth, i: int, j: int) -> FloatArray: ...
def area_scale(uv: ArrayLike) -> float: ...
def area_scale_jacobian(uv: ArrayLike, depth: Depth) -> FloatArray: ...
