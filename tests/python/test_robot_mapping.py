"""ibvs.joint_velocities / ibvs.JointMapping: camera twist -> joint velocities.

Checked against ViSP's formulas written out here (cVe = vpVelocityTwistMatrix(eMc^-1)),
Pinocchio's Jacobians of the Panda in both frames and central differences of its camera
pose, the closed-form damped solution, speed limits, the null-space task, bad input, and
a hypothesis property: every finite input gives finite joint velocities or a ValueError.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ibvs
from ibvs import sim


def skew(t):
    return np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])


def visp_twist_matrix(M):
    """ViSP's vpVelocityTwistMatrix(M) for M = aMb: [[R, [t]x R], [0, R]] maps b's twist to a's."""
    R, t = M[:3, :3], M[:3, 3]
    V = np.zeros((6, 6))
    V[:3, :3] = V[3:, 3:] = R
    V[:3, 3:] = skew(t) @ R
    return V


def random_pose(rng):
    return sim.pose(t=rng.normal(0, 0.1, 3), r=rng.uniform(-np.pi, np.pi, 3))


def test_camera_jacobian_is_visp_cVe_eJe(rng):
    for n in (1, 5, 6, 7, 16):
        eMc = random_pose(rng)
        eJe = rng.normal(size=(6, n))
        cVe = visp_twist_matrix(np.linalg.inv(eMc))
        r = ibvs.JointMapping(n, eMc).update(rng.normal(size=6), eJe)
        assert np.allclose(r.camera_jacobian, cVe @ eJe, atol=1e-13)
        # base frame: eJe = diag(bRe^T, bRe^T) bJe
        bRe = random_pose(rng)[:3, :3]
        bJe = np.r_[bRe @ eJe[:3], bRe @ eJe[3:]]
        rb = ibvs.JointMapping(n, eMc, frame="base").update(rng.normal(size=6), bJe, bRe=bRe)
        assert np.allclose(rb.camera_jacobian, cVe @ eJe, atol=1e-13)


def test_two_stage_equals_visp_one_stage(rng):
    """ViSP: qdot = -g (L cVe eJe)+ e; ibvs: v = -g L+ e, then qdot = Jc+ v. Equal for rank-6 L and Jc."""
    L = rng.normal(size=(8, 6))
    e = rng.normal(size=8)
    for n in (6, 7):
        eMc, eJe = random_pose(rng), rng.normal(size=(6, n))
        Jc = visp_twist_matrix(np.linalg.inv(eMc)) @ eJe
        one_stage = -0.5 * np.linalg.pinv(L @ Jc) @ e
        v = -0.5 * np.linalg.pinv(L) @ e
        assert np.allclose(ibvs.joint_velocities(v, eMc, eJe), one_stage, atol=1e-12)


@pytest.fixture(scope="module")
def panda():
    return sim.UrdfRobot(sim.example_robot_urdf("panda"), "panda_hand", sim.pose(t=(0.05, -0.03, 0.04), r=(0.1, -0.2, 0.3)))


def camera_jacobian_fd(robot, q, h=1e-6):
    """Central differences of the camera pose: column j = (T^-1 dT/dq_j)^vee (camera frame)."""
    Ti = np.linalg.inv(robot.camera(q))
    cols = []
    for j in range(len(q)):
        dq = np.zeros(len(q))
        dq[j] = h
        D = Ti @ (robot.camera(q + dq) - robot.camera(q - dq)) / (2 * h)
        cols.append([D[0, 3], D[1, 3], D[2, 3], D[2, 1], D[0, 2], D[1, 0]])
    return np.array(cols).T


def test_pinocchio_frames_and_finite_differences(panda, rng):
    """The Panda's LOCAL and LOCAL_WORLD_ALIGNED Jacobians give the same camera Jacobian, equal to central
    differences of its camera pose, and joint velocities that reproduce the twist."""
    import pinocchio as pin

    model, data, fid = panda.model, panda.data, panda.frame_id
    q = np.array(sim.cases.ARMS["panda"][0]) + rng.normal(0, 0.1, 7)
    pin.computeJointJacobians(model, data, q)
    bRe = pin.updateFramePlacement(model, data, fid).rotation
    local = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
    aligned = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    v = rng.normal(size=6)
    a = ibvs.JointMapping(7, panda.mount).update(v, local)
    b = ibvs.JointMapping(7, panda.mount, frame="base").update(v, aligned, bRe=bRe)
    assert np.allclose(a.camera_jacobian, b.camera_jacobian, atol=1e-14)
    assert np.allclose(a.camera_jacobian, camera_jacobian_fd(panda, q), atol=1e-8)
    assert np.allclose(a.qdot, b.qdot, atol=1e-12)
    assert np.allclose(a.camera_jacobian @ a.qdot, v, atol=1e-12)
    assert a.status == ibvs.Status.ok and a.rank == 6
    assert a.manipulability == pytest.approx(np.sqrt(np.linalg.det(a.camera_jacobian @ a.camera_jacobian.T)))


def test_null_space_task_leaves_the_camera_twist(panda, rng):
    q = np.array(sim.cases.ARMS["panda"][0])
    _, J = panda.kinematics(q)
    v = rng.normal(size=6)
    m = ibvs.JointMapping(7, panda.mount, damping=0.01)
    plain = m.update(v, J).qdot
    # e.g. joint-limit avoidance: move every joint towards the middle of its range
    z = 0.5 * ((panda.q_min + panda.q_max) / 2 - q)
    r = m.update(v, J, secondary=z)
    dq = r.qdot - plain
    assert np.linalg.norm(dq) > 0.01
    assert np.allclose(r.camera_jacobian @ dq, 0, atol=1e-12)
    # dq is the projection of z onto the null space: what is left of z lies in the row space
    rest = z - dq
    Jc = r.camera_jacobian
    assert np.allclose(np.linalg.pinv(Jc) @ (Jc @ rest), rest, atol=1e-10)


def test_damping_limits_and_rank(rng):
    J = rng.normal(size=(6, 6))
    v = rng.normal(size=6)
    # constant damping: (J^T J + l^2 I)^-1 J^T v
    qd = ibvs.joint_velocities(v, np.eye(4), J, damping=0.2)
    assert np.allclose(qd, np.linalg.solve(J.T @ J + 0.04 * np.eye(6), J.T @ v))
    # variable damping (eq. 3): none above singular_region, (1 - (w / eps)^2) damping^2 below
    w = abs(np.linalg.det(J))
    m = ibvs.JointMapping(6, np.eye(4), damping=0.2, singular_region=0.5 * w)
    assert m.update(v, J).damping == 0 and np.allclose(J @ m.update(v, J).qdot, v)
    r = ibvs.JointMapping(6, np.eye(4), damping=0.2, singular_region=2 * w).update(v, J)
    assert r.damping**2 == pytest.approx(0.04 * 0.75)
    # speed limits: one factor, direction kept
    limit = np.array([0.1, 0.2, 0.3, np.inf, 0.1, 0.1])
    r = ibvs.JointMapping(6, np.eye(4), max_joint_speed=limit).update(10 * v, J)
    assert r.saturated and 0 < r.saturation_scale < 1
    assert np.all(np.abs(r.qdot) <= limit * (1 + 1e-12))
    assert np.allclose(J @ r.qdot, r.saturation_scale * 10 * v)
    # fewer joints than 6: least squares; a repeated column: rank 5, singular, finite
    J3 = J[:, :3]
    assert np.allclose(ibvs.joint_velocities(v, np.eye(4), J3), np.linalg.lstsq(J3, v, rcond=None)[0])
    Js = J.copy()
    Js[:, 5] = Js[:, 4]
    r = ibvs.JointMapping(6, np.eye(4)).update(v, Js)
    assert r.status == ibvs.Status.singular and r.rank == 5 and np.all(np.isfinite(r.qdot))


def test_gantry_mapping_is_the_joint_mapping():
    g = sim.Gantry.afma6()
    q = np.array([0.1, -0.2, 0.05, 0.3, 0.7, -0.4])
    v = np.array([0.01, 0.02, -0.03, 0.1, -0.2, 0.05])
    T, J = g.kinematics(q)
    qd = ibvs.joint_velocities(v, g.mount, J, frame="base", bRe=T[:3, :3], damping=g.damping,
                               singular_region=g.singular_region)
    assert np.array_equal(qd, g.joint_velocity(q, v))
    assert g.frame == "base" and np.allclose(g.jacobian(q) @ qd, v)


def test_properties_and_repr():
    m = ibvs.JointMapping(3, np.eye(4), frame="base", damping=0.1, singular_region=0.2, max_joint_speed=[1, 2, 3])
    assert (m.n_joints, m.frame, m.damping, m.singular_region) == (3, "base", 0.1, 0.2)
    assert np.array_equal(m.max_joint_speed, [1, 2, 3]) and np.array_equal(m.eMc, np.eye(4))
    assert ibvs.JointMapping(2, np.eye(4)).max_joint_speed is None
    assert "JointMapping(" in repr(m)
    r = ibvs.JointMapping(6, np.eye(4)).update(np.ones(6), np.eye(6))
    assert "JointMappingResult(" in repr(r) and np.allclose(r.qdot, 1)


@pytest.mark.parametrize(
    "kwargs, error, words",
    [
        (dict(twist=np.ones(5)), ValueError, "twist"),
        (dict(twist="x"), TypeError, "twist"),
        (dict(twist=[np.nan] * 6), ValueError, "twist"),
        (dict(jacobian=np.ones((5, 3))), ValueError, "jacobian"),
        (dict(jacobian=np.ones((6, 17))), ValueError, "jacobian"),
        (dict(jacobian=np.full((6, 3), np.inf)), ValueError, "jacobian"),
        (dict(eMc=np.eye(3)), ValueError, "eMc"),
        (dict(eMc=2 * np.eye(4)), ValueError, "eMc"),
        (dict(frame="world"), ValueError, "frame"),
        (dict(frame=1), TypeError, "frame"),
        (dict(frame="base"), ValueError, "bRe"),
        (dict(bRe=np.eye(3)), ValueError, "bRe"),
        (dict(frame="base", bRe=2 * np.eye(3)), ValueError, "bRe"),
        (dict(frame="base", bRe=np.eye(4)), ValueError, "bRe"),
        (dict(damping=-0.1), ValueError, "damping"),
        (dict(damping="a"), TypeError, "damping"),
        (dict(singular_region=np.inf), ValueError, "singular_region"),
        (dict(max_joint_speed=[1, 1]), ValueError, "max_joint_speed"),
        (dict(max_joint_speed=0.0), ValueError, "max_joint_speed"),
        (dict(secondary=np.ones(4)), ValueError, "secondary"),
        (dict(secondary=[np.nan] * 3), ValueError, "secondary"),
    ],
)
def test_bad_input_names_the_argument(kwargs, error, words):
    args = dict(twist=np.ones(6), eMc=np.eye(4), jacobian=np.ones((6, 3)))
    args.update(kwargs)
    with pytest.raises(error, match=words):
        ibvs.joint_velocities(**args)


def test_bad_mapping_arguments():
    with pytest.raises(TypeError, match="n_joints"):
        ibvs.JointMapping(2.5, np.eye(4))
    with pytest.raises(ValueError, match="n_joints"):
        ibvs.JointMapping(17, np.eye(4))
    with pytest.raises(ValueError, match="jacobian"):
        ibvs.JointMapping(3, np.eye(4)).update(np.ones(6), np.ones((6, 4)))


finite = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(1, 16),
    data=st.data(),
    scale=st.sampled_from([1e-300, 1e-9, 1.0, 1e9, 1e300]),
    frame=st.sampled_from(["end_effector", "base"]),
    damping=st.sampled_from([0.0, 1e-6, 0.1]),
    limit=st.sampled_from([None, 0.5]),
)
def test_finite_or_refused(n, data, scale, frame, damping, limit):
    """Any finite input: finite joint velocities (within the limits when given), or a ValueError."""
    twist = np.array(data.draw(st.lists(finite, min_size=6, max_size=6)))
    unit = st.floats(-1, 1)
    J = scale * np.array(data.draw(st.lists(unit, min_size=6 * n, max_size=6 * n))).reshape(6, n)
    angles = data.draw(st.lists(st.floats(-4, 4), min_size=3, max_size=3))
    eMc = sim.pose(t=data.draw(st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3)), r=angles)
    kw = dict(bRe=sim.rotation(*angles[::-1])) if frame == "base" else {}
    try:
        qd = ibvs.joint_velocities(twist, eMc, J, frame=frame, damping=damping, max_joint_speed=limit, **kw)
    except ValueError as e:
        assert "overflow" in str(e)
        return
    assert qd.shape == (n,) and np.all(np.isfinite(qd))
    if limit is not None:
        assert np.all(np.abs(qd) <= limit * (1 + 1e-12))
