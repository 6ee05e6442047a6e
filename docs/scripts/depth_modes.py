"""Depth modes on the gantry: exact, pose, desired and estimated depth, with pixel noise (docs/beyond.md section 4).

The gantry case of the paper (distorted 640x480 camera, 10 cm target at 0.6 m, gain 2, 15 s, tolerance 0 so that
every run lasts 15 s) from random offsets of the goal with a rotation up to 90 degrees; start i draws from
numpy.random.default_rng(0) in turn and seeds the noise of its runs with i.
python docs/scripts/depth_modes.py [STARTS] (default 100: 17 s of CPU) prints the table.
"""
import sys

import numpy as np

import ibvs
from ibvs import sim

case = sim.cases.gantry_general_motion()
robot, cam = case.robot, case.camera
P_w = np.asarray(case.target.world_points())
goal_pose = robot.camera(case.goal)


def start(rng):
    """A random offset from the goal (rz up to 90 deg) as joints, or None: unreachable or the target not in view."""
    d, tilt = rng.uniform(0, 2 * np.pi), np.radians(rng.uniform(0, 8))
    off = sim.pose(t=rng.uniform([-0.04, -0.04, -0.1], [0.04, 0.04, 0.1]),
                   r=(tilt * np.cos(d), tilt * np.sin(d), np.radians(rng.uniform(0, 90))))
    Tcw = np.linalg.inv(goal_pose @ off)
    Pc = P_w @ Tcw[:3, :3].T + Tcw[:3, 3]
    m = np.asarray(cam.project(Pc[:, :2] / Pc[:, 2:]))
    if np.any((m < 0) | (m > [640, 480])):
        return None
    ik = sim.solve_ik(robot, goal_pose @ off, case.goal, restarts=0)  # Newton from the goal joints only
    return ik.q if ik.converged else None


def image_error_px(r):
    """True (noise-free) RMS pixel distance of the points to their goal per frame, and the true depths."""
    Tcw = np.linalg.inv(r.history.pose)
    Pc = np.einsum("kij,nj->kni", Tcw[:, :3, :3], P_w) + Tcw[:, None, :3, 3]
    m = np.asarray(cam.project((Pc[..., :2] / Pc[..., 2:]).reshape(-1, 2))).reshape(Pc.shape[0], -1, 2)
    return np.sqrt(((m - np.asarray(cam.project(r.uv_desired))) ** 2).sum(-1).mean(-1)), Pc[..., 2]


def study(starts, scheme, depth, noise, latency=0):
    """One row of the table: every start run with one scheme, depth mode, noise and latency."""
    settle, img, dp, dz, dz0, fails = [], [], [], [], [], {}
    for i, q in enumerate(starts):
        servo = ibvs.Servo(getattr(ibvs.Layout, scheme)(4), gain=2.0)
        r = sim.run(servo, cam, case.target, q, case.goal, robot=robot, duration=15.0, depth=depth,
                    noise=noise, latency=latency, seed=i, tolerance=0.0)  # tolerance 0: always the full 15 s
        if r.status.outcome != "timeout":
            fails[r.status.outcome] = fails.get(r.status.outcome, 0) + 1
            continue
        e, z = image_error_px(r)
        above = np.nonzero(e > 1.0)[0]  # settled: true image error below 1 px from then on
        settled = r.history.time[above[-1] + 1] if len(above) and above[-1] < len(e) - 1 else np.nan
        settle.append(settled if len(above) else 0.0)
        img.append(e[-60:].mean())  # means over the last second
        G = np.linalg.inv(r.goal) @ r.history.pose[-60:]
        dp.append(1e3 * np.linalg.norm(G[:, :3, 3], axis=1).mean())
        rel = np.abs(r.history.depth / z - 1)
        dz0.append(100 * rel[:180].mean())  # all points, first 3 s
        dz.append(100 * rel[-60:].mean(0).max())  # worst point, last second
    s = np.array(settle)

    def median(x, spec):  # n/a when every run of the row failed
        return format(np.median(x), spec) if len(x) else "n/a"

    print(f"| {scheme} | {depth}{'' if latency == 0 else f', latency {latency}'} | {noise:g} | "
          f"{np.isfinite(s).sum()}/{len(starts)} | {median(s[np.isfinite(s)], '.2f')} | "
          f"{median(img, '.3f')} | {median(dp, '.1f')} | {median(dz0, '.1f')} | {median(dz, '.1f')} | "
          f"{format(np.max(dz), '.0f') if dz else 'n/a'} | {', '.join(f'{v} {k}' for k, v in fails.items()) or 0} |",
          flush=True)


def main(n_starts: int) -> None:
    rng = np.random.default_rng(0)
    starts = [q for q in (start(rng) for _ in range(n_starts)) if q is not None]
    print("| scheme | depth | noise (px) | ends within 1 px | median time to 1 px (s) | final image error (px) "
          "| final Δp (mm) | depth error, first 3 s (%) | depth error, last 1 s, worst point (%) | its max (%) "
          "| failed |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for scheme in ("cartesian", "stacked"):
        for noise in (0.0, 0.5, 1.0):
            for depth in ("exact", "pose", "desired", "estimated"):
                study(starts, scheme, depth, noise)
        for noise in (0.5, 1.0):
            study(starts, scheme, "estimated", noise, latency=1)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100)
