"""The dot tracker: bright dots on a dark plate followed frame to frame (OpenCV)."""

from __future__ import annotations

import math
import time
from typing import Optional

import numpy as np

from .images import check_image, check_real, opencv
from .track import Track

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["DotTracker"]


class DotTracker:
    """Bright dots on a dark background, tracked frame to frame.

    DotTracker(n_points, image_size, threshold=None, gate=10.0, min_area=4, mask=None)
      image_size  (width, height) of the images (e.g. Renderer.size)
      mask        None, or (height, width): the pixels that see (non-zero), e.g. a fisheye's image
                  circle (Renderer.mask); a blob touching a pixel that does not is lost ("lost_border")
      threshold   gray level separating dots from the plate; None: Otsu's on the first image
      gate        px added to 1.5 dot radii: the half-side of the square searched around each
                  point's predicted position (constant-velocity prediction from its last two positions)
      min_area    px; smaller blobs are ignored (noise)
    reset(pixels) starts the tracks at guesses (N, 2) (a user clicking on the dots); track(image)
    finds each dot in its gate: threshold, connected components, the blob nearest the prediction,
    its sub-pixel intensity centroid (background-subtracted, over the blob grown by 2 px). A dot is
    lost when its blob touches the image border or its gate, or no blob is in its gate; a blob
    already taken by another point is refused ("conflict"): correspondences never swap.
    A lost dot is searched for again in every later frame (e.g. after an occlusion) around its
    position carried along by the others: the affine map that moves the dots tracked in two
    successive frames (least squares, >= 3 of them) is applied to its last estimate.
    """

    def __init__(
        self,
        n_points: int,
        image_size,
        threshold: Optional[float] = None,
        gate: float = 10.0,
        min_area: int = 4,
        mask=None,
    ):
        if (
            isinstance(n_points, bool)
            or not isinstance(n_points, (int, np.integer))
            or not 1 <= n_points <= 1000
        ):
            raise ValueError(f"n_points must be an int in [1, 1000], got {n_points!r}")
        if (
            not isinstance(image_size, (tuple, list))
            or len(image_size) != 2
            or not all(isinstance(s, (int, np.integer)) and 16 <= s <= 8192 for s in image_size)
        ):
            raise ValueError(f"image_size must be (width, height), ints in [16, 8192], got {image_size!r}")
        self.n = int(n_points)
        self.size = (int(image_size[0]), int(image_size[1]))
        self.threshold = None if threshold is None else check_real(threshold, "threshold", 0.0, 255.0)
        self.gate = check_real(gate, "gate", 1.0, 1000.0)
        if isinstance(min_area, bool) or not isinstance(min_area, (int, np.integer)) or min_area < 1:
            raise ValueError(f"min_area must be an int >= 1, got {min_area!r}")
        self.min_area = int(min_area)
        self._blind = None  # the pixels that do not see (uint8 1), or None
        if mask is not None:
            m = np.asarray(mask)
            if m.shape != (self.size[1], self.size[0]) or m.dtype.kind not in "biu":
                raise ValueError(
                    f"mask must be None or a (height, width) = {(self.size[1], self.size[0])} array of "
                    f"booleans or integers, got shape {m.shape} and dtype {m.dtype}"
                )
            self._blind = None if m.all() else (m == 0).astype(np.uint8)
        self._last = self._prev = None

    def reset(self, pixels) -> None:
        """Start tracking at the guesses pixels (N, 2)."""
        p = np.asarray(pixels, dtype=np.float64)
        if p.shape != (self.n, 2) or not np.isfinite(p).all():
            raise ValueError(
                f"pixels must be {self.n} finite guesses, shape ({self.n}, 2), got shape {p.shape}"
            )
        self._last, self._prev = p.copy(), None
        self._ghost = np.full((self.n, 2), np.nan)  # a lost dot's position carried by the others
        self._radius = np.full(self.n, np.nan)
        self._level = self.threshold

    def _carry(self, out: np.ndarray) -> None:
        """The lost dots' estimates moved by the affine map of the dots tracked in the last and this frame."""
        lost = ~np.isfinite(out).all(axis=1)
        if not lost.any():
            self._ghost[:] = np.nan
            return
        both = np.isfinite(out).all(axis=1) & np.isfinite(self._last).all(axis=1)
        if both.sum() < 3:
            return
        src = np.hstack([self._last[both], np.ones((int(both.sum()), 1))])
        A, *_ = np.linalg.lstsq(src, out[both], rcond=None)  # (3, 2): [x y 1] @ A
        start = np.where(np.isfinite(self._last), self._last, self._ghost)[lost]
        self._ghost[lost] = np.hstack([start, np.ones((len(start), 1))]) @ A
        self._ghost[~lost] = np.nan

    def track(self, image) -> Track:
        """The dots in this image (see the class)."""
        cv2 = opencv()
        image = check_image(image, self.size)
        if self._last is None:
            raise ValueError("reset(pixels) must start the tracks before track(image)")
        t0 = time.perf_counter()
        if self._level is None:
            self._level = float(cv2.threshold(image, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)[0])
        W, H = self.size
        if self._prev is None:
            pred = self._last.copy()
        else:  # constant velocity where a dot has two positions, else its last
            pred = np.where(np.isfinite(self._prev), 2 * self._last - self._prev, self._last)
        pred = np.where(np.isfinite(pred), pred, self._ghost)  # lost dots: where the others carried them
        out = np.full((self.n, 2), np.nan)
        status = ["lost_gate"] * self.n
        taken: list = []
        kernel = np.ones((5, 5), np.uint8)
        for i in range(self.n):
            if not np.isfinite(pred[i]).all():
                continue
            r = self._radius[i]
            g = (1.5 * r if np.isfinite(r) else 4 * self.gate) + self.gate
            x0, y0 = int(math.floor(pred[i, 0] - g)), int(math.floor(pred[i, 1] - g))
            x1, y1 = int(math.ceil(pred[i, 0] + g)) + 1, int(math.ceil(pred[i, 1] + g)) + 1
            cx0, cy0, cx1, cy1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
            if cx1 - cx0 < 2 or cy1 - cy0 < 2:
                status[i] = "lost_border"
                continue
            roi = image[cy0:cy1, cx0:cx1]
            binary = (roi > self._level).astype(np.uint8)
            count, labels, stats, cents = cv2.connectedComponentsWithStats(binary, connectivity=8)
            # the blob (of at least min_area pixels) whose centroid is nearest the prediction
            dist = np.hypot(cents[1:, 0] + cx0 - pred[i, 0], cents[1:, 1] + cy0 - pred[i, 1])
            dist[stats[1:, cv2.CC_STAT_AREA] < self.min_area] = np.inf
            if dist.size == 0 or not np.isfinite(dist.min()):
                continue
            best = int(np.argmin(dist)) + 1
            bx, by, bw, bh = stats[best, :4]
            gx0, gy0, gx1, gy1 = bx + cx0, by + cy0, bx + bw + cx0, by + bh + cy0  # blob box, image pixels
            if gx0 <= 0 or gy0 <= 0 or gx1 >= W or gy1 >= H:
                status[i] = "lost_border"
                continue
            if gx0 <= cx0 or gy0 <= cy0 or gx1 >= cx1 or gy1 >= cy1:
                status[i] = "lost_gate"
                continue
            blob = (labels == best).astype(np.uint8)
            grown = cv2.dilate(blob, kernel)
            if self._blind is not None and (grown & self._blind[cy0:cy1, cx0:cx1]).any():
                status[i] = "lost_border"  # cut by the edge of the image circle
                continue
            others = (labels > 0) & (blob == 0)
            bg_pixels = roi[(grown == 0) & ~others]
            bg = float(np.median(bg_pixels)) if bg_pixels.size else 0.0
            w = np.where((grown > 0) & ~others, np.maximum(roi.astype(np.float64) - bg, 0.0), 0.0)
            total = w.sum()
            if not total > 0:
                continue
            ys, xs = np.indices(w.shape)
            c = np.array([(w * xs).sum() / total + cx0, (w * ys).sum() / total + cy0])
            if any(np.hypot(*(c - out[j])) < 1.0 for j in taken):
                status[i] = "conflict"
                continue
            out[i] = c
            taken.append(i)
            status[i] = "tracked"
            self._radius[i] = math.sqrt(stats[best, cv2.CC_STAT_AREA] / math.pi)
        self._carry(out)
        self._prev, self._last = self._last, np.where(np.isfinite(out), out, np.nan)
        return Track(out, tuple(status), time.perf_counter() - t0)
