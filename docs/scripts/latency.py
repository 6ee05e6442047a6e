"""The gain range of the servo loop under a capture-to-command delay, without and with compensation
(docs/servo-loop.md, "Latency").

The loop (ibvs.loop.ServoLoop: rendered dots, the dot tracker, the servo - Cartesian and polar - the joint
mapping) drives
the kinematic Afma6-like gantry (ibvs.sim.Gantry.afma6, its joints integrated exactly on a SimClock)
from a start 40 mm / 17 degrees off the goal; the renderer's frames (30 Hz) reach the loop `delay`
seconds after their capture (ibvs.vision.sources.RendererSource's latency: an injected delay). For each
delay and gain, once uncompensated and once with the features predicted over the delay
(ibvs.loop.latency.FeaturePredictor), it records whether the loop converged (every dot within 0.5 px of
its goal by the end) and the overshoot: the largest excursion of the camera's pose error past the goal,
per component, as a share of that component's initial error (the components over 10 % of the largest).

    python docs/scripts/latency.py --delays 0 25 50 75 100 125 150 --out docs/figures/latency.png  # ~5 min

prints the Markdown table of docs/servo-loop.md and writes the figure and docs/figures/latency.json.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import ibvs
from ibvs import sim
from ibvs.loop import SimClock
from ibvs.loop.latency import FeaturePredictor
from ibvs.loop.servo_loop import LoopOptions, ServoLoop
from ibvs.ros.node import NodeParams, ServoNodeCore
from ibvs.vision import Renderer
from ibvs.vision.sources import RendererSource

GAINS = (1, 2, 4, 6, 8, 10, 12, 15, 20, 25, 30)
OFFSET = sim.pose(t=(0.03, -0.02, 0.02), r=(0.0, 0.0, 0.3))  # the start, in the goal camera's frame
OVERSHOOT = 0.05
KINEMATIC = True  # the predictor's model: the robot's kinematics (False: the interaction matrix alone)


class KinematicRobot:
    """The kinematic gantry as the loop sees a robot: q integrates the commanded dq exactly on the clock."""

    def __init__(self, model, q0, clock):
        self.kinematics, self.n_joints, self.rate = model, model.dof, 1000.0
        self.q, self.dq, self.clock = np.array(q0, dtype=float), np.zeros(model.dof), clock
        clock.on_advance(self._advance)

    def _advance(self, t0, t1):
        self.q = self.q + self.dq * (t1 - t0)

    def connect(self):
        pass

    def state(self):
        return SimpleNamespace(q=self.q.copy(), dq=self.dq.copy(), stamp=self.clock.now())

    def send_joint_velocity(self, dq, state=None):
        self.dq = np.array(dq, dtype=float)

    def stop(self):
        self.dq = np.zeros(self.n_joints)

    def disconnect(self):
        self.stop()


class TrueDepthPredictor(FeaturePredictor):
    """A diagnostic: the predictor given the points' true depths at capture (an oracle the loop does not have;
    the servo keeps its constant goal depth)."""

    def __init__(self, delay, model, target, **kw):
        super().__init__(delay, kinematics=model, **kw)
        self.model, self.world = model, np.asarray(target.world_points())

    def predict(self, uv, depth, t_capture):
        T_cw = np.linalg.inv(self.model.camera(self.q_at(t_capture)))
        return super().predict(uv, (self.world @ T_cw[:3, :3].T + T_cw[:3, 3])[:, 2], t_capture)


def episode(gain: float, delay: float, compensate: bool, duration: float, scheme: str = "cartesian",
            true_depth: bool = False) -> dict:
    """One run: {converged, overshoot, final_px}."""
    clock = SimClock()
    model = sim.Gantry.afma6()
    cam = ibvs.CameraModel.afma6()
    q_goal = np.array(sim.cases.GANTRY_GOAL_Q)
    goal_pose = model.camera(q_goal)
    target = sim.Target.square(0.1, goal_pose @ sim.pose(t=(0.0, 0.0, 0.6)))
    q0 = sim.solve_ik(model, goal_pose @ OFFSET, q_goal).q

    def pixels(q):
        T_cw = np.linalg.inv(model.camera(q))
        P = (T_cw[:3, :3] @ np.asarray(target.world_points()).T).T + T_cw[:3, 3]
        return cam.project(P[:, :2] / P[:, 2:3])

    robot = KinematicRobot(model, q0, clock)
    source = RendererSource(Renderer(cam, target, "dots"), lambda: model.camera(robot.q), clock=clock,
                            rate=cam.fps, latency=delay)
    predictor = FeaturePredictor(delay, kinematics=model if KINEMATIC else None) if compensate and delay > 0 else None
    if predictor is not None and true_depth:
        predictor = TrueDepthPredictor(delay, model, target)
    params = NodeParams(desired_pixels=pixels(q_goal), depth=0.6, scheme=scheme, gain=gain, max_linear_speed=0.25,
                        max_angular_speed=1.0, initial_pixels=pixels(q0), output="joint_velocities", eMc=np.eye(4),
                        joint_names=[f"j{i}" for i in range(6)], fps=cam.fps)
    core = ServoNodeCore(params, clock=lambda: int(round(clock.now() * 1e9)), jacobian=model.jacobian,
                         predictor=predictor)
    core.set_camera(cam)
    errors = []  # the camera's pose error (goal frame: t, theta-u) at every advance of the clock
    inv_goal = np.linalg.inv(goal_pose)

    def note(t0, t1):
        E = inv_goal @ model.camera(robot.q)
        errors.append(np.concatenate([E[:3, 3], ibvs.theta_u(E[:3, :3])]))

    clock.on_advance(note)
    options = LoopOptions(duration=duration, watchdog=max(0.5, 2 * delay), signals=False)
    report = ServoLoop(source, robot, core, clock, options, predictor).run()
    e = np.array(errors)
    e0 = e[0]
    big = np.abs(e0) > 0.1 * np.abs(e0).max()
    past = -(e[:, big] * np.sign(e0[big])).min(axis=0) / np.abs(e0[big])
    final = float(np.linalg.norm(pixels(robot.q) - pixels(q_goal), axis=1).max())
    return {"converged": bool(report.outcome == "duration" and final < 0.5), "overshoot": float(max(0.0, past.max())),
            "final_px": final}


def study(delays_ms, gains, schemes=("cartesian", "polar")) -> dict:
    out = {"gains": list(gains), "delays_ms": list(delays_ms), "schemes": list(schemes), "runs": []}
    for scheme in schemes:
        for d in delays_ms:
            for compensate in (False, True):
                for g in gains:
                    duration = min(10.0, max(2.0, 7.0 / g)) + d / 1e3
                    r = episode(float(g), d / 1e3, compensate, duration, scheme)
                    out["runs"].append({"scheme": scheme, "delay_ms": d, "compensated": compensate, "gain": g, **r})
    return out


def good(r) -> bool:
    return r["converged"] and r["overshoot"] <= OVERSHOOT


def ranges(res) -> dict:
    """(scheme, delay, compensated) -> the gains that converge within 5 % overshoot."""
    out: dict = {}
    for r in res["runs"]:
        gains = out.setdefault((r["scheme"], r["delay_ms"], r["compensated"]), [])
        if good(r):
            gains.append(r["gain"])
    return out


def _span(gs) -> str:
    return f"{min(gs):g} – {max(gs):g}" if gs else "none"


def table(res) -> str:
    rg = ranges(res)
    head = "| delay (ms) |" + "".join(f" {s} | {s}, compensated |" for s in res["schemes"])
    lines = [head, "|---:|" + "---|---|" * len(res["schemes"])]
    for d in res["delays_ms"]:
        cells = "".join(f" {_span(rg[(s, d, False)])} | {_span(rg[(s, d, True)])} |" for s in res["schemes"])
        lines.append(f"| {d:g} |{cells}")
    return "\n".join(lines)


def figure(res, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    rg = ranges(res)
    for scheme, colour in zip(res["schemes"], ("C0", "C1", "C2")):
        for comp, style, label in ((False, "o--", "uncompensated"), (True, "s-", "compensated")):
            ys = [max(rg[(scheme, d, comp)]) if rg[(scheme, d, comp)] else np.nan for d in res["delays_ms"]]
            ax.plot(res["delays_ms"], ys, style, color=colour, label=f"{scheme}, {label}")
    ds = np.linspace(max(1.0, min(res["delays_ms"])), max(res["delays_ms"]), 100)
    ax.plot(ds, 1 / (math.e * ds / 1e3), ":", color="gray", label="1 / (e d): continuous loop, no overshoot")
    ax.set_xlabel("capture-to-command delay d (ms)")
    ax.set_ylabel("largest gain, ≤ 5 % overshoot (1/s)")
    ax.set_ylim(0, max(res["gains"]) * 1.1)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--delays", type=float, nargs="+", default=[0, 25, 50, 75, 100, 125, 150], metavar="MS")
    p.add_argument("--gains", type=float, nargs="+", default=list(GAINS))
    p.add_argument("--schemes", nargs="+", default=["cartesian", "polar"])
    p.add_argument("--out", type=Path, help="the figure (PNG); its data beside it as .json")
    p.add_argument("--true-depth", action="store_true",
                   help="a diagnostic instead: the compensated runs with the predictor given the true depths")
    args = p.parse_args(argv)
    if args.true_depth:
        print("| scheme | delay (ms) | gains (1/s): compensated, true depths |\n|---|---:|---|")
        for scheme in args.schemes:
            for d in args.delays:
                gs = [g for g in args.gains if good(episode(g, d / 1e3, True, min(10.0, max(2.0, 7.0 / g)) + d / 1e3,
                                                            scheme, true_depth=True))]
                print(f"| {scheme} | {d:g} | {_span(gs)} |")
        return 0
    res = study(args.delays, args.gains, args.schemes)
    print(table(res))
    if args.out is not None:
        figure(res, args.out)
        args.out.with_suffix(".json").write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
