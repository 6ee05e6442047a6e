"""Target faces and collisions in the simulator (issue 11): target_backside and collision fire on
constructed cases, the six-point plate of the issue ends as one of them for IBVS-P, and the
paper's cases never do."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs
import ibvs.sim as sim
from ibvs.study import schemes
from ibvs.study.reproduce import CASES, DEPTH, DURATION, GAIN, SCHEMES

FACES = ("target_backside", "collision")


def test_outcomes_are_named_once():
    # the C++ enum's order: target_backside = 7, collision = 8 (lost_feature = 9 follows)
    assert sim.OUTCOMES[7:9] == FACES and len(set(sim.OUTCOMES)) == len(sim.OUTCOMES)


def test_six_point_plate_ends_behind_it():
    case = sim.cases.six_point_circle()
    for layout in (ibvs.Layout.polar(6), ibvs.Layout.stacked(6)):
        r = sim.run(ibvs.Servo(layout, gain=1.0, damping=0.01), case.camera, case.target, case.start,
                    case.goal, duration=case.duration)
        assert r.status.outcome == "target_backside" and r.status.frame == 1
        assert r.history.pose[1, 2, 3] > 0.5 > r.history.pose[0, 2, 3]  # behind the plate's plane z = 0.5
    r = sim.run(ibvs.Servo(ibvs.Layout.cartesian(6), gain=1.0, damping=0.01), case.camera, case.target,
                case.start, case.goal, duration=case.duration)
    assert r.converged


def test_camera_behind_the_plate_from_the_start():
    case = sim.cases.z_rotation()
    start = sim.pose(t=(0, 0, 6), r=(0, np.pi, 0))  # behind the plane z = 3, looking back at the points
    r = sim.run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0), case.camera, case.target, start, case.goal)
    assert (r.status.outcome, r.status.frame) == ("target_backside", 0)


def test_standoff_and_going_through():
    camera, target = sim.Camera.normalized(1.0), sim.Target.paper()
    goal = sim.pose(t=(0, 0, 2.5))  # 0.5 m from the plate
    run = lambda **kw: sim.run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0), camera, target, np.eye(4),
                               goal, duration=20.0, **kw)
    assert run().converged  # default standoff: 5 % of 0.5 m
    r = run(standoff_ratio=1.2)
    assert r.status.outcome == "collision" and r.status.point == -1
    assert 3.0 - r.history.pose[r.status.frame, 2, 3] == pytest.approx(0.6, abs=0.02)
    # Through the plate: 20 frames of latency keep the first large command going.
    tilted = sim.Target(target.points, sim.pose(t=(0, 0, 3), r=(-0.3, 0, 0)))
    r = sim.run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=4.0), sim.Camera.normalized(1e3), tilted, np.eye(4),
                sim.pose(t=(0, 0, 2.4)), latency=20, standoff_ratio=0.0)
    assert r.status.outcome == "collision"
    # A non-planar target: the standoff around each point, which is reported.
    pts = target.points.copy()
    pts[2, 2] = 0.05
    r = sim.run(ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0), camera, sim.Target(pts, target.pose),
                np.eye(4), goal, duration=20.0, standoff_ratio=1.2)
    assert r.status.outcome == "collision" and r.status.point >= 0
    with pytest.raises(ValueError, match="standoff_ratio"):
        run(standoff_ratio=-0.1)


@pytest.mark.parametrize("world", CASES)
def test_never_on_the_paper_cases(world):
    for name, make in CASES[world].items():
        c = make()
        for scheme in SCHEMES:
            r = sim.run(schemes.make(scheme, GAIN[world], len(c.target)), c.camera, c.target, c.start, c.goal,
                        robot=c.robot, duration=DURATION[world], depth=DEPTH[world], tolerance=1e-5)
            assert r.status.outcome not in FACES, (world, name, scheme, r)
