"""Convergence domains of servoing on what the camera sees (docs/direct.md): photometric servoing, photometric
moments, IBVS on KLT-tracked and on keypoint-homography corners of a textured plate, and IBVS on four dots,
against the initial displacement, with image noise and a lighting change.

A 320x240 camera (f = 400 px, 30 fps) 0.5 m in front of a 0.2 m square plate at the goal: the plate is the
procedural texture (ibvs.vision.texture) for the first four, four white dots at its corners for the last.
Every image has sensor noise (std NOISE gray levels); the goal image is taught at nominal lighting, and
each start is run twice: at the same lighting, and with the lighting of every frame of the episode changed
to gain x + offset (LIGHTING). Displacements of the start from the goal,
each of magnitude `level` in a random direction (numpy default_rng(trial)):
  translation  the camera moved by `level` m along a random 3-D direction;
  rotation     the camera turned by `level` degrees about its optical axis (through the plate's centre);
  tilt         the camera orbited the plate's centre by `level` degrees about a random axis of the plate's
               plane (the plate stays centred, seen at an angle).
Every scheme runs through ibvs.sim.run with gain GAIN for DURATION s (ending early once the measured corners, or
for the dense schemes the true ones, are within 0.25 px of the goal's); a run succeeds when at its end the true
corners (History.projected) are within 1 px of their goal image.

python docs/scripts/natural_domain.py [TRIALS] (default 2; about 2 minutes of CPU) prints the table and writes
docs/figures/direct_error_images.png (|I - I*| at the start and the end of a photometric run);
python docs/scripts/natural_domain.py 1 quick runs one level of one displacement for 1 s (the docs test) and
writes the figure into the working directory.
"""

import sys
import time
from pathlib import Path

import numpy as np

import ibvs
from ibvs import sim, vision
from ibvs.study import schemes

TRIALS = int(sys.argv[1]) if len(sys.argv) > 1 else 2
CAM = ibvs.CameraModel(400.0, 400.0, 159.5, 119.5, 0.0, 0.0, 320.0, 240.0, 30.0)
TARGET = sim.Target.square(0.2, sim.pose(t=(0, 0, 0.5)))
NOISE, LIGHTING, GAIN, DURATION = 2.0, (1.2, -10.0), 1.5, 5.0
LEVELS = {"translation": (0.01, 0.025, 0.05, 0.1), "rotation": (5, 15, 45, 90), "tilt": (5, 10, 20, 35)}
QUICK = sys.argv[2:3] == ["quick"]
if QUICK:
    LEVELS, DURATION = {"translation": (0.01,)}, 1.0
UNITS = {"translation": "m", "rotation": "°", "tilt": "°"}
SCHEMES = ("photometric", "photometric_moments", "klt", "keypoints", "dots")
CENTRE = sim.pose(t=(0, 0, 0.5))


def start(axis: str, level: float, trial: int) -> np.ndarray:
    """World <- camera at the start (the goal camera is the identity)."""
    rng = np.random.default_rng([trial, list(LEVELS).index(axis)])
    if axis == "translation":
        d = rng.normal(size=3)
        return sim.pose(t=level * d / np.linalg.norm(d))
    if axis == "rotation":
        return sim.pose(r=(0.0, 0.0, np.radians(level) * rng.choice([-1, 1])))
    phi = rng.uniform(0, 2 * np.pi)
    orbit = sim.pose(r=(np.radians(level) * np.cos(phi), np.radians(level) * np.sin(phi), 0.0))
    return CENTRE @ orbit @ np.linalg.inv(CENTRE)


def run(scheme: str, pose: np.ndarray, seed: int, lighting=LIGHTING):
    """One episode through sim.run, as ibvs.study runs the scheme (its image sensor or dense source)."""
    options = dict(noise=NOISE, seed=seed, lighting=lighting)
    servo = schemes.make("cartesian" if scheme == "dots" else scheme, GAIN, 4)
    if scheme in schemes.DENSE:
        cam, target = schemes.dense_target(scheme, CAM, TARGET, **options)
        vis = None
    else:
        vis = vision.ImageSensor.for_target(CAM, TARGET, scheme, **options)
        cam, target = CAM, TARGET
    return sim.run(servo, cam, target, pose, np.eye(4), duration=DURATION, vision=vis, tolerance=None,
                   tolerance_px=0.25, seed=seed)


GOAL_PX = np.array(CAM.project(np.array([[-0.2, -0.2], [0.2, -0.2], [0.2, 0.2], [-0.2, 0.2]])))


def success(r) -> bool:
    """The true corners within 1 px of their goal at the end (whatever the tracker measured)."""
    last = np.asarray(r.history.projected)[-1]
    return bool(np.isfinite(last).all() and np.abs(last - GOAL_PX).max() < 1.0)


def table() -> str:
    rows = []
    t0 = time.perf_counter()
    for axis, levels in LEVELS.items():
        for level in levels:
            cells = []
            for scheme in SCHEMES:
                same, changed = (sum(success(run(scheme, start(axis, level, k), k, light)) for k in range(TRIALS))
                                 for light in (None, LIGHTING))
                cells.append(f"{same} · {changed}")
            rows.append(f"| {axis} | {level:g} {UNITS[axis]} | " + " | ".join(cells) + " |")
    head = ("| displacement | magnitude | " + " | ".join(SCHEMES) + " |\n|---|---|" + "---|" * len(SCHEMES))
    print(f"({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    return head + "\n" + "\n".join(rows)


def error_images(out: Path) -> None:
    """|I - I*| at the start and at the end of one photometric run (translation 1 cm, trial 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pose = start("translation", 0.01, 0)
    r = run("photometric", pose, 0)
    measure = vision.PhotometricMeasure(CAM, TARGET, noise=NOISE, seed=0)
    goal = measure.renderer.render(np.eye(4)).astype(float)
    measure.renderer.set_lighting(*LIGHTING)
    first = measure.renderer.render(r.history.pose[0]).astype(float)
    last = measure.renderer.render(r.history.pose[-1]).astype(float)
    fig, ax = plt.subplots(1, 2, figsize=(8, 3.2))
    for a, img, title in ((ax[0], first, "start"), (ax[1], last, f"end ({r.status.outcome}, frame {r.status.frame})")):
        a.imshow(np.abs(img - goal), cmap="gray", vmin=0, vmax=80)
        a.set_title(f"|I − I*|, {title}", fontsize=9)
        a.axis("off")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    print(f"final pose error {r.metrics.final_translation_error * 1e3:.2f} mm, "
          f"{np.degrees(r.metrics.final_rotation_error):.2f}°")


if __name__ == "__main__":
    print(table())
    figures = Path(__file__).resolve().parents[1] / "figures"
    error_images(Path("direct_error_images.png") if QUICK else figures / "direct_error_images.png")
