"""Command line: `ibvs` / `python -m ibvs`.

    ibvs reproduce [--out DIR] [--quick]          every experiment of the paper, figures and summary
    ibvs run --world W --scheme S --case C ...    one simulated episode
    ibvs bench [...]                              control-step timings, bindings vs numpy
    ibvs sweep --out F.csv --episodes N ...       thousands of episodes per scheme, aggregate tables
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

    _add_sweep_parser(sub)

    b = sub.add_parser("bench", help="time the control step through the bindings next to numpy",
                       description="Time the control step through the bindings next to a numpy reference.")
    b.add_argument("args", nargs="*", help="options of python -m ibvs.bench (see python -m ibvs.bench --help)")
    return p


def _range(text: str) -> tuple[str, tuple[float, float]]:
    from .sweep import PARAMETERS

    name, sep, rest = text.partition("=")
    lo, sep2, hi = rest.partition(":")
    if not sep or name not in PARAMETERS:
        raise argparse.ArgumentTypeError(f"expected NAME=LO:HI or NAME=VALUE with NAME in {', '.join(PARAMETERS)}")
    try:
        a = float(lo)
        b = float(hi) if sep2 else a
    except ValueError:
        raise argparse.ArgumentTypeError(f"not numbers: {rest!r}") from None
    if not (math.isfinite(a) and math.isfinite(b) and a <= b):
        raise argparse.ArgumentTypeError(f"need finite LO <= HI, got {rest!r}")
    return name, (a, b)


def _grid_axis(text: str) -> tuple[str, list[float]]:
    from .sweep import PARAMETERS

    name, sep, rest = text.partition("=")
    if not sep or name not in PARAMETERS:
        raise argparse.ArgumentTypeError(f"expected NAME=V1,V2,... with NAME in {', '.join(PARAMETERS)}")
    try:
        values = [float(v) for v in rest.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"not numbers: {rest!r}") from None
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"values must be finite: {rest!r}")
    return name, values


def _positive_int(text: str) -> int:
    x = _non_negative_int(text)
    if x == 0:
        raise argparse.ArgumentTypeError("must be >= 1")
    return x


def _add_sweep_parser(sub) -> None:
    from .sweep import DEPTH_MODES, SCHEMES

    w = sub.add_parser("sweep", help="many episodes over random or grid start poses, per scheme; aggregate table",
                       description="Run a sweep of episodes (every scheme from the same starts), append one row per "
                                   "episode to a CSV (re-running with the same file resumes), print the aggregate "
                                   "table per scheme and rotation bin.")
    w.add_argument("--out", type=Path, required=True, help="CSV file of the rows (appended; resumable)")
    w.add_argument("--episodes", type=_non_negative_int, default=100, help="random start set-ups (default 100)")
    w.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the start set-ups and noise")
    w.add_argument("--schemes", nargs="+", choices=list(SCHEMES), metavar="SCHEME",
                   help=f"schemes to run (default all: {', '.join(SCHEMES)})")
    w.add_argument("--world", choices=["free", "gantry"], default="free", help="free-flying camera or gantry")
    w.add_argument("--range", type=_range, action="append", default=[], metavar="NAME=LO:HI",
                   help="override a sampling range (rz_deg, tilt_deg, tilt_dir_deg, tx, ty, tz, noise, depth_scale)")
    w.add_argument("--grid", type=_grid_axis, action="append", default=[], metavar="NAME=V1,V2,...",
                   help="grid mode: every combination of these values (replaces random sampling)")
    w.add_argument("--depth", choices=list(DEPTH_MODES), help="depth given to the controller (default per world)")
    w.add_argument("--gain", type=_positive_float, help="control gain (1/s)")
    w.add_argument("--duration", type=_positive_float, help="seconds per episode")
    w.add_argument("--boundary-margin", type=_non_negative_float, default=0.0,
                   help="image-boundary potential margin (measurement units; 0 = off)")
    w.add_argument("--boundary-gain", type=_non_negative_float, default=0.1, help="image-boundary potential gain")
    w.add_argument("--jobs", type=_positive_int, help="local worker processes (default: all cores)")
    w.add_argument("--batch", type=_positive_int, help="episodes per task")
    w.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address (needs ibvs[distributed])")
    w.add_argument("--figure", type=Path, help="PNG: success rate and retreat against rotation, per scheme")
    w.add_argument("--bin-width", type=_positive_float, default=30.0, help="rotation bin width in degrees")
    w.add_argument("--quiet", action="store_true", help="no progress bar")


def _sweep(args, parser) -> int:
    import numpy as np

    from . import sweep as sw

    if args.range and args.grid:
        parser.error("--range and --grid cannot be combined")
    edges = list(np.arange(0.0, 180.0, args.bin_width)) + [180.0]
    try:
        rows = sw.sweep(args.out, episodes=args.episodes, seed=args.seed, schemes=args.schemes, world=args.world,
                        ranges=dict(args.range) or None, grid=dict(args.grid) or None, gain=args.gain,
                        duration=args.duration, depth=args.depth, boundary_margin=args.boundary_margin,
                        boundary_gain=args.boundary_gain, jobs=args.jobs, batch=args.batch,
                        scheduler=args.scheduler, progress=not args.quiet)
    except ValueError as e:
        parser.error(str(e))
    table = sw.aggregate(rows, bins=edges)
    print(sw.format_table(table))
    print(f"\n{len(rows)} episodes in {args.out}")
    if args.figure:
        sw.figure(table, args.figure)
        print(f"figure {args.figure}")
    return 0


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
    if args.command == "sweep":
        return _sweep(args, parser)
    parser.print_help()
    return 0


if __name__ == "__main__":
    sys.exit(main())
