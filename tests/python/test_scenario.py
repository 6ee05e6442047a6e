"""Sweeps of a user's scenario: from Python and from a TOML file, locally and on Dask, resumed
after an interruption; every outcome a column of the table."""

from __future__ import annotations

import csv
import math
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest

import ibvs.study.sweep as sw
from ibvs import sim
from ibvs.study.scenario import PARAMETERS, Scenario, builtin, load

EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "scenario.toml"
FAST = dict(episodes=4, duration=4.0, progress=False)


def rotation_about_z(rng):
    """A start distribution as a callable: about the optical axis only, normal with 60 degrees std."""
    return (0.0, 0.0, rng.normal(0.0, math.radians(60)))


def lateral(rng):
    return rng.uniform(-0.03, 0.03, size=3)


def _mine(**kw) -> Scenario:
    cam = sim.Camera(600, 600, 320, 240, kud=-0.05, kdu=0.05, width=640, height=480, fps=30)
    pts = [[-0.05, -0.05, 0], [0.05, -0.05, 0], [0.05, 0.05, 0], [-0.05, 0.05, 0], [0, 0, -0.03]]
    return Scenario(cam, sim.Target(pts, sim.pose(t=(0, 0, 0.5))), np.eye(4), name="mine",
                    ranges={"rz_deg": (0, 120), "noise": (0, 0.5), "latency": (0, 2)}, depth="estimated", tolerance=5e-3,
                    **kw).validate()


def test_python_scenario_nonplanar_pixel_camera():
    rows = sw.sweep(None, scenario=_mine(), schemes=["cartesian", "stacked", "partitioned"], jobs=1, **FAST)
    assert len(rows) == 12 and {r["scenario"] for r in rows} == {"mine"}
    assert {r["depth"] for r in rows} == {"estimated"}
    assert all(r["latency"] in (0, 1, 2) and 0 <= r["noise"] <= 0.5 for r in rows)
    assert any(r["outcome"] == "converged" for r in rows)
    conv = [r for r in rows if r["outcome"] == "converged"]
    assert all(r["time_to_converge"] == r["frames_to_converge"] / 30 for r in conv)
    assert all(r["peak_linear_speed"] > 0 for r in rows if r["outcome"] != "invalid_start")
    # the spec travels to worker processes and Dask
    spec = sw.SweepSpec(_mine(), seed=1, episodes=2, schemes=("polar",))
    back = pickle.loads(pickle.dumps(spec))
    assert back.config() == spec.config()
    assert repr(sw.run_episode(back, 1, "polar")) == repr(sw.run_episode(spec, 1, "polar"))


def test_callable_start_distributions():
    mine = _mine(rotation=rotation_about_z, translation=lateral)
    rows = sw.sweep(None, scenario=mine, schemes=["polar"], jobs=2, batch=1, **{**FAST, "episodes": 6})
    assert all(r["tilt_deg"] < 1e-9 for r in rows)  # the rotation is about z only
    assert len({round(r["rz_deg"], 6) for r in rows}) == 6 and any(r["rz_deg"] < 0 for r in rows)
    assert all(abs(r[k]) <= 0.03 for r in rows for k in ("tx", "ty", "tz"))
    # a callable is part of the config: another one gives other ids
    other = mine.replace(rotation=lambda rng: np.eye(3))
    assert sw.SweepSpec(other).config() != sw.SweepSpec(mine).config()
    # the rows are a function of (seed, index): the same from one process or two
    assert repr(rows) == repr(sw.sweep(None, scenario=mine, schemes=["polar"], jobs=1, **{**FAST, "episodes": 6}))
    table = sw.aggregate(rows)
    assert table[0]["lo"] < 0 < table[-1]["hi"]  # bins follow the signed rotations


def test_scenario_checks():
    base = _mine()
    for change, match in [({"ranges": {"bogus": (0, 1)}}, "ranges"), ({"ranges": {"tx": (1, 0)}}, "ranges"),
                          ({"ranges": {"latency": (0, 0.5)}}, "latency"), ({"ranges": {"noise": (-1, 0)}}, "noise"),
                          ({"ranges": {"tz": (0, 1e300)}}, "tz"), ({"ranges": {"latency": (0, 600)}}, "latency"),
                          ({"gain": math.inf}, "gain"), ({"duration": 1e300}, "duration"), ({"depth": "pose"}, "planar"),
                          ({"depth": "guess"}, "depth"), ({"goal": sim.pose(t=(0, 0, 0.6))}, "goal"),
                          ({"rotation": 3}, "rotation")]:
        with pytest.raises((ValueError, TypeError), match=match):
            base.replace(**change).validate()
    with pytest.raises(TypeError, match="camera"):
        Scenario("cam", base.target, np.eye(4)).validate()
    bad = base.replace(rotation=lambda rng: np.ones((3, 3)))
    with pytest.raises(ValueError, match="rotation"):
        sw.sweep(None, scenario=bad, schemes=["polar"], jobs=1, **FAST)


def test_example_file_and_its_table(tmp_path):
    scenario, options = load(EXAMPLE)
    assert scenario.name == "pixel-camera-5-points" and len(scenario.target) == 5 and not scenario.target.planar
    assert options == {"episodes": 100, "seed": 0, "schemes": ["cartesian", "polar", "stacked", "partitioned"]}
    assert scenario.ranges["latency"] == (0, 2) and scenario.depth == "estimated"
    rows = sw.sweep(tmp_path / "ex.csv", scenario=EXAMPLE, episodes=3, schemes=["polar", "partitioned"], jobs=1,
                    duration=3.0, progress=False)
    assert len(rows) == 6
    table = sw.aggregate(rows)
    text = sw.format_table(table)
    for outcome in sim.OUTCOMES:  # one column per outcome, derived from ibvs.sim.OUTCOMES
        assert f" {outcome} |" in text.splitlines()[0]
    for t in table:
        if t["n"]:
            assert math.isclose(sum(t[o] for o in t["outcomes"]), 1.0)
    assert "peak commanded ‖T‖ (m/s)" in text and "peak camera ‖T‖ (m/s)" in text and "retreat (m)" in text


def test_an_outcome_added_later_gets_its_column(monkeypatch):
    rows = sw.sweep(None, schemes=["polar"], grid={"rz_deg": [10, 20]}, duration=2.0, jobs=1, progress=False)
    rows[0] = {**rows[0], "outcome": "collision"}
    table = sw.aggregate(rows, bins=[0, 180])
    assert "collision" in table[0]["outcomes"] and table[0]["collision"] == 0.5
    monkeypatch.setattr(sim, "OUTCOMES", (*sim.OUTCOMES, "target_backside"))
    assert "target_backside" in sw.format_table(sw.aggregate(rows, bins=[0, 180]))


def _write(tmp_path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


GANTRY_TOML = """
name = "my-gantry"
[camera]
from = "afma6"
[target]
from = "square"
side = 0.1
pose = { t = [0.8, 0.3, 0.4], r_deg = [0, 0, 0] }
[robot]
kind = "gantry"
[goal]
joints = [0.0, 0.0, 0.0, 0.0, 0.4, 0.0]
[start]
rz_deg = [0, 60]
tx = [-0.02, 0.02]
[control]
gain = 2.0
duration = 3.0
depth = "pose"
[sweep]
episodes = 3
schemes = ["cartesian", "polar"]
"""


def test_gantry_scenario_file(tmp_path):
    robot = sim.Gantry.afma6()
    goal_pose = robot.camera([0, 0, 0, 0, 0.4, 0])
    centre = (goal_pose @ sim.pose(t=(0, 0, 0.6)))[:3, 3]
    # the target faces the goal camera: give its pose as the goal camera's, 0.6 m ahead
    R = goal_pose[:3, :3]
    rx = math.atan2(-R[1, 2], R[2, 2])
    ry = math.asin(R[0, 2])
    rz = math.atan2(-R[0, 1], R[0, 0])
    text = GANTRY_TOML.replace("t = [0.8, 0.3, 0.4], r_deg = [0, 0, 0]", f"t = {centre.tolist()}, r = {[rx, ry, rz]}")
    rows = sw.sweep(None, scenario=_write(tmp_path, text), jobs=1, progress=False)
    assert len(rows) == 6 and {r["scenario"] for r in rows} == {"my-gantry"} and {r["depth"] for r in rows} == {"pose"}
    ok = [r for r in rows if r["outcome"] != "invalid_start"]
    assert ok and all(r["outcome"] in sim.OUTCOMES for r in ok)


@pytest.mark.parametrize("text, match", [
    ("[camera]\nfrom='afma6'\n[target]\nfrom='square'\n", "missing \\[goal\\]"),
    ("name='x'\nfoo=1\n", "unknown key 'foo'"),
    ("[camera]\nfrom='nope'\n[target]\nfrom='paper'\n[goal]\n", "from = 'nope'.*afma6.*normalized"),
    ("[camera]\nfocal=1\n[target]\nfrom='paper'\n[goal]\n", "\\[camera\\]"),
    ("[camera]\nfrom='normalized'\n[target]\nfrom='paper'\n[goal]\nr_deg=[0,0]\n", "\\[goal\\]"),
    ("[camera]\nfrom='normalized'\n[target]\nfrom='paper'\n[goal]\n[start]\nrz=[0,1]\n", "\\[start\\].*'rz'"),
    ("[camera]\nfrom='normalized'\n[target]\nfrom='paper'\n[goal]\n[robot]\nkind='arm'\n", "kind"),
    ("[camera]\nfrom='normalized'\n[target]\nfrom='paper'\n[goal]\n[start]\nrotation='nowhere:f'\n", "import"),
    ("[camera]\nfrom='normalized'\n[target]\nfrom='paper'\n[goal]\n[control]\ndepth='guess'\n", "depth"),
    ("not toml [", "not valid TOML"),
])
def test_bad_scenario_files(tmp_path, text, match):
    with pytest.raises(ValueError, match=match):
        load(_write(tmp_path, text))


def _ids(path) -> list:
    with open(path, newline="") as f:
        return [r["id"] for r in csv.DictReader(f)]


def test_scenario_file_locally_and_on_dask_resumes_without_loss(tmp_path):
    distributed = pytest.importorskip("distributed")
    f = tmp_path / "mine.toml"
    shutil.copy(EXAMPLE, f)
    kw = dict(episodes=5, schemes=["polar", "cartesian"], duration=3.0, progress=False)
    full = sw.sweep(tmp_path / "ref.csv", scenario=f, jobs=2, batch=2, **kw)
    part = sw.sweep(tmp_path / "s.csv", scenario=f, jobs=1, limit=4, **kw)  # interrupted after 4 rows
    assert len(part) == 4
    with open(tmp_path / "s.csv", "a") as fh:  # and a torn last line
        fh.write("abc,1,2")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as c:
        again = sw.sweep(tmp_path / "s.csv", scenario=f, scheduler=c.scheduler_address, batch=2, **kw)
    ids = _ids(tmp_path / "s.csv")
    assert len(ids) == len(set(ids)) == 10
    assert repr(again) == repr(full) and repr(sw.aggregate(again)) == repr(sw.aggregate(full))


def test_builtin_worlds_and_overrides():
    free = builtin("free")
    assert free.name == "free" and free.ranges["rz_deg"] == (0.0, 180.0) and free.depth == "exact"
    g = builtin("gantry")
    assert g.robot is not None and g.depth == "pose" and g.gain == 2.0
    s, _ = sw.resolve(world="gantry", ranges={"noise": (0, 1)}, gain=3.0)
    assert s.ranges["noise"] == (0, 1) and s.ranges["rz_deg"] == (0.0, 180.0) and s.gain == 3.0
    with pytest.raises(ValueError, match="world"):
        sw.resolve("moon")
    with pytest.raises(ValueError, match="world and scenario"):
        sw.resolve("free", world="free")
    assert set(PARAMETERS) >= {"latency", "noise", "depth_scale"}


def test_docs_python_example_runs(capsys):
    import re

    text = (EXAMPLE.parent / "sweeps.md").read_text()
    (code,) = [c for c in re.findall(r"```python\n(.*?)```", text, flags=re.S) if "Scenario(" in c]
    exec(compile(code, "docs/sweeps.md", "exec"), {"__name__": "docs_sweeps"})
    assert "| polar |" in capsys.readouterr().out
