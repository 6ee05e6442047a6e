"""ibvs.sim.run runs every servo the library offers with all its options: the episode's
servo has exactly the caller's options (adaptive gain, saturation, jacobian mode, damping,
automatic hybrid, partitioned law) and the caller's object is left as it was."""

import numpy as np
import pytest

import ibvs
import ibvs.sim as sim


def run(servo, case, **kw):
    kw = {"duration": case.duration, **kw}
    return sim.run(servo, case.camera, case.target, case.start, case.goal, robot=case.robot, **kw)


def first_twist_of(servo, result):
    """What the caller's servo commands for the episode's first frame."""
    h = result.history
    return servo.update(h.uv[0], h.depth[0], result.uv_desired, result.depth_desired).velocity


L = ibvs.Layout
SERVOS = {
    "adaptive": lambda: ibvs.Servo(L.cartesian(4), gain=ibvs.AdaptiveGain(4.0, 0.4, 30.0)),
    "saturated": lambda: ibvs.Servo(L.stacked(4), gain=1.0, max_linear_speed=0.05, max_angular_speed=0.2),
    "desired-damped": lambda: ibvs.Servo(L.polar(4), gain=1.0, damping=0.05, jacobian="desired"),
    "mean-radius": lambda: ibvs.Servo(L.stacked(4), gain=0.7, jacobian="mean", polar_min_radius=0.2),
    "automatic": lambda: ibvs.Servo.automatic_hybrid(4, gain=1.0, switch_radius=0.3),
    "cylindrical": lambda: ibvs.Servo(L.cylindrical(4), gain=1.0, diagnostics=False),
    "partitioned": lambda: ibvs.PartitionedServo(4, gain=1.0, damping=0.01, segment=(1, 3),
                                                 max_angular_speed=0.5),
}


@pytest.mark.parametrize("name", SERVOS)
def test_episode_runs_the_callers_servo_and_leaves_it_alone(name):
    servo = SERVOS[name]()
    before = (repr(servo), servo.gain, servo.damping)
    case = sim.cases.general_motion()
    r = run(servo, case, duration=2.0)
    assert r.status.outcome in ("timeout", "converged")
    # Same options: the first recorded twist is the caller's servo's twist on that frame.
    np.testing.assert_allclose(r.history.twist[0], first_twist_of(servo, r), rtol=1e-12, atol=1e-15)
    assert (repr(servo), servo.gain, servo.damping) == before
    # The copy keeps diagnostics on (diagnostics=False in "cylindrical"): sigma_min recorded.
    assert np.all(np.isfinite(r.history.sigma_min[: len(r.history) - 1]))


def test_adaptive_gain():
    case = sim.cases.general_motion()
    g = ibvs.AdaptiveGain(4.0, 0.4, 30.0)
    adaptive = run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=g), case, duration=30.0, tolerance=1e-5)
    constant = run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=0.4), case, duration=30.0, tolerance=1e-5)
    assert adaptive.converged and constant.converged
    # Near convergence the adaptive gain approaches 4: far faster than the constant 0.4.
    assert adaptive.metrics.frames_to_converge < 0.5 * constant.metrics.frames_to_converge
    # Each recorded twist is the adaptive gain of that frame's error norm times the unit-gain law.
    unit = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0)
    h = adaptive.history
    for k in (0, len(h) // 2):
        v = unit.update(h.uv[k], h.depth[k], adaptive.uv_desired).velocity
        np.testing.assert_allclose(h.twist[k], g(h.error_norm[k]) * v, rtol=1e-10, atol=1e-14)


def test_velocity_saturation():
    case = sim.cases.general_motion()
    vmax, wmax = 0.5, 0.3  # the unsaturated run peaks at 12.5 m/s and 3.5 rad/s
    layout = ibvs.Layout.stacked(4)
    free = run(ibvs.Servo(layout, gain=1.0), case, duration=30.0, tolerance=1e-5)
    limited = run(ibvs.Servo(layout, gain=1.0, max_linear_speed=vmax, max_angular_speed=wmax), case,
                  duration=30.0, tolerance=1e-5)
    tw = limited.history.twist
    assert np.linalg.norm(tw[:, :3], axis=1).max() <= vmax * (1 + 1e-12)
    assert np.linalg.norm(tw[:, 3:], axis=1).max() <= wmax * (1 + 1e-12)
    # The unsaturated run exceeds the limits, so the runs differ; both converge.
    assert np.linalg.norm(free.history.twist[:, :3], axis=1).max() > 2 * vmax
    assert free.converged and limited.converged
    assert limited.metrics.frames_to_converge > free.metrics.frames_to_converge
    # Uniform scaling keeps the twist's direction at the first frame.
    a, b = free.history.twist[0], tw[0]
    np.testing.assert_allclose(b / np.linalg.norm(b), a / np.linalg.norm(a), rtol=1e-10, atol=1e-14)


def test_partitioned_z_rotation_pi_without_retreat():
    case = sim.cases.z_rotation()
    servo = ibvs.PartitionedServo(4, gain=1.0)
    r = run(servo, case, duration=20.0, tolerance=1e-5)
    assert r.converged, r
    h = r.history
    assert r.metrics.camera_retreat < 1e-9 and r.metrics.path_length < 1e-9
    assert r.metrics.final_rotation_error < 1e-4
    wz = np.abs(h.twist[:, 5]).max()
    assert wz == pytest.approx(np.pi)  # the first wz is gain * pi
    assert np.abs(h.twist[:, :5]).max() < 1e-9 * wz  # a pure rotation about the optical axis
    # Its Cartesian error (M = 2N) and the sigma_min of its (Tx, Ty, wx, wy) columns.
    assert h.error.shape == (len(h), 8) and np.all(h.sigma_min > 0)
    assert servo.gain == 1.0


def test_partitioned_on_the_gantry():
    case = sim.cases.gantry_general_motion()
    r = run(ibvs.PartitionedServo(4, gain=2.0), case, depth="pose", tolerance=1e-5)
    assert r.converged, r
    assert r.metrics.final_translation_error < 1e-3


def test_wrong_servo_type_names_servo_and_the_accepted_types():
    case = sim.cases.z_rotation()
    for bad in (ibvs.Layout.cartesian(4), "polar", None, 1.0):
        with pytest.raises(TypeError, match=r"servo must be an ibvs\.Servo or an ibvs\.PartitionedServo"):
            run(bad, case)
    with pytest.raises(ValueError, match="points"):
        run(ibvs.PartitionedServo(3, gain=1.0), case)
