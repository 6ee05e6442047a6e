"""What a recorded episode's /ibvs/config topic holds (std_msgs/String, JSON): the servo's control law
with every option, the camera, the target, the episode's options (depth mode, latency, noise...), the
goal (desired pixels, normalised points and depths), the tracker and the pixels it was started from.
ibvs.ros.replay reads it back to run the same tracker and servo over the bag's images.

servo_spec(servo) / servo_from_spec(spec) turn an ibvs.Servo or PartitionedServo into a JSON-able
dict and back (a new object with the same options: its twists are the same to the last bit).
"""

from __future__ import annotations

import json
import math
from typing import Any, Dict

import numpy as np

from .._core import AdaptiveGain, CameraModel, Layout, PartitionedServo, Servo

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["servo_spec", "servo_from_spec"]

#: The version of the /ibvs/config format this module writes and reads.
FORMAT = 1


def _num(x: float):
    """A float for JSON: inf and NaN as strings (JSON has neither)."""
    x = float(x)
    return x if math.isfinite(x) else str(x)


def _float(x) -> float:
    return float(x)  # float("inf") and float("nan") read the strings back


def servo_spec(servo) -> Dict[str, Any]:
    """The control law of an ibvs.Servo or PartitionedServo with every option, as a JSON-able dict."""
    if isinstance(servo, PartitionedServo):
        return {"kind": "partitioned", "n_points": servo.n_points, "gain": _num(servo.gain),
                "damping": _num(servo.damping), "segment": list(servo.segment),
                "max_linear_speed": _num(servo.max_linear_speed), "max_angular_speed": _num(servo.max_angular_speed)}
    if not isinstance(servo, Servo):
        raise TypeError(f"servo must be an ibvs.Servo or PartitionedServo, got {type(servo).__name__}")
    g = servo.gain
    gain = ({"at_zero": g.at_zero, "at_infinity": g.at_infinity, "slope_at_zero": g.slope_at_zero}
            if isinstance(g, AdaptiveGain) else _num(g))
    task = getattr(servo, "task", None)  # a Servo of a Task: its point weights and DOF; other blocks refused
    extra: Dict[str, Any] = {}
    if task is not None:
        if task.features:
            raise ValueError("servo: a Task with feature blocks other than points is not recorded (replay takes "
                             "a scheme instead)")
        if list(task.point_weights):
            extra["point_weights"] = [float(w) for w in task.point_weights]
        if not all(task.dof):
            extra["dof"] = [bool(d) for d in task.dof]
    return {**extra, "kind": "servo", "blocks": [[int(p), str(r)] for p, r in servo.layout.blocks], "gain": gain,
            "damping": _num(servo.damping), "jacobian": servo.jacobian_mode,
            "polar_min_radius": _num(servo.polar_min_radius), "max_linear_speed": _num(servo.max_linear_speed),
            "max_angular_speed": _num(servo.max_angular_speed), "angle_wrap": servo.angle_wrap}


def servo_from_spec(spec: Dict[str, Any]):
    """A new servo from servo_spec()'s dict (diagnostics on, as the simulator runs it)."""
    try:
        if spec["kind"] == "partitioned":
            return PartitionedServo(int(spec["n_points"]), _float(spec["gain"]), damping=_float(spec["damping"]),
                                    segment=tuple(spec["segment"]), max_linear_speed=_float(spec["max_linear_speed"]),
                                    max_angular_speed=_float(spec["max_angular_speed"]))
        g = spec["gain"]
        gain = AdaptiveGain(g["at_zero"], g["at_infinity"], g["slope_at_zero"]) if isinstance(g, dict) else _float(g)
        layout = Layout([(int(p), r) for p, r in spec["blocks"]])
        if "point_weights" in spec or "dof" in spec:
            from .._core import Task

            layout = Task(layout)
            if "point_weights" in spec:
                layout.point_weights = [float(w) for w in spec["point_weights"]]
            if "dof" in spec:
                layout.dof = [bool(d) for d in spec["dof"]]
        return Servo(layout, gain, damping=_float(spec["damping"]),
                     jacobian=spec["jacobian"], polar_min_radius=_float(spec["polar_min_radius"]),
                     max_linear_speed=_float(spec["max_linear_speed"]),
                     max_angular_speed=_float(spec["max_angular_speed"]), angle_wrap=spec["angle_wrap"])
    except (KeyError, TypeError) as e:
        raise ValueError(f"/ibvs/config: servo: malformed ({type(e).__name__}: {e})") from None


def camera_spec(camera: CameraModel) -> Dict[str, Any]:
    """A CameraModel as a JSON-able dict (its intrinsics, distortion, bounds and fps)."""
    return {"px": camera.px, "py": camera.py, "u0": camera.u0, "v0": camera.v0, "distortion": camera.distortion,
            "coefficients": list(camera.coefficients), "bounds": list(camera.bounds), "fps": camera.fps}


def array(x) -> list:
    """A numpy array as nested lists of floats (NaN and inf as strings)."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 0:
        return _num(a)
    return [array(r) for r in a]


def unarray(x) -> np.ndarray:
    """array()'s lists back to a float64 array."""
    if isinstance(x, list):
        return np.array([unarray(r) for r in x], dtype=np.float64) if x else np.zeros(0)
    return np.float64(_float(x))


def dumps(config: Dict[str, Any]) -> str:
    """The JSON text of a config (floats written so that they read back exactly)."""
    return json.dumps(dict(config, format=FORMAT), allow_nan=False, sort_keys=True)


def loads(text: str) -> Dict[str, Any]:
    """A config from its JSON text, or a ValueError naming the topic."""
    try:
        config = json.loads(text)
    except ValueError as e:
        raise ValueError(f"/ibvs/config: not JSON ({e})") from None
    if not isinstance(config, dict) or config.get("format") != FORMAT:
        raise ValueError(f"/ibvs/config: format {config.get('format') if isinstance(config, dict) else None!r} "
                         f"is not {FORMAT} (recorded by another version of ibvs?)")
    return config
