"""Honest output (issue 20, item 6): "converged" only within a stated tolerance, with the error it was
judged on in the unit the user set (tolerance_px: pixels, as a tracker measures them); the speed a robot
actually moved the camera at beside the commanded twist; no nan or empty cell in printed tables; sweep
progress counted in the episodes the user asked for; CameraModel.from_yaml's frame rate stated."""

from __future__ import annotations

import io
import json
import math
import re
from pathlib import Path

import ibvs
import ibvs.study.sweep as sw
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ibvs import sim
from ibvs.cli.main import main
from ibvs.study import reproduce
from ibvs.study.scenario import builtin
from ibvs.study.sweep.progress import Progress

GANTRY = sim.cases.gantry_general_motion()
EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "scenario.toml"


def gantry_run(servo=None, **kw):
    c = GANTRY
    servo = servo or ibvs.Servo(ibvs.Layout.stacked(4), gain=2.0)
    return sim.run(servo, c.camera, c.target, c.start, c.goal, robot=c.robot, duration=15.0, depth="pose", **kw)


# --------------------------------------------------------------------------- tolerance_px


def test_a_noisy_run_converges_by_tolerance_px_and_not_by_tolerance():
    """0.5 px of noise: no error-norm tolerance of 1e-4 is ever met, every point within 1 px of its goal is."""
    noisy = dict(noise=0.5, latency=1, seed=7)
    by_norm = gantry_run(tolerance=1e-4, **noisy)
    assert by_norm.status.outcome == "timeout" and not by_norm.converged
    assert np.nanmin(by_norm.history.error_norm) > 1e-4
    by_px = gantry_run(tolerance_px=1.0, **noisy)
    k = by_px.status.frame
    assert by_px.converged and by_px.metrics.frames_to_converge == k and len(by_px.history) == k + 1
    # judged on the measured points (as a tracker sees them, before latency) against the goal's measurement
    err = by_px.pixel_error
    np.testing.assert_allclose(err, np.max(np.linalg.norm(by_px.history.measured - by_px.measured_desired, axis=2),
                                           axis=1))
    assert err[k] <= 1.0 and (err[:k] > 1.0).all()
    assert by_px.tolerance is None and by_px.tolerance_px == 1.0
    # the goal's measurement is what the sensor saw there: the projections of the goal (no noise)
    goal_pixels = GANTRY.camera.project(by_px.uv_desired)
    assert np.abs(by_px.measured_desired - goal_pixels).max() < 0.05  # ViSP's kud/kdu round trip
    # both tolerances given: both must hold (the norm never does here)
    both = gantry_run(tolerance=1e-4, tolerance_px=1.0, **noisy)
    assert both.status.outcome == "timeout"
    # the same run without noise converges by either, the pixels first
    clean_px, clean = gantry_run(tolerance_px=1.0), gantry_run(tolerance=1e-5)
    assert clean_px.converged and clean.converged and clean_px.status.frame < clean.status.frame


def test_tolerance_px_in_normalised_units_for_a_normalised_camera():
    c = sim.cases.z_rotation()
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), c.camera, c.target, c.start, c.goal, duration=30,
                tolerance_px=1e-3)
    assert r.converged and r.pixel_error[r.status.frame] <= 1e-3
    assert "normalised units from its goal <= tolerance_px 0.001" in repr(r)


@settings(max_examples=60, deadline=None)
@given(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-3, 3),
                 st.sampled_from([True, False, 1j, "1", b"1", [1.0], 0.0, -0.0, 5e-324, 1e300])))
def test_tolerance_px_finite_or_refused(value):
    """Any tolerance_px: a finite number > 0 runs (the episode judged by it), anything else is refused with
    a ValueError or TypeError naming tolerance_px."""
    c = sim.cases.general_motion()
    try:
        r = sim.run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0), c.camera, c.target, c.start, c.goal,
                    duration=0.2, tolerance_px=value)
    except (ValueError, TypeError) as e:
        assert "tolerance_px" in str(e), (value, e)
        real = isinstance(value, (int, float)) and not isinstance(value, bool)
        assert not real or not (math.isfinite(value) and value > 0), (value, "refused a valid tolerance_px", e)
        return
    assert isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0
    assert r.tolerance_px == float(value) and r.tolerance is None
    assert r.converged == bool(r.pixel_error[-1] <= value)


@settings(max_examples=40, deadline=None)
@given(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([True, "1", None, 0.0, 1e300])))
def test_scenario_tolerance_px_finite_or_refused(value):
    setup = builtin("free")
    try:
        s = setup.replace(tolerance_px=value).validate()
    except (ValueError, TypeError) as e:
        assert "tolerance_px" in str(e), (value, e)
        assert isinstance(value, (bool, str)) or not (math.isfinite(value) and 0 < value <= 1e6), value
        return
    assert value is None or 0 < value <= 1e6
    assert s.tolerances() == ((1e-5, None) if value is None else (None, float(value)))


def test_scenario_tolerances_keep_the_config_hash_of_earlier_sweeps():
    """A sweep without tolerance_px keeps its config hash (its CSV resumes); tolerance_px makes a new one."""
    free = builtin("free")
    assert free.tolerance is None and free.tolerances() == (1e-5, None)
    assert free.key() == free.replace(tolerance=1e-5).key()
    assert "tolerance_px" not in free.settings() and free.settings()["tolerance"] == 1e-5
    px = free.replace(tolerance_px=1.0)
    assert px.key() != free.key() and px.tolerances() == (None, 1.0)
    assert px.replace(tolerance=1e-3).tolerances() == (1e-3, 1.0)
    assert free.criterion() == "error norm < 1e-05"
    assert px.criterion() == "every measured point within 1 normalised units of its goal"


def test_a_sweep_converges_by_tolerance_px(tmp_path):
    kw = dict(world="gantry", episodes=5, seed=1, schemes=["stacked"], duration=10.0, jobs=1, progress=False,
              ranges={"noise": (0.5, 0.5)})
    by_norm = sw.sweep(None, **kw)
    by_px = sw.sweep(None, tolerance_px=1.0, **kw)
    timeouts = [a["index"] for a in by_norm if a["outcome"] == "timeout"]
    assert len(timeouts) >= 3 and not any(a["outcome"] == "converged" for a in by_norm)
    assert all(b["outcome"] == "converged" for b in by_px if b["index"] in timeouts)  # the same starts
    assert by_px[0]["config"] != by_norm[0]["config"]  # another sweep: its own rows
    # in a scenario file's [control] table
    toml = EXAMPLE.read_text().replace("[control]\n", "[control]\ntolerance_px = 1.5\n")
    assert "tolerance_px = 1.5" in toml
    (tmp_path / "px.toml").write_text(toml)
    setup, _ = sw.resolve(tmp_path / "px.toml")
    assert setup.tolerances() == (5e-3, 1.5)  # the file's two tests
    # --tolerance-px alone on the command line (or tolerance_px= alone): the pixels alone decide
    assert sw.resolve(EXAMPLE, tolerance_px=2.0)[0].tolerances() == (None, 2.0)
    assert sw.resolve(EXAMPLE, tolerance_px=2.0, tolerance=1e-3)[0].tolerances() == (1e-3, 2.0)
    assert sw.resolve(EXAMPLE)[0].tolerances() == (5e-3, None)


# --------------------------------------------------------------------------- what a Result says


def test_result_says_what_converged_means_and_the_pose_error_at_the_end():
    """The README's simulator block: converged by an error norm of 0.00172 < 0.002 on one noisy frame, while
    the camera is 17.8 mm / 1.69 deg from its goal at the last frame; both said, each for what it is."""
    r = gantry_run(noise=0.3, latency=1, seed=7, tolerance=2e-3)
    text = repr(r)
    assert r.converged and r.status.frame == 442
    assert "converged at frame 442 (error norm 0.00172 < tolerance 0.002)" in text
    assert "pose error at the last frame 17.8 mm / 1.69 deg" in text and "final error" not in text
    px = gantry_run(noise=0.5, latency=1, seed=7, tolerance_px=1.0)
    assert re.search(r"converged at frame \d+ \(worst point 0\.\d+ px from its goal <= tolerance_px 1\)", repr(px))
    late = gantry_run(noise=0.5, latency=1, seed=7)
    assert "timeout at frame 899 (not converged: error norm 0.0101 at frame 899 (tolerance 0.0001))" in repr(late)
    c = sim.cases.z_rotation()
    gone = sim.run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0), c.camera, c.target, c.start, c.goal, duration=5)
    assert "diverged at frame 38 (not converged: error norm 0.262 at frame 37 (tolerance 0.0001))" in repr(gone)
    assert "nan" not in repr(gone)


def test_gantry_reports_the_speed_it_moved_at_beside_the_commanded_twist():
    """The commanded twist of IBVS-P on the gantry peaks at 7.4 m/s; the gantry (0.2 m/s and 0.7 rad/s per
    joint) moves the camera at most 0.32 m/s: the speeds from the poses agree with J(q) qdot and every joint
    keeps its speed limit."""
    r = gantry_run(ibvs.Servo(ibvs.Layout.polar(4), gain=2.0), tolerance=1e-5)
    g, h, m = GANTRY.robot, r.history, r.metrics
    linear, angular = h.camera_speed()
    assert m.peak_linear_speed == linear.max() and m.peak_angular_speed == angular.max()
    assert m.peak_commanded_linear_speed == pytest.approx(7.356, abs=1e-3)
    assert m.peak_linear_speed == pytest.approx(0.320, abs=1e-3)
    assert m.peak_commanded_linear_speed > 20 * m.peak_linear_speed
    assert m.peak_commanded_angular_speed > 10 * m.peak_angular_speed
    qdot = np.diff(h.q, axis=0) / np.diff(h.time)[:, None]
    assert (np.abs(qdot) <= np.asarray(g.qdot_max) * (1 + 1e-9)).all()
    J = np.array([g.jacobian(q) for q in h.q[:-1]])
    v = np.einsum("kij,kj->ki", J, h.qdot[:-1])  # the camera twist the joints made (first order)
    assert np.abs(np.linalg.norm(v[:, :3], axis=1) - linear).max() < 5e-3
    assert np.abs(np.linalg.norm(v[:, 3:], axis=1) - angular).max() < 5e-3
    assert linear.max() <= np.linalg.norm(np.asarray(g.qdot_max)[:3]) + 0.5 * np.abs(g.qdot_max[3:]).sum()
    # free flight: the camera moves as commanded (the angular speed exactly, the linear up to a screw's chord)
    c = sim.cases.general_motion()
    f = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), c.camera, c.target, c.start, c.goal, duration=30,
                tolerance=1e-5).metrics
    assert f.peak_angular_speed == pytest.approx(f.peak_commanded_angular_speed, rel=1e-9)
    assert f.peak_linear_speed == pytest.approx(f.peak_commanded_linear_speed, rel=1e-3)


def _run_lines(capsys, *args) -> list[str]:
    rc = main(["run", *args])
    out = capsys.readouterr().out
    assert rc in (0, 1)
    return out.splitlines()[1:]


def test_ibvs_run_prints_no_empty_row_and_no_nan(capsys):
    for args in (["--world", "gantry"], ["--scheme", "cartesian", "--duration", "5"], [],
                 ["--world", "gantry", "--noise", "0.5", "--tolerance-px", "1", "--seed", "3"]):
        lines = _run_lines(capsys, *args)
        for line in lines:
            _, _, value = line.strip().partition("  ")
            assert value.strip(), (args, line)  # no empty row
            assert "nan" not in line.lower().replace("n/a", ""), (args, line)
        text = "\n".join(lines)
        assert "event" in text and "peak commanded ‖v‖ (m/s)" in text and "peak camera ‖v‖ (m/s)" in text


def test_ibvs_run_on_the_gantry_reports_both_speeds_and_what_converged_means(capsys):
    lines = _run_lines(capsys, "--world", "gantry")
    get = {ln.split("  ")[1].strip(): ln for ln in lines}
    assert "converged at frame 512: error norm 9.86e-06 < tolerance 1e-05" in lines[0]
    commanded = float(get["peak commanded ‖v‖ (m/s)"].split()[4])
    camera = float(get["peak camera ‖v‖ (m/s)"].split()[4])
    assert commanded == pytest.approx(7.356) and camera == pytest.approx(0.3201)
    assert "before the robot's joint speed limits" in get["peak commanded ‖v‖ (m/s)"]
    assert "how fast the robot moved the camera, from its poses" in get["peak camera ‖v‖ (m/s)"]
    assert get["event"].split()[-1] == "none"
    lines = _run_lines(capsys, "--world", "gantry", "--noise", "0.5", "--tolerance-px", "1", "--seed", "3")
    assert re.search(r"converged at frame \d+: worst point 0\.\d+ px from its goal <= tolerance_px 1$", lines[0])
    lines = _run_lines(capsys, "--scheme", "cartesian", "--duration", "5")
    assert "diverged at frame 38, not converged: error norm 0.262 at frame 37 (tolerance 1e-05)" in lines[0]
    assert any("frames to converge" in ln and "n/a (not converged)" in ln for ln in lines)
    assert any("joint limit" in ln and "n/a (free-flying camera, no joints)" in ln for ln in lines)


def test_reproduce_summary_has_no_nan_or_empty_cell():
    rows = [reproduce.summarise(w, c, s, reproduce.run_one(w, c, s, duration=5.0)[1])
            for w, c, s in (("free", "z-rotation", "cartesian"), ("free", "z-rotation", "polar"),
                            ("gantry", "general", "polar"))]
    table = reproduce.format_rows(rows)
    assert "nan" not in table and "|  |" not in table and "| |" not in table
    assert "n/a: frames to converge: not converged" in table
    assert "peak commanded ‖v‖ (m/s)" in table and "peak camera ‖v‖ (m/s)" in table
    gantry = rows[2]
    assert gantry.peak_v_camera < 0.4 and gantry.peak_v > 5


# --------------------------------------------------------------------------- sweep progress


def test_sweep_progress_counts_episodes_as_asked_for():
    """12000 episodes of 7 schemes: "N of 12000 episodes (M rows: 7 schemes each)", not "of 84000"."""
    stream = io.StringIO()
    bar = Progress(12000, 7, [0] * 7 + [1] * 3, True, stream=stream)
    assert (bar.rows, bar.complete) == (10, 1)
    bar.update([1] * 4 + [2] * 7 + [3])
    assert (bar.rows, bar.complete) == (22, 3)
    bar.close()
    last = stream.getvalue().split("\r")[-1]
    assert "3 of 12000 episodes (22 of 84000 rows: 7 schemes each)" in last and "84000 episodes" not in last


def test_sweep_progress_line_of_the_command(tmp_path):
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "ibvs", "sweep", "--out", str(tmp_path / "s.csv"), "--episodes", "3",
                        "--schemes", "polar", "cartesian", "--duration", "2", "--jobs", "1"],
                       capture_output=True, text=True, timeout=300, check=False)
    assert r.returncode == 0, r.stderr
    progress = r.stderr.split("\r")[-1]
    assert "3 of 3 episodes (6 of 6 rows: 2 schemes each)" in progress, r.stderr
    assert "3 episodes (6 rows: 2 schemes each) in" in r.stdout and "converged: error norm < 1e-05" in r.stdout


def test_an_older_sweep_file_resumes_in_its_own_columns(tmp_path):
    """Files written before the camera's actual speeds were recorded load (those NaN, shown n/a) and resume."""
    from ibvs.study.sweep.rows import COLUMNS, PREVIOUS_COLUMNS

    kw = dict(episodes=2, schemes=["polar"], duration=2.0, jobs=1, progress=False)
    rows = sw.sweep(None, **kw)
    old = tmp_path / "old.csv"
    old.write_text(",".join(PREVIOUS_COLUMNS) + "\n" + "".join(
        ",".join(str(r[c]) if isinstance(r[c], (str, int)) else repr(r[c]) for c in PREVIOUS_COLUMNS) + "\n"
        for r in rows[:1]))
    more = sw.sweep(old, **kw)
    assert [r["id"] for r in more] == [r["id"] for r in rows]
    lines = old.read_text().splitlines()
    assert len(lines) == 3 and all(len(ln.split(",")) == len(PREVIOUS_COLUMNS) for ln in lines)
    loaded = sw.load(old)
    assert all(math.isnan(r["peak_camera_linear_speed"]) for r in loaded) and set(loaded[0]) == set(COLUMNS)
    text = sw.format_table(sw.aggregate(loaded, bins=[0, 180]))
    assert "n/a (peak camera ‖T‖ (m/s), peak camera ‖ω‖ (rad/s)): not in the CSV" in text and "nan" not in text


# --------------------------------------------------------------------------- bench


def test_bench_vision_prints_na_and_why_not_nan(capsys):
    pytest.importorskip("cv2")
    from ibvs import bench

    assert bench.main(["--vision", "--frames", "6"]) == 0
    out = capsys.readouterr().out
    assert "nan" not in out.lower().replace("n/a", "")
    assert "n/a" in out and "n/a: image episode, per frame" in out and "timed once" in out
    assert bench.main(["--vision", "--frames", "6", "--json"]) == 0
    res = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"{c} in the JSON"))
    episode = res["cases"][-1]
    assert episode["p99_ms"] is None and episode["max_ms"] is None and "why" in episode


def test_tolerance_px_is_in_measurement_units_everywhere():
    """tolerance_px's unit is said the same way wherever it is documented or asked for: measurement units, that is
    pixels, or normalised units for a normalised camera (the free world's); never "pixels" alone. The outputs
    name the unit of the camera the run had."""
    root = Path(__file__).resolve().parents[2]
    texts = {str(p.relative_to(root)): p.read_text() for p in
             [*root.glob("docs/*.md"), root / "README.md", *(root / "python/ibvs").rglob("*.py")]}
    wrong = [f"{name}: {m.group(0)!r}" for name, text in texts.items()
             for m in re.finditer(r"tolerance[_-]px[^.;\n]{0,60}?(many pixels|\(measurement units: pixels\))", text)]
    assert not wrong, wrong
    from ibvs.cli import args

    for doc in (args.TOLERANCE_PX_HELP, sim.run.__doc__, sim.Result.__doc__):
        flat = " ".join(doc.split())
        assert "measurement units" in flat and "normalised units" in flat, flat[:200]
    with pytest.raises(ValueError, match=r"measurement units: pixels; normalised units"):
        gantry_run(tolerance_px=-1.0)
    free = sim.cases.z_rotation()
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), free.camera, free.target, free.start, free.goal,
                duration=1.0, tolerance_px=1e-3)
    assert "normalised units" in r.criterion() and "px" not in r.criterion()
    c = GANTRY
    r = sim.run(ibvs.Servo(ibvs.Layout.stacked(4), gain=2.0), c.camera, c.target, c.start, c.goal, robot=c.robot,
                duration=0.5, tolerance_px=1.0)
    assert "within 1 px of its goal" in r.criterion()


def test_paper_page_says_which_speed_and_leaves_no_cell_blank():
    """docs/paper.md's results table: the commanded twist's peak and the camera's, each named; every cell holds a
    value or n/a (the page says why)."""
    page = (Path(__file__).resolve().parents[2] / "docs/paper.md").read_text()
    rows = [line for line in page.splitlines() if line.startswith("| world | case |") or line.startswith("| free |")
            or line.startswith("| gantry |")]
    header = [c.strip() for c in rows[0].strip("|").split("|")]
    assert "peak commanded ‖v‖ (m/s)" in header and "peak camera ‖v‖ (m/s)" in header
    assert not [h for h in header if "‖v‖" in h and "commanded" not in h and "camera" not in h]
    for row in rows[1:]:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert len(cells) == len(header) and all(cells), row
        assert "—" not in cells, row  # n/a, as in summary.md
    assert '"n/a": a run that did not converge' in page
    commanded, camera = header.index("peak commanded ‖v‖ (m/s)"), header.index("peak camera ‖v‖ (m/s)")
    gantry = [[c.strip() for c in r.strip("|").split("|")] for r in rows if r.startswith("| gantry |")]
    assert all(float(r[camera]) < float(r[commanded]) and float(r[camera]) <= 0.4 for r in gantry)
