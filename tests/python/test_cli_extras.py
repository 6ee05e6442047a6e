"""The command line without an optional extra, and at its other edges: a command that needs an extra which is
not installed says in one line which extra to install from a clone (`pip install ".[plot]"`), with exit status
2 and no traceback, before any work; a reader that closes the pipe (`ibvs ... | head -1`) ends it quietly; `ibvs`
without a command exits 2 with its usage. A missing extra is simulated in a process of its own by an import hook
that refuses the extra's modules, as a Python without them would."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import ibvs

ENV = {**os.environ, "PYTHONPATH": str(Path(ibvs.__file__).parents[1])}  # this ibvs, from any directory
WITHOUT = """
import importlib.abc, sys
class Without(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {blocked!r}:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        return None
sys.meta_path.insert(0, Without())
from ibvs.cli.main import main
sys.exit(main({argv!r}))
"""


def _without(blocked: set[str], argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    code = WITHOUT.format(blocked=sorted(blocked), argv=argv)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=cwd, env=ENV)


CASES = [
    ("plot", {"matplotlib", "PIL"}, ["reproduce", "--out", "results", "--quick"]),
    ("plot", {"matplotlib", "PIL"}, ["run", "--plot", "run.png"]),
    ("plot", {"matplotlib", "PIL"}, ["sweep", "--out", "s.csv", "--episodes", "1", "--figure", "s.png"]),
    ("vision", {"cv2"}, ["run", "--world", "gantry", "--vision", "dots"]),
    ("distributed", {"dask", "distributed"},
     ["sweep", "--out", "s.csv", "--episodes", "1", "--scheduler", "tcp://127.0.0.1:9"]),
    ("ros", {"rosbags"}, ["run", "--record", "run.mcap"]),
    ("rerun", {"rerun"}, ["run", "--rerun", "run.rrd"]),
    ("robots", {"pinocchio", "example_robot_data"}, ["run", "--world", "arm"]),
]


@pytest.mark.parametrize("extra, blocked, argv", CASES, ids=[f"{c[0]}-{c[2][0]}" for c in CASES])
def test_a_missing_extra_is_one_line_naming_it(tmp_path, extra, blocked, argv):
    r = _without(blocked, argv, tmp_path)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr[-3000:]
    assert len(lines) == 1 and lines[0].startswith(f"ibvs {argv[0]}: error: "), r.stderr
    assert f'pip install ".[{extra}]"' in lines[0], lines[0]
    assert list(tmp_path.iterdir()) == [], "work started before the extra was found missing"


def test_other_import_errors_are_not_hidden(tmp_path):
    """A module of ibvs that fails to import is a bug: its traceback stays (no extra to name)."""
    from ibvs.cli import args

    assert args.missing_extra(ModuleNotFoundError("No module named 'ibvs.nothing'", name="ibvs.nothing")) is None
    try:
        try:
            import matplotlib_not_a_module  # noqa: F401
        except ImportError as inner:
            inner.name = "matplotlib"  # as a missing matplotlib would say
            raise ImportError("figures cannot be drawn") from inner
    except ImportError as e:
        assert args.missing_extra(e).endswith('pip install ".[plot]" from the ibvs repository root')


def test_no_command_exits_2_with_the_usage():
    r = subprocess.run([sys.executable, "-m", "ibvs"], capture_output=True, text=True, timeout=120, env=ENV)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.startswith("usage: ibvs") and "a command is required" in r.stderr.splitlines()[-1]


def test_a_closed_pipe_ends_the_command_quietly():
    """`ibvs run | head -1` where head has gone before ibvs writes (`true` reads nothing and exits at once, so the
    first write meets a closed pipe): the command stops without a traceback, with SIGPIPE's status."""
    cmd = f"{sys.executable} -m ibvs run --world free --case z-rotation --scheme polar | true"
    r = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], capture_output=True, text=True, timeout=300, env=ENV)
    assert r.stderr == "", r.stderr[-3000:]
    assert r.returncode == 141  # 128 + SIGPIPE, as shell tools that meet a closed pipe end
    cmd = cmd.replace("| true", "| head -1")  # a reader that stays for a line: all of the output fits in the pipe
    r = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], capture_output=True, text=True, timeout=300, env=ENV)
    assert len(r.stdout.splitlines()) == 1 and r.stderr == "" and r.returncode in (0, 141), r.stderr[-3000:]
