"""Command line: `ibvs` / `python -m ibvs`.

    ibvs reproduce [--out DIR] [--quick]          every experiment of the paper, figures and summary
    ibvs run --world W --scheme S --case C ...    one simulated episode (--plot, --animate)
    ibvs bench [...]                              control-step timings, bindings vs numpy
    ibvs sweep --out F.csv [--scenario S.toml]    thousands of episodes per scheme, aggregate tables
    ibvs --cmake-dir                              where ibvsConfig.cmake is, for find_package(ibvs)

Every bad argument exits with status 2 and one line before any work starts. An interrupted
sweep (Ctrl-C, SIGTERM) stops its workers, keeps every finished row and says how to resume.
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
from pathlib import Path

import ibvs

from . import _args as a

NOISE_HELP = ("std of the Gaussian noise added to the measured image points, in the camera's measurement units: "
              "pixels for a pixel camera (gantry), normalised image units (1 = the focal length) for the free "
              "world's normalised camera (default 0)")
DEPTH_HELP = ("depth the controller is given: exact (true depths), pose (from a planar pose estimate), desired "
              "(the constant goal depths) or estimated (online, per point, from the camera's motion)")
TOLERANCE_HELP = "converged when the servo's feature-error norm is below this (normalised units; default 1e-5)"
SEED_MAX = 2**63 - 1


def build_parser() -> argparse.ArgumentParser:
    from .study.reproduce import CASES, DEFAULT_CASE
    from .study.schemes import SCHEMES, TITLES

    p = a.Parser(prog="ibvs", description="Image-based visual servoing: Cartesian, polar and hybrid.")
    p.add_argument("--version", action="version", version=f"ibvs {ibvs.__version__}")
    p.add_argument("--cmake-dir", action="store_true", help="print the directory holding ibvsConfig.cmake and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    r = sub.add_parser("reproduce", help="run every experiment of the paper; write figures and a summary",
                       description="Run every experiment of the paper (Figs. 1-8), write PNG figures, summary.md and "
                                   "summary.csv, and print the summary table.")
    r.add_argument("--out", type=a.out_dir, default=Path("ibvs-results"),
                   help="output directory (default ./ibvs-results; created if missing)")
    r.add_argument("--quick", action="store_true", help="small, fast figures (for CI); the simulations are the same")
    _add_angle_wrap(r, "consistent")

    cases = sorted({c for w in CASES.values() for c in w})
    one = sub.add_parser("run", help="simulate one episode and print its status and metrics",
                         description="Simulate one episode and print its status and metrics; draw it (--plot) or "
                                     "animate it (--animate).")
    one.add_argument("--world", choices=sorted(CASES), default="free", help="free-flying camera or gantry")
    one.add_argument("--scheme", choices=list(SCHEMES), default="polar",
                     help="; ".join(f"{k}: {v}" for k, v in TITLES.items() if k in SCHEMES) + " (default polar)")
    one.add_argument("--case", choices=cases,
                     help="which start pose (default: " + ", ".join(f"{v} for {k}" for k, v in DEFAULT_CASE.items())
                          + ")")
    one.add_argument("--rotation-deg", type=a.number(-360, 360), metavar="DEG",
                     help="angle of the z-rotation case about the optical axis, in degrees (default 180)")
    one.add_argument("--plot", type=a.figure_file, metavar="FILE", help="save the episode's figure (PNG, PDF, SVG)")
    one.add_argument("--animate", type=a.animation_file, metavar="FILE",
                     help="write an animation: camera view and 3D scene (.gif, or .mp4 with imageio-ffmpeg)")
    one.add_argument("--vision", choices=["dots", "tag"],
                     help="close the loop through rendered images: white dots (tracked) or an AprilTag 36h11 "
                          "(cv2.aruco); a normalised camera becomes 640x480 with f = 800 px (needs ibvs[vision])")
    one.add_argument("--video", type=a.out_file(".mp4", ".gif"), metavar="FILE",
                     help="with --vision: the camera frames with detected (green) and desired (red) points, "
                          ".mp4 (imageio-ffmpeg; else a GIF, with a message) or .gif")
    one.add_argument("--speed", type=a.number(0, 1000, open_lo=True), default=1.0,
                     help="animation speed: simulated seconds per second of video (default 1, real time)")
    one.add_argument("--seed", type=a.number(0, SEED_MAX, integer=True), default=0, help="seed of the noise")
    one.add_argument("--noise", type=a.number(0, 1e4), default=0.0, metavar="STD", help=NOISE_HELP)
    one.add_argument("--latency", type=a.number(0, 1000, integer=True), default=0, metavar="FRAMES",
                     help="frames between capture and control (fewer than the episode's frames)")
    one.add_argument("--gain", type=a.number(0, 1e4, open_lo=True), help="control gain, 1/s (default per world)")
    one.add_argument("--duration", type=a.number(0, 3600, open_lo=True), metavar="SECONDS",
                     help="episode length in seconds, at most 3600 (default per world)")
    one.add_argument("--depth", choices=["exact", "pose", "desired", "estimated"], help=DEPTH_HELP)
    one.add_argument("--tolerance", type=a.number(0, 1e6), default=1e-5, help=TOLERANCE_HELP)
    _add_angle_wrap(one, "consistent")

    _add_sweep_parser(sub)

    b = sub.add_parser("bench", help="time the control step through the bindings next to numpy",
                       description="Time the control step through the bindings next to a numpy reference.")
    b.add_argument("args", nargs="*", help="options of python -m ibvs.bench (see python -m ibvs.bench --help)")
    return p


def _add_angle_wrap(parser, default) -> None:
    parser.add_argument("--angle-wrap", choices=["consistent", "per_point"], default=default,
                        help="theta errors wrapped as one rotation about their circular mean or each into "
                             "(-pi, pi] on its own, eq. (13) (default "
                             + (default or "the scenario's, else consistent") + ")")


def _range(text: str) -> tuple[str, tuple[float, float]]:
    from .study.scenario import PARAMETERS

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
    from .study.scenario import PARAMETERS

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


def _add_sweep_parser(sub) -> None:
    from .study.scenario import DEPTH_MODES, MAX_DURATION, MAX_GAIN, PARAMETERS
    from .study.sweep import MAX_EPISODES, MAX_JOBS, SCHEMES

    w = sub.add_parser("sweep", help="many episodes over random or grid start poses, per scheme; aggregate table",
                       description="Run a sweep of episodes (every scheme from the same starts) of a built-in world "
                                   "or of your own scenario file, append one row per episode to a CSV (re-running "
                                   "with the same file resumes), print the aggregate table per scheme and rotation "
                                   "bin. Ctrl-C stops it; the rows so far are kept.")
    w.add_argument("--out", type=a.out_file(), required=True, help="CSV file of the rows (appended; resumable)")
    where = w.add_mutually_exclusive_group()
    where.add_argument("--scenario", type=a.in_file, metavar="FILE.toml",
                       help="your scenario: camera, target, goal, robot, start distribution, control (docs/sweeps.md)")
    where.add_argument("--world", choices=["free", "gantry"], help="a built-in scenario (default free)")
    w.add_argument("--episodes", type=a.number(0, MAX_EPISODES, integer=True),
                   help="random start set-ups (default: the scenario file's, else 100)")
    w.add_argument("--seed", type=a.number(0, SEED_MAX, integer=True), help="seed of the start set-ups and noise")
    w.add_argument("--schemes", nargs="+", choices=list(SCHEMES), metavar="SCHEME",
                   help=f"schemes to run (default all: {', '.join(SCHEMES)})")
    w.add_argument("--range", type=_range, action="append", default=[], metavar="NAME=LO:HI",
                   help=f"override a sampling range ({', '.join(PARAMETERS)}; noise in measurement units: pixels "
                        f"for a pixel camera, normalised for the free world; latency in frames)")
    w.add_argument("--grid", type=_grid_axis, action="append", default=[], metavar="NAME=V1,V2,...",
                   help="grid mode: every combination of these values (replaces random sampling)")
    w.add_argument("--depth", choices=list(DEPTH_MODES), help=DEPTH_HELP + " (default per scenario)")
    w.add_argument("--gain", type=a.number(0, MAX_GAIN, open_lo=True), help="control gain, 1/s")
    w.add_argument("--duration", type=a.number(0, MAX_DURATION, open_lo=True), metavar="SECONDS",
                   help="seconds per episode")
    w.add_argument("--tolerance", type=a.number(0, 1e6), help=TOLERANCE_HELP.replace("default 1e-5", "default per "
                                                                                     "scenario"))
    w.add_argument("--boundary-margin", type=a.number(0, 1e6),
                   help="image-boundary potential margin (measurement units; 0 = off)")
    w.add_argument("--boundary-gain", type=a.number(0, 1e6), help="image-boundary potential gain")
    _add_angle_wrap(w, None)
    w.add_argument("--jobs", type=a.number(1, MAX_JOBS, integer=True), help="local worker processes (default: cores)")
    w.add_argument("--batch", type=a.number(1, MAX_EPISODES, integer=True), help="episodes per task")
    w.add_argument("--scheduler", metavar="ADDRESS",
                   help='Dask scheduler address, e.g. tcp://127.0.0.1:8786 (pip install ".[distributed]"; '
                        "docs/sweeps.md)")
    w.add_argument("--figure", type=a.figure_file, metavar="FILE",
                   help="figure: every outcome's rate, median retreat, path and peak twist against rotation")
    w.add_argument("--bin-width", type=a.number(0.1, 360), default=30.0, metavar="DEG",
                   help="rotation bin width in degrees (0.1 to 360; default 30)")
    w.add_argument("--quiet", action="store_true", help="no progress bar")


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that the sweep stops as on Ctrl-C."""


def _on_sigterm(signum, frame):
    raise _Terminated()


def _sweep(args, parser) -> int:
    from .study import sweep as sw

    prog = "ibvs sweep"
    if args.range and args.grid:
        a.fail(prog, "--range and --grid cannot be combined")
    settings = dict(gain=args.gain, duration=args.duration, depth=args.depth, tolerance=args.tolerance,
                    boundary_margin=args.boundary_margin, boundary_gain=args.boundary_gain,
                    angle_wrap=args.angle_wrap)
    try:  # everything is checked here, before any episode runs
        setup, options = sw.resolve(args.scenario, world=args.world, ranges=dict(args.range) or None, **settings)
        schemes = args.schemes or options.get("schemes")
        spec = sw.SweepSpec(setup, seed=args.seed if args.seed is not None else options.get("seed", 0),
                            episodes=args.episodes if args.episodes is not None else options.get("episodes", 100),
                            schemes=tuple(schemes) if schemes else tuple(sw.SCHEMES),
                            grid=dict(args.grid) or None).validate()
        sw.load(args.out, spec.config())
    except (ValueError, TypeError, OSError) as e:
        a.fail(prog, e)
    total = spec.size * len(spec.schemes)
    old = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        rows = sw.sweep(args.out, scenario=setup, episodes=spec.episodes, seed=spec.seed, schemes=spec.schemes,
                        grid=spec.grid, jobs=args.jobs, batch=args.batch, scheduler=args.scheduler,
                        progress=not args.quiet)
    except KeyboardInterrupt as e:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        saved = len(sw.load(args.out, spec.config()))
        what = "SIGTERM" if isinstance(e, _Terminated) else "interrupted"
        a.say(prog, f"{what}: {saved} of {total} episodes saved in {args.out}; run the same command again to "
                    f"resume")
        return 143 if isinstance(e, _Terminated) else 130
    except (ValueError, TypeError, ConnectionError, ImportError) as e:
        a.fail(prog, e)
    finally:
        if signal.getsignal(signal.SIGTERM) is _on_sigterm:
            signal.signal(signal.SIGTERM, old)
    table = sw.aggregate(rows, bins=sw.bins_for(rows, width=args.bin_width))
    print(sw.format_table(table))
    print(f"\n{len(rows)} episodes in {args.out}")
    if args.figure:
        sw.figure(table, args.figure)
        print(f"figure {args.figure}")
    return 0


def _run(args, parser) -> int:
    from . import sim
    from .study import reproduce

    prog = "ibvs run"
    case = args.case or reproduce.DEFAULT_CASE[args.world]
    if case not in reproduce.CASES[args.world]:
        a.fail(prog, f"argument --case: {case} is not available for --world {args.world}; "
                            f"choose from {', '.join(sorted(reproduce.CASES[args.world]))}")
    custom = None
    if args.rotation_deg is not None:
        if case != "z-rotation":
            a.fail(prog, "argument --rotation-deg: only with --case z-rotation")
        custom = sim.cases.z_rotation(math.radians(args.rotation_deg))
    c = custom or reproduce.make_case(args.world, case)
    duration = args.duration if args.duration is not None else reproduce.DURATION[args.world]
    frames = round(duration * c.camera.fps)
    if args.latency >= frames:
        a.fail(prog, f"argument --latency: {args.latency} frames is not shorter than the episode "
                            f"({frames} frames)")
    if (args.depth or reproduce.DEPTH[args.world]) == "pose" and not c.target.planar:
        a.fail(prog, "argument --depth: pose needs a planar target")
    sensor = None
    if args.video and not args.vision:
        a.fail(prog, "argument --video: needs --vision dots or --vision tag")
    if args.vision:
        try:
            from . import vision
        except ImportError as e:
            a.fail(prog, f"argument --vision: {e}")
        try:
            sensor = vision.ImageSensor.for_target(vision.image_camera(c.camera), c.target, args.vision,
                                                   keep_frames=bool(args.video))
        except ValueError as e:
            a.fail(prog, f"argument --vision: {e}")
    case_obj, result = reproduce.run_one(args.world, case, args.scheme, duration=duration, noise=args.noise,
                                         latency=args.latency, seed=args.seed, gain=args.gain, depth=args.depth,
                                         tolerance=args.tolerance, case_object=c, angle_wrap=args.angle_wrap,
                                         vision=sensor)
    row = reproduce.summarise(args.world, case, args.scheme, result, args.angle_wrap)
    from .study.schemes import TITLES

    wrap = "" if row.angle_wrap == "-" else f", {row.angle_wrap} wrap"
    title = f"{case_obj.description}, {TITLES.get(args.scheme, args.scheme)}{wrap}"
    print(title)
    for name, value in zip(reproduce.Row.HEADERS[3:], row.cells()[3:]):
        if name != "paper":
            print(f"  {name:18s} {value}")
    if args.plot:
        from . import viz

        viz.episode(result, title=title).savefig(args.plot, dpi=90)
        print(f"  figure             {args.plot}")
    if args.animate:
        from . import viz

        n = viz.animate(result, args.animate, labels=[title], speed=args.speed)
        print(f"  animation          {args.animate} ({n} frames)")
    if args.video:
        from . import vision

        cam = sensor.renderer.camera
        pixels = result.history.measured
        desired = cam.project(result.uv_desired)
        written = vision.write_video(args.video, sensor.frames, pixels, desired, fps=cam.fps)
        print(f"  video              {written} ({len(sensor.frames)} frames)")
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
        from .study.reproduce import reproduce

        reproduce(args.out, quick=args.quick, angle_wrap=args.angle_wrap)
        return 0
    if args.command == "run":
        return _run(args, parser)
    if args.command == "sweep":
        return _sweep(args, parser)
    parser.print_help()
    return 0


if __name__ == "__main__":
    sys.exit(main())
