"""The keypoint tracker: a planar target found in every image from a reference image of it (OpenCV).

Per image: keypoints and binary descriptors (ORB, Rublee et al. 2011, or AKAZE, Alcantarilla et al.
2013) matched to the reference's (brute force, Hamming distance, Lowe's ratio test), then the homography
reference -> image by cv2.findHomography with RANSAC (ransac_threshold px; its outliers rejected) and a
least-squares refit on the inliers, then refined to sub-pixel accuracy by ibvs.vision.planar.refine (the
reference warped by it, corners of the reference tracked from there by KLT: keypoints of a coarse scale
are located to a pixel or worse, the refined corners of the plate to a few hundredths). The target's points
are their reference pixels mapped by it.
confidence = inliers / matches of the last image; the target is "not_found" (every point) when fewer than
min_inliers matches support the homography, it is not one a plate in front of the camera gives, or the
reference warped by it does not look like the image (ibvs.vision.planar.correlation below min_correlation:
a homography fitted to a few wrong matches, which a plate seen far smaller than taught can give). Each
image is searched on its own (no prediction from the last one): a target found again after a loss is
reported again, with the same correspondences.
"""

from __future__ import annotations

import math
import time
from typing import Optional

import numpy as np

from .images import check_int, check_real, opencv
from .planar import PlanarTarget, check_gray, check_pixels, correlation, map_points, plausible, polygon_mask, refine
from .track import Track

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["KeypointTracker", "KEYPOINT_DETECTORS"]

#: The keypoint detectors a KeypointTracker can use (binary descriptors, Hamming distance).
KEYPOINT_DETECTORS = ("orb", "akaze")


class KeypointTracker(PlanarTarget):
    """A planar target matched in every image to a reference image of it.

    KeypointTracker(reference=None, points=None, region=None, detector="orb", n_features=500,
                    ratio=0.8, ransac_threshold=3.0, min_inliers=12, min_correlation=0.8, image_size=None)
      reference         uint8 (h, w) image of the target (a scan of the printed picture, the goal image...);
                        None: set it later with set_reference (the image sensor uses the goal image)
      points            (N, 2) pixels of the reference to report (default: its four corners, (-0.5, -0.5)
                        ... in Target.square's order: top-left, top-right, bottom-right, bottom-left)
      region            (K, 2) polygon of the reference where its keypoints are taken (default: the polygon
                        of the points when N >= 3, else the whole reference)
      detector          "orb" or "akaze"; n_features: ORB's keypoint budget per image
      ratio             Lowe's ratio test: a match is kept when its distance < ratio x the second best's
      ransac_threshold  px; min_inliers: inliers (>= 4) needed to report the target
      min_correlation   in [-1, 1]: the least normalised cross-correlation of the reference's region warped
                        by the homography with the image for the target to be reported (-1: no check)
      image_size        None, or (width, height) every image must have
    detect(image) -> Track (status "detected" or "not_found" per point); after it: homography (reference ->
    image), matches, inliers, confidence (inliers / matches, 0 when not found), correlation (of the
    last homography, NaN without one); region(), pose(camera, object_points): see PlanarTarget. A reference with fewer than min_inliers keypoints in its region is
    refused (ValueError naming reference).
    """

    def __init__(self, reference=None, points=None, region=None, detector: str = "orb", n_features: int = 500,
                 ratio: float = 0.8, ransac_threshold: float = 3.0, min_inliers: int = 12,
                 min_correlation: float = 0.8, image_size=None):
        cv2 = opencv()
        if detector not in KEYPOINT_DETECTORS:
            raise ValueError(f"detector must be one of {KEYPOINT_DETECTORS}, got {detector!r}")
        self.detector = detector
        self.n_features = check_int(n_features, "n_features", 10, 1000000)
        self.ratio = check_real(ratio, "ratio", 0.05, 1.0)
        self.ransac_threshold = check_real(ransac_threshold, "ransac_threshold", 1e-3, 1000.0)
        self.min_inliers = check_int(min_inliers, "min_inliers", 4, 100000)
        self.min_correlation = check_real(min_correlation, "min_correlation", -1.0, 1.0)
        if image_size is not None and (
                not isinstance(image_size, (tuple, list)) or len(image_size) != 2
                or not all(isinstance(s, (int, np.integer)) and not isinstance(s, bool) and 16 <= s <= 8192
                           for s in image_size)):
            raise ValueError(f"image_size must be None or (width, height), ints in [16, 8192], got {image_size!r}")
        self.image_size = None if image_size is None else (int(image_size[0]), int(image_size[1]))
        self.size = self.image_size or (0, 0)
        if detector == "orb":
            self._features = cv2.ORB_create(nfeatures=self.n_features, fastThreshold=10)
        else:
            # OpenCV 5 moved AKAZE to the contrib module xfeatures2d (opencv-contrib-python)
            akaze = getattr(cv2, "AKAZE_create", None) or cv2.xfeatures2d.AKAZE_create
            self._features = akaze(threshold=3e-4)
        self._matcher = cv2.BFMatcher(cv2.NORM_HAMMING)
        self._ref = None
        self.pixels = None
        self.homography: Optional[np.ndarray] = None
        self.matches, self.inliers, self.confidence, self.correlation = 0, 0, 0.0, float("nan")
        if reference is not None:
            self.set_reference(reference, points, region)
        elif points is not None or region is not None:
            raise ValueError("points, region: they belong to a reference image (reference is None)")

    def set_reference(self, reference, points=None, region=None) -> None:
        """The reference image of the target, the points to report in it and the region of its keypoints
        (see the class)."""
        cv2 = opencv()
        ref = check_gray(reference, "reference")
        h, w = ref.shape
        corners = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
        pts = corners if points is None else check_pixels(points, "points", 1)
        poly = (pts if len(pts) >= 3 else corners) if region is None else check_pixels(region, "region", 3)
        mask = polygon_mask(poly, (w, h))
        kp, desc = self._features.detectAndCompute(ref, mask)
        if desc is None or len(kp) < self.min_inliers:
            raise ValueError(f"reference: only {0 if desc is None else len(kp)} keypoints in its region (min_inliers"
                             f" = {self.min_inliers}): a textureless or too small reference image")
        self._ref = (np.array([k.pt for k in kp], np.float64), desc)
        self._points = pts.copy()
        self._region = poly.copy()
        self._reference = ref.copy()
        corners = cv2.goodFeaturesToTrack(ref, 300, 0.01, 5, mask=mask, blockSize=5)
        self._anchors = np.zeros((0, 2)) if corners is None else corners.reshape(-1, 2).astype(np.float64)

    def detect(self, image) -> Track:
        """The target's points in this image (see the class)."""
        cv2 = opencv()
        image = check_gray(image, "image", self.image_size)
        if self._ref is None:
            raise ValueError("set_reference(reference, points) must come before detect(image)")
        self.size = (image.shape[1], image.shape[0])
        t0 = time.perf_counter()
        n = len(self._points)
        self.homography, self.matches, self.inliers, self.confidence, self.correlation = None, 0, 0, 0.0, math.nan
        kp, desc = self._features.detectAndCompute(image, None)
        H = None
        if desc is not None and len(kp) >= 2:
            pairs = self._matcher.knnMatch(self._ref[1], desc, k=2)
            good = [m[0] for m in pairs if len(m) == 2 and m[0].distance < self.ratio * m[1].distance]
            self.matches = len(good)
            if len(good) >= self.min_inliers:
                src = self._ref[0][[m.queryIdx for m in good]]
                dst = np.array([kp[m.trainIdx].pt for m in good], np.float64)
                H, inl = cv2.findHomography(src, dst, cv2.RANSAC, self.ransac_threshold)
                if H is not None:
                    inl = inl.ravel().astype(bool)
                    self.inliers = int(inl.sum())
                    if self.inliers >= self.min_inliers:  # least squares on the inliers only, then refined
                        H = cv2.findHomography(src[inl], dst[inl], 0)[0]
                        fine = None if H is None or len(self._anchors) < self.min_inliers else refine(
                            cv2, self._reference, self._anchors, H, image, 21, self.ransac_threshold)
                        if fine is not None and fine[2].sum() >= self.min_inliers:
                            H = fine[0]
        found = H is not None and self.inliers >= self.min_inliers and plausible(H, self._points, self.size)
        if found and self.min_correlation > -1.0:  # does the reference warped by H look like the image?
            self.correlation = correlation(cv2, self._reference, self._region, H, image)
            found = self.correlation >= self.min_correlation
        if not found:
            self.pixels = np.full((n, 2), np.nan)
            self.inliers = 0 if H is None else self.inliers
            return Track(self.pixels.copy(), ("not_found",) * n, time.perf_counter() - t0)
        self.homography = H / H[2, 2]
        self.confidence = self.inliers / self.matches
        self.pixels = map_points(self.homography, self._points)
        return Track(self.pixels.copy(), ("detected",) * n, time.perf_counter() - t0)

    track = detect

    def reset(self, pixels=None) -> None:
        """Nothing to reset: every image is searched on its own (symmetry with DotTracker)."""

    def __repr__(self) -> str:
        return f"KeypointTracker({self.detector}, ratio={self.ratio:g}, min_inliers={self.min_inliers})"
