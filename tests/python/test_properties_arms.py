"""Property-based tests (hypothesis) of the arms' input paths: ibvs.sim.solve_ik's arguments and the
[robot] table of a scenario file. The rule of test_properties.py: every input is answered with finite
numbers (joints within the limits) or refused with ValueError/TypeError naming the argument (the file's
table and key), and only arguments beyond the documented limits are refused."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ibvs import sim
from ibvs.study.scenario import load

from test_properties import hostile_arrays
from test_properties_more import ENTRY, refused_by_name

pytest.importorskip("pinocchio")

ROBOTS = {"gantry": sim.Gantry.afma6(), "ur5": sim.cases.arm_robot("ur5")}
IK_ARGUMENTS = ("robot", "camera_pose", "q0", "tolerance", "max_iterations", "restarts", "seed", "max_step")
# Translations: plausible, huge, beyond the documented 1e6 m, or not finite.
METRES = st.one_of(st.floats(-1.0, 1.0), st.sampled_from([0.0, 5e-324, 1e5, 1e6, -1e6, 1.01e6, 1e300]),
                   st.floats(allow_nan=True, allow_infinity=True, width=64))
ANGLE = st.one_of(st.floats(-4.0, 4.0), st.sampled_from([math.pi, -math.pi, 1e-300, 1e10]))


@st.composite
def camera_poses(draw):
    """A rigid pose (most), or any 4x4 array (refused unless it happens to be rigid)."""
    if draw(st.integers(0, 3)) == 0:
        return draw(hostile_arrays(np.float64, (4, 4), elements=ENTRY))
    T = np.eye(4)
    T[:3, :3] = sim.poses.rotation_matrix(*(draw(ANGLE) for _ in range(3)))
    T[:3, 3] = [draw(METRES) for _ in range(3)]
    return T


def valid_pose(T) -> bool:
    R = T[:3, :3]
    if not np.isfinite(T).all() or np.abs(R).max() > 1 + 1e-6:
        return False
    return bool(np.abs(R @ R.T - np.eye(3)).max() <= 1e-6 and np.linalg.det(R) > 0
                and np.all(T[3] == (0, 0, 0, 1)) and np.abs(T[:3, 3]).max() <= 1e6)


@settings(max_examples=80)
@given(st.sampled_from(sorted(ROBOTS)), camera_poses(), st.one_of(st.none(), st.integers(4, 7)), st.data(),
       st.sampled_from([1e-9, 1e-3, 1.0, 0.0, -1.0, math.nan, math.inf, 2.0]),
       st.sampled_from([1, 5, 0, -1, 2.0]), st.sampled_from([0, 1, -1]), st.sampled_from([0, 7, -1, 2**63]),
       st.sampled_from([0.5, 2.0, 0.0, math.inf, math.nan, -1.0]))
def test_solve_ik_finite_or_refused(name, T, n_q0, data, tolerance, iterations, restarts, seed, max_step):
    robot = ROBOTS[name]
    q0 = None if n_q0 is None else data.draw(hostile_arrays(np.float64, n_q0, elements=ENTRY))
    try:
        r = sim.solve_ik(robot, T, q0, tolerance=tolerance, max_iterations=iterations, restarts=restarts, seed=seed,
                         max_step=max_step)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, *IK_ARGUMENTS), e
        valid = (valid_pose(T) and (q0 is None or (len(q0) == robot.dof and np.isfinite(q0).all()))
                 and 0 < tolerance <= 1 and isinstance(iterations, int) and 1 <= iterations and 0 <= restarts
                 and 0 <= seed < 2**63 and 0 < max_step <= 1e6)
        assert not valid, ("refused within the documented limits", e)
        return
    assert np.isfinite(r.q).all() and r.q.shape == (robot.dof,)
    assert np.all(r.q >= robot.q_min) and np.all(r.q <= robot.q_max)  # always within the limits
    assert math.isfinite(r.position_error) and math.isfinite(r.rotation_error) and r.position_error >= 0
    assert 1 <= r.attempts <= 1 + restarts and r.iterations >= 0
    if r.converged:
        assert r.position_error <= tolerance and r.rotation_error <= tolerance
        assert np.abs(robot.camera(r.q)[:3, 3] - T[:3, 3]).max() <= 2 * tolerance + 1e-12


# --------------------------------------------------------------------------- [robot] tables

KEYS = ("urdf", "example", "frame", "eMc", "q_min", "q_max", "qdot_max", "damping", "singular_region", "foo")
NUMBER = st.one_of(st.floats(-3.0, 3.0), st.sampled_from([0.0, 1e-300, 1e300, math.inf, -math.inf, math.nan]),
                   st.integers(-3, 3))
VALUE = st.one_of(
    st.sampled_from(["panda", "ur5", "kuka", "tool0", "panda_hand", "arm.urdf", "missing.urdf", ""]),
    NUMBER,
    st.booleans(),
    st.lists(NUMBER, min_size=0, max_size=8),
    st.fixed_dictionaries({"t": st.lists(NUMBER, min_size=2, max_size=4), "r": st.lists(NUMBER, min_size=3,
                                                                                        max_size=3)}),
)


def toml_value(x) -> str:
    """x as a TOML value (strings, booleans, numbers with inf/nan, arrays, inline tables)."""
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, str):
        return json.dumps(x)
    if isinstance(x, (int, float)):
        return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf") if math.isinf(x) else repr(x)
    if isinstance(x, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in x.items()) + " }"
    return "[" + ", ".join(toml_value(v) for v in x) + "]"


@st.composite
def robot_tables(draw):
    """Mostly a plausible arm (an example, or the URDF with its frame) with up to two keys drawn anything;
    sometimes another kind or an unknown key."""
    table = {"kind": draw(st.sampled_from(["urdf"] * 8 + ["gantry", "kuka", 3]))}
    table.update(draw(st.sampled_from([{"example": "panda"}, {"example": "ur5"}, {"urdf": "arm.urdf",
                                                                                  "frame": "tool0"}, {}])))
    for k in draw(st.lists(st.sampled_from(KEYS[:-1]), max_size=2, unique=True)):
        table[k] = draw(VALUE)
    if draw(st.integers(0, 9)) == 0:
        table["foo"] = 1
    return table


@settings(max_examples=80)
@given(robot_tables())
def test_robot_table_finite_or_refused(tmp_path_factory, table):
    d = tmp_path_factory.mktemp("robot")
    shutil.copy(sim.example_robot_urdf("ur5"), d / "arm.urdf")
    robot = "\n".join(f"{k} = {toml_value(v)}" for k, v in table.items())
    path = d / "s.toml"
    path.write_text(f"""[camera]\nfrom = "afma6"\n[target]\nfrom = "square"\nside = 0.1
pose = {{ t = [0.45, 0.0, 0.0] }}\n[robot]\n{robot}\n[goal]\nt = [0.45, 0.0, 0.5]\nr_deg = [180.0, 0.0, 0.0]
[control]\nduration = 1.0\n""")
    try:
        scenario, _ = load(path)
    except ValueError as e:  # the file's [robot] table and one of its keys, or the goal it cannot reach
        text = str(e)
        assert str(path) in text, text
        named = "[robot]" in text and any(k in text for k in (*table, "urdf", "example"))
        assert named or "goal" in text, text
        return
    q = scenario.goal_joints()
    assert np.isfinite(q).all() and scenario.robot.outside_limits(q) < 0
    assert np.abs(scenario.robot.camera(q) - scenario.goal_pose()).max() < 1e-9
