"""ibvs.SecondaryTask (secondary_task.hpp): null-space motions and joint-limit avoidance on top of JointMapping.

On the Panda (Pinocchio): the primary task's feature velocity L Jc qdot (classical projector) and error-norm rate
e^T L Jc qdot (large projector, Marey & Chaumette 2010) unchanged to 1e-9 by task- and joint-space secondary motions;
the large projector leaves room on a 6-joint arm where the classical one leaves none; joint-limit avoidance pushes a
joint in its zone back; the caps; refusals; and in the simulator, avoidance keeps a run that hit a joint limit going."""

import pickle

import numpy as np
import pytest

import ibvs
import ibvs.sim as sim

pytest.importorskip("pinocchio")


@pytest.fixture(scope="module")
def panda():
    return sim.cases.arm_robot("panda")


def primary(robot, q, n_points=4, seed=0):
    """The servo's L, e and twist at q for a random image, and JointMapping's qdot and Jc."""
    rng = np.random.default_rng(seed)
    uv = rng.uniform(-0.3, 0.3, (n_points, 2))
    uvd = rng.uniform(-0.3, 0.3, (n_points, 2))
    z = rng.uniform(0.3, 1.0, n_points)
    layout = ibvs.Layout.cartesian(n_points)
    r = ibvs.Servo(layout, gain=1.0).update(uv, z, uvd, z)
    T, J = robot.kinematics(q)
    m = ibvs.JointMapping(robot.dof, robot.mount).update(r.velocity, J)
    return np.array(r.jacobian), np.array(r.error), m.qdot, m.camera_jacobian


@pytest.mark.parametrize("n_points", [4, 2])  # L of rank 6, and of rank 4 (room for the classical projector)
@pytest.mark.parametrize("projector", ["classical", "large"])
def test_primary_task_unchanged(panda, n_points, projector):
    rng = np.random.default_rng(3)
    moved = 0
    for k in range(20):
        q = sim.cases.ARMS["panda"][0] + 0.2 * rng.standard_normal(7)
        L, e, qdot1, Jc = primary(panda, q, n_points, seed=k)
        task = ibvs.SecondaryTask(7, projector=projector)
        r = task.update(qdot1, Jc, L, e, twist=rng.standard_normal(6), joints=rng.standard_normal(7))
        d = r.qdot - qdot1
        LJ = L @ Jc
        if projector == "classical":
            assert np.abs(LJ @ d).max() < 1e-9 * max(1.0, np.abs(d).max())
        else:
            assert abs(e @ LJ @ d) < 1e-9 * max(1.0, np.abs(d).max())
        moved += np.abs(d).max() > 1e-6
    assert moved == 20


def test_large_projector_leaves_room_on_a_six_joint_arm():
    ur5 = sim.cases.arm_robot("ur5")
    q = np.array(sim.cases.ARMS["ur5"][0])
    L, e, qdot1, Jc = primary(ur5, q)
    z = np.ones(6)
    classical = ibvs.SecondaryTask(6).update(qdot1, Jc, L, e, joints=z)
    large = ibvs.SecondaryTask(6, projector="large").update(qdot1, Jc, L, e * 10, joints=z)  # |e| > 0.7: s = 1
    assert np.abs(classical.secondary).max() < 1e-9  # rank 6 of 6: no null space
    assert large.weight == 1.0 and np.abs(large.secondary).max() > 0.1
    assert classical.rank == 6 and large.rank == 6
    small = ibvs.SecondaryTask(6, projector="large").update(qdot1, Jc, L, e * 1e-3, joints=z)
    assert small.weight == 0.0 and np.abs(small.secondary).max() < 1e-9  # switched to the classical one


def test_joint_limit_avoidance_pushes_back(panda):
    q = np.array(sim.cases.ARMS["panda"][0])
    L, e, qdot1, Jc = primary(panda, q)
    lo, hi = panda.q_min, panda.q_max
    q_near = q.copy()
    q_near[0] = hi[0] - 0.02 * (hi[0] - lo[0])  # beyond q_l1 (rho = 0.1, rho1 = 0.3)
    task = ibvs.SecondaryTask(7, projector="large", q_min=lo, q_max=hi)
    r = task.update(qdot1, Jc, L, e, q=q_near)
    assert r.active == 1 and task.avoids_joint_limits
    assert abs(qdot1[0]) > 1e-3
    # ViSP's correction of joint i beyond q_l1: -(1 + lambda_tune) |qdot1_i| on joint i itself (P_ii > 0),
    # so -lambda_tune |qdot1_i| when the task drives it towards the limit
    assert r.qdot[0] == pytest.approx(qdot1[0] - 1.7 * abs(qdot1[0]), rel=1e-9)
    flipped = task.update(-qdot1, Jc, L, -e, q=q_near)  # the task driving joint 0 the other way
    assert flipped.qdot[0] == pytest.approx(-qdot1[0] - 1.7 * abs(qdot1[0]), rel=1e-9)
    assert max(r.qdot[0], flipped.qdot[0]) == pytest.approx(-0.7 * abs(qdot1[0]), rel=1e-9)  # both move back
    assert abs(e @ L @ Jc @ (r.qdot - qdot1)) < 1e-9
    safe = task.update(qdot1, Jc, L, e, q=q)
    assert safe.active == 0 and np.array_equal(safe.qdot, qdot1)


def test_caps(panda):
    q = np.array(sim.cases.ARMS["panda"][0])
    L, e, qdot1, Jc = primary(panda, q)
    prev = 0.1 * np.ones(7)
    task = ibvs.SecondaryTask(7, max_joint_speed=0.05, max_joint_acceleration=1.0, period=0.01)
    r = task.update(qdot1 * 100, Jc, L, e, qdot_previous=prev)
    assert np.abs(r.qdot - prev).max() <= 0.01 + 1e-15
    assert r.saturation_scale < 1 and r.acceleration_scale < 1


def test_refusals(panda):
    q = np.array(sim.cases.ARMS["panda"][0])
    L, e, qdot1, Jc = primary(panda, q)
    task = ibvs.SecondaryTask(7, q_min=panda.q_min, q_max=panda.q_max, max_joint_acceleration=1.0, period=0.01)
    with pytest.raises(ValueError, match="q \\(the joint positions\\)"):
        task.update(qdot1, Jc, L, e, qdot_previous=qdot1)
    with pytest.raises(ValueError, match="qdot_previous"):
        task.update(qdot1, Jc, L, e, q=q)
    with pytest.raises(ValueError, match="interaction and error"):
        task.update(qdot1, Jc, L, q=q, qdot_previous=qdot1)
    with pytest.raises(ValueError, match="error must have shape"):
        task.update(qdot1, Jc, L, e[:3], q=q, qdot_previous=qdot1)
    with pytest.raises(ValueError, match="camera_jacobian"):
        task.update(qdot1, Jc[:, :6], L, e, q=q, qdot_previous=qdot1)
    bad = q.copy()
    bad[2] = np.nan
    with pytest.raises(ValueError, match=r"q\[2\]"):
        task.update(qdot1, Jc, L, e, q=bad, qdot_previous=qdot1)
    with pytest.raises(ValueError, match="projector"):
        ibvs.SecondaryTask(7, projector="big")
    with pytest.raises(ValueError, match="rho"):
        ibvs.SecondaryTask(7, rho=0.7)
    with pytest.raises(ValueError, match="period"):
        ibvs.SecondaryTask(7, max_joint_acceleration=1.0)
    with pytest.raises(ValueError, match="q_min"):
        ibvs.SecondaryTask(7, q_min=np.ones(7), q_max=np.zeros(7))
    with pytest.raises(TypeError, match="n_joints"):
        ibvs.SecondaryTask(7.0)
    assert "SecondaryTask(n_joints=7" in repr(task) and "SecondaryTaskResult(" in repr(
        task.update(qdot1, Jc, L, e, q=q, qdot_previous=qdot1))


def test_robot_secondary_task_settings():
    g = sim.Gantry.afma6()
    assert g.secondary_task is None
    g.set_secondary_task("large", qddot_max=5.0)
    assert g.secondary_task["projector"] == "large" and np.all(g.secondary_task["qddot_max"] == 5.0)
    with pytest.raises(ValueError, match="rho"):
        g.set_secondary_task(rho=0.9)
    assert g.secondary_task["rho"] == 0.1  # a refused setting leaves the old one
    with pytest.raises(ValueError, match="qddot_max"):
        g.set_secondary_task(qddot_max=np.ones(3))
    g.clear_secondary_task()
    assert g.secondary_task is None


@pytest.mark.parametrize("make", [sim.Gantry.afma6, lambda: sim.UrdfRobot.example("ur5")], ids=["gantry", "ur5"])
def test_pickled_robot_keeps_its_secondary_task(make):
    """A sweep's worker (process pool, Dask) gets the robot by pickle: the settings travel with it."""
    robot = make()
    assert pickle.loads(pickle.dumps(robot)).secondary_task is None
    robot.set_secondary_task("large", avoid_joint_limits=False, rho=0.2, qddot_max=4.0, switch_high=0.6)
    again = pickle.loads(pickle.dumps(robot))
    a, b = robot.secondary_task, again.secondary_task
    assert b is not None and a.keys() == b.keys()
    for key in a:
        assert np.all(np.asarray(a[key]) == np.asarray(b[key])), key


def test_avoidance_turns_a_joint_limit_into_convergence():
    """The gantry case where IBVS-P drives joint 5 into its lower limit (paper Section V)."""
    case = sim.cases.gantry_joint_limit()
    servo = ibvs.Servo(ibvs.Layout.polar(4), gain=2.0)
    plain = sim.run(servo, case.camera, case.target, case.start, case.goal, robot=case.robot, duration=15.0,
                    depth="pose", tolerance=1e-5)
    assert plain.status.outcome == "joint_limit"
    robot = sim.Gantry.afma6()
    robot.set_secondary_task("large")
    avoided = sim.run(servo, case.camera, case.target, case.start, case.goal, robot=robot, duration=15.0,
                      depth="pose", tolerance=1e-5)
    assert avoided.status.outcome == "converged", avoided


def test_sweep_avoidance_turns_joint_limits_into_convergence():
    """ibvs.study.joint_limits on 8 random Panda starts (docs/arms.md has 100 per arm): stacked IBVS ends at a joint
    limit from some; with the large projector's avoidance none does and every such run converges."""
    from ibvs.study import joint_limits as jl

    rows = jl.sweep(("panda",), starts=8, laws=("stacked",), settings=("off", "large"))
    by = {(r.setting, r.start): r.outcome for r in rows}
    limited = [k for (s, k), o in by.items() if s == "off" and o == "joint_limit"]
    assert len(limited) >= 2
    assert all(by[("large", k)] == "converged" for k in limited)
    assert all(o != "joint_limit" for (s, _), o in by.items() if s == "large")
    table = jl.format_shares(jl.shares(rows))
    assert "| panda | stacked | large | 8/8 (100 %)" in table
