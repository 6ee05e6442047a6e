"""`ibvs sweep`: many episodes per scheme from a built-in world or a scenario file, appended to a
CSV (resumable), aggregated into a table and a figure. Ctrl-C and SIGTERM stop it and keep every
finished row; so does a Dask scheduler that dies. Progress and the final counts are in episodes (start
set-ups) as --episodes asks for them, with the rows they are (one per scheme)."""

from __future__ import annotations

import argparse
import math
import signal

from . import args as a


def _range(text: str) -> tuple[str, tuple[float, float]]:
    from ..study.scenario import PARAMETERS

    name, sep, rest = text.partition("=")
    lo, sep2, hi = rest.partition(":")
    if not sep or name not in PARAMETERS:
        raise argparse.ArgumentTypeError(f"expected NAME=LO:HI or NAME=VALUE with NAME in {', '.join(PARAMETERS)}")
    try:
        x = float(lo)
        y = float(hi) if sep2 else x
    except ValueError:
        raise argparse.ArgumentTypeError(f"not numbers: {rest!r}") from None
    if not (math.isfinite(x) and math.isfinite(y) and x <= y):
        raise argparse.ArgumentTypeError(f"need finite LO <= HI, got {rest!r}")
    if name == "latency":
        if x != int(x) or y != int(y):
            raise argparse.ArgumentTypeError(f"latency is in whole frames, got {rest!r}")
        return name, (int(x), int(y))
    return name, (x, y)


def _grid_axis(text: str) -> tuple[str, list[float]]:
    from ..study.scenario import PARAMETERS

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


def add_parser(sub) -> None:
    """The `sweep` subcommand's parser."""
    from ..study.scenario import DEPTH_MODES, MAX_DURATION, MAX_GAIN, PARAMETERS
    from ..study.schemes import points_only
    from ..study.sweep import MAX_EPISODES, MAX_JOBS, SCHEMES

    w = sub.add_parser("sweep", help="many episodes over random or grid start poses, per scheme; aggregate table",
                       description="Run a sweep of episodes (every scheme from the same starts) of a built-in world "
                                   "or of your own scenario file, append one row per episode to a CSV (re-running "
                                   "with the same file resumes), print the aggregate table per scheme and rotation "
                                   "bin. Ctrl-C stops it; the rows so far are kept.",
                       epilog=a.exit_status("every episode ran; the table is printed",
                                            "the Dask scheduler was lost: the finished rows are kept, the same command "
                                            "resumes", interrupted=": the finished rows are kept, the same command resumes"))
    a.add_output(w, "--out", type=a.out_file(), required=True, help="CSV file of the rows (appended; resumable)")
    where = w.add_mutually_exclusive_group()
    where.add_argument("--scenario", type=a.in_file, metavar="FILE.toml",
                       help="your scenario: camera, target, goal, robot, start distribution, control (docs/sweeps.md)")
    where.add_argument("--world", choices=["free", "gantry", "arm"],
                       help="a built-in scenario (default free; arm: the Franka Panda, needs the robots extra)")
    w.add_argument("--episodes", type=a.number(0, MAX_EPISODES, integer=True),
                   help="random start set-ups (default: the scenario file's, else 100)")
    w.add_argument("--seed", type=a.number(0, a.SEED_MAX, integer=True), help="seed of the start set-ups and noise")
    w.add_argument("--schemes", nargs="+", choices=list(SCHEMES), metavar="SCHEME",
                   help=f"schemes to run (default: those on points only, {', '.join(points_only())})")
    w.add_argument("--range", type=_range, action="append", default=[], metavar="NAME=LO:HI",
                   help=f"override a sampling range ({', '.join(PARAMETERS)}; noise in measurement units: pixels "
                        f"for a pixel camera, normalised for the free world; latency in frames)")
    w.add_argument("--grid", type=_grid_axis, action="append", default=[], metavar="NAME=V1,V2,...",
                   help="grid mode: every combination of these values (replaces random sampling)")
    w.add_argument("--depth", choices=list(DEPTH_MODES), help=a.DEPTH_HELP + " (default per scenario)")
    w.add_argument("--gain", type=a.number(0, MAX_GAIN, open_lo=True), help="control gain, 1/s")
    w.add_argument("--duration", type=a.number(0, MAX_DURATION, open_lo=True), metavar="SECONDS",
                   help="seconds per episode")
    w.add_argument("--tolerance", type=a.number(0, 1e6), help=a.TOLERANCE_HELP.replace("default 1e-5", "default per "
                                                                                     "scenario"))
    w.add_argument("--tolerance-px", type=a.number(0, 1e6, open_lo=True), metavar="PX",
                   help=a.TOLERANCE_PX_HELP + " (default per scenario: none)")
    w.add_argument("--boundary-margin", type=a.number(0, 1e6),
                   help="image-boundary potential margin (measurement units; 0 = off)")
    w.add_argument("--boundary-gain", type=a.number(0, 1e6), help="image-boundary potential gain")
    a.add_angle_wrap(w, None)
    w.add_argument("--goal-pose", choices=["taught", "given"],
                   help=a.GOAL_POSE_HELP + " (default per scenario: taught)")
    w.add_argument("--jobs", type=a.number(1, MAX_JOBS, integer=True), help="local worker processes (default: cores)")
    w.add_argument("--batch", type=a.number(1, MAX_EPISODES, integer=True), help="episodes per task")
    w.add_argument("--scheduler", metavar="ADDRESS",
                   help='Dask scheduler address, e.g. tcp://127.0.0.1:8786 (pip install ".[distributed]"; '
                        "docs/sweeps.md)")
    a.add_output(w, "--figure", type=a.figure_file, metavar="FILE",
                   help="figure: every outcome's rate, median retreat, path and peak twist against rotation")
    w.add_argument("--bin-width", type=a.number(0.1, 360), default=30.0, metavar="DEG",
                   help="rotation bin width in degrees (0.1 to 360; default 30)")
    w.add_argument("--quiet", action="store_true", help="no progress bar")


def _saved(out, spec) -> str:
    """What the CSV holds of the sweep asked for: "N of E episodes (M of R rows: K schemes each)"."""
    from ..study import sweep as sw
    from ..study.sweep.progress import count, tally

    wanted = set(spec.schemes)
    rows, complete = tally((r["index"] for r in sw.load(out, spec.config())
                            if r["scheme"] in wanted and r["index"] < spec.size), len(spec.schemes))
    return count(spec.size, len(spec.schemes), rows, complete)


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that the sweep stops as on Ctrl-C."""


def _on_sigterm(signum, frame):
    raise _Terminated()


def command(args) -> int:
    """Run `ibvs sweep`; the exit status (130 on Ctrl-C, 143 on SIGTERM, 1 when the Dask scheduler is lost)."""
    from ..study import sweep as sw
    from ..study.schemes import points_only
    from ..writer_lock import WriterBusy

    prog = "ibvs sweep"
    if args.range and args.grid:
        a.fail(prog, "--range and --grid cannot be combined")
    settings = dict(gain=args.gain, duration=args.duration, depth=args.depth, tolerance=args.tolerance,
                    tolerance_px=args.tolerance_px, boundary_margin=args.boundary_margin, boundary_gain=args.boundary_gain,
                    angle_wrap=args.angle_wrap, goal_pose_mode=args.goal_pose)
    try:  # everything is checked here, before any episode runs
        setup, options = sw.resolve(args.scenario, world=args.world, ranges=dict(args.range) or None, **settings)
        schemes = args.schemes or options.get("schemes")
        spec = sw.SweepSpec(setup, seed=args.seed if args.seed is not None else options.get("seed", 0),
                            episodes=args.episodes if args.episodes is not None else options.get("episodes", 100),
                            schemes=tuple(schemes) if schemes else points_only(),
                            grid=dict(args.grid) or None).validate()
        sw.load(args.out, spec.config())
    except (ValueError, TypeError, OSError) as e:
        a.fail(prog, e)
    old = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        rows = sw.sweep(args.out, scenario=setup, episodes=spec.episodes, seed=spec.seed, schemes=spec.schemes,
                        grid=spec.grid, jobs=args.jobs, batch=args.batch, scheduler=args.scheduler,
                        progress=not args.quiet)
    except KeyboardInterrupt as e:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        what = "SIGTERM" if isinstance(e, _Terminated) else "interrupted"
        a.say(prog, f"{what}: {_saved(args.out, spec)} saved in {args.out}; run the same command again to resume")
        return 143 if isinstance(e, _Terminated) else 130
    except sw.SchedulerLost as e:
        a.say(prog, f"{e}: {_saved(args.out, spec)} saved in {args.out}; start a scheduler (and its workers) and "
                    f"run the same command again to resume")
        return 1
    except (ValueError, TypeError, ConnectionError, ImportError, WriterBusy) as e:
        a.fail(prog, e)  # WriterBusy: another process writes --out (ibvs.writer_lock); nothing was written
    finally:
        if signal.getsignal(signal.SIGTERM) is _on_sigterm:
            signal.signal(signal.SIGTERM, old)
    table = sw.aggregate(rows, bins=sw.bins_for(rows, width=args.bin_width))
    print(sw.format_table(table))
    k = len(spec.schemes)
    print(f"\nconverged: {setup.criterion()}")
    print(f"{spec.size} episodes ({len(rows)} rows: {k} scheme{'s' if k != 1 else ''} each) in {args.out}")
    print(sw.format_starts(rows))
    if args.figure:
        sw.figure(table, args.figure)
        print(f"figure {args.figure}")
    return 0
