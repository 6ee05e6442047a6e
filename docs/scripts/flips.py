"""Does the branch chosen near the half-turn alternate from frame to frame? (issue 11, item 2)

python docs/scripts/flips.py [SEEDS] (docs/beyond.md section 7; 40 seeds: about a minute of CPU).

Free-flying camera, the paper's target, gain 1 and 0.1, 60 Hz, exact depth, noise 1e-3 (normalised),
latency 0-2 frames, starts within 0.5 deg of a half-turn about the optical axis (both signs).
The closed loop is written out here (the simulator's free-flight step: project, add noise,
delay, servo, T <- T exp(v dt)) so that the consistent wrap can be run with and without its
frame-to-frame memory (reset() before every update = no memory).
A flip: wz changes sign from one frame to the next while the camera is still more than 90 deg
from the goal about z.
"""
import itertools
import sys

import numpy as np

import ibvs
from ibvs import sim

P = np.asarray(sim.Target.paper().world_points())
FPS, SECONDS, NOISE = 60, 3.0, 1e-3


def rotz(a):
    T = np.eye(4)
    T[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    return T


def project(T):
    Tcw = np.linalg.inv(T)
    Pc = P @ Tcw[:3, :3].T + Tcw[:3, 3]
    return Pc[:, :2] / Pc[:, 2:], Pc[:, 2]


def episode(layout, wrap, memory, start, seed, latency, gain):
    servo = ibvs.Servo(layout, gain=gain, angle_wrap=wrap)
    uvd, _ = project(np.eye(4))
    rng = np.random.default_rng(seed)
    T, ring, wz, angle, peak = rotz(start), [], [], [], 0.0
    for k in range(int(SECONDS * FPS)):
        uv, z = project(T)
        ring.append((uv + NOISE * rng.standard_normal(uv.shape), z))
        seen = ring[max(0, k - latency)]
        if not memory:
            servo.reset()
        if np.any(seen[1] <= 1e-3) or np.any(np.abs(seen[0]) > 10):
            break  # a point behind the camera, or beyond the servo's |u|, |v| <= 10: the simulator would stop here
        v = servo.update(seen[0], seen[1], uvd).velocity
        wz.append(v[5])
        angle.append(abs(np.arctan2(T[1, 0], T[0, 0])))
        peak = max(peak, np.linalg.norm(v[:3]))
        T = T @ ibvs.se3_exp(v / FPS)
    s = np.sign(wz)
    far = np.array(angle[1:]) > np.pi / 2
    return int(np.sum((s[1:] != s[:-1]) & far)), peak


def main(seeds=40):
    laws = {"polar": ibvs.Layout.polar(4), "stacked": ibvs.Layout.stacked(4)}
    modes = [("per_point", False), ("consistent", False), ("consistent", True)]
    print("| law | gain | wrap | episodes | episodes with a flip | flips (total) | most flips in one "
          "| peak \\|T\\| max (m/s) |")
    print("|---|---:|---|---:|---:|---:|---:|---:|")
    for (name, layout), gain in itertools.product(laws.items(), (1.0, 0.1)):
        for wrap, memory in modes:
            counts, peaks = [], []
            for seed in range(seeds):
                for latency in (0, 1, 2):
                    for sign in (-1, 1):
                        off = np.random.default_rng([seed, latency]).uniform(0, np.radians(0.5))
                        n, p = episode(layout, wrap, memory, np.pi + sign * off, seed, latency, gain)
                        counts.append(n)
                        peaks.append(p)
            label = wrap + (", continuity" if memory else ", no memory" if wrap == "consistent" else "")
            c = np.array(counts)
            print(f"| {name} | {gain:g} | {label} | {len(c)} | {np.sum(c > 0)} | {c.sum()} | {c.max()} "
                  f"| {max(peaks):.3g} |")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 40)
