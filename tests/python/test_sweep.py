"""ibvs.study.sweep: reproducible rows, resume, aggregate tables, figure, Dask path, CLI."""

import csv
import pickle

import numpy as np
import pytest

import ibvs
import ibvs.study.sweep as sw
from ibvs import sim
from ibvs.cli.main import main
from ibvs.study.schemes import points_only

# Small and fast: short episodes, few starts.
SMALL = dict(episodes=6, seed=7, duration=6.0, progress=False)


def test_reproducible_for_a_seed(tmp_path):
    a = sw.sweep(tmp_path / "a.csv", jobs=1, **SMALL)
    b = sw.sweep(tmp_path / "b.csv", jobs=2, **SMALL)
    assert len(a) == 6 * len(points_only())
    assert [r["id"] for r in a] == [r["id"] for r in b]
    assert repr(a) == repr(b)
    # what is in the file is what was returned
    loaded = sw.load(tmp_path / "a.csv")
    assert [r["id"] for r in loaded] == [r["id"] for r in sorted(a, key=lambda r: (r["config"], r["index"], r["scheme"]))]
    c = sw.sweep(None, jobs=1, **{**SMALL, "seed": 8})
    assert [r["rz_deg"] for r in c] != [r["rz_deg"] for r in a]


def test_same_start_for_every_scheme_and_index_stable():
    spec = sw.SweepSpec(seed=3, episodes=5)
    assert sw.samples(spec, [4]) == sw.samples(sw.SweepSpec(seed=3, episodes=50), [4])
    rows = sw.sweep(None, jobs=1, **{**SMALL, "episodes": 2})
    for i in range(2):
        starts = {tuple(r[p] for p in sw.PARAMETERS) for r in rows if r["index"] == i}
        assert len(starts) == 1


def test_resume_after_interruption(tmp_path):
    out = tmp_path / "s.csv"
    full = sw.sweep(tmp_path / "ref.csv", jobs=1, **SMALL)
    n = len(full)
    part = sw.sweep(out, jobs=1, limit=n // 2 + 1, **SMALL)  # "interrupted" after half
    assert len(part) == n // 2 + 1
    with open(out, "a") as f:  # a torn last line, as a kill mid-write leaves
        f.write("abc,def,1")
    again = sw.sweep(out, jobs=2, **SMALL)
    with open(out, newline="") as f:
        ids = [r["id"] for r in csv.DictReader(f)]
    assert len(ids) == len(set(ids)) == n
    assert repr(again) == repr(full)
    assert repr(sw.aggregate(again)) == repr(sw.aggregate(full))
    # a third run does nothing new; more episodes extend the same file
    assert repr(sw.sweep(out, jobs=1, **SMALL)) == repr(again)
    more = sw.sweep(out, jobs=1, **{**SMALL, "episodes": 7})
    assert len(more) == n + len(points_only())


def test_aggregate_and_table():
    rows = sw.sweep(None, jobs=1, schemes=["cartesian", "polar"], grid={"rz_deg": [0, 60, 170]}, duration=15.0,
                    progress=False)
    assert len(rows) == 6
    table = sw.aggregate(rows, bins=[0, 90, 180])
    assert [(t["scheme"], t["bin"], t["n"]) for t in table] == [
        ("cartesian", "[0, 90)", 2), ("cartesian", "[90, 180]", 1), ("polar", "[0, 90)", 2), ("polar", "[90, 180]", 1)]
    by = {(t["scheme"], t["lo"]): t for t in table}
    assert by[("polar", 90.0)]["converged"] == 1.0
    # large rotation: Cartesian IBVS retreats far more than IBVS-P
    assert by[("cartesian", 90.0)]["retreat"] > 0.5 > by[("polar", 90.0)]["retreat"]
    for t in table:
        assert 0 <= t["left_image"] <= 1 and t["joint_limit"] == 0
        assert sum(t[o] for o in t["outcomes"]) == pytest.approx(1)  # every outcome has its column
    text = sw.format_table(table)
    assert all(o in text.splitlines()[0] for o in sim.OUTCOMES)
    assert text.count("\n|") == 5 and "| polar | [90, 180] | 1 | 100.0 %" in text
    # no nan, no empty cell: n/a, and why under the table (Cartesian IBVS never converged past 90 deg)
    assert "nan" not in text and "|  |" not in text and "n/a (time (s)): no episode of the bin converged" in text
    with pytest.raises(ValueError, match="by"):
        sw.aggregate(rows, by="nope")
    with pytest.raises(ValueError, match="bins"):
        sw.aggregate(rows, bins=[10, 0])


def test_figure(tmp_path):
    pytest.importorskip("matplotlib")
    rows = sw.sweep(None, jobs=1, schemes=["polar"], grid={"rz_deg": [10, 100]}, duration=4.0, progress=False)
    sw.figure(sw.aggregate(rows), tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 1000


def test_registry_and_bad_arguments(tmp_path):
    def mine(gain):
        return ibvs.Servo(ibvs.Layout.polar(4), gain=gain)

    sw.register_scheme("polar-copy", mine)
    try:
        with pytest.raises(ValueError, match="already registered"):
            sw.register_scheme("polar-copy", mine)
        rows = sw.sweep(None, jobs=1, schemes=["polar", "polar-copy"], **{**SMALL, "episodes": 2})
        a = [r for r in rows if r["scheme"] == "polar"]
        b = [r for r in rows if r["scheme"] == "polar-copy"]
        assert [r["frames_to_converge"] for r in a] == [r["frames_to_converge"] for r in b]
    finally:
        del sw.SCHEMES["polar-copy"]
    with pytest.raises(TypeError, match="factory"):
        sw.register_scheme("x", 3)
    for kw, match in [({"schemes": ["nope"]}, "schemes"), ({"world": "moon"}, "world"), ({"episodes": -1}, "episodes"),
                      ({"jobs": 0}, "jobs"), ({"ranges": {"nope": (0, 1)}}, "ranges"),
                      ({"ranges": {"tx": (1, 0)}}, "ranges"), ({"depth": "guess"}, "depth"),
                      ({"ranges": {"depth_scale": (0, 1)}}, "depth_scale")]:
        with pytest.raises(ValueError, match=match):
            sw.sweep(None, progress=False, **kw)
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="out"):
        sw.sweep(bad, episodes=1, progress=False)


def _broken_in_workers(parent: int, gain: float):
    """A scheme factory that works in the caller (the sweep may try it there first) and fails in workers.
    Module level, so that any multiprocessing start method can send it (functools.partial of it)."""
    import os

    if os.getpid() == parent:
        return ibvs.Servo(ibvs.Layout.polar(4), gain=gain)
    raise ValueError("boom from a worker")


def test_a_worker_error_reaches_the_caller_and_no_worker_is_left():
    import functools
    import multiprocessing
    import os

    sw.register_scheme("broken", functools.partial(_broken_in_workers, os.getpid()))
    try:
        with pytest.raises(ValueError, match="boom from a worker") as info:
            sw.sweep(None, jobs=2, batch=2, schemes=["broken"], **{**SMALL, "episodes": 20})
    finally:
        del sw.SCHEMES["broken"]
    assert "_broken_in_workers" in str(info.value.__cause__)  # the worker's traceback comes along
    assert multiprocessing.active_children() == []


def test_partitioned_scheme(tmp_path, capsys):
    """The partitioned law (a PartitionedServo) is a registered, picklable scheme: a pure rotation
    about the optical axis needs no camera retreat, unlike Cartesian IBVS."""
    assert pickle.loads(pickle.dumps(sw.SCHEMES["partitioned"]))(1.0).gain == 1.0
    rows = sw.sweep(None, jobs=1, schemes=["partitioned", "cartesian"], grid={"rz_deg": [30, 170]}, duration=20.0,
                    progress=False)
    by = {(r["scheme"], r["rz_deg"]): r for r in rows}
    for rz in (30.0, 170.0):
        assert by[("partitioned", rz)]["outcome"] == "converged"
        assert by[("partitioned", rz)]["camera_retreat"] < 1e-9
    assert by[("cartesian", 170.0)]["camera_retreat"] > 0.5
    assert main(["sweep", "--out", str(tmp_path / "p.csv"), "--episodes", "2", "--schemes", "partitioned",
                 "--duration", "4", "--jobs", "1", "--quiet"]) == 0
    assert "| partitioned |" in capsys.readouterr().out


def test_gantry_world():
    rows = sw.sweep(None, jobs=1, world="gantry", schemes=["cartesian"], episodes=2, seed=1, duration=3.0,
                    progress=False)
    assert len(rows) == 2 and all(r["depth"] == "pose" for r in rows)
    assert all(r["outcome"] in ("converged", "timeout", "joint_limit", "invalid_start", "left_image") for r in rows)


def test_dask_matches_local():
    distributed = pytest.importorskip("distributed")
    local = sw.sweep(None, jobs=1, **SMALL)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as c:
        remote = sw.sweep(None, scheduler=c.scheduler_address, batch=5, **SMALL)
        with distributed.Client(c) as client:
            remote2 = sw.sweep(None, scheduler=client, **SMALL)
    assert repr(sw.aggregate(remote)) == repr(sw.aggregate(local)) == repr(sw.aggregate(remote2))
    assert repr(remote) == repr(local) == repr(remote2)


def test_cli(tmp_path, capsys):
    out = tmp_path / "cli.csv"
    assert main(["sweep", "--out", str(out), "--episodes", "3", "--schemes", "polar", "cartesian", "--duration", "4",
                 "--jobs", "1", "--quiet", "--range", "rz_deg=0:90", "--bin-width", "45"]) == 0
    text = capsys.readouterr().out
    assert "| polar | [0, 45)" in text and "3 episodes (6 rows: 2 schemes each) in" in text
    assert all(o in text for o in ("diverged", "timeout", "target_backside", "collision"))
    for bad in (["sweep"], ["sweep", "--out", str(out), "--episodes", "-3"], ["sweep", "--out", str(out), "--schemes", "x"],
                ["sweep", "--out", str(out), "--range", "tx=1:0"], ["sweep", "--out", str(out), "--range", "bogus=0:1"],
                ["sweep", "--out", str(out), "--jobs", "0"], ["sweep", "--out", str(out), "--world", "moon"],
                ["sweep", "--out", str(out), "--grid", "rz_deg=a,b"],
                ["sweep", "--out", str(out), "--range", "noise=-1:0"]):
        with pytest.raises(SystemExit) as e:
            main(bad)
        assert e.value.code == 2, bad
    capsys.readouterr()


def test_angle_wrap_option():
    """The sweep's angle_wrap is set on every ibvs.Servo, recorded per row and part of the config."""
    kw = dict(jobs=1, schemes=["polar", "partitioned"], grid={"rz_deg": [179.8]}, duration=2.0,
              progress=False)
    a = sw.sweep(None, **kw)
    b = sw.sweep(None, angle_wrap="per_point", **kw)
    assert {r["angle_wrap"] for r in a} == {"consistent"} and {r["angle_wrap"] for r in b} == {"per_point"}
    assert a[0]["config"] != b[0]["config"]
    with pytest.raises(ValueError, match="angle_wrap"):
        sw.sweep(None, angle_wrap="both", **kw)


def test_goal_pose_option():
    """The sweep's goal_pose reaches every PBVS episode and is part of the config only when given (a taught sweep's
    config is the one it had before the option). With the pose depth mode the estimate's translation is times
    depth_scale k: a taught goal is scaled alike and PBVS reaches it; a given one is not, and PBVS stops where k t =
    t*, |t*| |1/k - 1| from the goal (the rotation estimate is unscaled)."""
    kw = dict(jobs=1, schemes=["pbvs"], grid={"depth_scale": [1.25]}, depth="pose", duration=20.0, progress=False)
    default = sw.sweep(None, **kw)
    taught, given = (sw.sweep(None, goal_pose=g, **kw) for g in ("taught", "given"))
    assert default == taught and taught[0]["config"] != given[0]["config"]
    assert taught[0]["outcome"] == given[0]["outcome"] == "converged"
    setup = sw.resolve(world="free")[0]
    t_star = np.linalg.norm((np.linalg.inv(setup.goal_pose()) @ np.asarray(setup.target.pose))[:3, 3])
    assert taught[0]["final_translation_error"] < 1e-4
    # the error norm's tolerance (1e-5 m and rad) leaves k t within 1e-5 of t*: 1e-4 m covers it
    assert given[0]["final_translation_error"] == pytest.approx(t_star * abs(1 / 1.25 - 1), abs=1e-4)
    with pytest.raises(ValueError, match="goal_pose"):
        sw.sweep(None, goal_pose="measured", **kw)


@pytest.mark.parametrize("key, field, good, bad", [("angle_wrap", "angle_wrap", "per_point", "both"),
                                                    ("goal_pose", "goal_pose_mode", "given", "measured")])
def test_control_keys_in_a_scenario_file(tmp_path, key, field, good, bad):
    """angle_wrap and goal_pose are [control] keys of scenario files; a bad value is refused naming the key."""
    from pathlib import Path

    from ibvs.study import scenario

    text = (Path(__file__).parents[2] / "docs" / "scenario.toml").read_text()
    for value, ok in ((good, True), (bad, False)):
        path = tmp_path / f"{value}.toml"
        path.write_text(text.replace("[control]\n", f'[control]\n{key} = "{value}"\n'))
        if ok:
            assert getattr(scenario.load(path)[0], field) == good
        else:
            with pytest.raises(ValueError, match=key):
                scenario.load(path)
