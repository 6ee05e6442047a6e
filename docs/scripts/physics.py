"""The physics testbed against the kinematic simulator (docs/physics.md), and its cost.

python docs/scripts/physics.py compare [--size 320x240] [--duration 15] [--cases all]
    The paper's cases on the Panda, each run twice with the same servo, camera (testbed_camera, 30 fps),
    dots and tracker (ibvs.vision.DotTracker), exact depths and tolerance (every dot within 0.5 px):
    kinematically (ibvs.sim.run with vision=ImageSensor: the joints do what they are told) and on the
    MuJoCo testbed (ibvs.sim.physics.run: velocity actuators, inertia, torque limits, images rendered by
    MuJoCo). Prints a markdown table. About 2 min of CPU at 320x240.
python docs/scripts/physics.py latency [--size 320x240] [--delays 0 25 ... 150] [--gains ...] [--json FILE]
    The testbed's column of the latency study (docs/scripts/latency.py: the same gains, delays, start offset,
    polar servo and overshoot): the Panda through ibvs.loop, its frames delivered `delay` after exposure, the
    loop uncompensated and with ibvs.loop.latency.FeaturePredictor; prints the gain ranges that converge
    (every dot within 0.5 px at the end) with at most 5 % overshoot.
python docs/scripts/physics.py bench [--size 320x240] [--seconds 5]
    The testbed's cost per simulated second: physics alone (1 kHz steps, the arm tracking a command),
    and with the camera rendered at 30 Hz (MuJoCo, OSMesa).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import ibvs
from ibvs import sim
from ibvs.sim import physics
from ibvs.sim.physics.episode import overshoot
from ibvs.vision import ImageSensor

SCHEMES = {"cartesian": ibvs.Layout.cartesian, "polar": ibvs.Layout.polar}


def cases(which: str) -> list:
    """(case, scheme): the three paper motions eye-in-hand and eye-to-hand (the z rotation of pi with polar IBVS
    only: Cartesian IBVS retreats to infinity there, the paper's Fig. 2)."""
    out = [(sim.cases.arm_general_motion("panda"), s) for s in SCHEMES]
    if which == "all":
        out += [(sim.cases.arm_motion("panda", "x_translation"), s) for s in SCHEMES]
        out += [(sim.cases.arm_motion("panda", "z_rotation"), "polar")]
        out += [(sim.cases.eye_to_hand("panda", "x_translation"), s) for s in SCHEMES]
        out += [(sim.cases.eye_to_hand("panda", "general_motion"), s) for s in SCHEMES]
        out += [(sim.cases.eye_to_hand("panda", "z_rotation"), "polar")]
    return out


def kinematic(case, scheme: str, gain: float, camera, duration: float) -> dict:
    servo = ibvs.Servo(SCHEMES[scheme](len(case.target)), gain=gain)
    r = sim.run(servo, camera, case.target, case.start, case.goal, robot=case.robot, duration=duration,
                vision=ImageSensor.for_target(camera, case.target), tolerance_px=0.5, depth="exact", turn=turn(case))
    h = r.history
    desired = h.projected[-1] if r.converged else _goal_pixels(case, camera)
    err = (h.measured - desired).reshape(len(h.measured), -1)
    return {"outcome": r.status.outcome, "frames": r.metrics.frames_to_converge, "overshoot": overshoot(err),
            "tracking": 0.0, "torque": None, "final": r.metrics.final_translation_error}


def _goal_pixels(case, camera):
    T = np.linalg.inv(case.robot.camera(case.goal)) @ case.target.pose
    P = (T[:3, :3] @ np.asarray(case.target.points).T).T + T[:3, 3]
    return camera.project(P[:, :2] / P[:, 2:])


def turn(case) -> float:
    """The eye-in-hand half-turn goes the way joint 7's limits allow (+pi: sim.cases.arm_motion), not the noise's;
    the eye-to-hand half-turn leaves it to the noise (as before: its runs converge)."""
    return math.pi if case.name == "panda_z_rotation" else math.nan


def dynamic(case, scheme: str, gain: float, camera, duration: float) -> dict:
    servo = ibvs.Servo(SCHEMES[scheme](len(case.target)), gain=gain)
    if not math.isnan(turn(case)):
        servo.continue_turn(turn(case))
    r = physics.run(case, servo, camera=camera, duration=duration)
    return {"outcome": r.outcome, "frames": r.frames_to_converge, "overshoot": r.overshoot,
            "tracking": r.tracking_rms, "torque": r.peak_torque / r.effort, "final": r.final_translation_error}


def through_loop(case, scheme: str, gain: float, camera, duration: float) -> dict:
    r = physics.run_loop(case, scheme, gain, camera=camera, duration=duration, turn=turn(case))
    return {"outcome": r.outcome, "frames": r.frames_to_converge, "overshoot": r.overshoot,
            "tracking": r.tracking_rms, "torque": r.peak_torque / r.effort, "final": r.final_translation_error}


def compare(args) -> None:
    w, h = (int(x) for x in args.size.split("x"))
    camera = physics.testbed_camera(w, h, fps=30.0)
    print(f"camera {w}x{h} at 30 fps, gain {args.gain}, tolerance 0.5 px, {args.duration} s at most\n")
    print("| case | scheme | run | outcome | frames | overshoot | tracking RMS (rad/s) | peak torque / limit "
          "| camera error (mm) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for case, scheme in cases(args.cases):
        runs = (("kinematic", kinematic), ("physics", dynamic))
        if case.robot.mounting == "eye_in_hand":  # ibvs.loop's core maps eye-in-hand twists
            runs += (("physics, ibvs.loop", through_loop),)
        for name, fn in runs:
            start = time.process_time()
            r = fn(case, scheme, args.gain, camera, args.duration)
            torque = "—" if r["torque"] is None else \
                f"{100 * r['torque'].max():.0f} % (joint {int(np.argmax(r['torque'])) + 1})"
            print(f"| {case.name} | {scheme} | {name} | {r['outcome']} | {r['frames']} | "
                  f"{100 * r['overshoot']:.1f} % | {r['tracking']:.3g} | {torque} | {1e3 * r['final']:.2f} |",
                  flush=True)
            if args.verbose:
                print(f"  ({time.process_time() - start:.1f} s of CPU)")


def bench(args) -> None:
    w, h = (int(x) for x in args.size.split("x"))
    case = sim.cases.arm_general_motion("panda")
    with physics.World(case.robot, case.target, physics.testbed_camera(w, h)) as world:
        world.render()  # the OpenGL context, once
        qdot = np.array([0.1, -0.1, 0.1, 0.1, -0.1, 0.1, 0.2])
        rows = []
        for label, fps in (("physics only (1 kHz steps)", 0.0), (f"physics + rendering {w}x{h} at 30 Hz", 30.0)):
            world.reset(case.goal)
            world.command(qdot)
            t0 = time.perf_counter()
            if fps:
                for k in range(int(args.seconds * fps)):
                    world.step_to((k + 1) / fps)
                    world.render()
            else:
                world.step_to(args.seconds)
            rows.append((label, (time.perf_counter() - t0) / args.seconds))
        t0 = time.perf_counter()
        for _ in range(30):
            world.render()
        render = (time.perf_counter() - t0) / 30
    print("| testbed (Panda, 1 kHz) | wall time per simulated second |")
    print("|---|---|")
    for label, s in rows:
        print(f"| {label} | {1e3 * s:.0f} ms ({1 / s:.1f}x real time) |")
    print(f"| one render {w}x{h} | {1e3 * render:.1f} ms |")


# The latency study's grid and start: those of docs/scripts/latency.py (the kinematic gantry), here on the Panda.
GAINS = (0.5, 1, 2, 3, 4, 5, 6, 8, 10, 12, 15, 20, 25)
OFFSET = sim.pose(t=(0.03, -0.02, 0.02), r=(0.0, 0.0, 0.3))  # the start, in the goal camera's frame
OVERSHOOT = 0.05


def latency_case(camera):
    """The Panda at its ARMS goal, the 10 cm square 0.5 m ahead, the start OFFSET from the goal camera."""
    robot = sim.cases.arm_robot("panda")
    goal = np.array(sim.cases.ARMS["panda"][0])
    goal_pose = robot.camera(goal)
    target = sim.Target.square(0.1, goal_pose @ sim.pose(t=(0.0, 0.0, sim.cases.ARM_DESIRED_DEPTH)))
    start = sim.solve_ik(robot, goal_pose @ OFFSET, goal).q
    return sim.cases.Case("panda_latency", "the latency study's start on the Panda", camera, target, start, goal,
                          robot, 10.0)


def pose_overshoot(e: np.ndarray) -> float:
    """docs/scripts/latency.py's overshoot: the largest excursion of the camera's pose error past the goal, per
    component, as a share of that component's initial error (the components over 10 % of the largest)."""
    e0 = e[0]
    big = np.abs(e0) > 0.1 * np.abs(e0).max()
    past = -(e[:, big] * np.sign(e0[big])).min(axis=0) / np.abs(e0[big])
    return float(max(0.0, past.max()))


def latency(args) -> None:
    import json

    w, h = (int(x) for x in args.size.split("x"))
    camera = physics.testbed_camera(w, h, fps=30.0)
    case = latency_case(camera)
    runs = []
    with physics.World(case.robot, case.target, camera) as world:
        for d in args.delays:
            for compensate in (False, True):
                for g in args.gains:
                    duration = min(10.0, max(2.0, 7.0 / g)) + d / 1e3
                    r = physics.run_loop(case, args.scheme, float(g), camera=camera, duration=duration, latency=d / 1e3,
                                         compensate=compensate, lag=args.lag if compensate else 0.0,
                                         tolerance_px=None, world=world)
                    final = float(np.linalg.norm(r.error[-1].reshape(-1, 2), axis=1).max()) if len(r.error) else \
                        float("inf")
                    runs.append({"delay_ms": d, "compensated": compensate, "gain": g, "outcome": r.outcome,
                                 "converged": bool(r.outcome == "timeout" and final < 0.5), "final_px": final,
                                 "overshoot": pose_overshoot(r.pose_error),
                                 "peak_torque_ratio": float((r.peak_torque / r.effort).max())})
                    if args.verbose:
                        print(runs[-1], flush=True)
    res = {"gains": list(args.gains), "delays_ms": list(args.delays), "size": args.size, "lag": args.lag,
           "scheme": args.scheme,
           "runs": runs}
    if args.json:
        with open(args.json, "w") as f:
            f.write(json.dumps(res, indent=1) + "\n")
    print(latency_table(res))


def latency_table(res) -> str:
    def good(r):
        return r["converged"] and r["overshoot"] <= OVERSHOOT

    spans = {}
    for r in res["runs"]:
        spans.setdefault((r["delay_ms"], r["compensated"]), [])
        if good(r):
            spans[(r["delay_ms"], r["compensated"])].append(r["gain"])

    def span(gs):
        """"a – b" when every gain tried from a to b is good, else the good gains listed."""
        if not gs:
            return "none"
        idx = [res["gains"].index(g) for g in gs]
        if idx == list(range(idx[0], idx[-1] + 1)):
            return f"{gs[0]:g} – {gs[-1]:g}" if len(gs) > 1 else f"{gs[0]:g}"
        return ", ".join(f"{g:g}" for g in gs)

    lines = [f"| delay (ms) | testbed {res.get('scheme', 'polar')}, uncompensated: gains (1/s) "
             f"| testbed {res.get('scheme', 'polar')}, compensated: gains (1/s) |",
             "|---:|---|---|"]
    for d in res["delays_ms"]:
        lines.append(f"| {d:g} | {span(spans[(d, False)])} | {span(spans[(d, True)])} |")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="what", required=True)
    c = sub.add_parser("compare")
    c.add_argument("--size", default="320x240")
    c.add_argument("--duration", type=float, default=15.0)
    c.add_argument("--gain", type=float, default=1.0)
    c.add_argument("--cases", choices=("all", "general"), default="all")
    c.add_argument("--verbose", action="store_true")
    b = sub.add_parser("bench")
    b.add_argument("--size", default="320x240")
    b.add_argument("--seconds", type=float, default=5.0)
    lat = sub.add_parser("latency")
    lat.add_argument("--size", default="320x240")
    lat.add_argument("--delays", type=float, nargs="+", default=[0, 25, 50, 75, 100, 125, 150], metavar="MS")
    lat.add_argument("--gains", type=float, nargs="+", default=list(GAINS))
    lat.add_argument("--scheme", default="polar", choices=("polar", "cartesian"))
    lat.add_argument("--lag", type=float, default=0.0, help="the robot's velocity lag given to the predictor (s)")
    lat.add_argument("--json", help="write the runs there")
    lat.add_argument("--verbose", action="store_true")
    args = p.parse_args()
    {"compare": compare, "bench": bench, "latency": latency}[args.what](args)


if __name__ == "__main__":
    main()
