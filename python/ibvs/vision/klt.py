"""The KLT tracker: corners of a planar target followed frame to frame (OpenCV), the target's points
carried by the homography they fit.

Per frame (Lucas & Kanade's pyramidal optical flow, Bouguet's implementation in cv2.calcOpticalFlowPyrLK;
Shi & Tomasi's corners, cv2.goodFeaturesToTrack):
  1. the features of the last image are tracked into this one, then back (forward-backward check,
     Kalal et al. 2010): a feature whose backward track ends more than fb_threshold px from where it
     started, or that either pass loses, or that leaves the image, is dropped;
  2. H = the homography from the features' reference positions (in the first image) to their positions
     now, cv2.findHomography with RANSAC (ransac_threshold px): its outliers are dropped too;
  3. H is refined without drift (ibvs.vision.planar.refine: the first image warped by H, the features
     tracked from it: a frame-to-frame KLT step is biased by the rotation and scale between the frames,
     about 1 % of the motion, which would add up), and the features moved to where it finds them;
     the target's points are their first-image pixels mapped by H;
  4. when fewer than redetect_below x the first image's count remain, new corners are detected inside
     the target's polygon (away from the live ones) and given reference positions by H^-1.
The target is lost (every point "lost_features") when fewer than min_inliers features support H, H is not
one a plate in front of the camera gives, or the first image's target warped by H does not look like this
image (ibvs.vision.planar.correlation below min_correlation); it stays lost until reset.
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
__all__ = ["KltTracker"]


class KltTracker(PlanarTarget):
    """KLT features on a planar target, and the target's points through their homography.

    KltTracker(image_size, max_features=300, quality=0.01, min_distance=5, window=21, levels=3,
               fb_threshold=1.0, ransac_threshold=2.0, min_inliers=10, redetect_below=0.6, min_correlation=0.8)
      image_size      (width, height) of the images
      max_features    corners detected in the target's polygon (cv2.goodFeaturesToTrack)
      quality         their minimum quality relative to the best corner; min_distance px between them
      window, levels  cv2.calcOpticalFlowPyrLK's window (px, odd) and pyramid levels beyond the image
      fb_threshold    px: forward-backward error above which a feature is dropped
      ransac_threshold px: cv2.findHomography's RANSAC reprojection threshold
      min_inliers     features (>= 4) below which the target is lost
      redetect_below  fraction of the first count of features below which new ones are detected
      min_correlation in [-1, 1]: the least normalised cross-correlation of the first image's target warped
                      by H with this image (-1: no check); correlation: the last frame's
    reset(image, pixels) starts on the first image, pixels (N, 2) the target's points in it (N >= 3: a
    user clicking on the plate's corners; features are taken inside their polygon); track(image) -> Track
    (status "tracked", or "lost_features" for every point). features: the live features now (M, 2);
    homography: first image -> last image; region(), pose(camera, object_points): see PlanarTarget.
    """

    def __init__(self, image_size, max_features: int = 300, quality: float = 0.01, min_distance: float = 5.0,
                 window: int = 21, levels: int = 3, fb_threshold: float = 1.0, ransac_threshold: float = 2.0,
                 min_inliers: int = 10, redetect_below: float = 0.6, min_correlation: float = 0.8):
        if (not isinstance(image_size, (tuple, list)) or len(image_size) != 2
                or not all(isinstance(s, (int, np.integer)) and not isinstance(s, bool) and 16 <= s <= 8192
                           for s in image_size)):
            raise ValueError(f"image_size must be (width, height), ints in [16, 8192], got {image_size!r}")
        self.size = (int(image_size[0]), int(image_size[1]))
        self.max_features = check_int(max_features, "max_features", 4, 100000)
        self.quality = check_real(quality, "quality", 1e-6, 1.0)
        self.min_distance = check_real(min_distance, "min_distance", 0.0, 1000.0)
        self.window = check_int(window, "window", 3, 201)
        self.levels = check_int(levels, "levels", 0, 8)
        self.fb_threshold = check_real(fb_threshold, "fb_threshold", 1e-3, 1000.0)
        self.ransac_threshold = check_real(ransac_threshold, "ransac_threshold", 1e-3, 1000.0)
        self.min_inliers = check_int(min_inliers, "min_inliers", 4, 100000)
        self.redetect_below = check_real(redetect_below, "redetect_below", 0.0, 1.0)
        self.min_correlation = check_real(min_correlation, "min_correlation", -1.0, 1.0)
        self.correlation = math.nan
        self._prev = None
        self.pixels = None
        self.homography: Optional[np.ndarray] = None

    def _detect(self, cv2, image: np.ndarray, polygon: np.ndarray, avoid: np.ndarray) -> np.ndarray:
        """New corners (K, 2) inside polygon, at least min_distance from the points `avoid` (M, 2)."""
        mask = polygon_mask(polygon, self.size)
        r = max(int(round(self.min_distance)), 1)
        for x, y in avoid:
            cv2.circle(mask, (int(round(x)), int(round(y))), r, 0, -1)
        pts = cv2.goodFeaturesToTrack(image, self.max_features - len(avoid), self.quality, self.min_distance,
                                      mask=mask, blockSize=5)
        return np.zeros((0, 2)) if pts is None else pts.reshape(-1, 2).astype(np.float64)

    def reset(self, image, pixels) -> None:
        """Start on `image` (uint8, image_size) with the target's points `pixels` (N, 2), N >= 3, in it."""
        cv2 = opencv()
        image = check_gray(image, "image", self.size)
        p = check_pixels(pixels, "pixels", 3)
        self._reference = p.copy()
        feats = self._detect(cv2, image, p, np.zeros((0, 2)))
        if len(feats) < self.min_inliers:
            raise ValueError(f"image: only {len(feats)} corners inside the target's polygon (min_inliers = "
                             f"{self.min_inliers}): a textureless or too small target")
        self._features, self._anchors = feats, feats.copy()  # positions now; in the first image
        self._first_count = len(feats)
        self._prev, self.homography, self.pixels, self._lost = image, np.eye(3), p.copy(), False
        self.correlation = math.nan
        self._first = image.copy()

    @property
    def features(self) -> np.ndarray:
        """The live features' pixels (M, 2) in the last image."""
        return np.zeros((0, 2)) if self._prev is None else self._features.copy()

    def track(self, image) -> Track:
        """The target's points in this image (see the class)."""
        cv2 = opencv()
        image = check_gray(image, "image", self.size)
        if self._prev is None:
            raise ValueError("reset(image, pixels) must start the tracker before track(image)")
        t0 = time.perf_counter()
        n = len(self._reference)
        if not self._lost:
            self._step(cv2, image)
        self._prev = image
        if self._lost:
            self.pixels = np.full((n, 2), np.nan)
            return Track(self.pixels.copy(), ("lost_features",) * n, time.perf_counter() - t0)
        return Track(self.pixels.copy(), ("tracked",) * n, time.perf_counter() - t0)

    def _step(self, cv2, image: np.ndarray) -> None:
        self.correlation = math.nan
        lk = dict(winSize=(self.window, self.window), maxLevel=self.levels,
                  criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
        p0 = self._features.astype(np.float32).reshape(-1, 1, 2)
        keep = np.zeros(len(p0), bool)
        if len(p0):
            p1, st1, _ = cv2.calcOpticalFlowPyrLK(self._prev, image, p0, None, **lk)
            back, st2, _ = cv2.calcOpticalFlowPyrLK(image, self._prev, p1, None, **lk)
            fb = np.linalg.norm((back - p0).reshape(-1, 2), axis=1)
            q = p1.reshape(-1, 2).astype(np.float64)
            W, H = self.size
            inside = (q[:, 0] >= 0) & (q[:, 0] <= W - 1) & (q[:, 1] >= 0) & (q[:, 1] <= H - 1)
            keep = (st1.ravel() == 1) & (st2.ravel() == 1) & (fb < self.fb_threshold) & inside & np.isfinite(q).all(1)
            self._features = q
        self._features, self._anchors = self._features[keep], self._anchors[keep]
        Hm = None
        if len(self._features) >= self.min_inliers:
            Hm, inl = cv2.findHomography(self._anchors, self._features, cv2.RANSAC, self.ransac_threshold)
            if Hm is not None:
                inl = inl.ravel().astype(bool)
                self._features, self._anchors = self._features[inl], self._anchors[inl]
                fine = refine(cv2, self._first, self._anchors, Hm, image, self.window, self.ransac_threshold)
                if fine is not None:
                    Hm, found, keep = fine
                    self._features, self._anchors = found[keep], self._anchors[keep]
        if (Hm is None or len(self._features) < self.min_inliers
                or not plausible(Hm, self._reference, self.size)):
            self._lost = True
            return
        if self.min_correlation > -1.0:  # does the first image warped by H look like this one?
            self.correlation = correlation(cv2, self._first, self._reference, Hm, image)
            if self.correlation < self.min_correlation:
                self._lost = True
                return
        self.homography = Hm / Hm[2, 2]
        self.pixels = map_points(self.homography, self._reference)
        if len(self._features) < self.redetect_below * self._first_count:
            new = self._detect(cv2, image, self.pixels, self._features)
            if len(new):
                anchors = map_points(np.linalg.inv(self.homography), new)
                ok = np.isfinite(anchors).all(1)
                self._features = np.vstack([self._features, new[ok]])
                self._anchors = np.vstack([self._anchors, anchors[ok]])

    def __repr__(self) -> str:
        return (f"KltTracker({self.size[0]}x{self.size[1]}, max_features={self.max_features}, "
                f"fb_threshold={self.fb_threshold:g} px)")
