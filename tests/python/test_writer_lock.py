"""One writer per results file (ibvs.writer_lock): a sweep holds an exclusive lock on its CSV for its whole run;
a second writer, started while the first runs (local workers or the Dask back end), gets one line naming the
file and the holder's pid and exit status 2, and writes nothing; a sweep killed with SIGKILL leaves no lock that
stops the next run, which resumes the file without a lost or a duplicated row."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import ibvs.study.sweep as sw
from ibvs.writer_lock import WriterBusy, lock_path, one_writer

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="the processes are driven with POSIX signals")

ARGS = ["--duration", "1", "--schemes", "polar", "--seed", "3", "--quiet"]


def _sweep(out: Path, episodes: int, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "ibvs", "sweep", "--out", str(out), "--episodes", str(episodes),
                             *ARGS, *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for(condition, proc: subprocess.Popen, what: str, timeout: float = 120.0, poll: float = 0.05) -> None:
    """Poll until condition() (a generous timeout: the machine may be loaded; not a timing test)."""
    deadline = time.monotonic() + timeout
    while not condition():
        if proc.poll() is not None:
            pytest.fail(f"the first sweep ended (status {proc.returncode}) before {what}: {proc.stderr.read()}")
        if time.monotonic() > deadline:
            proc.kill()
            pytest.fail(f"no {what} within {timeout:g} s")
        time.sleep(poll)


def _holds_lock(out: Path, pid: int):
    def check() -> bool:
        try:
            return lock_path(out).read_text().split() == [str(pid)]
        except FileNotFoundError:
            return False
    return check


def _rows(out: Path) -> int:
    return max(0, len(out.read_text().splitlines()) - 1) if out.exists() else 0


def _second_writer_refused(out: Path, holder: int) -> None:
    before = out.read_bytes() if out.exists() else b""
    r = subprocess.run([sys.executable, "-m", "ibvs", "sweep", "--out", str(out), "--episodes", "5", *ARGS],
                       capture_output=True, text=True, timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert lines[0].startswith("ibvs sweep: error: ") and str(out) in lines[0] and f"process {holder}" in lines[0]
    assert r.stdout == ""
    after = out.read_bytes()
    assert after.startswith(before)  # the first writer's rows only (it may have appended more meanwhile)


def _stop(proc: subprocess.Popen) -> None:
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)  # waits, reads and closes the pipes
    assert proc.returncode == 143, err


def test_a_second_writer_is_refused_while_a_local_sweep_runs(tmp_path):
    out = tmp_path / "same.csv"
    first = _sweep(out, 100000, "--jobs", "2")
    try:
        _wait_for(_holds_lock(out, first.pid), first, "lock")
        _second_writer_refused(out, first.pid)
    finally:
        _stop(first)
    assert not lock_path(out).exists()  # released and removed
    ids = [r["id"] for r in sw.load(out)]
    assert len(ids) == len(set(ids))


DASK_SWEEP = """
import sys
from distributed import Client, LocalCluster
import ibvs.study.sweep as sw
with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \\
        Client(cluster) as client:
    sw.sweep(sys.argv[1], episodes=100000, duration=1.0, schemes=["polar"], seed=3, scheduler=client, progress=False)
"""


def test_a_second_writer_is_refused_while_a_dask_sweep_runs(tmp_path):
    pytest.importorskip("distributed", reason="the Dask back end needs the distributed extra")
    out = tmp_path / "same.csv"
    first = subprocess.Popen([sys.executable, "-c", DASK_SWEEP, str(out)], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        _wait_for(_holds_lock(out, first.pid), first, "lock")
        _wait_for(lambda: _rows(out) >= 2, first, "rows")  # the Dask back end is writing
        _second_writer_refused(out, first.pid)
    finally:
        first.kill()
        first.communicate(timeout=60)
    ids = [r["id"] for r in sw.load(out)]
    assert len(ids) == len(set(ids))


def test_sigkill_mid_sweep_then_resume_loses_and_duplicates_nothing(tmp_path):
    out = tmp_path / "killed.csv"
    # One episode per task and enough of them (~1 s of work) that the kill lands mid-run even when this process is
    # starved on a loaded machine (160 episodes in batches of 20 once all finished before the kill in CI).
    episodes = 600
    first = _sweep(out, episodes, "--jobs", "2", "--batch", "1")
    _wait_for(lambda: _rows(out) >= 10, first, "rows", poll=0.005)
    first.send_signal(signal.SIGKILL)
    first.communicate(timeout=60)
    assert lock_path(out).exists()  # left behind by the killed process, with its pid: no obstacle
    killed_at = _rows(out)
    again = subprocess.run([sys.executable, "-m", "ibvs", "sweep", "--out", str(out), "--episodes", str(episodes),
                            *ARGS, "--jobs", "2"], capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert f"{episodes} episodes ({episodes} rows" in again.stdout
    assert not lock_path(out).exists()
    rows = sw.load(out)
    ids = [r["id"] for r in rows]
    assert len(ids) == len(set(ids)) == episodes and killed_at < episodes
    lines = out.read_text().splitlines()
    assert len(lines) == episodes + 1  # no duplicated line, no torn one kept
    whole = sw.sweep(None, episodes=episodes, duration=1.0, schemes=["polar"], seed=3, jobs=1, progress=False)
    assert repr(rows) == repr(whole)  # the same rows as an uninterrupted run


def test_one_writer_in_process(tmp_path):
    out = tmp_path / "x.csv"
    with one_writer(out) as lock:
        assert lock.read_text().split() == [str(os.getpid())]
        child = subprocess.run([sys.executable, "-c", "import sys\nfrom ibvs.writer_lock import one_writer\n"
                                "try:\n    with one_writer(sys.argv[1]): pass\nexcept Exception as e: print(e)",
                                str(out)], capture_output=True, text=True, timeout=60)
        assert f"{out} is being written by process {os.getpid()}" in child.stdout, child
    assert not lock.exists()
    with one_writer(out):  # free again
        pass
    (tmp_path / "stale.csv.lock").write_text("999999999\n")  # a killed holder's sidecar: no lock on it
    with one_writer(tmp_path / "stale.csv") as lock:
        assert lock.read_text().split() == [str(os.getpid())]
    assert issubclass(WriterBusy, RuntimeError)
