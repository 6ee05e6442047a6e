"""Smoke tests of the benchmarks: they run, print what they promise, and the
numpy reference agrees with the C++ step. No timing assertion anywhere."""

from __future__ import annotations

import json
import os
import re
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
    """The newest ibvs-bench of: PATH (pip install .), next to the interpreter, a build tree (a stale installed
    copy must not stand in for the one just built)."""
    found = [shutil.which("ibvs-bench"), str(Path(sys.executable).parent / "ibvs-bench")]
    found += [str(p) for p in (ROOT / "build").glob("**/bench/ibvs-bench")]
    found = [f for f in found if f and Path(f).is_file()]
    return max(found, key=lambda f: Path(f).stat().st_mtime) if found else None


@pytest.mark.parametrize("kind", bench.LAYOUTS)
@pytest.mark.parametrize("n", [4, 7])
def test_numpy_step_matches_servo(kind: str, n: int) -> None:
    assert bench.check_agreement(kind, n, damping=0.01, gain=0.5) <= 1e-9
    uv, z, uvd = bench.make_frames(n, count=1)[0]
    layout = {"cartesian": ibvs.Layout.cartesian, "polar": ibvs.Layout.polar, "stacked": ibvs.Layout.stacked}[kind](n)
    v = ibvs.Servo(layout, gain=0.5, damping=0.01).update(uv, z, uvd).velocity
    np.testing.assert_allclose(bench.numpy_step(uv, z, uvd, kind, 0.01, 0.5), v, rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("kind", bench.LAYOUTS)
def test_goal_moved_frames_move_the_goal_and_the_servo_follows(kind: str) -> None:
    """The goal-moved row's frames change the goal on every frame, and one servo updated through them all
    (its goal caches invalidated every frame) gives numpy's twist on each."""
    frames = bench.make_frames(4, count=40, moved=True)
    assert all(np.abs(a[2] - b[2]).max() > 0 for a, b in zip(frames, frames[1:]))
    layout = {"cartesian": ibvs.Layout.cartesian, "polar": ibvs.Layout.polar, "stacked": ibvs.Layout.stacked}[kind](4)
    servo = ibvs.Servo(layout, gain=0.5, damping=0.01)
    for uv, z, uvd in frames:
        np.testing.assert_allclose(servo.update(uv, z, uvd).velocity, bench.numpy_step(uv, z, uvd, kind, 0.01, 0.5),
                                   rtol=1e-10, atol=1e-14)


def test_python_bench_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--iterations", "200"]) == 0
    out = capsys.readouterr().out
    assert "median" in out and "p99" in out and "numpy/ibvs" in out
    for kind in bench.LAYOUTS:
        assert f"{kind}(4)" in out
    assert "numpy vectorised" in out and "ibvs Servo.update damped" in out and "/tuned" in out
    assert not re.search(r"\bnan\b", out.lower())
    rows = [line for line in out.splitlines() if line.startswith("  ") and "x6 " in line]
    assert rows and all(not line.endswith(" ") and len(line.split()) >= 8 for line in rows), "a blank cell"
    assert "n/a" in out and "ratio n/a: only" in out  # the baselines have nothing to compare with, said so


def test_python_bench_table_says_na_not_nan() -> None:
    """A figure that is not finite (or missing) prints n/a, never nan, inf or a blank."""
    case = {"name": "x", "layout": "stacked", "n": 4, "rows": 16, "median_us": float("nan"), "p99_us": None,
            "max_us": 1.0, "calls_per_s": float("inf"), "implementation": "ibvs", "numpy_ratio": float("nan")}
    res = {"version": "0", "processor": "cpu", "python": "3", "numpy": "2", "timer_overhead_ns": 30.0,
           "damping": 0.01, "gain": 0.5, "iterations": 10, "cases": [case]}
    row = next(line for line in bench.format_table(res).splitlines() if line.startswith("  x "))
    assert row.split()[3:] == ["n/a", "n/a", "1.0", "n/a", "n/a"]


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
        assert ("ibvs Servo.update, goal moved every frame (default)", kind) in names
        assert ("numpy vectorised, damped normal eqs", kind) in names
    for c in res["cases"]:
        assert 0.0 <= c["median_us"] <= c["p99_us"] <= c["max_us"]
        assert c["calls_per_s"] > 0
        if c["name"] == "ibvs Servo.update damped":
            assert c["twist_difference"] <= 1e-9 and c["numpy_ratio"] > 0
        if c["name"].startswith("ibvs Servo.update default"):
            assert c["default_over_tuned"] > 0


def test_python_bench_task_rows(capsys: pytest.CaptureFixture[str]) -> None:
    """`ibvs bench` times the tasks of feature blocks too (default and tuned), their twists checked against numpy."""
    assert bench.main(["--iterations", "100", "--json"]) == 0
    cases = [c for c in json.loads(capsys.readouterr().out)["cases"] if c.get("task")]
    assert {(c["name"], c["layout"]) for c in cases} == {
        (n, t) for n in ("ibvs Servo.update default (damping 0, diagnostics)",
                         "ibvs Servo.update tuned (damped, no diagnostics)") for t in bench.TASKS}
    for c in cases:
        assert 0.0 <= c["median_us"] <= c["p99_us"] <= c["max_us"]
        if c["name"].startswith("ibvs Servo.update tuned"):
            assert c["twist_difference"] <= 1e-9
        else:
            assert c["default_over_tuned"] > 0
    assert bench.main(["--iterations", "50"]) == 0
    out = capsys.readouterr().out
    assert "stacked+moments 22x6" in out and "moments 6x6" in out and "2.5-D 6x6" in out


def test_task_agreement_check_raises_on_mismatch(monkeypatch: pytest.MonkeyPatch) -> None:
    name, task, args = bench.make_task_frames(count=2)[0]
    assert bench.check_task_agreement(task, args, damping=0.01, gain=0.5) <= 1e-9
    real = np.linalg.solve
    monkeypatch.setattr(bench.np.linalg, "solve", lambda A, b: 1.01 * real(A, b))
    with pytest.raises(RuntimeError, match="disagree"):
        bench.check_task_agreement(task, args, damping=0.01, gain=0.5)


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
    # Every row of the step tables (case column: 45 characters) has all nine cells: no blank, no nan
    # (n/a, and the header says why).
    rows = [line for line in out.splitlines() if re.match(r"  \S.* (8|16)x6 ", line)]
    assert rows and all(len(line[47:].split()) == 9 for line in rows), "a blank cell"
    assert not re.search(r"\bnan\b", out) and "n/a: not a Servo::update row" in out


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
            # frames solved by the QR + SVD route, counted on the plain step's rows (-1: a row of another
            # option, e.g. the smooth law, whose route the bench does not count)
            assert 0 <= c["robust_frames"] <= 64 or (c["robust_frames"] == -1 and "smooth" in c["name"]), c
    assert [p["rate_hz"] for p in res["paced"]] == [60, 1000]
    for p in res["paced"]:
        assert p["steps"] >= 1 and p["misses"] >= 0 and p["lateness_max_us"] >= p["lateness_p99_us"]
    assert len(res["episodes"]) == 3
    for e in res["episodes"]:
        assert e["frames"] == 600 and e["outcome"] == "timeout"  # tolerance 0: the whole 10 s
        assert e["allocs_per_episode"] == 0 and 0.0 < e["median_ms"] <= e["max_ms"]


TASK_ROWS = {"moments": 6, "pbvs": 6, "pbvs(object)": 6, "2.5-D": 6, "stacked+moments": 22}
STEP_ROWS = ("Servo::update default (damping 0, diag.)", "Servo::update tuned (damped, no diag.)",
             "Eigen floor: fixed-size LLT step")


def test_cpp_bench_tasks_section(cpp_bench: str) -> None:
    """Issue 21: every task of feature blocks has its default and tuned Servo::update rows beside its
    fixed-size Eigen floor, none allocating. ibvs-bench exits 1 without a table when a floor's twist
    disagrees with Servo::update's (relative 1e-9), so the floors printed agree."""
    r = subprocess.run([cpp_bench, "--iterations", "300", "--sections", "tasks", "--json"], check=True,
                       capture_output=True, text=True, timeout=300)
    cases = json.loads(r.stdout)["cases"]
    assert {(c["name"], c["layout"]) for c in cases} == {(n, t) for n in STEP_ROWS for t in TASK_ROWS}
    for c in cases:
        assert c["section"] == "tasks" and c["rows"] == TASK_ROWS[c["layout"]], c
        assert c["allocs_per_call"] == 0, c  # the real-time path of every task allocates nothing
        assert 0.0 <= c["median_us"] <= c["p99_us"] <= c["max_us"]
        if c["name"].startswith("Servo::update"):
            assert 0 <= c["robust_frames"] <= 64, c
            assert c["diagnostics"] == c["name"].startswith("Servo::update default"), c
    assert c["n"] == 4  # the mixed task (last) has the 4 points of its stacked layout
    for task, rows in TASK_ROWS.items():  # the human table (stderr with --json): each task's rows
        assert f"{task} {rows}x6" in r.stderr, task
    assert "disagrees" not in r.stderr and not re.search(r"\bnan\b", r.stderr)


def test_cpp_bench_default_sections_include_tasks(cpp_bench: str) -> None:
    r = subprocess.run([cpp_bench, "--help"], check=True, capture_output=True, text=True, timeout=60)
    assert "components, tasks, growth" in r.stdout and "default all seven" in r.stdout


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
    for c in cases:  # the joint mapping (eye-in-hand, eye-to-hand) and the secondary task's step
        assert c["name"].startswith(("JointMapping::update", "SecondaryTask::update")), c
        assert c["allocs_per_call"] == 0, c
    assert any(c["name"].startswith("SecondaryTask::update") for c in cases)


def test_cpp_bench_rejects_bad_options(cpp_bench: str) -> None:
    for bad in (["--layout", "nope"], ["--damping", "0"], ["--iterations", "x"], ["--frobnicate"]):
        r = subprocess.run([cpp_bench, *bad], check=False, capture_output=True, text=True, timeout=60)
        assert r.returncode == 2 and "ibvs-bench" in r.stderr, bad
    r = subprocess.run([cpp_bench, "--help"], check=False, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "--paced" in r.stdout


@pytest.mark.skipif(os.environ.get("IBVS_BENCH_REQUIRE_CLI") != "1", reason="set IBVS_BENCH_REQUIRE_CLI=1 to require it")
def test_ibvs_bench_on_path() -> None:
    assert shutil.which("ibvs-bench"), "pip install . should put ibvs-bench on PATH"


def _report():
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_report", ROOT / "bench/report.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_report_cells_are_numbers_or_na_with_a_reason(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """bench/report.py: a figure no run measured (null, NaN) is "n/a", with the reason under its table; a Python row
    without a counterpart has ratio n/a, said why; no cell is blank or nan."""
    case = {"section": "components", "name": "solve", "layout": "stacked", "n": 4, "rows": 16, "median_us": 0.5,
            "p99_us": None, "max_us": 2.0, "steps_per_s": 1e6, "allocs_per_call": 0}
    cpp = {"benchmark": "ibvs-bench", "cpu": "cpu", "iterations": 10, "cases": [case],
           "paced": [{"rate_hz": 60, "duration_s": 1, "spin_us": 0, "realtime": False, "steps": 0, "misses": 0,
                      "lateness_median_us": None, "lateness_p99_us": None, "lateness_max_us": None,
                      "step_median_us": None, "step_max_us": None}],
           "episodes": []}
    py_case = {"name": "baseline", "layout": "stacked", "n": 4, "rows": 16, "median_us": 0.1, "p99_us": 0.2,
               "max_us": 1.0, "calls_per_s": 1e7, "implementation": "binding"}
    py = {"benchmark": "ibvs.bench", "iterations": 10, "python": "3", "numpy": "2", "cases": [py_case]}
    paths = []
    for k, run in enumerate([cpp, py]):
        path = tmp_path / f"run{k}.json"
        path.write_text(json.dumps(run))
        paths.append(str(path))
    assert _report().main(paths) == 0
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.startswith("| ") and not line.startswith("| case")]
    assert rows and not any("nan" in r.lower() or "| |" in r or "|  |" in r for r in rows), out
    assert "| solve | stacked(4) 16×6 | 0.500 | n/a | 2.0 |" in out
    assert "| 60 Hz | 1 s | normal | 0 | 0 | n/a |" in out
    assert out.count("n/a: not measured") == 2  # under the components and the paced tables
    assert "| baseline | stacked(4) 16×6 | 0.10 | 0.20 | 1.0 | 10,000,000 | n/a |" in out
    assert "ratio n/a: only" in out


def test_loop_benchmark_runs_and_reports_its_parts(capsys) -> None:
    pytest.importorskip("cv2", reason="the loop benchmark renders and tracks dots (the vision extra)")
    assert bench.main(["--loop", "--frames", "12", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["frames"] == 12 and res["outcome"] == "ended" and res["image"] == "640x480"
    for key in ("median", "p99", "max"):
        assert res["overhead_ms"][key] > 0
    assert 0 < res["tracker_ms"]["median"] < res["overhead_ms"]["max"]
    assert bench.main(["--loop", "--frames", "5"]) == 0
    assert "of which the dot tracker" in capsys.readouterr().out
PHOTOMETRIC_ROWS = {"LuminanceServo::update J desired (LM)", "floor: per-pixel L^T e, J desired",
                    "LuminanceServo::update J current (LM)", "floor: per-pixel H, L^T e, J current",
                    "part: 7-tap gradients of the grid", "part: error e = I - I*",
                    "part: 6x6 LM solve (LLT of H + mu diag H)"}


def test_cpp_bench_photometric_section(cpp_bench: str) -> None:
    """Issue 36: LuminanceServo::update at 160x120 and 320x240 beside its per-pixel floor and the floor's parts,
    the servo allocating nothing; ibvs-bench exits 1 when the floor's twist disagrees (relative 1e-4)."""
    r = subprocess.run([cpp_bench, "--iterations", "20", "--warmup", "2", "--sections", "photometric", "--json"],
                       check=True, capture_output=True, text=True, timeout=300)
    cases = json.loads(r.stdout)["cases"]
    assert {(c["name"], c["layout"]) for c in cases} == {(n, s) for n in PHOTOMETRIC_ROWS
                                                         for s in ("160x120", "320x240")}
    for c in cases:
        assert c["section"] == "photometric" and c["allocs_per_call"] == 0, c
        assert 0.0 <= c["median_us"] <= c["p99_us"] <= c["max_us"], c
    assert {c["n"] for c in cases if c["name"].startswith("LuminanceServo")} == {140 * 100, 300 * 220}
    assert "LuminanceServo::update / floor (medians), 320x240" in r.stderr and "disagrees" not in r.stderr


def test_python_bench_photometric() -> None:
    from ibvs import bench

    res = bench.run_photometric(iterations=3)
    assert [(c["name"], c["layout"]) for c in res["cases"]] == [
        (f"ibvs LuminanceServo.update J {j} (LM)", s) for s in ("160x120", "320x240") for j in ("desired", "current")]
    assert all(0.0 < c["median_us"] <= c["max_us"] for c in res["cases"])
    assert "LuminanceServo.update J current" in bench.format_photometric(res)
