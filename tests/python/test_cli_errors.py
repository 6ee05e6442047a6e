"""The command line's edges: every bad argument exits 2 with one line before any work; every
scheme and depth mode runs; a sweep stops on SIGINT / SIGTERM within a second with its workers
gone and its CSV consistent, and resumes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import ibvs.study.sweep as sw
from ibvs.cli.main import main
from ibvs.study.schemes import DENSE, SCHEMES, VISION

pytest.importorskip("matplotlib")
EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "scenario.toml"


def _bad(tmp_path) -> list:
    d = tmp_path
    (d / "file.txt").write_text("x")
    (d / "sub").mkdir(exist_ok=True)
    (d / "bad.toml").write_text("[camera]\nfocal = 3\n[target]\nfrom = \"paper\"\n[goal]\n")
    out = str(d / "s.csv")
    return [
        (["run", "--duration", "1e300"], "--duration"),
        (["run", "--duration", "nan"], "--duration"),
        (["run", "--duration", "0"], "--duration"),
        (["run", "--latency", "5000"], "--latency"),
        (["run", "--latency", "600", "--duration", "10"], "--latency"),
        (["run", "--latency", "-1"], "--latency"),
        (["run", "--gain", "inf"], "--gain"),
        (["run", "--gain", "1e300"], "--gain"),
        (["run", "--noise", "1e300"], "--noise"),
        (["run", "--seed", str(2**64)], "--seed"),
        (["run", "--tolerance", "-1"], "--tolerance"),
        (["run", "--rotation-deg", "1e9"], "--rotation-deg"),
        (["run", "--rotation-deg", "30", "--case", "general"], "--rotation-deg"),
        (["run", "--world", "gantry", "--case", "z-rotation"], "--case"),
        (["run", "--world", "free", "--case", "joint-limit"], "--case"),
        (["run", "--plot", str(d / "missing" / "run.png")], "--plot"),
        (["run", "--plot", str(d / "sub")], "--plot"),
        (["run", "--plot", str(d / "run.xyz")], "--plot"),
        (["run", "--animate", str(d / "run.avi")], "--animate"),
        (["run", "--animate", str(d / "missing" / "run.gif")], "--animate"),
        (["run", "--speed", "0"], "--speed"),
        (["run", "--depth", "guess"], "--depth"),
        (["run", "--goal-pose", "measured"], "--goal-pose"),
        (["sweep", "--out", str(d / "sub")], "--out"),
        (["sweep", "--out", str(d / "missing" / "s.csv")], "--out"),
        (["sweep", "--out", str(d / "file.txt")], "out"),  # not an ibvs sweep file
        (["sweep", "--out", out, "--bin-width", "1e-300"], "--bin-width"),
        (["sweep", "--out", out, "--episodes", "1e12"], "--episodes"),
        (["sweep", "--out", out, "--episodes", str(10**9)], "--episodes"),
        (["sweep", "--out", out, "--jobs", "100000"], "--jobs"),
        (["sweep", "--out", out, "--seed", "-1"], "--seed"),
        (["sweep", "--out", out, "--gain", "inf"], "--gain"),
        (["sweep", "--out", out, "--duration", "1e300"], "--duration"),
        (["sweep", "--out", out, "--range", "tz=0:1e300"], "tz"),
        (["sweep", "--out", out, "--range", "latency=0:0.5"], "latency"),
        (["sweep", "--out", out, "--range", "latency=0:5000"], "latency"),
        (["sweep", "--out", out, "--grid", "rz_deg=1e300"], "rz_deg"),
        (["sweep", "--out", out, "--range", "noise=0:1", "--grid", "tx=0"], "--grid"),
        (["sweep", "--out", out, "--scenario", str(d / "nope.toml")], "--scenario"),
        (["sweep", "--out", out, "--scenario", str(d / "bad.toml")], "[camera]"),
        (["sweep", "--out", out, "--scenario", str(EXAMPLE), "--world", "free"], "--world"),
        (["sweep", "--out", out, "--scenario", str(EXAMPLE), "--depth", "pose"], "planar"),
        (["sweep", "--out", out, "--goal-pose", "Given"], "--goal-pose"),
        (["sweep", "--out", out, "--figure", str(d / "missing" / "f.png")], "--figure"),
        (["sweep", "--out", out, "--schemes", "spherical"], "--schemes"),
        (["sweep", "--out", out, "--scheduler", "no-port"], "scheduler"),
        (["sweep", "--out", out, "--scheduler", ""], "scheduler"),
        (["bench", "--gain", "inf"], "--gain"),
        (["bench", "--iterations", "0"], "--iterations"),
        (["bench", "--n", "1e9"], "--n"),
        (["bench", "--damping", "nan"], "--damping"),
        (["reproduce", "--out", str(d / "file.txt")], "--out"),
        (["reproduce", "--out", str(d / "file.txt" / "below")], "--out"),
        (["run", "--tolerance-px", "0"], "--tolerance-px"),
        (["run", "--tolerance-px", "nan"], "--tolerance-px"),
        (["sweep", "--out", out, "--tolerance-px", "-1"], "--tolerance-px"),
        # output paths this process cannot write, whatever the permission bits say (root included): tried
        *[(args, option) for args, option in _unwritable()],
    ]


# Places no process can write into: /proc and /sys refuse new files, even to root (permission bits would not
# tell: os.access says yes to root everywhere).
UNWRITABLE = [p for p in ("/proc", "/sys") if Path(p).is_dir()]


def _unwritable() -> list:
    out = []
    for place in UNWRITABLE:
        out += [
            (["sweep", "--out", f"{place}/ibvs.csv"], "--out"),
            (["sweep", "--out", "s.csv", "--figure", f"{place}/ibvs.png"], "--figure"),
            (["reproduce", "--out", f"{place}/ibvs-results"], "--out"),
            (["reproduce", "--out", f"{place}/ibvs/results/deeper"], "--out"),
            (["run", "--plot", f"{place}/ibvs.png"], "--plot"),
            (["run", "--animate", f"{place}/ibvs.gif"], "--animate"),
            (["run", "--video", f"{place}/ibvs.gif", "--vision", "dots"], "--video"),
            (["run", "--record", f"{place}/ibvs.mcap"], "--record"),
            (["run", "--rerun", f"{place}/ibvs.rrd"], "--rerun"),
            (["replay", "/", "--out", f"{place}/ibvs.csv"], "--out"),
            (["replay", "/", "--out", "t.csv", "--bag-out", f"{place}/ibvs.mcap"], "--bag-out"),
        ]
    return out


def test_every_bad_argument_exits_2_with_one_line_before_any_work(tmp_path, capsys):
    for args, word in _bad(tmp_path):
        before = sorted(p.name for p in tmp_path.rglob("*"))
        try:
            rc = main(args)
        except SystemExit as e:
            rc = e.code
        out, err = capsys.readouterr()
        lines = err.strip().splitlines()
        assert rc == 2, (args, rc, err)
        assert len(lines) == 1 and word in lines[0] and "error" in lines[0], (args, err)
        assert out == "", args
        assert sorted(p.name for p in tmp_path.rglob("*")) == before, args  # nothing written


@pytest.mark.skipif(not UNWRITABLE, reason="needs /proc or /sys")
def test_unwritable_outputs_exit_2_with_one_line_through_the_command(tmp_path):
    """The same through `python -m ibvs` (a process of its own): the option named, no traceback, exit 2."""
    import ibvs

    env = {**os.environ, "PYTHONPATH": str(Path(ibvs.__file__).parents[1])}  # this ibvs, from any directory
    for args, option in _unwritable()[:4] + [(["reproduce"], "--out")]:
        cwd = tmp_path
        if args == ["reproduce"]:  # the default ./ibvs-results, in a directory nobody can write into
            cwd = Path(UNWRITABLE[0])
        r = _cli(*args, cwd=cwd, env=env)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and option in lines[0] and "Traceback" not in r.stderr, \
            (args, r.stderr)
        assert "cannot write" in lines[0], lines[0]


def _cli(*args, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ibvs", *args], capture_output=True, text=True, timeout=120, **kw)


def test_unreachable_scheduler_fails_fast_with_one_line(tmp_path):
    t0 = time.monotonic()
    r = _cli("sweep", "--out", str(tmp_path / "s.csv"), "--episodes", "1", "--quiet",
             "--scheduler", "tcp://127.0.0.1:9")
    assert time.monotonic() - t0 < 15
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "scheduler" in r.stderr and "127.0.0.1:9" in r.stderr


# the schemes measured in rendered images (klt, keypoints, photometric...) have their own episodes
# (tests/python/test_vision_loop.py): photometric servoing does not reach the goal from 60 degrees
@pytest.mark.parametrize("scheme", [s for s in SCHEMES if not s.startswith("moments") and s not in VISION
                                    and s not in DENSE])
def test_run_every_scheme(scheme, capsys):
    rc = main(["run", "--scheme", scheme, "--rotation-deg", "60", "--duration", "15"])
    out = capsys.readouterr().out
    assert rc == 0 and "converged" in out, out


def test_run_moments_on_the_square_is_refused(capsys):
    """The paper's square is centrally symmetric: no image-moments orientation (docs/compare.md)."""
    with pytest.raises(SystemExit) as e:
        main(["run", "--scheme", "moments"])
    assert e.value.code == 2 and "centrally symmetric" in capsys.readouterr().err


def test_run_options(tmp_path, capsys):
    # the gantry world picks a gantry case; the online depth estimate; the tolerance
    assert main(["run", "--world", "gantry", "--scheme", "cartesian", "--depth", "estimated",
                 "--tolerance", "1e-4"]) == 0
    out = capsys.readouterr().out
    assert "general motion on the gantry" in out and "converged" in out
    assert main(["run", "--rotation-deg", "90", "--scheme", "partitioned", "--duration", "20",
                 "--animate", str(tmp_path / "r.gif"), "--speed", "10", "--plot", str(tmp_path / "r.svg")]) == 0
    out = capsys.readouterr().out
    assert "1.5708 rad" in out and "frames)" in out
    assert (tmp_path / "r.gif").stat().st_size > 1000 and (tmp_path / "r.svg").stat().st_size > 1000
    helptext = _cli("run", "--help").stdout
    assert "pixels for a pixel camera" in " ".join(helptext.split()) and "estimated" in helptext


def test_sweep_scenario_cli(tmp_path, capsys):
    out = tmp_path / "s.csv"
    assert main(["sweep", "--scenario", str(EXAMPLE), "--out", str(out), "--episodes", "2", "--duration", "3",
                 "--schemes", "polar", "cylindrical", "automatic", "--jobs", "1", "--quiet",
                 "--figure", str(tmp_path / "f.png")]) == 0
    text = capsys.readouterr().out
    assert "| automatic |" in text and "timeout" in text.splitlines()[0]
    assert "2 episodes (6 rows: 3 schemes each)" in text and "converged: error norm < 0.005" in text
    assert (tmp_path / "f.png").stat().st_size > 10_000


def _children(pid: int) -> list:
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(x) for x in path.read_text().split()] if path.exists() else []


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    return stat.exists() and stat.read_text().split()[2] != "Z"


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs /proc to see the worker processes")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_signal_stops_a_sweep_within_a_second(tmp_path, sig):
    out = tmp_path / "s.csv"
    args = ["sweep", "--out", str(out), "--episodes", "3000", "--duration", "10", "--jobs", "2", "--batch", "5",
            "--schemes", "polar", "cartesian", "--quiet"]
    # SIGINT as a terminal delivers it: a shell's background job (how CI may run us) inherits it ignored
    p = subprocess.Popen([sys.executable, "-m", "ibvs", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and (not out.exists() or out.read_text().count("\n") < 12):
            time.sleep(0.05)
        workers = _children(p.pid)
        assert len(workers) >= 2 and p.poll() is None
        t0 = time.monotonic()
        p.send_signal(sig)
        _, err = p.communicate(timeout=10)
        elapsed = time.monotonic() - t0
    finally:  # a hung sweep must not outlive the test; its workers notice within a second and exit
        if p.poll() is None:
            p.kill()
            p.communicate(timeout=30)
    assert elapsed < 1.0, elapsed
    assert p.returncode == (130 if sig == signal.SIGINT else 143)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and " saved in " in lines[0] and "run the same command again" in lines[0], err
    assert not any(_alive(w) for w in workers)
    saved = sw.load(out)
    # counted as asked for: episodes (start set-ups), and the rows they are (one per scheme)
    done = sum(1 for i in {r["index"] for r in saved} if sum(r["index"] == i for r in saved) == 2)
    assert f"{done} of 3000 episodes ({len(saved)} of 6000 rows: 2 schemes each) saved" in lines[0], lines[0]
    ids = [r["id"] for r in saved]
    assert len(ids) == len(set(ids)) and out.read_text().endswith("\n")
    # resuming runs the missing episodes first, and only them
    more = sw.sweep(out, episodes=3000, duration=10.0, schemes=["polar", "cartesian"], jobs=1, limit=10,
                    progress=False)
    again = [r["id"] for r in sw.load(out)]
    assert len(again) == len(set(again)) == len(ids) + 10 and set(ids) < set(again)
    assert len(more) == len(ids) + 10


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs /proc to see the worker processes")
def test_workers_exit_when_the_sweep_is_killed(tmp_path):
    """SIGKILL leaves the sweep no time to stop its workers: they notice that their parent is gone and exit
    (within a second, after their batch) instead of running on, holding the caller's pipes."""
    out = tmp_path / "s.csv"
    args = ["sweep", "--out", str(out), "--episodes", "3000", "--duration", "10", "--jobs", "2", "--batch", "5",
            "--schemes", "polar", "cartesian", "--quiet"]
    p = subprocess.Popen([sys.executable, "-m", "ibvs", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and (not out.exists() or out.read_text().count("\n") < 12):
        time.sleep(0.05)
    workers = _children(p.pid)
    assert len(workers) >= 2
    t0 = time.monotonic()
    p.kill()
    p.communicate(timeout=30)  # returns when the last holder of its stdout and stderr, the workers, is gone
    assert time.monotonic() - t0 < 5.0
    time.sleep(0.1)
    assert not any(_alive(w) for w in workers)

