"""Smoke tests of the benchmarks: they run, print what they promise, and the
numpy reference agrees with the C++ step. No timing assertion anywhere."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import ibvs
import numpy as np
import pytest
from ibvs import bench

ROOT = Path(__file__).resolve().parents[2]


def _ibvs_bench() -> str | None:
    """ibvs-bench on PATH (pip install .), next to the interpreter, or in a build tree."""
    found = shutil.which("ibvs-bench")
    if found:
        return found
    beside = Path(sys.executable).parent / "ibvs-bench"
    if beside.is_file():
        return str(beside)
    candidates = sorted((ROOT / "build").glob("**/bench/ibvs-bench"), key=lambda p: p.stat().st_mtime)
    return str(candidates[-1]) if candidates else None


@pytest.mark.parametrize("kind", bench.LAYOUTS)
@pytest.mark.parametrize("n", [4, 7])
def test_numpy_step_matches_servo(kind: str, n: int) -> None:
    assert bench.check_agreement(kind, n, damping=0.01, gain=0.5) <= 1e-9
    uv, z, uvd = bench.make_frames(n, count=1)[0]
    layout = {"cartesian": ibvs.Layout.cartesian, "polar": ibvs.Layout.polar, "stacked": ibvs.Layout.stacked}[kind](n)
    v = ibvs.Servo(layout, gain=0.5, damping=0.01).update(uv, z, uvd).velocity
    np.testing.assert_allclose(bench.numpy_step(uv, z, uvd, kind, 0.01, 0.5), v, rtol=1e-10, atol=1e-14)


def test_python_bench_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--iterations", "200"]) == 0
    out = capsys.readouterr().out
    assert "median" in out and "p99" in out and "numpy/ibvs" in out
    for kind in bench.LAYOUTS:
        assert f"{kind}(4)" in out
    assert "numpy vectorised" in out and "ibvs Servo.update damped" in out and "/tuned" in out


def test_python_bench_accepts_forwarded_separator(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--", "--iterations", "50", "--json"]) == 0  # `ibvs bench -- --iterations 50 --json`
    assert json.loads(capsys.readouterr().out)["iterations"] == 50


def test_python_bench_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--iterations", "200", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["benchmark"] == "ibvs.bench" and res["version"] == ibvs.__version__
    names = {(c["name"], c["layout"]) for c in res["cases"]}
    for kind in bench.LAYOUTS:
        assert ("ibvs Servo.update damped", kind) in names
        assert ("numpy vectorised, damped normal eqs", kind) in names
    for c in res["cases"]:
        assert 0.0 <= c["median_us"] <= c["p99_us"] <= c["max_us"]
        assert c["calls_per_s"] > 0
        if c["name"] == "ibvs Servo.update damped":
            assert c["twist_difference"] <= 1e-9 and c["numpy_ratio"] > 0
        if c["name"].startswith("ibvs Servo.update default"):
            assert c["default_over_tuned"] > 0


def test_agreement_check_raises_on_mismatch(monkeypatch: pytest.MonkeyPatch) -> None:
    real = bench.numpy_step
    monkeypatch.setattr(bench, "numpy_step", lambda *a: 1.01 * real(*a))
    with pytest.raises(RuntimeError, match="disagree"):
        bench.check_agreement("stacked", 4, damping=0.01, gain=0.5)


def test_python_bench_module_entry_point() -> None:
    out = subprocess.run([sys.executable, "-m", "ibvs.bench", "--iterations", "100", "--json"], check=True,
                         capture_output=True, text=True, timeout=120).stdout
    assert json.loads(out)["benchmark"] == "ibvs.bench"


@pytest.fixture(scope="module")
def cpp_bench() -> str:
    exe = _ibvs_bench()
    if exe is None:
        pytest.skip("ibvs-bench not built (not on PATH, not in build/)")
    return exe


def test_cpp_bench_table(cpp_bench: str) -> None:
    out = subprocess.run([cpp_bench, "--iterations", "300", "--layout", "cartesian,stacked", "--n", "4",
                          "--paced", "1000", "--duration", "0.05", "--episodes", "2",
                          "--sections", "components,growth,paced,episode"],
                         check=True, capture_output=True, text=True, timeout=300).stdout
    for what in ("median", "p99", "steps/s", "Servo::update default", "Servo::update tuned", "Eigen floor", "jacobian",
                 "solve: normal route", "solve: robust route", "robust", "ViSP stand-in", "stacked(4) 16x6",
                 "cartesian(4) 8x6", "misses", "episodes/s"):
        assert what in out, what


def test_cpp_bench_json(cpp_bench: str) -> None:
    out = subprocess.run([cpp_bench, "--iterations", "300", "--layout", "stacked", "--n", "4,8", "--paced", "60,1000",
                          "--duration", "0.05", "--episodes", "2", "--sections", "components,growth,paced,episode", "--json"],
                         check=True, capture_output=True, text=True, timeout=300).stdout
    res = json.loads(out)
    assert res["benchmark"] == "ibvs-bench" and res["version"] == ibvs.__version__
    cases = res["cases"]
    assert {c["section"] for c in cases} == {"components", "growth"}
    assert {c["n"] for c in cases if c["section"] == "growth"} == {4, 8}
    for c in cases:
        assert 0.0 <= c["median_us"] <= c["p99_us"] <= c["max_us"]
        if c["name"].startswith("Servo::update"):
            assert c["allocs_per_call"] == 0, c  # the real-time path allocates nothing
            assert 0 <= c["robust_frames"] <= 64, c  # frames solved by the QR + SVD route, counted
    assert [p["rate_hz"] for p in res["paced"]] == [60, 1000]
    for p in res["paced"]:
        assert p["steps"] >= 1 and p["misses"] >= 0 and p["lateness_max_us"] >= p["lateness_p99_us"]
    assert len(res["episodes"]) == 3
    for e in res["episodes"]:
        assert e["frames"] == 600 and e["outcome"] == "timeout"  # tolerance 0: the whole 10 s
        assert e["allocs_per_episode"] == 0 and 0.0 < e["median_ms"] <= e["max_ms"]


def test_cpp_bench_camera_section(cpp_bench: str) -> None:
    """The perception path is timed: camera model both ways (three distortions), the pixel step and
    the two estimators, none of them allocating."""
    out = subprocess.run([cpp_bench, "--iterations", "300", "--sections", "camera", "--json"], check=True,
                         capture_output=True, text=True, timeout=300).stdout
    cases = json.loads(out)["cases"]
    assert {c["name"] for c in cases} == {"CameraModel::normalize", "CameraModel::project", "CameraModel::to_bearing",
                                          "spherical servo step (fisheye pixels)",
                                          "Servo::update_pixels damped", "DepthEstimator::update (4x4 motion)",
                                          "PlanarPose::estimate"}
    assert {c["layout"] for c in cases if c["name"] == "CameraModel::normalize"} == {"visp", "plumb_bob",
                                                                                      "equidistant"}
    assert {c["layout"] for c in cases if c["name"] == "CameraModel::to_bearing"} == {
        "visp", "plumb_bob", "equidistant", "fisheye 200deg", "omnidir"}
    for c in cases:
        assert c["section"] == "camera" and c["allocs_per_call"] == 0, c
        assert 0.0 <= c["median_us"] <= c["p99_us"] <= c["max_us"]


def test_cpp_bench_undamped_dynamic_kernel_allocates_nothing(cpp_bench: str) -> None:
    # Rows 32 and 256 take the dynamic kernel; its damping = 0 (QR + SVD) route once called malloc
    # 12 times per step inside Eigen's Householder QR (found by ibvs-bench's malloc counter).
    out = subprocess.run([cpp_bench, "--iterations", "200", "--layout", "stacked", "--n", "8,64", "--sections",
                          "growth", "--json"], check=True, capture_output=True, text=True, timeout=300).stdout
    for c in json.loads(out)["cases"]:
        assert c["allocs_per_call"] == 0, c


def test_cpp_bench_robot_mapping_allocates_nothing(cpp_bench: str) -> None:
    out = subprocess.run([cpp_bench, "--iterations", "200", "--sections", "robot", "--json"], check=True,
                         capture_output=True, text=True, timeout=300).stdout
    cases = json.loads(out)["cases"]
    assert {c["n"] for c in cases} == {6, 7, 16}
    for c in cases:
        assert c["name"].startswith("JointMapping::update") and c["allocs_per_call"] == 0, c


def test_cpp_bench_rejects_bad_options(cpp_bench: str) -> None:
    for bad in (["--layout", "nope"], ["--damping", "0"], ["--iterations", "x"], ["--frobnicate"]):
        r = subprocess.run([cpp_bench, *bad], check=False, capture_output=True, text=True, timeout=60)
        assert r.returncode == 2 and "ibvs-bench" in r.stderr, bad
    r = subprocess.run([cpp_bench, "--help"], check=False, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "--paced" in r.stdout


@pytest.mark.skipif(os.environ.get("IBVS_BENCH_REQUIRE_CLI") != "1", reason="set IBVS_BENCH_REQUIRE_CLI=1 to require it")
def test_ibvs_bench_on_path() -> None:
    assert shutil.which("ibvs-bench"), "pip install . should put ibvs-bench on PATH"
