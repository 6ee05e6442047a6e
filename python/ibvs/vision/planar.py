"""What the natural-feature trackers share: a planar target followed through a homography.

Both trackers (ibvs.vision.klt.KltTracker, ibvs.vision.keypoints.KeypointTracker) estimate, every frame,
the homography H from a reference view of the planar target to the current image (cv2.findHomography,
RANSAC: outliers rejected) and report the target's points (N, 2) as H maps their reference pixels: the
form DotTracker and TagDetector give (an ibvs.vision.Track, NaN rows for lost points), so any point task
servoes on them. Beside the points: region() the target's polygon as a mask (image moments), pose() the
camera <- target pose from the points with ibvs.PlanarPose.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from .._core import CameraModel, PlanarPose
from ..finite import finite_within
from .images import opencv

__all__: list = []  # helpers of the trackers


def check_gray(image, name: str, size=None) -> np.ndarray:
    """image as a 2-D uint8 array (of the given (width, height) when size is not None), or a clear error."""
    if not isinstance(image, np.ndarray):
        raise TypeError(f"{name} must be a numpy array (a grayscale uint8 image), got {type(image).__name__}")
    if image.dtype != np.uint8:
        raise TypeError(f"{name} must have dtype uint8 (an 8-bit grayscale image; NaN cannot be a pixel), got "
                        f"{image.dtype}")
    if image.ndim != 2 or image.shape[0] < 16 or image.shape[1] < 16:
        raise ValueError(f"{name} must be a 2-D (height, width) image of at least 16x16 pixels, got shape "
                         f"{image.shape}")
    if size is not None and image.shape != (size[1], size[0]):
        raise ValueError(f"{name} must have shape (height, width) = ({size[1]}, {size[0]}), got {image.shape}")
    return image


def check_pixels(pixels, name: str, min_rows: int = 1) -> np.ndarray:
    p = np.asarray(pixels, dtype=np.float64) if not isinstance(pixels, str) else np.zeros((0, 0))
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < min_rows or not np.isfinite(p).all():
        raise ValueError(f"{name} must be finite pixels, shape (N, 2) with N >= {min_rows}, got shape {p.shape}")
    return p


def polygon_mask(polygon: np.ndarray, size) -> np.ndarray:
    """uint8 (height, width): 255 inside the polygon (K, 2) of pixels (its convex hull), 0 elsewhere."""
    cv2 = opencv()
    w, h = size
    mask = np.zeros((h, w), np.uint8)
    hull = cv2.convexHull(np.round(polygon * 16).astype(np.int32).reshape(-1, 1, 2))
    cv2.fillConvexPoly(mask, hull, 255, lineType=cv2.LINE_8, shift=4)
    return mask


def map_points(H: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """pixels (N, 2) mapped by the homography H (3, 3); NaN rows where they map to infinity."""
    p = np.column_stack([pixels, np.ones(len(pixels))]) @ H.T
    with np.errstate(divide="ignore", invalid="ignore"):
        out = p[:, :2] / p[:, 2:]
    out[~(np.abs(p[:, 2]) > 1e-12)] = np.nan
    return out


def plausible(H: Optional[np.ndarray], reference: np.ndarray, size) -> bool:
    """A homography a rigid plate seen in front of the camera can give: finite, orientation kept (the
    reference points' polygon not mirrored), and the reference points mapped within 10 image sizes."""
    if H is None or not np.isfinite(H).all():
        return False
    q = map_points(H, reference)
    if not finite_within(q, 10 * max(size)):
        return False
    p = np.column_stack([reference, np.ones(len(reference))]) @ H.T
    return bool((p[:, 2] * np.sign(p[0, 2]) > 0).all() and np.linalg.det(H) * p[0, 2] ** -3 > 0)


class PlanarTarget:
    """The target's points (N, 2) in the last image (NaN when lost), its region and its pose: what both
    natural-feature trackers report beside their Track."""

    size: tuple
    pixels: Optional[np.ndarray] = None

    def region(self) -> np.ndarray:
        """The target's region in the last image: uint8 (height, width), 255 inside the convex hull of its
        points (e.g. for ibvs.vision.image_moments), all 0 when it is lost."""
        w, h = self.size
        if self.pixels is None or len(self.pixels) < 3 or not np.isfinite(self.pixels).all():
            return np.zeros((h, w), np.uint8)
        return polygon_mask(self.pixels, self.size)

    def pose(self, camera, object_points) -> Optional[np.ndarray]:
        """Camera <- target pose (4, 4) of the last image's points from ibvs.PlanarPose: object_points
        (N, 3) the points in the target frame (z = 0, metres, the order of the tracked points); camera
        the ibvs.CameraModel of the images. None when lost or degenerate."""
        if not isinstance(camera, CameraModel):
            raise TypeError(f"camera must be an ibvs.CameraModel, got {type(camera).__name__}")
        P = np.asarray(object_points, dtype=np.float64)
        n = 0 if self.pixels is None else len(self.pixels)
        if self.pixels is None or P.shape != (n, 3) or not np.isfinite(P).all():
            raise ValueError(f"object_points must be finite (N, 3) with N = {n} (one per tracked point), got shape "
                             f"{P.shape}")
        if not np.isfinite(self.pixels).all():
            return None
        uv = camera.normalize(self.pixels, invalid="nan")
        if not np.isfinite(uv).all():
            return None
        pose, _, degenerate = PlanarPose(P).estimate(uv)
        return None if degenerate or not np.isfinite(pose).all() else np.asarray(pose)


def _area(p: np.ndarray) -> float:
    """The area of the polygon p (K, 2) (shoelace formula)."""
    return 0.5 * abs(float(p[:, 0] @ np.roll(p[:, 1], -1) - p[:, 1] @ np.roll(p[:, 0], -1)))


def correlation(cv2, reference: np.ndarray, polygon: np.ndarray, H: np.ndarray, image: np.ndarray) -> float:
    """How well H explains the image: the median over square tiles of the target of the normalised
    cross-correlation (in [-1, 1]) of the reference's polygon (K, 2) warped by H with the image where it
    lands. Both sides are smoothed by a Gaussian whose width follows the magnification of the polygon by H
    (sensor noise, and the detail an enlarged reference lacks); a tile counts when the polygon covers 3/4
    of it and the warped reference varies in it (std >= 2 gray levels). Invariant to an affine change of the
    lighting; the median keeps it for a target up to half occluded, while a wrong H leaves most tiles
    uncorrelated (near 0), and a tile where the image is flat (std < 1 gray level) scores 0. 0 when H takes
    part of the polygon through infinity, or fewer than 4 tiles of 8 px or more count (a target under about
    22 px across)."""
    h, w = image.shape
    rh, rw = reference.shape
    ph = np.column_stack([polygon, np.ones(len(polygon))]) @ H.T
    if not (np.isfinite(ph).all() and ((ph[:, 2] > 0).all() or (ph[:, 2] < 0).all())):
        return 0.0
    seen = cv2.warpPerspective(polygon_mask(polygon, (rw, rh)), H, (w, h), flags=cv2.INTER_NEAREST)
    seen = cv2.erode(seen, np.ones((3, 3), np.uint8))
    x, y, bw, bh = cv2.boundingRect(seen)
    t = int(min(24, max(8, min(bw, bh) // 4)))  # the tile's side, px
    if bw < 2 * t or bh < 2 * t:
        return 0.0
    nx, ny = bw // t, bh // t
    x0, y0 = x + (bw - nx * t) // 2, y + (bh - ny * t) // 2  # the tiles, centred on the target
    m = 4  # a margin for the smoothing
    cx0, cy0, cx1, cy1 = max(0, x0 - m), max(0, y0 - m), min(w, x0 + nx * t + m), min(h, y0 + ny * t + m)
    T = np.array([[1.0, 0.0, -cx0], [0.0, 1.0, -cy0], [0.0, 0.0, 1.0]])
    warped = cv2.warpPerspective(reference, T @ H, (cx1 - cx0, cy1 - cy0), flags=cv2.INTER_LINEAR)
    zoom = np.sqrt(_area(ph[:, :2] / ph[:, 2:]) / max(_area(polygon), 1e-9))
    sigma = float(min(max(1.0, zoom), t / 3.0))
    a = cv2.GaussianBlur(warped.astype(np.float32), (0, 0), sigma)
    b = cv2.GaussianBlur(image[cy0:cy1, cx0:cx1].astype(np.float32), (0, 0), sigma)
    sl = (slice(y0 - cy0, y0 - cy0 + ny * t), slice(x0 - cx0, x0 - cx0 + nx * t))
    k = (seen[cy0:cy1, cx0:cx1][sl] > 0).astype(np.float64)
    a, b = a[sl].astype(np.float64) * k, b[sl].astype(np.float64) * k

    def means(z):  # (ny, nx): the mean of z over each tile (area interpolation of whole tiles is exact)
        return cv2.resize(z, (nx, ny), interpolation=cv2.INTER_AREA).astype(np.float64)

    n = means(k)
    with np.errstate(invalid="ignore", divide="ignore"):
        ma, mb = means(a) / n, means(b) / n
        va = means(a * a) / n - ma * ma
        vb = means(b * b) / n - mb * mb
        cov = means(a * b) / n - ma * mb
        ok = (n >= 0.75) & (va >= 4.0)
        # a tile of the image flat to a gray level: no evidence for H (0), not a ratio of rounding errors
        r = np.where(vb[ok] >= 1.0, cov[ok] / np.sqrt(va[ok] * np.maximum(vb[ok], 1.0)), 0.0)
    r = r[np.isfinite(r)]
    return float(np.clip(np.median(r), -1.0, 1.0)) if len(r) >= 4 else 0.0


def refine(cv2, reference: np.ndarray, anchors: np.ndarray, H: np.ndarray, image: np.ndarray, window: int,
           threshold: float):
    """H (reference -> image) refined without drift: the reference warped by H into the image, its gray
    levels matched to the image's (mean and std over the warped area: a lighting change), the anchors
    (K, 2, reference pixels) tracked from it by cv2.calcOpticalFlowPyrLK (the residual motion is small and
    has no rotation or scale left, where a frame-to-frame KLT step is biased by them), H fitted again
    (RANSAC then least squares on its inliers). Returns (H, the anchors' pixels (K, 2), inlier mask (K,)),
    or None when too few anchors are left."""
    h, w = image.shape
    warped = cv2.warpPerspective(reference, H, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    seen = cv2.warpPerspective(np.full(reference.shape, 255, np.uint8), H, (w, h), flags=cv2.INTER_NEAREST)
    seen = cv2.erode(seen, np.ones((window, window), np.uint8))
    p0 = map_points(H, anchors)
    ok = np.isfinite(p0).all(1) & (p0[:, 0] >= 0) & (p0[:, 0] <= w - 1) & (p0[:, 1] >= 0) & (p0[:, 1] <= h - 1)
    ij = np.round(np.where(ok[:, None], p0, 0)).astype(int)
    ok &= seen[ij[:, 1], ij[:, 0]] > 0
    if ok.sum() < 4 or not seen.any():
        return None
    m_ref, s_ref = cv2.meanStdDev(warped, mask=seen)
    m_img, s_img = cv2.meanStdDev(image, mask=seen)
    if not (s_ref[0, 0] > 1e-3 and s_img[0, 0] > 1e-3):
        return None
    a = s_img[0, 0] / s_ref[0, 0]
    matched = cv2.convertScaleAbs(warped, alpha=a, beta=m_img[0, 0] - a * m_ref[0, 0])
    q0 = p0[ok].astype(np.float32).reshape(-1, 1, 2)
    q1, st, _ = cv2.calcOpticalFlowPyrLK(matched, image, q0, q0.copy(), winSize=(window, window), maxLevel=1,
                                         flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
                                         criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
    q1 = q1.reshape(-1, 2).astype(np.float64)
    good = (st.ravel() == 1) & np.isfinite(q1).all(1) & (np.linalg.norm(q1 - p0[ok], axis=1) < 4 * threshold)
    idx = np.flatnonzero(ok)[good]
    if len(idx) < 4:
        return None
    H2, inl = cv2.findHomography(anchors[idx], q1[good], cv2.RANSAC, threshold)
    if H2 is None:
        return None
    inl = inl.ravel().astype(bool)
    if inl.sum() < 4:
        return None
    H2 = cv2.findHomography(anchors[idx][inl], q1[good][inl], 0)[0]
    if H2 is None:
        return None
    pixels = np.full((len(anchors), 2), np.nan)
    pixels[idx] = q1[good]
    mask = np.zeros(len(anchors), bool)
    mask[idx[inl]] = True
    return H2 / H2[2, 2], pixels, mask
