"""Every code block of README.md and docs/*.md is executed, compiled or matched to a file that is; none is skipped
in silence.

- python: run as written (in a fresh namespace, in a temporary working directory), except where SHRINK replaces a
  study's thousands of episodes by a handful (the text's numbers come from the full run; here it must run and print).
- bash / sh: run by bash, `ibvs` being `python -m ibvs` of this interpreter and `docs/...` the repository's, with the
  same shrinking; or listed in NOT_RUN with the reason.
- cpp, cmake: the README's are tests/consumer/quickstart.cpp and the statements of tests/consumer/CMakeLists.txt,
  which CI builds and runs against an installed prefix and against the wheel (.ci/run).
- toml: loaded as a scenario and swept.
- A block that only includes a file (`--8<-- "path"`, MkDocs' snippets) shows that file, tested where it lives.
- text: printed output or a formula, not code.
A block that no rule covers fails the test, and so does a rule that no longer matches a block.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import ibvs

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md"] + sorted((ROOT / "docs").rglob("*.md"))
FENCE = re.compile(r"^(?P<indent>[ \t]*)```(?P<lang>[\w+-]*)[^\n]*\n(?P<body>.*?)^(?P=indent)```[ \t]*$", re.M | re.S)
INCLUDE = re.compile(r'^-{1,}8<-{1,}\s+"(?P<path>[^"]+)"$')


class Block:
    def __init__(self, page: Path, lang: str, body: str, line: int):
        self.page, self.lang, self.body, self.line = page, lang, body, line
        self.name = str(page.relative_to(ROOT))

    @property
    def id(self) -> str:
        return f"{self.name}:{self.line}"


def blocks() -> list[Block]:
    found = []
    for page in PAGES:
        text = page.read_text()
        for m in FENCE.finditer(text):
            indent = m.group("indent")
            body = "".join(x[len(indent):] if x.startswith(indent) else x for x in m.group("body").splitlines(True))
            found.append(Block(page, m.group("lang"), body, text.count("\n", 0, m.start()) + 1))
    return found


BLOCKS = blocks()

# A rule is keyed by (page, a text the block contains).
# Studies shrunk to a few episodes: [(text, replacement)]. The full run takes minutes (its time is written next to
# the command) and its numbers are the text's; the test checks that the block runs.
SHRINK = {
    ("docs/beyond.md", "ibvs sweep --out sweep.csv"): [("--episodes 1000", "--episodes 2 --jobs 1")],
    ("docs/beyond.md", "ibvs sweep --world gantry"): [("--episodes 1000", "--episodes 2 --jobs 1")],
    ("docs/beyond.md", 'sw.sweep("depth_scale.csv"'): [("episodes=1000", "episodes=12, jobs=1")],
    ("docs/beyond.md", "docs/scripts/depth_modes.py"): [(" 100 ", " 3 ")],
    ("docs/beyond.md", "docs/scripts/halfturn.py"): [(" 1200 ", " 12 ")],
    ("docs/beyond.md", "docs/scripts/flips.py"): [(" 40 ", " 1 ")],
    ("docs/direct.md", "docs/scripts/natural_domain.py"): [(" 2 ", " 1 quick ")],
    ("docs/direct.md", "ibvs bench --natural"): [("--frames 100", "--frames 4")],
    ("docs/sweeps.md", "--out mine.csv --figure mine.png"): [
        ("--figure mine.png\n", "--figure mine.png --episodes 2 --jobs 1\n"),
        ("--episodes 1000", "--episodes 3 --jobs 1")],
    ("docs/plots.md", 'frames = ibvs.viz.animate(result, "run.gif")'): [("duration=30.0", "duration=3.0")],
    # The reader's own arm: here the UR5 of example-robot-data, copied to my_arm.urdf.
    ("docs/sweeps.md", "--robot my_arm.urdf"): [
        ("ibvs sweep --scenario docs/scenario_arm.toml --out arm.csv\n",
         "cp \"$(python -c 'from ibvs import sim; print(sim.example_robot_urdf(\"ur5\"))')\" my_arm.urdf\n"
         "ibvs sweep --scenario docs/scenario_arm.toml --out arm.csv --episodes 2 --jobs 1\n")],
    ("docs/benchmarks.md", "--sections components --layout cartesian,stacked"): [("50000", "300"), ("20000", "300")],
    # The photometric rows of the page (2000 calls each, ~1 min): a smoke run here.
    ("docs/photometric.md", "--sections photometric"): [("taskset -c 1 ", ""), ("--iterations 2000", "--iterations 20")],
    # Issue 21's tasks beside their floors: pinned and 30000 iterations for the page's figures, a smoke run here.
    ("docs/benchmarks.md", "--sections components,tasks"): [("taskset -c 1 ", ""), ("30000", "300"), ("20000", "300")],
    # The full run (2 min on 2 cores) rewrites the page's tables; here a few episodes, written into the test's folder.
    ("docs/features.md", "python docs/scripts/moments_starts.py"): [
        ("python docs/scripts/moments_starts.py ", "python docs/scripts/moments_starts.py --shapes 1 ")],
    ("docs/hand-eye.md", "python docs/scripts/hand_eye.py"): [
        ("python docs/scripts/hand_eye.py\n", "python docs/scripts/hand_eye.py --quick --jobs 1 --docs .\n")],
    # The full run (about 2 min) rewrites the arms page's table; here 2 starts, written into the test's folder.
    ("docs/arms.md", "python docs/scripts/joint_limits.py"): [
        ("python docs/scripts/joint_limits.py\n", "python docs/scripts/joint_limits.py --quick --docs .\n")],
    # The physics testbed (docs/physics.md): one short case, one delay and gain, a fraction of a simulated second.
    ("docs/physics.md", "physics.py compare"): [
        ("--size 320x240 --duration 15", "--size 160x120 --duration 1 --cases general")],
    ("docs/physics.md", "physics.py latency"): [
        ("--json docs/figures/physics_latency.json", "--size 160x120 --delays 50 --gains 2"),
        ("--json docs/figures/physics_latency_cartesian.json", "--size 160x120 --delays 50 --gains 2")],
    ("docs/physics.md", "physics.py bench"): [("--seconds 5", "--seconds 0.2")],
    # The full study (about 10 min) wrote the page's table and figure; here two delays, one gain, one servo.
    ("docs/servo-loop.md", "docs/scripts/latency.py"): [
        ("--delays 0 25 50 75 100 125 150 --out docs/figures/latency.png",
         "--delays 0 100 --gains 4 --schemes cartesian --out latency.png")],
    ("docs/servo-loop.md", "ibvs bench --loop"): [("--frames 300", "--frames 20")],
}

# Blocks not run here, and why.
NOT_RUN = {
    ("README.md", 'pip install ".[test,plot,cpp]" && ibvs reproduce'):
        "the two commands: .ci/run runs them first, from a clean clone",
    ("docs/index.md", 'pip install ".[test,plot,cpp]" && ibvs reproduce'):
        "the README's two commands: .ci/run runs them",
    ("README.md", 'pip install ".[plot,robots]"'):
        "it builds and installs the package (minutes); .ci/run installs it the same way",
    ("README.md", "pip install --no-build-isolation"):
        "the development set-up (two full builds, minutes, and `bash .ci/run`, all of CI) is not run by the tests; "
        "CI builds and tests the same sources through the README's install and its own CMake build",
    ("docs/sweeps.md", "dask scheduler"):
        "it starts servers, one per terminal: tests/python/test_sweep_cluster.py runs these commands",
    ("docs/ros.md", "ibvs replay my_robot_bag"):
        "a real robot's bag, which the repository does not hold; tests/python/test_ros_replay.py replays a bag "
        "without /ibvs/config the same way",
    ("docs/ros.md", "ros2 launch"):
        "it needs ROS 2 (ros2 launch, rclpy), which the machine that tests ibvs does not have; "
        "tests/python/test_ros_node.py tests the node's logic and compiles the launch file",
    ("docs/installation.md", "pip wheel . -w dist"):
        "it builds the package (minutes from a clean checkout); .ci/run builds, installs and tests the wheel",
    ("docs/installation.md", "cibuildwheel"):
        "cibuildwheel builds Linux wheels in manylinux containers (Docker or Podman), which this machine does not "
        "run",
    ("docs/benchmarks.md", "--realtime"):
        "minutes of timing, taskset pinning and SCHED_FIFO (root); tests/python/test_bench.py runs the same "
        "programs briefly",
}

# Blocks that need something prepared first, and why.
PRELUDE = {
    # A figure of the reader's `result` in a window: a test has no display, so pyplot runs on Agg here, and
    # plt.show() warns that it cannot show (the warning is expected).
    ("docs/plots.md", "plt.show()"):
        "import matplotlib\nmatplotlib.use('Agg')\nimport ibvs\nfrom ibvs import sim\ncase = sim.cases.z_rotation()\n"
        "result = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), case.camera, case.target, case.start, "
        "case.goal, duration=2.0)\n",
}

# What a block must print: claims of the text, checked where they are cheap.
PRINTS = {
    # the luminance law and the photometric moments reach the goal (pose errors ~1e-10 and ~1e-13)
    ("docs/photometric.md", "servo.set_mu(0.0)"): ["ok rms error", "pose error 1.4e-10"],
    ("docs/photometric.md", "ibvs.photometric_moments(cam, render(T))"): ["pose error 5.9e-14"],
    ("README.md", "layout = ibvs.Layout.stacked(4)"): ["status 0 velocity"],
    ("README.md", "panda.kinematics(q)"): ["joint velocities (rad/s):"],
    ("docs/plots.md", "ibvs.viz.compare(runs, labels)"): ["converged / diverged"],
    # frame 218 and 1.0 mm with OpenCV 5.0, 220 and 1.1 mm with 4.14 (sub-pixel corners differ between versions)
    ("docs/arms.md", "cv2.aruco.ArucoDetector"): ["(converged)", "camera 1."],
    ("docs/arms.md", "print(r, r.history.q.shape)"): ["converged at frame 765"],
    ("docs/wide.md", 'ImageSensor.for_target(fish, target, "dots"'): ["converged at frame"],
    ("docs/arms.md", 'sim.cases.eye_to_hand("ur5", "z_rotation")'): ["eye_to_hand)", "converged at frame 795", "True"],
    ("docs/arms.md", "for projector in (None"): ["no avoidance: joint_limit", "classical: joint_limit",
                                                  "large: converged"],
    ("docs/arms.md", "ibvs.SecondaryTask(7, projector"): ["active=1", "d|e|^2/dt changed by"],
    ("docs/simulator.md", "goal_pose=goal_pose)"): ["taught: converged, 0.0 mm from the goal",
                                                     "given: converged, 750.0 mm from the goal, z = -750.0 mm"],
    ("docs/simulator.md", "sim.LineSource(i, (i + 1) % 4)"): ["lines          converged at frame 368",
                                                                "points + lines converged at frame 369"],
    ("docs/simulator.md", "sim.SegmentSource(0, 4), sim.SegmentSource(2, 6)"): [
        "segments:         converged at frame 392", "disc + diameters: converged at frame 383, 0.004 mm"],
    ("docs/vision.md", 'vision.blob_source(case.camera, disc, "ellipse")'): [
        "ellipse from images: converged at frame 361", "moments from images: converged at frame",
        "moments from images within 5 mm and 0.1 deg of the goal: True"],
    ("docs/simulator.md", "noise=0.3, latency=1, seed=7"): [
        "converged at frame 442 (error norm 0.00172 < tolerance 0.002)",
        "converged at frame 377 (worst point 0.931 px from its goal <= tolerance_px 1)",
        "pose error at the last frame 17.8 mm / 1.69 deg", "pose error at the last frame 62.5 mm / 5.93 deg"],
    ("docs/control-law.md", "ibvs.PartitionedServo(4, gain=1.0)"): ["cartesian    Tz"],
    ("docs/control-law.md", "max_linear_speed=0.5, max_angular_speed=1.0"): ["True 0.0625"],
    ("docs/hand-eye.md", 'mount="eye_in_hand", method="park")'): ["eMc error: 1.12 mm, 0.099 deg"],
    # sub-pixel tag corners differ between OpenCV versions: 0.50 mm, 0.054 deg with 4.14; 0.41 mm, 0.050 deg with 5.1
    ("docs/hand-eye.md", "detector.detect(grab(q))"): ["10 stations; bMc error 0.", " mm, 0.0"],
    ("docs/hand-eye.md", "def median_ms(case, robot, runs=9)"): ["us more per frame"],
    ("docs/hand-eye.md", "MiscalibratedRobot(case.robot, wrong)"): ["UrdfRobot: converged", "MiscalibratedRobot: converged"],
    ("docs/beyond.md", "docs/scripts/gain_saturation.py"): ["| z_rotation | polar | gain 1 | converged | 13.2 |"],
    ("docs/ros.md", 'record="gantry.mcap"'): ["largest difference from the recorded twists: 0"],
    ("docs/servo-loop.md", "ibvs servo docs/servo.toml"): ["converged: every point within 0.5 px", "dry run"],
    ("docs/servo-loop.md", "ibvs bench --loop"): ["servo loop overhead per frame"],
    ("docs/servo-loop.md", "docs/scripts/latency.py"): ["| 100 | "],
    ("docs/ros.md", "core = ros.ServoNodeCore"): ["camera_optical_frame", "ramping"],
    ("docs/wide.md", "measurements_desired=goal"): ["target centre 100.6 deg off the axis", "converged at frame"],
    ("docs/wide.md", "estimator.estimate_bearings(fish.to_bearing(pixels))"): [
        "deg off the axis: [100.  113.8 109.3  96.1]", "depth=exact: converged", "depth=pose: converged"],
    ("docs/ros.md", "--record run.mcap --rerun run.rrd"): ["converged", "123 twists compared, largest difference"],
    ("docs/features.md", "the same segment, from its other end"): ["error against its reverse: 0.0"],
    ("docs/features.md", "def turn(feature, degrees"): [
        "| p, third_order | 0.0 deg, 0.0 mm from the goal, z range 0.0 mm | 0.0 deg, 0.0 mm from the goal, z range 0.0 mm",
        "| 180.0 deg, 0.0 mm from the goal"],
    ("docs/features.md", "docs/scripts/moments_starts.py"): ["| radius up to (m) | interaction matrix | region, p |"],
    ("docs/features.md", "kite (an axis of symmetry)"): [
        "| kite (an axis of symmetry) | 5, ", "| rectangle (central symmetry) | 4, 0 | 6, "],
}


def rule(table: dict, block: Block):
    keys = [k for k in table if k[0] == block.name and k[1] in block.body]
    assert len(keys) <= 1, f"{block.id}: several rules match: {keys}"
    return (keys[0], table[keys[0]]) if keys else (None, None)


def substituted(block: Block) -> str:
    body = block.body
    for old, new in rule(SHRINK, block)[1] or []:
        assert old in body, f"{block.id}: {old!r} is no longer in the block: update SHRINK"
        body = body.replace(old, new)
    return body


def is_include(block: Block) -> bool:
    lines = [x.strip() for x in block.body.splitlines() if x.strip()]
    return bool(lines) and all(INCLUDE.match(x) for x in lines)


def by_lang(*langs: str) -> list[Block]:
    return [b for b in BLOCKS if b.lang in langs and not is_include(b)]


def test_every_block_has_a_rule():
    known = {"python", "bash", "sh", "cpp", "cmake", "toml", "text"}
    for b in BLOCKS:
        assert b.lang in known or is_include(b), f"{b.id}: a ```{b.lang} block: no rule runs or matches it"
        assert b.lang or is_include(b), f"{b.id}: a block without a language (```text for output)"
    used = {rule(t, b)[0] for t in (SHRINK, NOT_RUN, PRELUDE, PRINTS) for b in BLOCKS} - {None}
    stale = [k for t in (SHRINK, NOT_RUN, PRELUDE, PRINTS) for k in t if k not in used]
    assert not stale, f"rules that match no block: {stale}"
    assert len(by_lang("python")) >= 20 and len(by_lang("bash", "sh")) >= 8


def test_included_files_exist():
    includes = [(b, INCLUDE.match(x.strip())) for b in BLOCKS if is_include(b)
                for x in b.body.splitlines() if x.strip()]
    assert includes
    for b, m in includes:
        assert (ROOT / m.group("path").split(":")[0]).is_file(), f"{b.id}: {m.group('path')} does not exist"


@pytest.mark.parametrize("block", by_lang("python"), ids=lambda b: b.id)
def test_python_block_runs(block, tmp_path, monkeypatch, capsys):
    assert rule(NOT_RUN, block)[0] is None, "Python blocks all run"
    monkeypatch.chdir(tmp_path)  # the blocks write their files into the working directory
    monkeypatch.setattr(sys, "argv", [block.id])
    code = (rule(PRELUDE, block)[1] or "") + substituted(block)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="FigureCanvasAgg is non-interactive")  # plt.show() under Agg
        exec(compile(code, block.id, "exec"), {"__name__": "__main__"})
    out = capsys.readouterr().out
    for expected in rule(PRINTS, block)[1] or []:
        assert expected in out, f"{block.id} should print {expected!r}; it printed:\n{out}"


def _bench_cli() -> str | None:
    from test_bench import _ibvs_bench  # the same search as the benchmark's own tests

    return _ibvs_bench()


@pytest.mark.parametrize("block", by_lang("bash", "sh"), ids=lambda b: b.id)
def test_shell_block_runs(block, tmp_path):
    reason = rule(NOT_RUN, block)[1]
    if reason:
        pytest.skip(f"not run here: {reason}")
    body = substituted(block)
    body = re.sub(r"(?<![\w/.])docs/", str(ROOT / "docs") + "/", body)
    if "ibvs-bench" in body:
        cli = _bench_cli()
        if cli is None:
            if os.environ.get("IBVS_BENCH_REQUIRE_CLI"):
                pytest.fail("ibvs-bench is required (IBVS_BENCH_REQUIRE_CLI) but not found")
            pytest.skip("ibvs-bench is not built here (pip install . installs it; CI requires it)")
        body = body.replace("ibvs-bench", shlex.quote(cli))
    python = shlex.quote(sys.executable)
    prelude = f"set -euo pipefail\nibvs() {{ {python} -m ibvs \"$@\"; }}\npython() {{ {python} \"$@\"; }}\n"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(Path(ibvs.__file__).resolve().parents[1])] + [p for p in [os.environ.get("PYTHONPATH")] if p]),
        MPLBACKEND="Agg")
    run = subprocess.run(["bash", "-c", prelude + body], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 0, f"{block.id} failed ({run.returncode}):\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}"
    for expected in rule(PRINTS, block)[1] or []:
        assert expected in run.stdout, f"{block.id} should print {expected!r}; it printed:\n{run.stdout}"


def test_cpp_blocks_are_the_consumer_ci_builds():
    (cpp,) = by_lang("cpp")  # the README's; docs/cpp.md includes the files themselves
    assert cpp.name == "README.md" and cpp.body == (ROOT / "tests/consumer/quickstart.cpp").read_text()


def _statements(cmake: str) -> list[list[str]]:
    """CMake commands as token lists, comments dropped, a find_package version argument dropped."""
    text = re.sub(r"#[^\n]*", "", cmake)
    out = []
    for name, args in re.findall(r"(\w+)\s*\(([^)]*)\)", text):
        tokens = [name] + args.split()
        if name == "find_package":
            tokens = [t for t in tokens if not re.fullmatch(r"\d+(\.\d+)*", t)]
        out.append(tokens)
    return out


def test_cmake_blocks_are_statements_of_the_consumer_ci_builds():
    consumer = _statements((ROOT / "tests/consumer/CMakeLists.txt").read_text())
    blocks_ = by_lang("cmake")
    assert blocks_
    for b in blocks_:
        for statement in _statements(b.body):
            assert statement in consumer, f"{b.id}: {' '.join(statement)} is not in tests/consumer/CMakeLists.txt"


def test_scenario_file_blocks_run(tmp_path):
    import ibvs.study.sweep as sw

    tomls = by_lang("toml")
    assert tomls
    for b in tomls:
        path = tmp_path / "my.toml"
        path.write_text(b.body)
        rows = sw.sweep(None, scenario=path, episodes=2, schemes=["polar"], duration=2.0, jobs=1, progress=False)
        assert len(rows) == 2 and rows[0]["scenario"] == "my-camera" and rows[0]["depth"] == "estimated"


def test_named_scripts_exist():
    """Every `python path/to/script.py` the README or the docs name is a file of the repository."""
    for page in PAGES:
        for path in re.findall(r"\bpython3? ((?:[\w.-]+/)*[\w.-]+\.py)\b", page.read_text()):
            assert (ROOT / path).is_file(), f"{page.relative_to(ROOT)} names {path}, which does not exist"
