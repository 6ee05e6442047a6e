"""Command line: `ibvs` / `python -m ibvs`.

    ibvs reproduce [--out DIR] [--quick]          every experiment of the paper, figures and summary
    ibvs run --world W --scheme S --case C ...    one simulated episode (--plot, --animate)
    ibvs bench [...]                              control-step timings, bindings vs numpy
    ibvs sweep --out F.csv [--scenario S.toml]    thousands of episodes per scheme, aggregate tables
    ibvs compare --out DIR [--docs]               every law against the half-turn and the retreat, side by side
    ibvs wide --out DIR [--docs]                  a 220-degree fisheye: perspective against spherical features
    ibvs replay BAG --out twists.csv              a ROS 2 bag's images through a tracker and the servo
    ibvs servo CONFIG.toml [--dry-run]            the real-time servo loop: camera -> servo -> robot
    ibvs --cmake-dir                              where ibvsConfig.cmake is, for find_package(ibvs)

Every bad argument exits with status 2 and one line before any work starts (so does a missing optional
extra, naming it, and `ibvs` without a command, after its usage); every output path is registered with
args.add_output and tried for writing then (test_cli_outputs.py walks every command's parser to check it). A
sweep locks its CSV (ibvs.writer_lock): a second writer gets one line naming the holder's pid and status 2. An
interrupted command (Ctrl-C: 130, SIGTERM: 143) says so in one line; a sweep keeps every finished row and says how
to resume, as does a sweep whose Dask scheduler dies (exit status 1). An internal error (a bug) prints its
traceback and one line, status 3. Output into a closed pipe (`ibvs ... | head -1`) ends the command quietly with
status 141. Each command's --help ends with what its statuses mean (args.exit_status).

Modules: args (argument types, options shared by commands), run (`ibvs run`), sweep (`ibvs
sweep`), replay (`ibvs replay`); `ibvs reproduce` and `ibvs bench` hand over to ibvs.study.reproduce and ibvs.bench.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys

import ibvs

from . import args as a
from . import replay, run, servo, sweep


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command but `bench` (whose options go to ibvs.bench as they are)."""
    p = a.Parser(prog="ibvs", description="Image-based visual servoing: Cartesian, polar and hybrid.")
    p.add_argument("--version", action="version", version=f"ibvs {ibvs.__version__}")
    p.add_argument("--cmake-dir", action="store_true", help="print the directory holding ibvsConfig.cmake and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    r = sub.add_parser("reproduce", help="run every experiment of the paper; write figures and a summary",
                       description="Run every experiment of the paper (Figs. 1-8), write PNG figures, summary.md and "
                                   "summary.csv, and print the summary table.",
                       epilog=a.exit_status("every experiment ran; the figures and the summary are written"))
    a.add_output(r, "--out", type=a.out_dir, default="ibvs-results",  # a string: checked by out_dir too
                   help="output directory (default ./ibvs-results; created if missing)")
    r.add_argument("--quick", action="store_true", help="small, fast figures (for CI); the simulations are the same")
    a.add_angle_wrap(r, "consistent")

    run.add_parser(sub)
    sweep.add_parser(sub)
    replay.add_parser(sub)
    servo.add_parser(sub)

    sub.add_parser("compare", help="IBVS, IBVS-P, stacked, cylindrical, partitioned, moments, 2.5-D and PBVS side by "
                                   "side (python -m ibvs.study.compare --help)", add_help=False)
    sub.add_parser("wide", help="a 220-degree fisheye servoed on perspective and on spherical features "
                                "(python -m ibvs.study.wide --help)", add_help=False)
    b = sub.add_parser("bench", help="time the control step through the bindings next to numpy",
                       description="Time the control step through the bindings next to a numpy reference.",
                       epilog=a.exit_status("timed; the table (or the JSON line) printed"))
    b.add_argument("args", nargs="*", help="options of python -m ibvs.bench (see python -m ibvs.bench --help)")
    return p


#: The commands whose options another module parses (`ibvs CMD ...` hands over to module.main), and
#: the module whose build_parser() makes that parser.
HANDED_OVER = {"compare": "ibvs.study.compare", "wide": "ibvs.study.wide", "bench": "ibvs.bench"}


def command_parsers() -> dict[str, argparse.ArgumentParser]:
    """Every command's full parser, by name (those handed over included): what the tests walk to find
    every option (every output path must be registered with args.add_output)."""
    import importlib

    top = build_parser()
    sub = next(x for x in top._actions if isinstance(x, argparse._SubParsersAction))
    parsers = dict(sub.choices)
    for name, module in HANDED_OVER.items():
        mod = importlib.import_module(module)
        parsers[name] = mod.build_parser("ibvs bench") if name == "bench" else mod.build_parser()
    return parsers


def main(argv: list[str] | None = None) -> int:
    """Run the command line (sys.argv[1:] by default); returns the exit status.

    A command that needs an optional extra which is not installed says which (one line, status 2); a reader
    that stops reading (`ibvs ... | head -1`) ends the command quietly with status 141, as SIGPIPE would."""
    argv = sys.argv[1:] if argv is None else list(argv)
    command = argv[0] if argv[:1] and argv[0] in COMMANDS else ""
    prog = f"ibvs {command}".strip()
    try:  # SIGTERM as Ctrl-C, so that every command unwinds (closing its files) and exits 143
        old = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread: leave the signals alone
        old = None
    try:
        return _main(argv)
    except KeyboardInterrupt as e:
        terminated = isinstance(e, Terminated)
        a.say(prog, "terminated (SIGTERM)" if terminated else "interrupted")
        return 143 if terminated else 130
    except BrokenPipeError:
        # Nothing more can be written: send what Python would still flush to /dev/null, and say nothing.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
        return 141
    except ImportError as e:
        message = a.missing_extra(e)
        if message is None:
            raise
        a.say(prog, message)
        return 2
    except Exception:  # a bug: its traceback, then one line, and a status of its own (1 is a result for some)
        import traceback

        traceback.print_exc()
        a.say(prog, "internal error (the traceback above): please report it")
        return 3
    finally:
        if old is not None:
            signal.signal(signal.SIGTERM, old)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that a command stops as on Ctrl-C (exit status 143)."""


def _on_sigterm(signum, frame):
    raise Terminated()


#: The commands of the parser.
COMMANDS = ("reproduce", "run", "sweep", "replay", "compare", "wide", "servo", "bench")


def _main(argv: list[str]) -> int:
    if argv[:1] == ["bench"] and not {"-h", "--help"} & set(argv[1:2]):
        # Every option after `bench` belongs to python -m ibvs.bench (argparse's REMAINDER drops `--x`).
        from .. import bench

        return bench.main(argv[1:], prog="ibvs bench")
    if argv[:1] == ["compare"]:
        from ..study import compare

        return compare.main(argv[1:])
    if argv[:1] == ["wide"]:
        from ..study import wide

        return wide.main(argv[1:])
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.cmake_dir:
        print(ibvs.cmake_dir())
        return 0
    if args.command == "reproduce":
        a.require("ibvs reproduce", "matplotlib", "drawing the figures")
        from ..study.reproduce import reproduce

        reproduce(args.out, quick=args.quick, angle_wrap=args.angle_wrap)
        return 0
    if args.command == "run":
        return run.command(args)
    if args.command == "sweep":
        return sweep.command(args)
    if args.command == "replay":
        return replay.command(args)
    if args.command == "servo":
        return servo.command(args)
    # No command: what there is to run, on stderr, and the status of a usage error.
    parser.print_help(sys.stderr)
    a.say("ibvs", "a command is required (reproduce, run, sweep, replay, servo or bench), or --version or --cmake-dir")
    return 2
