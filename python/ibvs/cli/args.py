"""Command-line argument checks: every bad argument is refused by the parser, before any work,
with exit status 2 and one line naming the option (`ibvs run: error: argument --duration: ...`);
every output path is tried for writing there; and the options that several commands share (their
help texts, --angle-wrap, --tolerance-px).

Output paths: every option of every command that names a file or directory to write is registered
with add_output(parser, "--flag", out_file(".csv") | out_dir | figure_file | animation_file, ...).
The parser then tries the path for writing before any work (one line naming the path and the reason,
exit status 2). tests/python/test_cli_outputs.py walks every command's parser (main.command_parsers)
and fails for an option that writes a path without add_output, and tries each registered one with
paths that cannot be written."""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from typing import NoReturn


class _Formatter(argparse.HelpFormatter):
    """argparse's formatter, except that the exit-status table (exit_status()) keeps its lines."""

    def _fill_text(self, text, width, indent):
        if text.startswith(EXIT_STATUS_TITLE):
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (no usage block): prog: error: message."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", _Formatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}\n")


# --------------------------------------------------------------------------- exit status

EXIT_STATUS_TITLE = "exit status:"
#: Exit statuses of every command (`ibvs` main turns an uncaught exception into 3, Ctrl-C into 130, SIGTERM
#: into 143); 0 and 1 are each command's own (exit_status()).
EXIT_2 = ("a bad argument, a missing optional extra, an output path that cannot be written, or a results file "
          "another process is writing: one line on stderr, before any work")
EXIT_3 = "an internal error (a bug): a traceback, then one line; please report it"
EXIT_130 = "interrupted (Ctrl-C, SIGINT)"
EXIT_143 = "terminated (SIGTERM)"
EXIT_141 = "the reader of the output went away (`ibvs ... | head -1`): quietly"


def exit_status(zero: str, one: str | None = None, interrupted: str = "") -> str:
    """The --help epilog of a command's exit statuses: `zero` and `one` (None: the command never
    exits 1) say what 0 and 1 mean for it; `interrupted` is added to 130 and 143."""
    import textwrap

    rows = [("0", zero)] + ([("1", one)] if one else []) + [
        ("2", EXIT_2), ("3", EXIT_3), ("130", EXIT_130 + interrupted), ("143", EXIT_143 + interrupted),
        ("141", EXIT_141)]
    lines = [EXIT_STATUS_TITLE]
    for code, text in rows:
        wrapped = textwrap.wrap(text, 100)
        lines.append(f"  {code:>3}  {wrapped[0]}")
        lines += [f"       {w}" for w in wrapped[1:]]
    return "\n".join(lines)


def number(lo: float, hi: float, *, open_lo: bool = False, integer: bool = False):
    """argparse type: a finite number (an integer with integer=True) in [lo, hi] ((lo, hi] with open_lo)."""

    def parse(text: str):
        try:
            x = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {'an integer' if integer else 'a number'}: {text!r}") from None
        if not math.isfinite(x) or x > hi or x < lo or (open_lo and x == lo):
            raise argparse.ArgumentTypeError(f"must be in {'(' if open_lo else '['}{lo:g}, {hi:g}], got {text}")
        return x

    parse.__name__ = "integer" if integer else "number"
    return parse


def _cannot_write(p: Path):
    """Why this process cannot write file p (None if it can): tried, not guessed from permission
    bits, which say yes to root everywhere and know nothing of read-only or virtual file systems
    (/proc, /sys). An existing file is opened for appending (not changed); a new one is created
    and removed again."""
    try:
        if p.exists():
            with open(p, "ab"):
                pass
        else:
            os.close(os.open(p, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            os.unlink(p)
    except OSError as e:
        return e.strerror or type(e).__name__
    return None


def _cannot_write_into(d: Path):
    """Why this process cannot create files in directory d (None if it can), by creating one."""
    import tempfile

    try:
        fd, name = tempfile.mkstemp(prefix=".ibvs-write-check-", dir=d)
        os.close(fd)
        os.unlink(name)
    except OSError as e:
        return e.strerror or type(e).__name__
    return None


def _output_type(parse, example: str):
    """Mark an argparse type as an output path's (add_output accepts only these); `example` is a name
    it accepts (the tests build bad paths from it)."""
    parse.output_example = example
    return parse


def out_file(*suffixes: str):
    """argparse type: a file this process can write (an existing writable file, or a new one in an
    existing writable directory), not a directory, ending in one of `suffixes` if given."""

    def parse(text: str) -> Path:
        p = Path(text)
        if not text or p.is_dir():
            raise argparse.ArgumentTypeError(f"{text!r} is a directory, not a file")
        if suffixes and p.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(f"{text!r} must end in {' or '.join(suffixes)}")
        parent = p.parent if str(p.parent) else Path(".")
        if not parent.exists():
            raise argparse.ArgumentTypeError(f"directory {str(parent)!r} does not exist")
        if not parent.is_dir():
            raise argparse.ArgumentTypeError(f"cannot write {text!r}: {str(parent)!r} is not a directory")
        why = _cannot_write(p)
        if why is not None:
            raise argparse.ArgumentTypeError(f"cannot write {text!r} ({why})")
        return p

    parse.__name__ = "file"
    return _output_type(parse, "out" + (suffixes[0] if suffixes else ".txt"))


def out_dir(text: str) -> Path:
    """argparse type: a directory to write into (created if missing, below a writable one)."""
    p = Path(text)
    if p.exists() and not p.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is a file, not a directory")
    existing = p
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise argparse.ArgumentTypeError(f"cannot write into {text!r}: {str(existing)!r} is not a directory")
    why = _cannot_write_into(existing)
    if why is not None:
        raise argparse.ArgumentTypeError(f"cannot write into {str(existing.absolute())!r} ({why})")
    return p


_output_type(out_dir, "out")


def in_file(text: str) -> Path:
    """argparse type: a readable file."""
    p = Path(text)
    if not p.is_file() or not os.access(p, os.R_OK):
        raise argparse.ArgumentTypeError(f"no readable file {text!r}")
    return p


def figure_file(text: str) -> Path:
    """argparse type: out_file() with an extension matplotlib can save (png, pdf, svg, ...);
    matplotlib must be installed."""
    try:
        from matplotlib.backend_bases import FigureCanvasBase
    except ImportError:
        raise argparse.ArgumentTypeError(f"figures need matplotlib (the plot extra): {install_line('plot')}") from None
    kinds = sorted(FigureCanvasBase.get_supported_filetypes())
    return out_file(*(f".{k}" for k in kinds))(text)


_output_type(figure_file, "out.png")


def animation_file(text: str) -> Path:
    """argparse type: out_file() ending in .gif or .mp4 (MP4 needs imageio-ffmpeg)."""
    p = out_file(".gif", ".mp4")(text)
    try:
        from matplotlib.backend_bases import FigureCanvasBase  # noqa: F401
    except ImportError:
        raise argparse.ArgumentTypeError(f"animations need matplotlib (the plot extra): {install_line('plot')}") \
            from None
    from ..viz.animation import check_path

    try:
        check_path(p)
    except (ImportError, ValueError) as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return p


_output_type(animation_file, "out.gif")


def add_output(parser, *flags: str, type, **kwargs) -> argparse.Action:
    """Add an option naming a path the command writes (--out, --plot, --record, --log, ...): `type` is one of
    the output types (out_file(*suffixes), out_dir, figure_file, animation_file), which try the path for
    writing when the arguments are parsed, before any work. Every output option of every command goes
    through here (test_cli_outputs.py checks it); kwargs are add_argument's (help, metavar, default...)."""
    if not hasattr(type, "output_example"):
        raise TypeError(f"add_output {flags}: type must be an output type of ibvs.cli.args (out_file(...), out_dir, "
                        f"figure_file, animation_file), got {type!r}")
    action = parser.add_argument(*flags, type=type, **kwargs)
    action.output = True
    return action


def is_output(action: argparse.Action) -> bool:
    """Whether an option was registered with add_output."""
    return getattr(action, "output", False) is True


def say(prog: str, message) -> None:
    """Print `prog: error: message` on stderr, as one line."""
    print(f"{prog}: error: {' '.join(str(message).split())}", file=sys.stderr)


def fail(prog: str, message) -> NoReturn:
    """A bad argument found after parsing: one line, then exit status 2 (as argparse's own errors)."""
    say(prog, message)
    raise SystemExit(2)


# --------------------------------------------------------------------------- optional extras

#: The optional modules a command may need -> the extra of pyproject.toml that installs them.
EXTRAS = {"matplotlib": "plot", "PIL": "plot", "imageio_ffmpeg": "video", "cv2": "vision", "dask": "distributed",
          "distributed": "distributed", "rosbags": "ros", "rerun": "rerun", "pinocchio": "robots",
          "example_robot_data": "robots"}


def install_line(extra: str) -> str:
    """How to install an extra, from a clone (ibvs is on no package index)."""
    return f'pip install ".[{extra}]" from the ibvs repository root'


def missing_extra(error: ImportError) -> str | None:
    """One line saying which extra to install, when `error` (or what caused it) is an optional module of
    EXTRAS that is not installed; None for any other ImportError (a bug, not a missing extra)."""
    e: BaseException | None = error
    while isinstance(e, ImportError):
        top = (e.name or "").split(".")[0]
        if top in EXTRAS:
            return f"{top} is not installed (the {EXTRAS[top]} extra): {install_line(EXTRAS[top])}"
        e = e.__cause__ or e.__context__
    text = " ".join(str(error).split())
    return text if 'pip install ".[' in text else None


def require(prog: str, module: str, what: str) -> None:
    """Exit 2 with one line unless `module` can be imported: `what` (e.g. "drawing the figures") needs it,
    which extra installs it and how: `ibvs reproduce: error: drawing the figures needs matplotlib, which is
    not installed (the plot extra): pip install ...`."""
    import importlib

    try:
        importlib.import_module(module)
    except ImportError as e:
        top = (e.name or module).split(".")[0]
        if top in EXTRAS:
            fail(prog, f"{what} needs {top}, which is not installed (the {EXTRAS[top]} extra): "
                       f"{install_line(EXTRAS[top])}")
        fail(prog, f"{what} needs {module}: {e}")


# --------------------------------------------------------------------------- options of several commands

NOISE_HELP = ("std of the Gaussian noise added to the measured image points, in the camera's measurement units: "
              "pixels for a pixel camera (gantry), normalised image units (1 = the focal length) for the free "
              "world's normalised camera (default 0)")
GOAL_POSE_HELP = ("goal pose of the PBVS, 2.5-D and moments schemes: taught (estimated from the goal's image as the "
                  "depth mode knows it) or given (the true one)")
DEPTH_HELP = ("depth the controller is given: exact (true depths), pose (from a planar pose estimate), desired "
              "(the constant goal depths) or estimated (online, per point, from the camera's motion)")
TOLERANCE_HELP = ("converged when the servo's feature-error norm is below this (normalised units; default 1e-5, "
                  "none with --tolerance-px alone)")
TOLERANCE_PX_HELP = ("converged when every measured point (as a tracker sees it) is within this distance of its goal, "
                     "in measurement units: pixels for a pixel camera, normalised units for the free world's camera; "
                     "with --tolerance too, both must hold")
#: The error-norm tolerance when neither --tolerance nor --tolerance-px is given.
DEFAULT_TOLERANCE = 1e-5


def tolerance_of(args, default=DEFAULT_TOLERANCE):
    """The error-norm tolerance of parsed arguments: --tolerance, else none with --tolerance-px
    (the pixels alone decide), else `default`."""
    if args.tolerance is not None:
        return args.tolerance
    return None if args.tolerance_px is not None else default
#: Largest seed (the simulator's noise generator takes a non-negative int64).
SEED_MAX = 2**63 - 1


def add_angle_wrap(parser, default) -> None:
    """The --angle-wrap option (default None: the scenario's)."""
    parser.add_argument("--angle-wrap", choices=["consistent", "per_point"], default=default,
                        help="theta errors wrapped as one rotation about their circular mean or each into "
                             "(-pi, pi] on its own, eq. (13) (default "
                             + (default or "the scenario's, else consistent") + ")")
