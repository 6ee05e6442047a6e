"""3-D (PBVS), 2.5-D and user-defined feature blocks (ibvs.PbvsFeature, ibvs.Point25DFeature,
ibvs.FunctionFeature): theta u against OpenCV's Rodrigues, each interaction matrix against central
differences of its own measurement (the camera moved by small twists, the poses measured anew) and
against the published formulas written out here, the straight-line paths in closed loop from large
rotations (170 degrees about the optical axis among them), and the refusals (validate and update alike)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import ibvs


def skew(a):
    return np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def rot(tu):
    return cv2.Rodrigues(np.asarray(tu, float).reshape(3, 1))[0]


def pose(tu, t):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rot(tu), t
    return T


def L_tu(tu):
    """I + (theta/2)[u]x + (1 - sinc(theta)/sinc^2(theta/2)) [u]x^2 (Malis et al. 1999; ViSP cdRc)."""
    th = np.linalg.norm(tu)
    L = np.eye(3) + skew(tu) / 2
    if th > 1e-6:
        U = skew(tu / th)
        L += (1 - np.sinc(th / np.pi) / np.sinc(th / 2 / np.pi) ** 2) * U @ U
    return L


def random_pose(rng, max_angle):
    axis = rng.normal(size=3)
    t = [*rng.uniform(-0.5, 0.5, 2), rng.uniform(0.8, 3)]
    return pose(rng.uniform(0, max_angle) * axis / np.linalg.norm(axis), t)


def moved(cMo, xi):
    """The object pose seen after the camera moves with twist xi for unit time."""
    return np.linalg.inv(ibvs.se3_exp(xi)) @ cMo


def test_theta_u_is_opencv_rodrigues(rng):
    for th in [0.0, 1e-12, 1e-6, 0.5, 2.0, np.pi - 1e-6, *rng.uniform(0, np.pi - 1e-6, 50)]:
        axis = rng.normal(size=3)
        tu = th * axis / np.linalg.norm(axis)
        np.testing.assert_allclose(ibvs.theta_u(rot(tu)), tu, atol=1e-12)
        if 1e-3 < th < np.pi - 1e-3:  # OpenCV rounds small angles to 0, and is loose near pi
            np.testing.assert_allclose(ibvs.theta_u(rot(tu)), cv2.Rodrigues(rot(tu))[0].ravel(), atol=1e-9)
    # At pi the axis' sign: its largest component positive.
    tu = ibvs.theta_u(rot(-np.pi * np.array([0.36, -0.48, 0.8])))
    assert np.isclose(np.linalg.norm(tu), np.pi) and tu[2] > 0
    with pytest.raises(ValueError, match="rotation"):
        ibvs.theta_u(np.diag([1.0, 1.0, -1.0]))


def test_theta_u_interaction_is_its_derivative(rng):
    for th in [0.0, 1e-9, 1e-3, 1.0, 3.0, np.pi - 1e-3, *rng.uniform(0, np.pi - 1e-3, 30)]:
        axis = rng.normal(size=3)
        tu = th * axis / np.linalg.norm(axis)
        R, h = rot(tu), 1e-6
        Ln = np.column_stack([(ibvs.theta_u(R @ rot(h * e)) - ibvs.theta_u(R @ rot(-h * e))) / (2 * h)
                              for e in np.eye(3)])
        L = ibvs.theta_u_interaction(tu)
        np.testing.assert_allclose(L, Ln, atol=1e-7)
        np.testing.assert_allclose(L, L_tu(tu), atol=1e-9)
    assert np.isfinite(ibvs.theta_u_interaction([np.pi, 0, 0])).all()
    with pytest.raises(ValueError, match="tu"):
        ibvs.theta_u_interaction([7.0, 0, 0])


KINDS = {
    "desired_camera": (ibvs.PbvsFeature("desired_camera"),
                       lambda T, Td: ibvs.PbvsFeature.measure(T, Td, "desired_camera")),
    "object": (ibvs.PbvsFeature("object"), lambda T, Td: ibvs.PbvsFeature.measure(T, Td, "object")),
    "2.5-D": (ibvs.Point25DFeature(), lambda T, Td: ibvs.Point25DFeature.measure(T, Td, [0.1, -0.05, 0.02])),
}


def published(kind, m, cMo, cdMo):
    """The formulas: Chaumette & Hutchinson 2006 Sec. IV (PBVS), Malis et al. 1999 (2.5-D), as in ViSP."""
    L = np.zeros((6, 6))
    L[3:, 3:] = L_tu(m[3:])
    if kind == "desired_camera":
        L[:3, :3] = cdMo[:3, :3] @ cMo[:3, :3].T
    elif kind == "object":
        L[:3, :3], L[:3, 3:] = -np.eye(3), skew(cMo[:3, 3])
    else:
        x, y, Z = m[:3]
        L[0] = [-1 / Z, 0, x / Z, x * y, -(1 + x * x), y]
        L[1] = [0, -1 / Z, y / Z, 1 + y * y, -x * y, -x]
        L[2] = [0, 0, -1 / Z, -y, x, 0]
    return L


@pytest.mark.parametrize("kind", KINDS)
def test_interaction_is_the_derivative_of_the_measurement(rng, kind):
    f, measure = KINDS[kind]
    checked = 0
    for _ in range(60):
        cMo, cdMo = random_pose(rng, 2.5), random_pose(rng, 0.5)
        m = measure(cMo, cdMo)
        if np.linalg.norm(m[3:]) > np.pi - 1e-3:
            continue
        h = 1e-6
        Ln = np.column_stack([(f.value(measure(moved(cMo, h * e), cdMo))
                               - f.value(measure(moved(cMo, -h * e), cdMo))) / (2 * h) for e in np.eye(6)])
        L = f.interaction(m)
        np.testing.assert_allclose(L, Ln, atol=1e-6 * max(1, np.abs(L).max()))
        np.testing.assert_allclose(L, published(kind, m, cMo, cdMo), atol=1e-10)
        checked += 1
    assert checked > 30
    # The goal's measurement: zeros (desired camera), (c*t_o, 0) (object), (x*, y*, Z*, 0) (2.5-D); error 0.
    cdMo = random_pose(rng, 0.5)
    md = measure(cdMo, cdMo)
    np.testing.assert_allclose(md[3:], 0, atol=1e-15)
    np.testing.assert_allclose(f.error(md, md), 0, atol=1e-15)


def off_line(p, a, b):
    d = (b - a) / np.linalg.norm(b - a)
    r = p - a
    return np.linalg.norm(r - (r @ d) * d) / np.linalg.norm(b - a)


START_ANGLES = [np.deg2rad(170) * np.array([0, 0, 1.0]),
                np.deg2rad(150) * np.array([0.2, -0.3, 0.93]) / np.linalg.norm([0.2, -0.3, 0.93])]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("start", range(len(START_ANGLES)))
def test_closed_loop_straight_line(kind, start):
    """PBVS to the desired camera: the camera centre on a straight line; PBVS to the object: the object
    origin's image on one; 2.5-D: the reference point's image on one (to O(dt): 0.5 % at dt = 5 ms)."""
    f, measure = KINDS[kind]
    if kind == "2.5-D":
        measure = lambda T, Td: ibvs.Point25DFeature.measure(T, Td)  # noqa: E731  (the object origin)
    servo = ibvs.Servo(ibvs.Task().add(f), gain=1.0)
    oMcd = pose([0, 0, 0], [0, 0, -1.0])
    oMc = pose(START_ANGLES[start], [0.3, -0.2, -1.6])
    cdMo = np.linalg.inv(oMcd)
    md = measure(cdMo, cdMo)
    if kind == "desired_camera":
        track = lambda cMo, oMc: oMc[:3, 3]  # noqa: E731  (the camera centre)
    else:
        track = lambda cMo, oMc: cMo[:2, 3] / cMo[2, 3]  # noqa: E731  (the object origin's image)
    a, b = track(np.linalg.inv(oMc), oMc), track(cdMo, oMcd)
    worst, dt = 0.0, 5e-3
    none, none_z = np.zeros((0, 2)), np.zeros(0)
    for _ in range(int(30 / dt)):
        cMo = np.linalg.inv(oMc)
        r = servo.update(none, none_z, none, measurements=[measure(cMo, cdMo)], measurements_desired=[md])
        worst = max(worst, off_line(track(cMo, oMc), a, b))
        if r.error_norm < 1e-9:
            break
        oMc = oMc @ ibvs.se3_exp(r.velocity * dt)
    d = np.linalg.inv(oMcd) @ oMc
    assert np.linalg.norm(d[:3, 3]) < 1e-8 and np.linalg.norm(ibvs.theta_u(d[:3, :3])) < 1e-8
    assert worst < 5e-3


def test_function_feature_stacks_with_the_others():
    """A user's Cartesian point block: four of them are the Layout of four points; stacked with a PBVS block,
    the twist is the stacked least-squares solution."""
    def point(m):
        x, y, z = m
        return m[:2], ibvs.jacobian([[x, y]], z, ibvs.Layout.cartesian(1))

    f = ibvs.FunctionFeature(2, 3, point, name="point")
    assert (f.rows, f.size, f.name) == (2, 3, "point") and repr(f) == "<ibvs feature point(rows=2)>"
    uv = np.array([[0.16, -0.05], [-0.16, 0.05], [0.05, 0.16], [-0.05, -0.16]])
    uvd = np.array([[0.1, -0.1], [-0.1, 0.1], [0.1, 0.1], [-0.1, -0.1]])
    z = np.array([0.6, 0.7, 0.8, 0.9])
    task = ibvs.Task()
    for _ in range(4):
        task.add(f)
    ref = ibvs.Servo(ibvs.Layout.cartesian(4), gain=0.5).update(uv, z, uvd)
    got = ibvs.Servo(task, gain=0.5).update(np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)),
                                            measurements=[[*uv[i], z[i]] for i in range(4)],
                                            measurements_desired=[[*uvd[i], 1.0] for i in range(4)])
    np.testing.assert_allclose(got.velocity, ref.velocity, rtol=1e-12, atol=1e-15)
    copy = task.features[0]  # a copy of the block, the same callable
    assert isinstance(copy, ibvs.FunctionFeature) and copy.fn is point
    np.testing.assert_allclose(copy.error([0.3, 0.1, 2.0], [0.1, 0.1, 1.0]), [0.2, 0.0])
    # Mixed with the image points of a Layout and a PBVS block, weighted.
    mixed = ibvs.Task(ibvs.Layout.cartesian(1)).add(f, weight=2.0).add(ibvs.PbvsFeature("object"))
    m_pbvs, md_pbvs = [0.05, -0.02, 1.4, 0.1, 0.2, -0.3], [0, 0, 1.0, 0, 0, 0]
    r = ibvs.Servo(mixed, gain=1.0).update([[0.2, 0.1]], 1.2, [[0.0, 0.0]],
                                           measurements=[[0.1, -0.2, 1.5], m_pbvs],
                                           measurements_desired=[[0, 0, 1.0], md_pbvs])
    J = np.vstack([ibvs.jacobian([[0.2, 0.1]], 1.2, ibvs.Layout.cartesian(1)), 2 * point([0.1, -0.2, 1.5])[1],
                   ibvs.PbvsFeature("object").interaction(m_pbvs)])
    e = np.concatenate([[0.2, 0.1], [0.2, -0.4], np.subtract(m_pbvs, md_pbvs)])
    np.testing.assert_allclose(r.velocity, -np.linalg.lstsq(J, e, rcond=None)[0], rtol=1e-10)


def test_function_feature_refusals():
    none, none_z = np.zeros((0, 2)), np.zeros(0)

    def update(fn, m=(1.0,), md=(1.0,)):
        servo = ibvs.Servo(ibvs.Task().add(ibvs.FunctionFeature(1, 1, fn)), gain=1.0)
        return servo.update(none, none_z, none, measurements=[m], measurements_desired=[md])

    ok = lambda m: (m, np.ones((1, 6)))  # noqa: E731
    assert np.isfinite(update(ok).velocity).all()
    with pytest.raises(ValueError, match=r"measurements\[0\]: fn raised ZeroDivisionError"):
        update(lambda m: (1 / float(m[0]), np.ones((1, 6))), m=[0.0])
    with pytest.raises(ValueError, match="fn's s is not finite"):
        update(lambda m: ([np.nan], np.ones((1, 6))))
    with pytest.raises(ValueError, match="fn's L is not finite"):
        update(lambda m: (m, np.full((1, 6), np.inf)))
    with pytest.raises(ValueError, match=r"fn's L must have shape \(1, 6\)"):
        update(lambda m: (m, np.ones((2, 6))))
    with pytest.raises(ValueError, match="pair"):
        update(lambda m: m)
    with pytest.raises(ValueError, match=r"measurements_desired\[0\]\[0\]: is not finite"):
        update(ok, md=[np.nan])
    with pytest.raises(TypeError, match="callable"):
        ibvs.FunctionFeature(1, 1, 3.0)
    with pytest.raises(ValueError, match="rows"):
        ibvs.FunctionFeature(0, 1, ok)
    with pytest.raises(ValueError, match="rows"):
        ibvs.FunctionFeature(65, 1, ok)
    # Called once per measurement per frame: check() evaluates it, value and interaction reuse that.
    calls = []
    counted = lambda m: (calls.append(1), (m, np.ones((1, 6))))[1]  # noqa: E731
    update(counted, m=[2.0], md=[1.0])
    assert len(calls) == 2


def test_pose_refusals():
    T = np.eye(4)
    with pytest.raises(ValueError, match="target"):
        ibvs.PbvsFeature("camera")
    with pytest.raises(ValueError, match="pose_desired"):
        ibvs.PbvsFeature.measure(T, np.diag([1.0, 2.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match="pose must be a 4x4"):
        ibvs.PbvsFeature.measure(np.eye(3), T)
    with pytest.raises(ValueError, match="behind"):
        ibvs.Point25DFeature.measure(T, T)  # the origin at depth 0
    with pytest.raises(ValueError, match=r"measurement\[2\]: the depth Z"):
        ibvs.Point25DFeature().value([0.1, 0.1, -1.0, 0, 0, 0])
    with pytest.raises(ValueError, match="at most 2 pi"):
        ibvs.PbvsFeature().value([0, 0, 1, 7.0, 0, 0])
    # A task of feature blocks only needs no depth_desired for the goal's interaction matrix.
    servo = ibvs.Servo(ibvs.Task().add(ibvs.PbvsFeature()), gain=1.0, jacobian="mean")
    r = servo.update(np.zeros((0, 2)), [], np.zeros((0, 2)), measurements=[[0, 0, 1, 0.1, 0, 0]],
                     measurements_desired=[np.zeros(6)])
    assert np.isfinite(r.velocity).all()
    # theta in (pi, 2 pi]: the principal form, the same rotation.
    s = ibvs.PbvsFeature().value([0, 0, 1, 4.0, 0, 0])
    np.testing.assert_allclose(s[3:], [4.0 - 2 * np.pi, 0, 0])
