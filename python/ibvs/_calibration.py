"""The calibration-file reader under the name the compiled module imports it by.

CameraModel.from_yaml (cpp/bindings/bind_camera.cpp) calls ibvs._calibration.read; the reader
itself is ibvs.camera_files. This alias goes when the binding imports ibvs.camera_files.
"""

from __future__ import annotations

from .camera_files import read

__all__ = ["read"]
