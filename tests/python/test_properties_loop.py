"""Hypothesis properties of the servo loop's config (ibvs.loop.config): any [loop] table gives LoopOptions
whose numbers are finite and within their ranges, or a ValueError naming the offending key; any value put
into a valid config file is taken or refused with the file, the section and the key named."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ibvs.loop.config import LOOP_KEYS, load, loop_options

VALUES = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6),
                   st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
                   st.lists(st.floats(-10, 10), max_size=3))
NUMBERS = ("rate", "duration", "watchdog", "state_watchdog", "late", "latency", "lag", "converge_px")


@settings(max_examples=300, deadline=None)
@given(st.dictionaries(st.sampled_from(LOOP_KEYS + ("bogus",)), VALUES, max_size=6))
def test_loop_table_is_taken_or_refused_naming_the_key(table):
    table = {k: v for k, v in table.items() if v is not None}  # TOML has no null
    try:
        o = loop_options(table)
    except ValueError as e:
        assert any(k in str(e) for k in table), str(e)
        return
    for name in NUMBERS:
        x = getattr(o, name)
        assert x is None or (isinstance(x, float) and math.isfinite(x) and x >= 0)
    assert o.watchdog > 0 and o.state_watchdog > 0 and isinstance(o.dry_run, bool)
    assert set(table) <= set(LOOP_KEYS)


GOOD = """
[camera]
px = 600.0
py = 600.0
u0 = 320.0
v0 = 240.0
width = 640
height = 480
fps = 30
[source]
kind = "render"
latency = 0.0
[target]
points = [[-0.05, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.05, 0.05, 0.0]]
pose = { t = [0.0, 0.0, 0.5] }
[tracker]
kind = "dots"
desired_pixels = [[260.0, 180.0], [380.0, 180.0], [380.0, 300.0], [260.0, 300.0]]
[servo]
scheme = "polar"
gain = 1.0
depth = 0.5
[robot]
kind = "sim"
[loop]
duration = 1.0
"""

SLOTS = [("source", "latency"), ("source", "drop"), ("servo", "gain"), ("servo", "depth"), ("servo", "scheme"),
         ("tracker", "desired_pixels"), ("tracker", "kind"), ("loop", "duration"), ("loop", "watchdog"),
         ("loop", "dry_run"), ("source", "kind"), ("robot", "kind"), ("servo", "turn")]
TOML_VALUES = st.one_of(st.booleans(), st.integers(-10**4, 10**4), st.floats(-1e3, 1e3), st.sampled_from(
    ["'polar'", "'x'", "'dots'", "'render'", "[1.0, 2.0]", "[[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]", "nan", "inf",
     "-inf", "'sim'"]))


def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else "nan"
    return str(v)


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(SLOTS), TOML_VALUES)
def test_a_value_in_a_config_is_taken_or_refused_naming_where(tmp_path_factory, slot, value):
    section, key = slot
    text, lines, inside = GOOD, [], None
    for line in text.splitlines():
        if line.startswith("["):
            inside = line.strip("[]")
        if inside == section and line.split("=")[0].strip() == key:
            continue
        lines.append(line)
        if line == f"[{section}]":
            lines.append(f"{key} = {_toml(value)}")
    path = Path(tmp_path_factory.mktemp("cfg")) / "servo.toml"
    path.write_text("\n".join(lines) + "\n")
    try:
        cfg = load(path)
    except ValueError as e:
        assert str(path) in str(e) and (f"[{section}]" in str(e) or key in str(e)), str(e)
        return
    assert cfg.doc[section][key] == value or (isinstance(value, float) and math.isnan(value)) or \
        isinstance(cfg.doc[section][key], (str, list))
    o = cfg.options
    assert o.duration is None or math.isfinite(o.duration)


def test_the_good_config_loads(tmp_path):
    path = tmp_path / "servo.toml"
    path.write_text(GOOD)
    cfg = load(path)
    assert cfg.robot_kind == "sim" and cfg.clock == "sim" and cfg.options.duration == 1.0


@pytest.mark.parametrize("edit, match", [
    (("[robot]\nkind = \"sim\"", ""), "missing \\[robot\\]"),
    (("kind = \"render\"", "kind = \"webcam\""), "\\[source\\] kind"),
    (("gain = 1.0", "gain = -1.0"), "\\[servo\\] gain"),
    (("duration = 1.0", "duration = 1.0\nrecord = \"x.bag\""), "record: must end in .mcap"),
    (("depth = 0.5", "depth = [0.5, 0.5]"), "\\[servo\\] depth"),
    (("[loop]", "[loops]"), "unknown key 'loops'"),
    (("depth = 0.5", "depth = 0.5\nturn = 4.0"), "\\[servo\\] turn"),
    (("depth = 0.5", "depth = 0.5\nturn = nan"), "\\[servo\\] turn"),
    (("scheme = \"polar\"", "scheme = \"partitioned\"\nturn = 3.0"), "partitioned scheme has no consistent angle wrap"),
])
def test_bad_configs_name_what_is_wrong(tmp_path, edit, match):
    path = tmp_path / "servo.toml"
    path.write_text(GOOD.replace(*edit))
    with pytest.raises(ValueError, match=match):
        load(path)


FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=200, deadline=None)
@given(delay=FLOATS, lag=FLOATS, twist=st.lists(FLOATS, min_size=6, max_size=6),
       uv=st.lists(st.floats(-2, 2), min_size=6, max_size=6), z=st.floats(1e-3, 1e3), t=FLOATS)
def test_predictor_gives_finite_points_or_refuses(delay, lag, twist, uv, z, t):
    """Any input to the latency predictor: finite predicted points and depths > 0, or a ValueError."""
    from ibvs.loop.latency import FeaturePredictor

    try:
        p = FeaturePredictor(delay, lag)
    except ValueError as e:
        assert "delay" in str(e) or "lag" in str(e)
        return
    try:
        p.commanded(t, twist)
    except ValueError as e:
        assert "commanded" in str(e)
        return
    if not (math.isfinite(p.delay) and abs(p.delay) < 1e3 and np.abs(twist).max() < 1e3):
        return
    try:
        out, depth = p.predict(np.reshape(uv, (3, 2)), z, t)
    except ValueError as e:
        assert "leaves the camera's field" in str(e)
        return
    assert out.shape == (3, 2) and depth.shape == (3,) and np.isfinite(out).all()
    assert np.isfinite(depth).all() and (depth > 0).all()
