"""docs/sweeps.md's cluster recipe, as written: `dask scheduler`, two `dask worker`s, and
`ibvs sweep --scenario ... --scheduler ...`, whose rows equal a local run's; a scheduler killed mid-sweep
(one line, exit 1, the CSV resumes) and a worker killed mid-sweep (nothing lost)."""

from __future__ import annotations

import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import ibvs.study.sweep as sw

pytest.importorskip("distributed")
ROOT = Path(__file__).resolve().parents[2]


def _dask() -> str:
    exe = Path(sys.executable).parent / "dask"
    found = str(exe) if exe.exists() else shutil.which("dask")
    if found is None:
        pytest.fail("the dask command is missing: pip install '.[distributed]'")
    return found


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_docs_cluster_recipe(tmp_path):
    docs = (ROOT / "docs" / "sweeps.md").read_text()
    for command in ("dask scheduler --host 127.0.0.1 --port 8786", "dask worker tcp://127.0.0.1:8786 --nthreads 1",
                    "ibvs sweep --scenario docs/scenario.toml --out mine.csv --scheduler tcp://127.0.0.1:8786"):
        assert command in docs
    port = _free_port()  # the docs' 8786, unless taken
    address = f"tcp://127.0.0.1:{port}"
    dask = _dask()
    # All three start at once: the workers retry until the scheduler listens, and the sweep's tasks wait
    # for the workers.
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        procs += [subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--no-dashboard"], cwd=ROOT,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for _ in range(2)]
        from distributed import Client

        with Client(address, timeout=60):  # the scheduler listens
            pass
        args = ["--scenario", "docs/scenario.toml", "--episodes", "4", "--duration", "2", "--schemes", "polar",
                "cartesian", "--quiet"]
        remote = subprocess.run([sys.executable, "-m", "ibvs", "sweep", *args, "--out", str(tmp_path / "mine.csv"),
                                 "--scheduler", address], cwd=ROOT, capture_output=True, text=True, timeout=120)
        assert remote.returncode == 0, remote.stderr
        assert "4 episodes (8 rows: 2 schemes each)" in remote.stdout
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:  # a worker slow to leave (a loaded machine): killed, and reaped
                p.kill()
                p.wait()
    local = sw.sweep(None, scenario=ROOT / "docs" / "scenario.toml", episodes=4, duration=2.0,
                     schemes=["polar", "cartesian"], jobs=1, progress=False)
    assert repr(sw.load(tmp_path / "mine.csv")) == repr(sorted(local, key=lambda r: (r["config"], r["index"], r["scheme"])))


def _start_cluster(dask: str, port: int, workers: int) -> list:
    address = f"tcp://127.0.0.1:{port}"
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    procs += [subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--no-dashboard"], cwd=ROOT,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for _ in range(workers)]
    from distributed import Client

    with Client(address, timeout=60) as c:  # the scheduler listens and the workers have joined
        c.wait_for_workers(workers, timeout=60)
    return procs


def _stop(procs: list) -> None:
    for p in procs:
        if p.poll() is None:
            p.terminate()
    for p in procs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


SWEEP = ["--episodes", "300", "--duration", "4", "--schemes", "polar", "cartesian", "--batch", "2", "--quiet"]


def _sweep_until(out: Path, address: str, rows: int) -> subprocess.Popen:
    """An `ibvs sweep --scheduler` in a process of its own, returned once its CSV holds `rows` rows."""
    p = subprocess.Popen([sys.executable, "-m", "ibvs", "sweep", *SWEEP, "--out", str(out), "--scheduler", address],
                         cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and p.poll() is None and (not out.exists() or
                                                                out.read_text().count("\n") < rows + 1):
        time.sleep(0.05)
    assert p.poll() is None, p.communicate()
    return p


def _local(out: Path) -> list:
    return sw.sweep(out, episodes=300, duration=4.0, schemes=["polar", "cartesian"], jobs=1, progress=False)


def test_a_dead_scheduler_ends_the_sweep_with_one_line_and_it_resumes(tmp_path):
    """A real scheduler process killed (SIGKILL) mid-sweep: the sweep ends with one line saying how many
    episodes are saved and how to resume, exit status 1, no traceback; the CSV resumes without loss."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = _start_cluster(_dask(), port, 1)
    out = tmp_path / "s.csv"
    try:
        p = _sweep_until(out, address, 20)
        procs[0].kill()  # the scheduler
        t0 = time.monotonic()
        _, err = p.communicate(timeout=60)
        elapsed = time.monotonic() - t0
    finally:
        _stop(procs)
    assert elapsed < 30, elapsed
    lines = err.strip().splitlines()
    assert p.returncode == 1 and len(lines) == 1 and "Traceback" not in err, err
    saved = sw.load(out)
    complete = sum(1 for i in {r["index"] for r in saved} if sum(r["index"] == i for r in saved) == 2)
    assert lines[0].startswith(f"ibvs sweep: error: scheduler: lost the Dask scheduler at {address}"), lines[0]
    assert (f"{complete} of 300 episodes ({len(saved)} of 600 rows: 2 schemes each) saved in {out}; start a "
            "scheduler (and its workers) and run the same command again to resume") in lines[0], lines[0]
    assert 20 <= len(saved) < 600 and out.read_text().endswith("\n")
    ids = [r["id"] for r in saved]
    rows = _local(out)  # resume (here on local processes: the rows are the same)
    assert len(rows) == 600 and {r["id"] for r in rows} >= set(ids)
    again = [r["id"] for r in sw.load(out)]
    assert len(again) == len(set(again)) == 600


def test_a_killed_worker_loses_nothing(tmp_path):
    """One of two Dask workers killed mid-sweep: the scheduler hands its tasks to the other and the sweep ends
    normally with every row, the same as a local run's."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = _start_cluster(_dask(), port, 2)
    out = tmp_path / "s.csv"
    try:
        p = _sweep_until(out, address, 20)
        procs[1].kill()
        stdout, err = p.communicate(timeout=300)
    finally:
        _stop(procs)
    assert p.returncode == 0, err
    assert "300 episodes (600 rows: 2 schemes each)" in stdout
    saved = sw.load(out)
    assert len(saved) == len({r["id"] for r in saved}) == 600
    assert repr(saved) == repr(sw.load(tmp_path / "local.csv") or _local(tmp_path / "local.csv"))
