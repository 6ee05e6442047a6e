"""Videos of image episodes: the camera frames with the detected and desired points drawn."""

from __future__ import annotations

import numpy as np

from .images import check_real, opencv

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["draw_points", "write_video"]


def draw_points(image, detected=None, desired=None) -> np.ndarray:
    """An RGB copy of a grayscale image with the detected points (green crosses, numbered) and the
    desired ones (red circles)."""
    cv2 = opencv()
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 2:
        raise TypeError("image must be a 2-D uint8 numpy array (grayscale)")
    rgb = cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    sh = 4  # fixed-point bits: sub-pixel drawing
    if desired is not None:
        for u, v in np.asarray(desired, dtype=np.float64).reshape(-1, 2):
            if np.isfinite([u, v]).all():
                cv2.circle(
                    rgb, (int(round(u * 16)), int(round(v * 16))), 6 * 16, (255, 60, 60), 1, cv2.LINE_AA, sh
                )
    if detected is not None:
        for i, (u, v) in enumerate(np.asarray(detected, dtype=np.float64).reshape(-1, 2)):
            if np.isfinite([u, v]).all():
                cv2.drawMarker(rgb, (int(round(u)), int(round(v))), (60, 255, 60), cv2.MARKER_CROSS, 10, 1)
                cv2.putText(
                    rgb,
                    str(i),
                    (int(round(u)) + 5, int(round(v)) - 5),
                    cv2.FONT_HERSHEY_SIMPLEX,
                    0.4,
                    (60, 255, 60),
                    1,
                    cv2.LINE_AA,
                )
    return rgb


def write_video(path, frames, detected=None, desired=None, fps: float = 60.0) -> str:
    """Write the frames (uint8 grayscale) with the detected points (K, N, 2) and the desired ones (N, 2)
    drawn: an MP4 through imageio-ffmpeg when installed (the video extra); otherwise, or for a .gif
    path, a GIF (Pillow, which comes with matplotlib); PNG frames in a directory for any other path
    or without Pillow. A fallback says so on stdout. Returns the path written."""
    import pathlib

    path = pathlib.Path(path)
    frames = list(frames)
    if not frames:
        raise ValueError("frames must hold at least one image")
    fps = check_real(fps, "fps", 0.1, 1000.0)
    rgb = [draw_points(f, None if detected is None else detected[k], desired) for k, f in enumerate(frames)]
    if path.suffix.lower() == ".mp4":
        try:
            import imageio_ffmpeg
        except ImportError:
            gif = path.with_suffix(".gif")
            print(f'imageio-ffmpeg is not installed (pip install ".[video]" from the ibvs repository root): '
                  f"writing {gif} instead")
            path = gif
        else:
            h, w = rgb[0].shape[:2]
            writer = imageio_ffmpeg.write_frames(str(path), (w, h), fps=fps, macro_block_size=1)
            writer.send(None)
            for f in rgb:
                writer.send(np.ascontiguousarray(f))
            writer.close()
            return str(path)
    if path.suffix.lower() == ".gif":
        try:
            from PIL import Image
        except ImportError:  # Pillow comes with matplotlib (the plot extra); without it, PNG frames
            path = path.with_suffix("")
            print(f'Pillow is not installed (pip install ".[plot]" from the ibvs repository root): '
                  f"writing PNG frames into {path}/ instead")
        else:
            ims = [Image.fromarray(f) for f in rgb]
            ims[0].save(path, save_all=True, append_images=ims[1:], duration=int(round(1000 / fps)), loop=0)
            return str(path)
    cv2 = opencv()
    path.mkdir(parents=True, exist_ok=True)
    for k, f in enumerate(rgb):
        cv2.imwrite(str(path / f"frame_{k:05d}.png"), cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    return str(path)
