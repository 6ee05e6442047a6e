"""Image moments from a general start (docs/moments.md): converged share by interaction matrix.

Random seven-vertex star-shaped objects (seeds 0 .. shapes-1) of two sizes, in the plane z = 0; the goal: the
camera 0.8 m in front of them, parallel; the start: 5 cm and 4 cm off, tilted by 0.15 and -0.1 rad, turned by
0.5 rad about the optical axis, 1.1 m away. Gain 1, 60 frames/s, 4000 frames at most; converged: within 1e-6 m
and 1e-6 rad of the goal. python docs/scripts/moments_starts.py prints the table (about a minute of CPU;
--shapes N for fewer objects).
"""
import argparse

import numpy as np

import ibvs


def star(rng, n, size):
    t = 2 * np.pi * (np.arange(n) + 0.5 + rng.uniform(-0.3, 0.3, n)) / n
    r = size * rng.uniform(0.5, 1.0, n)
    return np.column_stack([r * np.cos(t), r * np.sin(t), np.zeros(n)])


def in_camera(T_wc, Pw):
    T = np.linalg.inv(T_wc)
    return Pw @ T[:3, :3].T + T[:3, 3]


def converges(feature, Pw, jacobian, Zd=0.8):
    servo = ibvs.Servo(ibvs.Task().add(feature), gain=1.0, jacobian=jacobian)
    goal = np.eye(4)
    goal[2, 3] = -Zd
    md = ibvs.MomentsFeature.project(in_camera(goal, Pw), feature.source, depth_desired=Zd)
    T = ibvs.se3_exp([0.05, -0.04, 0.0, 0.15, -0.1, 0.5])
    T[2, 3] = -1.1
    none = np.zeros((0, 2))
    for _ in range(4000):
        try:
            m = ibvs.MomentsFeature.project(in_camera(T, Pw), feature.source, md[15], Zd)
        except ValueError:  # the object left the camera's front
            return False
        r = servo.update(none, np.zeros(0), none, depth_desired=np.zeros(0), measurements=[m],
                         measurements_desired=[md])
        if r.error_norm < 1e-9:
            break
        T = T @ ibvs.se3_exp(r.velocity / 60.0)
    D = np.linalg.inv(goal) @ T
    angle = np.arccos(np.clip((np.trace(D[:3, :3]) - 1) / 2, -1, 1))
    return bool(np.linalg.norm(D[:3, 3]) < 1e-6 and angle < 1e-6)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shapes", type=int, default=12)
    n = ap.parse_args().shapes
    choices = [(s, i) for s in ("region", "points") for i in ("p", "s")]
    print("| radius up to (m) | interaction matrix | " + " | ".join(f"{s}, {i}" for s, i in choices) + " |")
    print("|---|---|" + "---:|" * len(choices))
    for size in (0.15, 0.3):
        for jacobian in ("current", "desired", "mean"):
            objects = [star(np.random.default_rng(k), 7, size) for k in range(n)]
            counts = [sum(converges(ibvs.MomentsFeature(s, i), Pw, jacobian) for Pw in objects)
                      for s, i in choices]
            print(f"| {size:.2f} | {jacobian} | " + " | ".join(f"{c}/{n}" for c in counts) + " |")


if __name__ == "__main__":
    main()
