"""Command line: `ibvs` / `python -m ibvs`.

    ibvs reproduce [--out DIR] [--quick]          every experiment of the paper, figures and summary
    ibvs run --world W --scheme S --case C ...    one simulated episode
    ibvs bench [...]                              control-step timings, bindings vs numpy
    ibvs --cmake-dir                              where ibvsConfig.cmake is, for find_package(ibvs)
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import ibvs


def _non_negative_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(x) or x < 0:
        raise argparse.ArgumentTypeError(f"must be finite and >= 0, got {text}")
    return x


def _positive_float(text: str) -> float:
    x = _non_negative_float(text)
    if x == 0:
        raise argparse.ArgumentTypeError("must be > 0")
    return x


def _non_negative_int(text: str) -> int:
    try:
        x = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if x < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {x}")
    return x


def build_parser() -> argparse.ArgumentParser:
    from .reproduce import CASES, SCHEMES

    p = argparse.ArgumentParser(prog="ibvs", description="Image-based visual servoing: Cartesian, polar and hybrid.")
    p.add_argument("--version", action="version", version=f"ibvs {ibvs.__version__}")
    p.add_argument("--cmake-dir", action="store_true", help="print the directory holding ibvsConfig.cmake and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    r = sub.add_parser("reproduce", help="run every experiment of the paper; write figures and a summary",
                       description="Run every experiment of the paper (Figs. 1-8), write PNG figures, summary.md and "
                                   "summary.csv, and print the summary table.")
    r.add_argument("--out", type=Path, default=Path("ibvs-results"), help="output directory (default ./ibvs-results)")
    r.add_argument("--quick", action="store_true", help="small, fast figures (for CI); the simulations are the same")

    cases = sorted({c for w in CASES.values() for c in w})
    one = sub.add_parser("run", help="simulate one episode and print its status and metrics",
                         description="Simulate one episode and print its status and metrics.")
    one.add_argument("--world", choices=sorted(CASES), default="free", help="free-flying camera or gantry")
    one.add_argument("--scheme", choices=list(SCHEMES), default="polar",
                     help="cartesian (IBVS), polar (IBVS-P), hybrid (per point), stacked (16x6)")
    one.add_argument("--case", choices=cases, default="z-rotation", help="which start pose")
    one.add_argument("--plot", type=Path, help="save the episode's figure to this PNG file")
    one.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the pixel noise")
    one.add_argument("--noise", type=_non_negative_float, default=0.0,
                     help="std of the measurement noise (pixels on the gantry, normalised units in free flight)")
    one.add_argument("--latency", type=_non_negative_int, default=0, help="frames between capture and control")
    one.add_argument("--gain", type=_positive_float, help="control gain (1/s)")
    one.add_argument("--duration", type=_positive_float, help="seconds")
    one.add_argument("--depth", choices=["exact", "pose", "desired"], help="depth given to the controller")

    b = sub.add_parser("bench", help="time the control step through the bindings next to numpy",
                       description="Time the control step through the bindings next to a numpy reference.")
    b.add_argument("args", nargs="*", help="options of python -m ibvs.bench (see python -m ibvs.bench --help)")
    return p


def _run(args, parser) -> int:
    from . import reproduce

    if args.case not in reproduce.CASES[args.world]:
        parser.error(f"--case {args.case} is not available for --world {args.world}; "
                     f"choose from {', '.join(sorted(reproduce.CASES[args.world]))}")
    case, result = reproduce.run_one(args.world, args.case, args.scheme, duration=args.duration, noise=args.noise,
                                     latency=args.latency, seed=args.seed, gain=args.gain, depth=args.depth)
    row = reproduce.summarise(args.world, args.case, args.scheme, result)
    print(f"{case.description}, {reproduce.SCHEME_TITLES[args.scheme]}")
    for name, value in zip(reproduce.Row.HEADERS[3:-1], row.cells()[3:-1]):
        print(f"  {name:18s} {value}")
    if args.plot:
        from . import plots

        limits = (case.robot.q_min, case.robot.q_max) if case.robot is not None else None
        plots.run_figure(result, f"{case.description}, {reproduce.SCHEME_TITLES[args.scheme]}",
                         reproduce.image_bounds(case.camera), reproduce.target_points(case.target), str(args.plot),
                         joint_limits=limits)
        print(f"  figure             {args.plot}")
    return 0 if result.status.outcome == "converged" else 1


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["bench"] and not {"-h", "--help"} & set(argv[1:2]):
        # Every option after `bench` belongs to python -m ibvs.bench (argparse's REMAINDER drops `--x`).
        from . import bench

        return bench.main(argv[1:])
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.cmake_dir:
        print(ibvs.cmake_dir())
        return 0
    if args.command == "reproduce":
        from .reproduce import reproduce

        reproduce(args.out, quick=args.quick)
        return 0
    if args.command == "run":
        return _run(args, parser)
    parser.print_help()
    return 0


if __name__ == "__main__":
    sys.exit(main())
