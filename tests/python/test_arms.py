"""Arms everywhere: [robot] kind = "urdf" in scenario files (an example arm or a URDF path relative to the
file, its frame and eMc), their errors naming the key; sweeps over an arm whose unreachable starts are
rows with outcome "unreachable", counted in the tables and the summary, locally, in worker processes and
on Dask; `ibvs run --world arm --robot panda|ur5|PATH.urdf`; and a missing Pinocchio said in one line."""

from __future__ import annotations

import math
import pickle
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import ibvs.study.sweep as sw
from ibvs import sim
from ibvs.cli.main import main
from ibvs.study.scenario import Scenario, load, offset
from ibvs.study.schemes import SCHEMES

pytest.importorskip("pinocchio")
EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "scenario_arm.toml"
#: Six starts straight back from the goal: the first (1.5 m back, 2 m above the target) out of the
#: Panda's reach, the other five reachable.
GRID = {"tz": [-1.5, -0.05, 0.0, 0.03, 0.05, 0.08]}

ARM_FILE = """
name = "{name}"
[camera]
from = "afma6"
[target]
from = "square"
side = 0.1
pose = {{ t = {target} }}
[robot]
kind = "urdf"
{robot}
[goal]
{goal}
[start]
rz_deg = [0.0, 60.0]
tz = [-0.05, 0.05]
[control]
duration = 3.0
depth = "pose"
"""
LOOKING_DOWN = "t = [0.45, 0.0, 0.5]\nr_deg = [180.0, 0.0, 0.0]"


def write(tmp_path, robot: str, goal: str = LOOKING_DOWN, name: str = "arm", target=(0.45, 0.0, 0.0)) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(ARM_FILE.format(name=name, robot=robot, goal=goal, target=[float(x) for x in target]))
    return path


@pytest.fixture(scope="module")
def example():
    return load(EXAMPLE)


def test_example_file(example):
    scenario, options = example
    robot = scenario.robot
    assert isinstance(robot, sim.UrdfRobot) and robot.example_name == "panda" and robot.dof == 7
    assert np.allclose(robot.mount, sim.pose(t=(0.05, 0.0, 0.04)))
    q = scenario.goal_joints()  # the goal pose, reached by solve_ik once
    assert np.abs(robot.camera(q) - scenario.goal_pose()).max() < 1e-9 and robot.outside_limits(q) < 0
    assert scenario.goal_joints() is q
    assert options == {"episodes": 40, "seed": 0, "schemes": ["cartesian", "polar", "stacked"]}


def test_urdf_path_relative_to_the_file_and_goal_joints(tmp_path):
    shutil.copy(sim.example_robot_urdf("ur5"), tmp_path / "my_arm.urdf")
    goal = list(sim.cases.ARMS["ur5"][0])
    mount = sim.pose(t=(0.0, 0.0, 0.02), r=(0.0, 0.0, 0.1))
    seen = (sim.cases.arm_robot("ur5", mount).camera(goal) @ sim.pose(t=(0, 0, 0.5)))[:3, 3]  # 0.5 m ahead
    path = write(tmp_path, 'urdf = "my_arm.urdf"\nframe = "tool0"\neMc = { t = [0.0, 0.0, 0.02], r = [0.0, 0.0, 0.1] }',
                 goal=f"joints = {goal}", target=seen)
    scenario, _ = load(path)
    assert scenario.robot.example_name is None and Path(scenario.robot._args[0]) == tmp_path / "my_arm.urdf"
    assert np.array_equal(scenario.goal_joints(), goal)
    rows = sw.sweep(None, scenario=scenario, episodes=2, schemes=["cartesian"], jobs=1, progress=False)
    assert len(rows) == 2 and all(r["outcome"] not in sw.NOT_RUN for r in rows)
    # the config hash follows the URDF's content, not where it lies
    other = tmp_path / "elsewhere"
    other.mkdir()
    shutil.copy(tmp_path / "my_arm.urdf", other / "my_arm.urdf")
    shutil.copy(path, other / "arm.toml")
    assert load(other / "arm.toml")[0].key() == scenario.key()


@pytest.mark.parametrize("robot, goal, words", [
    ('example = "kuka"', LOOKING_DOWN, ["[robot]", "example", "panda"]),
    ('example = "panda"\nurdf = "a.urdf"', LOOKING_DOWN, ["[robot]", "urdf", "example"]),
    ("", LOOKING_DOWN, ["[robot]", "urdf", "example"]),
    ('urdf = "missing.urdf"\nframe = "tool0"', LOOKING_DOWN, ["[robot]", "urdf", "missing.urdf"]),
    ('urdf = "arm.urdf"', LOOKING_DOWN, ["[robot]", "frame"]),
    ('urdf = "arm.urdf"\nframe = "hand"', LOOKING_DOWN, ["[robot]", "frame 'hand'", "tool0"]),
    ('urdf = 3\nframe = "tool0"', LOOKING_DOWN, ["[robot]", "urdf"]),
    ('example = "panda"\nframe = 7', LOOKING_DOWN, ["[robot]", "frame"]),
    ('example = "panda"\nfoo = 1', LOOKING_DOWN, ["[robot]", "'foo'", "eMc"]),
    ('example = "panda"\neMc = { t = [0.0, 0.0] }', LOOKING_DOWN, ["[robot] eMc", "t must be 3"]),
    ('example = "panda"\neMc = { x = 1 }', LOOKING_DOWN, ["[robot] eMc", "'x'"]),
    ('example = "panda"\neMc = [1, 2]', LOOKING_DOWN, ["[robot] eMc", "table"]),
    ('example = "panda"\nq_min = [0.0, 1.0]', LOOKING_DOWN, ["[robot]", "q_min", "7 joints"]),
    ('example = "panda"\ndamping = "much"', LOOKING_DOWN, ["[robot]", "damping"]),
    ('example = "panda"', "joints = [0.0, 0.1]", ["goal", "7 finite joint positions"]),
    ('example = "panda"', "joints = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]", ["goal", "joint 4", "limits"]),
    ('example = "panda"', 'joints = ["a"]', ["[goal]", "joints"]),
    ('example = "panda"', "t = [0.45, 0.0, 3.0]\nr_deg = [180.0, 0.0, 0.0]", ["goal", "cannot reach"]),
])
def test_bad_robot_tables_are_refused_naming_the_key(tmp_path, robot, goal, words):
    shutil.copy(sim.example_robot_urdf("ur5"), tmp_path / "arm.urdf")
    path = write(tmp_path, robot, goal)
    with pytest.raises(ValueError) as e:
        load(path)
    text = str(e.value)
    assert str(path) in text and all(w in text for w in words), text


def test_sweep_counts_the_unreachable_start(example, tmp_path, capsys):
    """Six starts on the Panda, the first unreachable: its rows say so (no episode run), the table and the
    summary count it; the rows are the same in worker processes."""
    scenario = example[0].replace(duration=4.0)
    out = tmp_path / "arm.csv"
    rows = sw.sweep(out, scenario=scenario, grid=GRID, schemes=["cartesian", "stacked"], jobs=2, batch=1,
                    progress=False)
    assert len(rows) == 12
    gone = [r for r in rows if r["outcome"] == "unreachable"]
    assert [(r["index"], r["tz"]) for r in gone] == [(0, -1.5), (0, -1.5)]
    assert all(r["frame"] == -1 and math.isnan(r["path_length"]) for r in gone)
    assert any(r["outcome"] == "converged" for r in rows)
    assert sw.starts(rows) == {"starts": 6, "run": 5, "invalid_start": 0, "unreachable": 1}
    assert "6 starts: 5 run, 1 unreachable by the robot" in sw.format_starts(rows)
    table = sw.aggregate(rows, by="tz", bins=[-2.0, 0.0, 0.1])
    for scheme in ("cartesian", "stacked"):
        first, second = (t for t in table if t["scheme"] == scheme)
        assert (first["n"], first["unreachable"], first["invalid"]) == (1, 1, 0)  # tz -1.5 and -0.05
        assert (second["n"], second["unreachable"]) == (4, 0)
        assert "unreachable" not in first["outcomes"]
    text = sw.format_table(table, by="tz")
    assert "unreachable starts" in text.splitlines()[0]
    # in-process rows equal the worker processes' (and those saved in the file)
    again = sw.sweep(None, scenario=scenario, grid=GRID, schemes=["cartesian", "stacked"], jobs=1, progress=False)
    assert repr(again) == repr(rows) == repr(sw.load(out))


def test_scenario_with_an_arm_pickles_and_keeps_its_key(example, tmp_path):
    scenario = example[0]
    back = pickle.loads(pickle.dumps(scenario))
    assert back.key() == scenario.key() and back.robot.example_name == "panda"
    assert pickle.dumps(scenario.robot).count(b"panda.urdf") == 0  # an example travels by its name
    path_robot = sim.UrdfRobot(sim.example_robot_urdf("ur5"), "tool0", sim.pose(t=(0, 0, 0.02)))
    again = pickle.loads(pickle.dumps(path_robot))
    q = np.array(sim.cases.ARMS["ur5"][0])
    assert again.camera(q).tobytes() == path_robot.camera(q).tobytes() and again.fingerprint() == path_robot.fingerprint()
    spec = sw.SweepSpec(scenario.replace(duration=2.0), episodes=2, schemes=("cartesian",))
    back = pickle.loads(pickle.dumps(spec))
    assert back.config() == spec.config()
    assert repr(sw.run_episode(back, 1, "cartesian")) == repr(sw.run_episode(spec, 1, "cartesian"))
    # the config hash is the same in another process (no Pinocchio object's address in it)
    code = f"from ibvs.study.scenario import load; print(load({str(EXAMPLE)!r})[0].key())"
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert other.stdout.strip() == scenario.key()


def test_dask_worker_processes_rebuild_the_arm(example):
    distributed = pytest.importorskip("dask.distributed")
    scenario = example[0].replace(duration=2.0)
    grid = {"tz": GRID["tz"][:3]}
    local = sw.sweep(None, scenario=scenario, grid=grid, schemes=["cartesian"], jobs=1, progress=False)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as c, \
            distributed.Client(c) as client:
        rows = sw.sweep(None, scenario=scenario, grid=grid, schemes=["cartesian"], scheduler=client, progress=False)
    assert repr(rows) == repr(local) and rows[0]["outcome"] == "unreachable"


def test_sweep_cli_over_an_arm(tmp_path, capsys):
    out = tmp_path / "arm.csv"
    assert main(["sweep", "--scenario", str(EXAMPLE), "--out", str(out), "--grid", "tz=-1.5,0", "--duration", "2",
                 "--schemes", "cartesian", "--jobs", "1", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "| unreachable starts |" in text.splitlines()[0]
    assert "2 starts: 1 run, 1 unreachable by the robot" in text


def test_sweep_cli_over_the_builtin_arm(tmp_path, capsys):
    """`ibvs sweep --world arm`: the built-in arm scenario (the Panda), its starts solved by IK, every one counted."""
    out = tmp_path / "arm.csv"
    assert main(["sweep", "--world", "arm", "--out", str(out), "--episodes", "2", "--duration", "2",
                 "--schemes", "cartesian", "--jobs", "1", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "2 episodes (2 rows: 1 scheme each)" in text and re.search(r"2 starts: \d run, \d unreachable", text)
    assert len(out.read_text().splitlines()) == 3  # header + one row per start


def test_run_on_an_arm_converges_by_default(capsys):
    """Without --scheme an arm runs the stacked hybrid, which converges; IBVS-P (the other worlds' default)
    loses a point from the image early in the arm's general motion. --help says so."""
    assert main(["run", "--world", "arm"]) == 0
    out = capsys.readouterr().out
    assert "stacked hybrid" in out and "converged at frame 765" in out
    assert main(["run", "--world", "arm", "--scheme", "polar", "--duration", "2"]) == 1
    assert "left_image" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    assert "stacked for --world arm" in " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize("robot", ["panda", "ur5"])
def test_run_an_example_arm(robot, capsys):
    assert main(["run", "--world", "arm", "--robot", robot, "--scheme", "stacked"]) == 0
    out = capsys.readouterr().out
    assert f"camera on the {robot} arm" in out and "converged" in out and re.search(r"joint limit +no", out)


def test_run_every_scheme_and_option_on_an_arm(capsys):
    """Every scheme, and the depth, noise, latency, gain, tolerance, angle-wrap and vision options, on the Panda
    (1 s episodes: what matters here is that the arm takes every option of `ibvs run`)."""
    for scheme in (s for s in SCHEMES if not s.startswith("moments")):  # moments: not on the square
        assert main(["run", "--world", "arm", "--scheme", scheme, "--duration", "1"]) in (0, 1)
        assert "status" in capsys.readouterr().out
    assert main(["run", "--world", "arm", "--robot", "ur5", "--scheme", "polar", "--duration", "1", "--depth", "estimated",
                 "--noise", "0.5", "--latency", "2", "--gain", "0.5", "--tolerance", "1e-3", "--angle-wrap",
                 "per_point", "--seed", "3"]) in (0, 1)
    out = capsys.readouterr().out
    assert "camera on the ur5 arm" in out and "per-point wrap" in out
    pytest.importorskip("cv2")
    assert main(["run", "--world", "arm", "--scheme", "cartesian", "--duration", "1", "--vision", "dots"]) in (0, 1)
    assert "status" in capsys.readouterr().out


def test_run_an_arm_from_its_urdf_with_plot_and_animation(tmp_path, capsys):
    urdf = tmp_path / "my_ur5.urdf"
    shutil.copy(sim.example_robot_urdf("ur5"), urdf)
    goal = ",".join(map(str, sim.cases.ARMS["ur5"][0]))
    args = ["run", "--world", "arm", "--robot", str(urdf), "--frame", "tool0", "--emc", "0.05,-0.03,0.04,0.1,-0.2,0.3",
            "--goal-joints", goal, "--scheme", "cartesian", "--plot", str(tmp_path / "arm.png"),
            "--animate", str(tmp_path / "arm.gif"), "--speed", "30"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "camera on the my_ur5 arm" in out and "converged" in out
    assert (tmp_path / "arm.png").stat().st_size > 10_000 and (tmp_path / "arm.gif").stat().st_size > 1000
    # the same arm as the example's: the same episode, to the bit
    assert main(["run", "--world", "arm", "--robot", "ur5", "--scheme", "cartesian"]) == 0
    assert capsys.readouterr().out.split("\n", 1)[1] == out.split("\n", 1)[1].split("  figure")[0]


@pytest.mark.parametrize("args, word", [
    (["--robot", "kuka"], "--robot"),
    (["--robot", "missing.urdf"], "--robot"),
    (["--robot", "{urdf}"], "--frame"),
    (["--robot", "{urdf}", "--frame", "hand"], "--frame"),
    (["--emc", "1,2,3"], "--emc"),
    (["--emc", "0,0,0,0,0,nan"], "--emc"),
    (["--goal-joints", "0,0"], "--goal-joints"),
    (["--goal-joints", "0,0,0,0,0,0,0"], "--goal-joints"),  # joint 4 of the Panda outside its limits
    (["--robot", "{urdf}", "--frame", "panda_link8", "--goal-joints", "0,0,0,-1.5,0,1.5,0"],
     "--goal-joints"),  # the start, 12 cm back from the upright arm's camera, is out of its reach
    (["--world", "gantry", "--robot", "ur5"], "--robot"),
    (["--world", "free", "--emc", "0,0,0,0,0,0"], "--emc"),
    (["--case", "z-rotation"], "--case"),
])
def test_bad_arm_arguments_exit_2_with_one_line(tmp_path, capsys, args, word):
    urdf = tmp_path / "arm.urdf"
    shutil.copy(sim.example_robot_urdf("panda"), urdf)
    args = [a.format(urdf=urdf) for a in args]
    world = [] if "--world" in args else ["--world", "arm"]
    with pytest.raises(SystemExit) as e:
        main(["run", *world, *args])
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1 and word in err and "Traceback" not in err, err


def test_missing_pinocchio_is_one_line(tmp_path, monkeypatch, capsys):
    """Without Pinocchio: `ibvs run --world arm`, a scenario file with an arm and UrdfRobot say how to
    install it (from the repository root: ibvs is on no package index)."""
    monkeypatch.setitem(sys.modules, "pinocchio", None)  # import pinocchio raises ImportError
    with pytest.raises(SystemExit) as e:
        main(["run", "--world", "arm"])
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1 and 'pip install ".[robots]"' in err and "root" in err
    with pytest.raises(SystemExit) as e:
        main(["sweep", "--scenario", str(EXAMPLE), "--out", str(tmp_path / "s.csv")])
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1 and "[robot]" in err and 'pip install ".[robots]"' in err
    with pytest.raises(ImportError, match=r'pip install "\.\[robots\]"'):
        sim.UrdfRobot(sim.example_robot_urdf("ur5"), "tool0")


def test_python_scenario_with_an_arm_object():
    """A Scenario built in Python with a UrdfRobot and a goal pose, as the docs show."""
    arm = sim.UrdfRobot.example("ur5", sim.pose(t=(0.0, 0.0, 0.02)))
    goal = arm.camera(np.array(sim.cases.ARMS["ur5"][0]))
    target = sim.Target.square(0.1, goal @ sim.pose(t=(0, 0, 0.5)))
    s = Scenario(sim.Camera.afma6(), target, goal, robot=arm, ranges={"tz": (-0.05, 0.05)}, duration=3.0,
                 depth="pose", name="ur5").validate()
    assert s.goal_joints().tobytes() == sim.solve_ik(arm, goal).q.tobytes()
    rows = sw.sweep(None, scenario=s, episodes=2, schemes=["cartesian"], jobs=1, progress=False)
    assert len(rows) == 2 and all(r["outcome"] not in sw.NOT_RUN for r in rows)
    p = s.sample(0, 1)
    start = s.start(p)
    assert np.abs(arm.camera(start) - s.goal_pose() @ offset(p)).max() < 1e-9
