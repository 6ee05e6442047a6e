"""`ibvs servo CONFIG.toml`: a bad config (unknown robot, malformed value, unwritable output, unreachable
robot) is one line `ibvs servo: error: ...` and exit status 2, before anything moves."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ibvs.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "docs" / "servo.toml"


def _config(tmp_path, *edits) -> Path:
    text = EXAMPLE.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "servo.toml"
    path.write_text(text)
    return path


def _one_line_error(capsys, argv) -> str:
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ibvs servo: error: "), err
    return err[0]


@pytest.mark.parametrize("edits, match", [
    ([('kind = "sim"', 'kind = "kuka"')], "kind"),
    ([("gain = ", "gain = -")], "[servo] gain"),
    ([("duration = ", "duration = 'soon' #")], "[loop] duration"),
    ([("watchdog = 0.5 ", "watchdog = nan ")], "[loop] watchdog"),
    ([('log = "servo-run.jsonl"', 'log = "no/such/dir/run.jsonl"')], "[loop] log"),
    ([("[loop]", "[loop]\nrecord = \"run.bag\"")], "must end in .mcap"),
    ([("[tracker]", "[tracker]\ninitial_pixels = [[1.0, 2.0]]")], "initial_pixels"),
])
def test_bad_config_is_one_line_and_status_2(tmp_path, capsys, edits, match):
    line = _one_line_error(capsys, ["servo", str(_config(tmp_path, *edits))])
    assert match in line, line


def test_missing_config_file(tmp_path, capsys):
    line = _one_line_error(capsys, ["servo", str(tmp_path / "none.toml")])
    assert "none.toml" in line


def test_not_toml(tmp_path, capsys):
    path = tmp_path / "x.toml"
    path.write_text("[loop\n")
    assert "not valid TOML" in _one_line_error(capsys, ["servo", str(path)])


def test_unreachable_robot_is_status_2(tmp_path, capsys):
    pytest.importorskip("franky", reason="the franky adapter needs franky-control (the franka extra)")
    import socket

    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    try:
        from ibvs.robot import ROBOTS
    except ImportError:
        pytest.skip("ibvs.robot is not merged")
    if "franky" not in ROBOTS:
        pytest.skip("no franky adapter")
    text = EXAMPLE.read_text()
    start, end = text.index("\n[robot]") + 1, text.index("\n[loop]") + 1
    path = tmp_path / "servo.toml"
    path.write_text(text[:start] + f'[robot]\nkind = "franky"\nhost = "127.0.0.1:{port}"\nkinematics = "panda"\n\n' + text[end:])
    line = _one_line_error(capsys, ["servo", str(path)])
    assert "franky" in line and "RobotError" in line and "cannot connect" in line, line


def test_example_config_runs_and_stops(tmp_path):
    """docs/servo.toml end to end (the kinematic robot, the renderer, a simulated clock): it converges."""
    pytest.importorskip("cv2", reason="the loop's tracker (the vision extra)")
    pytest.importorskip("ibvs.robot.sim", reason="the kinematic SimRobot of ibvs.robot (the robot branch)")
    log = tmp_path / "run.jsonl"
    r = subprocess.run([sys.executable, "-m", "ibvs", "servo", str(EXAMPLE), "--log", str(log)], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "converged" in r.stdout and "capture-to-command latency" in r.stdout
    assert log.read_text().splitlines()[-1].startswith('{"kind": "end"')
