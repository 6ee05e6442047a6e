"""ibvs.vision: the image in the loop. What the simulated camera sees of a planar target, and
the dots or the tag found in it (OpenCV: the ``vision`` extra, pip install ".[vision]").

    renderer = Renderer(camera, target, kind="dots")     # white dots on a dark plate, kind="tag", "texture"...
    image = renderer.render(pose_wc)                     # uint8 (height, width), the camera's lens
    tracker = DotTracker(len(target))
    tracker.reset(initial_pixels)                        # the user's clicks on the dots
    track = tracker.track(image)                         # pixels (N, 2), NaN rows = lost, status per point
    sensor = ImageSensor(renderer, tracker)              # for ibvs.sim.run(..., vision=sensor)

Pixel coordinates are OpenCV's (and CameraModel's, cv2.projectPoints'): the centre of the pixel in
column c and row r is (u, v) = (c, r). A camera for images has a pixel sensor whose bounds are
[0, width] x [0, height] with integer width and height.

Modules: images (cameras with images, image checks), renderer (Renderer; rays: its path for fisheye and
omnidirectional lenses, through each pixel's bearing), track (Track), dots
(DotTracker), tag (TagDetector), klt (KltTracker) and keypoints (KeypointTracker): natural features
of a textured plate (planar: what they share), dense (photometric servoing and photometric moments as
feature sources of rendered images), moments (image_moments: a binary image's moments), blob (blob_source: blob
moments and ellipses from rendered images, for sim.Target(features=...)), sensor (ImageSensor), textures (texture: a procedural texture; load_texture), video (draw_points, write_video); this
package re-exports their public names. Rendering is described in ibvs.vision.renderer.
"""

from __future__ import annotations

from .blob import BLOB_FEATURES, BlobMeasure, blob_source
from .dense import DENSE_FEATURES, PhotometricMeasure, luminance_block, photometric_source
from .dots import DotTracker
from .images import check_image, image_camera
from .keypoints import KEYPOINT_DETECTORS, KeypointTracker
from .klt import KltTracker
from .moments import image_moments
from .renderer import KINDS, Renderer
from .sensor import SENSOR_KINDS, ImageSensor
from .tag import TagDetector
from .textures import load_texture, texture
from .track import Track
from .video import draw_points, write_video

__all__ = [
    "BLOB_FEATURES",
    "DENSE_FEATURES",
    "KEYPOINT_DETECTORS",
    "KINDS",
    "SENSOR_KINDS",
    "BlobMeasure",
    "DotTracker",
    "ImageSensor",
    "KeypointTracker",
    "KltTracker",
    "PhotometricMeasure",
    "Renderer",
    "TagDetector",
    "Track",
    "blob_source",
    "check_image",
    "draw_points",
    "image_camera",
    "image_moments",
    "load_texture",
    "luminance_block",
    "photometric_source",
    "texture",
    "write_video",
]
