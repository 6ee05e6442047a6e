"""The tag detector: square fiducial markers found by cv2.aruco, their corners as the servo's points."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from .images import check_image, opencv
from .track import Track

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["TagDetector"]

#: The tag families the renderer draws and the detector finds: name -> cv2.aruco dictionary.
TAG_DICTIONARIES = {"apriltag_36h11": "DICT_APRILTAG_36h11", "aruco_4x4_50": "DICT_4X4_50"}


class TagDetector:
    """Square fiducial markers found by cv2.aruco, their corners as the servo's points.

    TagDetector(ids=(0,), dictionary="apriltag_36h11", refine=True, image_size=None, decimate=2)
      ids       the tags whose corners are the points, in this order: point 4 k + j is corner j of
                tag ids[k], corners in cv2.aruco's order (top-left, top-right, bottom-right,
                bottom-left of the marker: the order of ibvs.sim.Target.square)
      refine    sub-pixel corners: cv2.cornerSubPix on the full-resolution image
      decimate  1 or 2: cv2.aruco searches an image shrunk this many times (area average), as
                AprilTag's own decimation (faster); a tag not found there is searched again at
                full resolution
    detect(image) -> Track: status "detected" or "not_found" per corner.
    """

    def __init__(
        self,
        ids: Sequence[int] = (0,),
        dictionary: str = "apriltag_36h11",
        refine: bool = True,
        image_size=None,
        decimate: int = 2,
    ):
        cv2 = opencv()
        ids = tuple(ids) if isinstance(ids, (tuple, list)) else None
        if (
            not ids
            or any(isinstance(i, bool) or not isinstance(i, (int, np.integer)) or i < 0 for i in ids)
            or len(set(ids)) != len(ids)
        ):
            raise ValueError(f"ids must be a non-empty sequence of distinct non-negative ints, got {ids!r}")
        if dictionary not in TAG_DICTIONARIES:
            raise ValueError(f"dictionary must be one of {tuple(TAG_DICTIONARIES)}, got {dictionary!r}")
        self.ids, self.dictionary = tuple(int(i) for i in ids), dictionary
        self.size = None if image_size is None else tuple(image_size)
        if decimate not in (1, 2) or isinstance(decimate, bool):
            raise ValueError(f"decimate must be 1 or 2, got {decimate!r}")
        self.decimate, self.refine = int(decimate), bool(refine)
        aruco = cv2.aruco
        params = aruco.DetectorParameters()
        # cv2.aruco drops a candidate close to another one (within minMarkerDistanceRate of its
        # perimeter, 0.125 by default): the contour of the tag's white plate cut by the image border
        # is such a neighbour, and the tag was lost (test_tag_episode_plate_at_the_border).
        params.minMarkerDistanceRate = 0.02
        self._detector = aruco.ArucoDetector(
            aruco.getPredefinedDictionary(getattr(aruco, TAG_DICTIONARIES[dictionary])), params
        )

    @property
    def n_points(self) -> int:
        return 4 * len(self.ids)

    def reset(self, pixels=None) -> None:
        """Nothing to reset: every frame is detected on its own (symmetry with DotTracker)."""

    def detect(self, image) -> Track:
        if self.size is not None:
            image = check_image(image, self.size)
        elif not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 2:
            raise TypeError("image must be a 2-D uint8 numpy array (grayscale)")
        cv2 = opencv()
        t0 = time.perf_counter()
        out = np.full((self.n_points, 2), np.nan)
        status = ["not_found"] * self.n_points
        h, w = image.shape
        for scale in sorted({self.decimate, 1}, reverse=True):
            small = (
                image
                if scale == 1
                else cv2.resize(image, (w // scale, h // scale), interpolation=cv2.INTER_AREA)
            )
            corners, found, _ = self._detector.detectMarkers(small)
            for c, i in zip(corners, np.asarray(found).ravel() if found is not None else ()):
                k = self.ids.index(int(i)) if int(i) in self.ids else -1
                if k < 0 or status[4 * k] == "detected":
                    continue
                # pixel c of the shrunk image is centred on scale c + (scale - 1) / 2 of the full one
                out[4 * k : 4 * k + 4] = (
                    np.asarray(c, dtype=np.float64).reshape(4, 2) * scale + (scale - 1) / 2
                )
                status[4 * k : 4 * k + 4] = ["detected"] * 4
            if "not_found" not in status:
                break
        found_rows = np.isfinite(out[:, 0])
        if self.refine and found_rows.any():
            c = out[found_rows].astype(np.float32).reshape(-1, 1, 2)
            crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 0.001)
            out[found_rows] = cv2.cornerSubPix(image, c, (5, 5), (-1, -1), crit).reshape(-1, 2)
        return Track(out, tuple(status), time.perf_counter() - t0)

    track = detect
