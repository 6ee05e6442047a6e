"""The paper's cases through images vs the point simulator: the table of docs/vision.md.

    python bench/vision_table.py            (about a minute; needs the vision extra)

Each case runs three times: exact projected points (the point simulator), dots found by
ibvs.vision.DotTracker in rendered frames, and the AprilTag's corners found by cv2.aruco. Same
servo, start, goal, depth mode and tolerance; a normalised case is given the 640x480 camera of
ibvs.vision.image_camera (f = 800 px, the same +-0.3 field vertically).
"""

import math

import ibvs
import numpy as np
from ibvs import sim, vision
from ibvs.sim import cases

ROWS = [
    # name, case, servo layout, gain, duration, tolerance
    ("z-rotation pi, IBVS-P (free)", cases.z_rotation(), "polar", 2.0, 5.0, 2e-3),
    ("z-rotation pi, Cartesian (free)", cases.z_rotation(), "cartesian", 1.0, 2.0, 2e-3),
    ("general motion, stacked (free)", cases.general_motion(), "stacked", 1.0, 20.0, 1e-4),
    (
        "gantry general motion, distorted camera, stacked",
        cases.gantry_general_motion(),
        "stacked",
        1.0,
        15.0,
        1e-5,
    ),
    (
        "gantry general motion, distorted camera, IBVS-P",
        cases.gantry_general_motion(),
        "polar",
        1.0,
        15.0,
        1e-5,
    ),
]


def layout(name):
    return getattr(ibvs.Layout, name)(4)


def main():
    print(
        "| case | measurement | outcome | frames | retreat (m) | path (m) | final Δp (mm) | final Δθ (°) "
        "| detection error median / max (px) |"
    )
    print("|---|---|---|---:|---:|---:|---:|---:|---:|")
    for name, c, lay, gain, duration, tol in ROWS:
        cam = vision.image_camera(c.camera)
        for how in (None, "dots", "tag"):
            servo = ibvs.Servo(layout(lay), gain=gain)
            r = sim.run(
                servo,
                cam,
                c.target,
                c.start,
                c.goal,
                robot=c.robot,
                duration=duration,
                tolerance=tol,
                vision=how,
            )
            m = r.metrics
            err = np.abs(r.history.measured - r.history.projected)
            det = f"{np.nanmedian(err):.3f} / {np.nanmax(err):.3f}" if how else ""
            print(
                f"| {name} | {how or 'points'} | {r.status.outcome} | {len(r.history)} "
                f"| {m.camera_retreat:.3g} "
                f"| {m.path_length:.3g} | {1e3 * m.final_translation_error:.3g} "
                f"| {math.degrees(m.final_rotation_error):.3g} | {det} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
