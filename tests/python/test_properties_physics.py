"""Property-based tests (hypothesis) of the physics testbed's input paths (ibvs.sim.physics): every camera size
and field of view, joint command, time, latency and frame-read timeout gives finite numbers or is refused with a
ValueError/TypeError naming the argument; the world's state stays finite and its time never goes back."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("mujoco", reason="the physics extra (mujoco) is not installed")
pytest.importorskip("pinocchio", reason="the robots extra (pin) is not installed")
pytest.importorskip("cv2", reason="the vision extra (OpenCV) is not installed")
from ibvs import sim  # noqa: E402
from ibvs.sim import physics  # noqa: E402

ANY = st.floats(allow_nan=True, allow_infinity=True, width=64)
SPEED = st.one_of(st.floats(-5.0, 5.0), ANY)

@pytest.fixture(scope="module")
def world():
    """One small world for all examples (building one takes ~0.1 s); closed at the end (its OpenGL context)."""
    case = sim.cases.arm_general_motion("panda")
    with physics.World(case.robot, case.target, physics.testbed_camera(32, 24)) as w:
        yield w


def _named(e: Exception, name: str) -> bool:
    return isinstance(e, (ValueError, TypeError)) and name in str(e)


@settings(max_examples=200)
@given(st.one_of(st.integers(-10, 5000), ANY), st.one_of(st.integers(-10, 5000), ANY), st.one_of(ANY, st.integers()))
def test_testbed_camera_finite_or_refused(width, height, fov):
    try:
        cam = physics.testbed_camera(width, height, fov=fov)
    except (ValueError, TypeError) as e:
        assert any(_named(e, n) for n in ("width", "height", "fov")), e
        return
    assert np.isfinite([cam.px, cam.py, cam.u0, cam.v0]).all() and cam.px > 0


@settings(max_examples=60)
@given(st.lists(SPEED, min_size=7, max_size=7), st.floats(0.0, 0.05))
def test_commands_and_steps_keep_the_state_finite(world, dq, dt):
    w = world
    if w.time > 1.0:
        w.reset(np.array(sim.cases.ARMS["panda"][0]))
    t0 = w.time
    try:
        w.command(np.array(dq))
    except ValueError as e:
        assert _named(e, "dq") and not (np.abs(dq) <= physics.world.MAX_SPEED).all()
        return
    w.step_to(t0 + dt)
    assert t0 <= w.time <= t0 + dt + w.timestep
    assert np.isfinite(w.q).all() and np.isfinite(w.dq).all() and np.isfinite(w.torque).all()
    assert (np.abs(w.torque) <= w.effort * (1 + 1e-9)).all()


@settings(max_examples=60)
@given(ANY)
def test_step_to_any_time(world, t):
    w = world
    t0 = w.time
    if not np.isfinite(t):
        with pytest.raises(ValueError, match="t must be finite"):
            w.step_to(t)
        return
    w.step_to(min(t, t0 + 0.01))
    assert w.time >= t0


@settings(max_examples=100)
@given(st.one_of(ANY, st.integers(-5, 100), st.booleans()), st.one_of(ANY, st.floats(0.0, 0.1)))
def test_camera_latency_and_timeout_finite_or_refused(world, latency, timeout):
    w = world
    try:
        source = physics.MujocoCamera(w, latency=latency)
    except ValueError as e:
        assert _named(e, "latency"), e
        return
    source.open()
    t0 = w.time
    try:
        frame = source.read(timeout)
    except ValueError as e:
        assert _named(e, "timeout") and not (np.isfinite(timeout) and timeout >= 0), e
        return
    assert w.time >= t0
    if frame is not None:
        assert frame.image.shape == (24, 32) and np.isfinite(frame.stamp) and frame.stamp <= w.time
