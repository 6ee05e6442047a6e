"""docs/sweeps.md's cluster recipe, as written: `dask scheduler`, two `dask worker`s, and
`ibvs sweep --scenario ... --scheduler ...`, whose rows equal a local run's."""

from __future__ import annotations

import shutil
import socket
import subprocess
import sys
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
        assert "8 episodes" in remote.stdout
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
    local = sw.sweep(None, scenario=ROOT / "docs" / "scenario.toml", episodes=4, duration=2.0,
                     schemes=["polar", "cartesian"], jobs=1, progress=False)
    assert repr(sw.load(tmp_path / "mine.csv")) == repr(sorted(local, key=lambda r: (r["config"], r["index"], r["scheme"])))
