"""`ibvs servo CONFIG.toml`: the servo loop (ibvs.loop) on a camera and a robot named in a config file.

The config is read and checked, the output paths are tried for writing, the robot driver is built and
connected and the source opened before the loop starts: any error there is one line
(`ibvs servo: error: ...`) and exit status 2, with the robot stopped and disconnected. The run ends
with the loop's outcome (ibvs.loop.servo_loop): 0 for a normal end (its duration, convergence, the end
of a video or bag), 1 for a stop on the watchdog, lost features or a robot failure (one line saying
what happened and where the log is), 130 / 143 for SIGINT / SIGTERM; the robot is stopped on every path.
"""

from __future__ import annotations

import argparse

from . import args as a

PROG = "ibvs servo"
#: What the exit statuses 0 and 1 mean for `ibvs servo` (its --help epilog and docs/conventions.md).
EXIT_0 = "a normal end (the duration, convergence, the end of a video or bag); the robot was stopped"
EXIT_1 = ("a safe stop: the watchdog (no frame or no robot state in time), lost features, a robot failure or an "
          "error in the loop; one line says what happened and where the log is")


def add_parser(sub) -> None:
    """The `servo` subcommand's parser."""
    s = sub.add_parser("servo", help="run the real-time servo loop of a config file (camera -> servo -> robot)",
                       description="Run the servo loop of a TOML config: frames from a camera, a video, a bag or "
                                   "the renderer, tracked, servoed and sent to a robot (ibvs.robot) at the camera's "
                                   "rate; timing printed at the end and logged. See docs/servo-loop.md.",
                       epilog=a.exit_status(EXIT_0, EXIT_1, "; the robot was stopped, then disconnected"))
    s.add_argument("config", type=a.in_file, metavar="CONFIG.toml", help="the loop's config (docs/servo.toml)")
    s.add_argument("--dry-run", action="store_true", help="compute and log the commands, send none (overrides "
                                                          "[loop] dry_run)")
    s.add_argument("--duration", type=a.number(0, 1e7, open_lo=True), metavar="S",
                   help="seconds to run (overrides [loop] duration)")
    # The config's [loop] log / record / rerun paths are checked by _check_outputs with the same out_file.
    a.add_output(s, "--log", type=a.out_file(".jsonl", ".json"), metavar="FILE.jsonl",
                 help="the per-frame log (overrides [loop] log)")
    a.add_output(s, "--record", type=a.out_file(".mcap"), metavar="RUN.mcap",
                 help="record the run as a ROS 2 bag (overrides [loop] record; the ros extra)")
    a.add_output(s, "--rerun", type=a.out_file(".rrd"), metavar="RUN.rrd",
                 help="record the run for Rerun (overrides [loop] rerun; the rerun extra)")


def _check_outputs(options) -> None:
    """Every output path of the config tried for writing before anything runs (one line, exit 2)."""
    # Output paths: the same check as the command line's out_file (ibvs.cli.args).
    for key, suffixes in (("log", (".jsonl", ".json")), ("record", (".mcap",)), ("rerun", (".rrd",))):
        path = getattr(options, key)
        if path is None:
            continue
        try:
            a.out_file(*suffixes)(str(path))
        except argparse.ArgumentTypeError as e:
            a.fail(PROG, f"[loop] {key}: {e}")


def command(args) -> int:
    """Run `ibvs servo`; the loop's exit status (see the module docstring)."""
    from ..loop.config import load
    from ..loop.setup import Setup

    try:
        cfg = load(args.config)
    except ValueError as e:
        a.fail(PROG, e)
    if args.dry_run:
        cfg.options.dry_run = True
    if args.duration is not None:
        cfg.options.duration = args.duration
    for key in ("log", "record", "rerun"):
        if getattr(args, key) is not None:
            setattr(cfg.options, key, getattr(args, key))
    _check_outputs(cfg.options)
    if cfg.options.record is not None:
        a.require(PROG, "rosbags", "[loop] record")
    if cfg.options.rerun is not None:
        a.require(PROG, "rerun", "[loop] rerun")
    try:
        setup = Setup(cfg)
    except (ValueError, TypeError, FileNotFoundError) as e:
        a.fail(PROG, e)
    except ImportError as e:
        a.fail(PROG, a.missing_extra(e) or e)
    try:
        setup.connect()
    except Exception as e:  # noqa: BLE001 - unreachable robot, missing device, bad bag: one line, stopped
        setup.close()
        a.fail(PROG, f"{cfg.robot_kind} robot / {cfg.doc['source']['kind']} source: {type(e).__name__}: {e}")
    loop = setup.loop(signals=True)
    try:
        report = loop.run()
    except Exception as e:  # noqa: BLE001 - the loop stopped the robot before re-raising
        log = f"; log {cfg.options.log}" if cfg.options.log else ""
        a.say(PROG, f"stopped the robot on an error in the loop: {type(e).__name__}: {e}{log}")
        return 1
    print(report.timing.text())
    if cfg.options.dry_run:
        print(f"dry run: {report.frames} commands computed and logged, none sent")
    if report.status != 0:
        a.say(PROG, f"{report.outcome}: {report.reason}; the robot was stopped"
                    + (f"; log {report.log}" if report.log else ""))
    else:
        print(f"{report.outcome}: {report.reason}" + (f"; log {report.log}" if report.log else ""))
    return report.status
