"""The arm of `ibvs run --world arm`: the options naming it (--robot, --frame, --emc, --goal-joints) and
the case they make, the paper's general motion transposed to that arm (ibvs.sim.cases.arm_general_motion:
a 10 cm square 0.5 m in front of the camera at the goal, the start a camera offset from it solved by
ibvs.sim.solve_ik)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from . import args as a

#: The example arms --robot names (ibvs.sim.cases.ARMS, from example-robot-data).
EXAMPLES = ("panda", "ur5")


def robot_name(text: str) -> str:
    """argparse type: an example arm's name, or a readable .urdf file."""
    if text in EXAMPLES:
        return text
    if not text.lower().endswith(".urdf"):
        raise argparse.ArgumentTypeError(f"expected {', '.join(EXAMPLES)} or a .urdf file, got {text!r}")
    return str(a.in_file(text))


def numbers(count: int | None, what: str, bound: float):
    """argparse type: comma-separated finite numbers (`count` of them, or any number >= 1), each at most
    `bound` in magnitude."""

    def parse(text: str) -> list[float]:
        try:
            xs = [float(x) for x in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if (count is not None and len(xs) != count) or not all(math.isfinite(x) and abs(x) <= bound for x in xs):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return xs

    parse.__name__ = "numbers"
    return parse


def add_options(parser) -> None:
    """--robot, --frame, --emc, --goal-joints on the `run` parser."""
    parser.add_argument("--robot", type=robot_name, metavar="panda|ur5|PATH.urdf",
                        help="with --world arm: the Franka Panda or the UR5 of example-robot-data, or any arm's URDF "
                             '(default panda; needs pip install ".[robots]" from the ibvs repository root)')
    parser.add_argument("--frame", metavar="FRAME",
                        help="with --robot PATH.urdf: the URDF frame (link) the camera is mounted on, e.g. tool0 "
                             "(default for panda / ur5: panda_hand / tool0)")
    parser.add_argument("--emc", type=numbers(6, "6 numbers TX,TY,TZ,RX,RY,RZ (m, rad)", 100.0),
                        metavar="TX,TY,TZ,RX,RY,RZ",
                        help="the camera's pose on that frame, frame <- camera: translation (m) and rotation "
                             "Rx Ry Rz (rad) (default for panda / ur5: 5 cm off the flange axis, tilted; for a "
                             "URDF: the frame itself; write --emc=-0.05,... when the first number is negative)")
    parser.add_argument("--goal-joints", type=numbers(None, "joint positions Q1,Q2,... (rad or m)", 1e3),
                        metavar="Q1,Q2,...",
                        help="the arm's joints at the goal (default for panda / ur5: a posture well inside the "
                             "limits; for a URDF: the middle of every joint's range; --goal-joints=-1,... when the "
                             "first is negative)")


def check(prog: str, args) -> None:
    """Refuse the arm options without --world arm, and --frame / --emc needs."""
    used = [o for o, v in (("--robot", args.robot), ("--frame", args.frame), ("--emc", args.emc),
                           ("--goal-joints", args.goal_joints)) if v is not None]
    if args.world != "arm" and used:
        a.fail(prog, f"argument {used[0]}: only with --world arm")
    if args.world == "arm" and args.robot not in (None, *EXAMPLES) and args.frame is None:
        a.fail(prog, "argument --frame: required with --robot PATH.urdf (the frame the camera is mounted on)")


def case(prog: str, args):
    """The arm's general-motion case of the arguments, or one line and exit 2 when it cannot be built
    (Pinocchio missing, a frame the URDF lacks, goal joints outside the limits, an unreachable start)."""
    from .. import sim

    name = args.robot or "panda"
    try:
        emc = None if args.emc is None else sim.pose(args.emc[:3], args.emc[3:])
        if name in EXAMPLES and args.frame in (None, sim.urdf.EXAMPLE_ROBOTS[name][1]):
            robot = sim.cases.arm_robot(name, emc)
        else:
            path = sim.example_robot_urdf(name) if name in EXAMPLES else name
            robot = sim.UrdfRobot(path, args.frame, emc)
    except (ImportError, FileNotFoundError) as e:
        a.fail(prog, f"argument --robot: {e}")
    except ValueError as e:
        a.fail(prog, f"argument {'--frame' if 'frame' in str(e) else '--emc' if 'eMc' in str(e) else '--robot'}: {e}")
    label = name if name in EXAMPLES else Path(name).stem
    goal = args.goal_joints
    if goal is None and name in EXAMPLES:  # whatever the frame and mount, the example's goal posture
        goal = sim.cases.ARMS[name][0]
    try:
        return sim.cases.arm_general_motion(label, robot=robot, goal=goal)
    except ValueError as e:
        if str(e).startswith("start"):
            where = "the middle of the joint ranges" if goal is None else ",".join(f"{x:g}" for x in goal)
            a.fail(prog, f"argument --goal-joints: from the goal joints ({where}) the general motion's {e}; "
                         f"give other --goal-joints")
        a.fail(prog, f"argument --goal-joints: {e}")
