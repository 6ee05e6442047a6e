"""Message classes and the helpers every conversion shares: where the classes come from, how a message
is built, how a field is read and checked, and stamps.

The conversions are duck-typed: an incoming message is read by its field names only, so rclpy's
classes (sensor_msgs.msg.Image...) and rosbags' typestore classes work alike. An outgoing message
needs its class: every function that builds one takes `types`, which is
  None            rosbags' ROS 2 Humble typestore (the `ros` extra: pip install ".[ros]");
  a Typestore     of rosbags (rosbags.typesys.get_typestore(Stores.ROS2_JAZZY)...);
  a mapping       "sensor_msgs/msg/Image" -> class;
  a callable      name -> class (the rclpy node passes rosidl_runtime_py's get_message).
Messages are built with every field given as a keyword (rosbags' dataclasses have no defaults; rclpy's
constructors take the same keywords); numeric arrays are numpy arrays for rosbags' classes and Python
lists (bytes for uint8 data) for any other class, as rclpy's setters want them.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable

import numpy as np

# Nothing public: the ROS message helpers of the ibvs.ros modules, used inside ibvs only.
__all__: list[str] = []

ROS_INSTALL = 'pip install ".[ros]" from the ibvs repository root'

_default_typestore = None


def typestore():
    """rosbags' ROS 2 Humble typestore (made once), or an ImportError saying how to install rosbags."""
    global _default_typestore
    if _default_typestore is None:
        try:
            from rosbags.typesys import Stores, get_typestore
        except ImportError as e:
            raise ImportError(f"ibvs.ros needs rosbags for message classes and bags: {ROS_INSTALL}") from e
        _default_typestore = get_typestore(Stores.ROS2_HUMBLE)
    return _default_typestore


def lookup(types) -> Callable[[str], Any]:
    """A function name -> message class from `types` (see the module docstring)."""
    if types is None:
        types = typestore()
    if hasattr(types, "types") and isinstance(getattr(types, "types"), dict):  # a rosbags Typestore
        table = types.types
        return lambda name: _get(table, name)
    if isinstance(types, dict):
        return lambda name: _get(types, name)
    if callable(types):
        return types
    raise TypeError(f"types must be None, a rosbags Typestore, a mapping or a callable name -> class, "
                    f"got {type(types).__name__}")


def _get(table: dict, name: str):
    try:
        return table[name]
    except KeyError:
        raise ValueError(f"types: no message class {name!r}") from None


def is_rosbags(cls) -> bool:
    """Whether cls is one of rosbags' dataclasses (numeric arrays as numpy arrays) rather than rclpy's."""
    return dataclasses.is_dataclass(cls) and hasattr(cls, "__msgtype__")


def make(types, msgtype: str, /, **fields):
    """A message of type `name` (e.g. "sensor_msgs/msg/Image") with these fields. Numeric arrays given as
    numpy arrays are kept for rosbags' classes and turned into lists (uint8 data into bytes) for others."""
    cls = lookup(types)(msgtype)
    if not is_rosbags(cls):
        fields = {k: (v.tobytes() if v.dtype == np.uint8 else v.tolist()) if isinstance(v, np.ndarray) else v
                  for k, v in fields.items()}
    return cls(**fields)


# ---------------------------------------------------------------------------- stamps

NS = 1_000_000_000


def to_ns(seconds: float) -> int:
    """Seconds (float) -> integer nanoseconds, rounded to nearest."""
    return int(round(float(seconds) * NS))


def time_msg(types, ns: int):
    """builtin_interfaces/msg/Time of integer nanoseconds (>= 0)."""
    if ns < 0:
        raise ValueError(f"stamp must be >= 0, got {ns} ns")
    return make(types, "builtin_interfaces/msg/Time", sec=int(ns // NS), nanosec=int(ns % NS))


def header(types, ns: int, frame_id: str):
    """std_msgs/msg/Header at integer nanoseconds in frame_id."""
    return make(types, "std_msgs/msg/Header", stamp=time_msg(types, ns), frame_id=str(frame_id))


def stamp_ns(msg, what: str = "msg") -> int:
    """The header stamp of a message (or a Time itself) in integer nanoseconds."""
    t = getattr(field(msg, "header", what), "stamp") if hasattr(msg, "header") else msg
    sec, nanosec = field(t, "sec", f"{what}.header.stamp"), field(t, "nanosec", f"{what}.header.stamp")
    return int(sec) * NS + int(nanosec)


# ---------------------------------------------------------------------------- reading fields

def field(msg, name: str, what: str = "msg"):
    """msg.name, or a TypeError naming the field a message lacks."""
    try:
        return getattr(msg, name)
    except AttributeError:
        raise TypeError(f"{what}.{name}: the message has no field {name!r} "
                        f"(a {type(msg).__name__}, not the expected message type)") from None


def uint(msg, name: str, what: str, lo: int = 0, hi: int = 2**32 - 1) -> int:
    """An unsigned integer field within [lo, hi], or a clear error naming it."""
    x = field(msg, name, what)
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)):
        raise TypeError(f"{what}.{name} must be an integer, got {type(x).__name__}")
    if not lo <= int(x) <= hi:
        raise ValueError(f"{what}.{name} must be in [{lo}, {hi}], got {int(x)}")
    return int(x)


def floats(msg, name: str, what: str, length: int | None = None, finite: bool = True) -> np.ndarray:
    """A float array field (any sequence) as float64, of `length` if given, finite if asked."""
    x = field(msg, name, what)
    try:
        a = np.asarray(x, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"{what}.{name} must be a sequence of numbers, got {type(x).__name__}") from None
    if length is not None and a.size != length:
        raise ValueError(f"{what}.{name} must have {length} elements, got {a.size}")
    if finite and not np.isfinite(a).all():
        raise ValueError(f"{what}.{name} must be finite, got {a.tolist()}")
    return a


def text(msg, name: str, what: str) -> str:
    x = field(msg, name, what)
    if not isinstance(x, str):
        raise TypeError(f"{what}.{name} must be a string, got {type(x).__name__}")
    return x


def real(x, name: str) -> float:
    """A finite real scalar, or a TypeError / ValueError naming it."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(x).__name__}")
    if not math.isfinite(float(x)):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return float(x)
