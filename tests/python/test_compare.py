"""The simulator's moments, PBVS and 2.5-D sources, the schemes built on them, and the comparison
(ibvs.study.compare) with the known properties of each law."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import ibvs
from ibvs import sim
from ibvs.study import compare, schemes
from ibvs.study.scenario import DEFAULTS, offset


def off_line(path: np.ndarray) -> float:
    """The largest distance of a path's points from the segment joining its ends, relative to its length."""
    a, b = path[0], path[-1]
    d = (b - a) / np.linalg.norm(b - a)
    r = path - a
    return float(np.max(np.linalg.norm(r - np.outer(r @ d, d), axis=1)) / np.linalg.norm(b - a))


def start(**p) -> np.ndarray:
    return offset(dict(DEFAULTS, **p))


GENERAL = dict(rz_deg=60.0, tilt_deg=8.0, tilt_dir_deg=30.0, tx=0.1, ty=-0.05, tz=-0.3)


def camera_poses(r) -> list[np.ndarray]:
    """camera <- target of every frame."""
    return [np.linalg.inv(T) @ np.asarray(r.target.pose) for T in r.history.pose]


# ------------------------------------------------------------------ the sources against their features


@pytest.mark.parametrize("scheme", ["pbvs", "pbvs_object", "2.5d"])
def test_pose_sources_measure_what_the_feature_measures(scheme):
    r = compare.run(scheme, start(**GENERAL))
    cdMo = np.asarray(r.target.pose)  # the goal camera is the world origin
    P0 = np.asarray(r.target.points)[0]
    m = r.history.measurements
    assert r.status.converged and m.shape[1] == 6
    for k in (0, 10, 100, len(m) - 1):
        cMo = camera_poses(r)[k]
        if scheme == "2.5d":
            want = ibvs.Point25DFeature.measure(cMo, cdMo, P0)
        else:
            want = ibvs.PbvsFeature.measure(cMo, cdMo, "desired_camera" if scheme == "pbvs" else "object")
        np.testing.assert_allclose(m[k], want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("scheme", ["moments", "moments_pi"])
def test_moments_source_measures_the_projection(scheme):
    r = compare.run(scheme, start(**GENERAL))
    P = np.asarray(r.target.points)
    to_camera = lambda T: P @ T[:3, :3].T + T[:3, 3]  # noqa: E731
    goal_points = to_camera(np.asarray(r.target.pose))
    g = ibvs.MomentsFeature.of_polygon(goal_points[:, :2] / goal_points[:, 2:])
    depth_desired = compare.DEPTH  # the plane is parallel to the image at the goal
    goal = ibvs.MomentsFeature.project(goal_points, "region", depth_desired=depth_desired)
    assert goal[15] == pytest.approx(g[0], rel=1e-12)
    np.testing.assert_allclose(r.measurements_desired, goal, rtol=1e-12, atol=1e-14)
    m = r.history.measurements
    for k in (0, 10, 100, len(m) - 1):
        want = ibvs.MomentsFeature.project(to_camera(camera_poses(r)[k]), "region", area_desired=goal[15],
                                           depth_desired=depth_desired)
        np.testing.assert_allclose(m[k], want, rtol=1e-10, atol=1e-13)


def test_depth_pose_modes_feed_the_pose_sources():
    """With depth="pose" the PBVS source takes ibvs.PlanarPose's estimate: without noise, the true pose."""
    case = sim.cases.gantry_general_motion()
    for scheme in ("pbvs", "2.5d", "pbvs_object"):
        servo = schemes.make(scheme, 2.0)
        r = sim.run(servo, case.camera, schemes.target_for(scheme, case.target), case.start, case.goal,
                    robot=case.robot, duration=15.0, depth="pose", tolerance=1e-6)
        assert r.status.converged, (scheme, r.status)
        assert r.metrics.final_translation_error < 1e-4 and r.metrics.final_rotation_error < 1e-4


def test_sources_pickle_and_describe():
    for src in (sim.MomentsSource(), sim.MomentsSource("points"), sim.PbvsSource(), sim.PbvsSource("object"),
                sim.Point25DSource(2)):
        back = pickle.loads(pickle.dumps(src))
        assert repr(back) == repr(src) and back.size == src.size
    t = compare.target().with_features([sim.PbvsSource("object")])
    assert repr(pickle.loads(pickle.dumps(t)).features[0]) == "PbvsSource('object')"
    assert sim.MomentsSource().source == "region" and sim.PbvsSource().target == "desired_camera"
    assert sim.Point25DSource(3).i == 3


def test_sources_refuse_what_they_cannot_measure():
    with pytest.raises(ValueError, match="source"):
        sim.MomentsSource("polygon")
    with pytest.raises(ValueError, match="target"):
        sim.PbvsSource("camera")
    with pytest.raises((ValueError, TypeError)):
        sim.Point25DSource(-1)
    with pytest.raises(ValueError, match="not a target point"):
        compare.target().with_features([sim.Point25DSource(4)])
    raised = sim.Target(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.5]], float))
    with pytest.raises(ValueError, match="z = 0 plane"):
        raised.with_features([sim.MomentsSource()])
    # a source that does not fit its block
    servo = schemes.make("pbvs", 1.0)
    with pytest.raises(ValueError, match="cannot measure"):
        sim.run(servo, sim.cases.z_rotation().camera, compare.target().with_features([sim.PbvsSource("object")]),
                start(rz_deg=10.0), np.eye(4), duration=0.1)


def test_a_pbvs_task_converges_on_a_panda_arm():
    pytest.importorskip("pinocchio")
    case = sim.cases.arm_general_motion("panda")
    r = sim.run(schemes.make("pbvs", 1.0), case.camera, schemes.target_for("pbvs", case.target), case.start,
                case.goal, robot=case.robot, duration=case.duration, depth="exact", tolerance=1e-6)
    assert r.status.converged, r.status
    assert r.metrics.final_translation_error < 1e-4


# ------------------------------------------------------------------ the known properties


def _at_fps(scheme: str, fps: float):
    """A general start servoed by `scheme` on the compared target, the camera at `fps` frames/s."""
    camera = sim.Camera.normalized(0.3, fps=fps)
    r = sim.run(schemes.make(scheme, compare.GAIN), camera, schemes.target_for(scheme, compare.target()),
                start(**GENERAL), np.eye(4), duration=20.0, tolerance=1e-6)
    assert r.status.converged, r.status
    return np.asarray(r.history.pose)[:, :3, 3], np.asarray(r.history.uv)[:, 0, :]


def test_pbvs_moves_the_camera_centre_on_a_straight_line():
    """Straight in continuous time; the simulator holds each twist for a frame (a screw), which leaves the line
    by O(gain dt): measured 0.10 % of the path at 60 frames/s, halving with dt."""
    (centres, image), (centres2, _) = _at_fps("pbvs", 60.0), _at_fps("pbvs", 120.0)
    assert off_line(centres) < 0.1 * compare.GAIN / 60.0
    assert 0.45 < off_line(centres2) / off_line(centres) < 0.55
    assert off_line(image) > 0.05  # its image is free


def test_25d_keeps_its_reference_point_image_on_a_straight_line():
    """0.24 % of the image path at 60 frames/s, halving with dt."""
    (centres, image), (_, image2) = _at_fps("2.5d", 60.0), _at_fps("2.5d", 120.0)
    assert off_line(image) < 0.2 * compare.GAIN / 60.0
    assert 0.45 < off_line(image2) / off_line(image) < 0.55
    assert off_line(centres) > 0.05  # the camera's path is not a line


@pytest.mark.parametrize("deg", [90.0, 150.0, 180.0])
def test_moments_turn_the_camera_about_its_axis_without_retreat(deg):
    r = compare.run("moments", start(rz_deg=deg))
    assert r.status.converged and compare.summarise("", "", "moments", r).reached
    assert r.metrics.camera_retreat < 1e-6
    assert np.max(np.abs(np.asarray(r.history.pose)[:, :3, 3])) < 1e-6  # no sideways motion either


def test_moments_pi_settles_on_the_half_turn():
    """alpha from second-order moments is defined modulo pi: a turn of 150 deg is read as -30 deg."""
    r = compare.run("moments_pi", start(rz_deg=150.0))
    assert r.status.converged
    R = np.asarray(r.history.pose)[-1, :3, :3]
    assert np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))) == pytest.approx(180.0, abs=1e-3)


def test_cartesian_retreats_where_moments_do_not():
    rows = {s: compare.summarise("", "", s, compare.run(s, start(rz_deg=150.0))) for s in ("cartesian", "moments")}
    assert rows["cartesian"].camera_retreat > 1.0 and rows["moments"].camera_retreat < 1e-6


def test_moments_refuse_the_centrally_symmetric_square():
    with pytest.raises(ValueError, match="centrally symmetric"):
        schemes.target_for("moments", sim.Target.paper())


def test_depth_error_moves_the_pbvs_goal_not_the_image_based_one():
    """Depths scaled by 2: Cartesian IBVS still reaches the goal (its error is zero only there); PBVS converges
    where its scaled translation is zero, the camera at Z*/2 from the target (3 m -> 1.5 m), and so does 2.5-D
    here (its Z is the depth mode's, against the goal's true Z*)."""
    rows = {s: compare.summarise("", "", s, compare.run(s, start(**GENERAL), depth_scale=2.0), 2.0)
            for s in ("cartesian", "pbvs", "2.5d")}
    assert rows["cartesian"].reached
    assert rows["pbvs"].converged and rows["pbvs"].final_translation_error == pytest.approx(1.5, abs=1e-3)
    assert rows["2.5d"].converged and rows["2.5d"].final_translation_error == pytest.approx(1.5, abs=0.05)


@pytest.mark.parametrize("scale", [0.5, 2.0])
def test_depth_error_taught_by_showing_leaves_pbvs_at_the_goal(scale):
    """The pose depth mode scaled by s: the goal's pose (and 2.5-D's Z*) estimated from the goal's image carries the
    same s as every frame's (teach by showing), so PBVS and 2.5-D head for the true goal whatever s (PBVS's
    translation at the rate gain * s: with s = 0.5 it is 1e-5 m away after 20 s, exp(-10) of its start)."""
    setup = compare.scenario().replace(depth="pose")
    for s in ("pbvs", "pbvs_object", "2.5d"):
        row = compare.summarise("", "", s, compare.run(s, start(**GENERAL), depth_scale=scale, setup=setup), scale)
        assert row.reached and row.final_translation_error < 1e-4 and row.final_rotation_error < 1e-6, row
        assert row.converged or scale < 1, row


# ------------------------------------------------------------------ schemes, sweeps and the command


def test_schemes_beyond_points_are_registered_and_picklable():
    for s in ("moments", "moments_pi", "pbvs", "pbvs_object", "2.5d"):
        assert s in schemes.SCHEMES and s in schemes.TARGETS and s not in schemes.points_only()
        e = pickle.loads(pickle.dumps(schemes.entry(s)))
        assert e.factory is schemes.SCHEMES[s] and e.target is schemes.TARGETS[s]
    assert schemes.points_only()[:7] == ("cartesian", "polar", "hybrid", "stacked", "cylindrical", "automatic",
                                         "partitioned")


def test_register_scheme_with_a_target_function():
    try:
        schemes.register_scheme("test_pbvs", schemes.pbvs, target=schemes.pbvs_target)
        assert schemes.TARGETS["test_pbvs"] is schemes.pbvs_target
        with pytest.raises(TypeError, match="target"):
            schemes.register_scheme("test_pbvs", schemes.pbvs, target=3, replace=True)
        schemes.register_scheme("test_pbvs", schemes.cartesian, replace=True)
        assert "test_pbvs" not in schemes.TARGETS
    finally:
        schemes.SCHEMES.pop("test_pbvs", None)
        schemes.TARGETS.pop("test_pbvs", None)


def test_a_sweep_runs_the_new_schemes_and_refuses_moments_on_the_square(tmp_path):
    from ibvs.study import sweep

    rows = sweep.sweep(tmp_path / "s.csv", scenario=compare.scenario(), episodes=2, schemes=("polar", "moments",
                                                                                             "pbvs", "2.5d"),
                       jobs=1, progress=False)
    assert len(rows) == 8 and {r["scheme"] for r in rows} == {"polar", "moments", "pbvs", "2.5d"}
    assert all(r["outcome"] in sim.OUTCOMES or r["outcome"] == "invalid_start" for r in rows)
    with pytest.raises(ValueError, match="centrally symmetric"):
        sweep.sweep(None, world="free", episodes=1, schemes=("moments",), progress=False)


def test_compare_command_writes_its_table_and_figures(tmp_path, capsys):
    assert compare.main(["--out", str(tmp_path), "--rotations", "2", "--general", "1"]) == 0
    page = (tmp_path / "compare.md").read_text()
    for s in compare.SCHEMES:
        assert f"`{s}`" in page
    for name in ("rotation", "depth", "calibration"):
        assert (tmp_path / "figures" / f"compare_{name}.png").stat().st_size > 1000
        assert f"](figures/compare_{name}.png)" in page
    # the columns the issue asks for, and the limits of alpha: which target, which alpha each row uses
    assert "| stayed in image |" in page and "## Calibration error" in page
    for c in compare.CALIBRATIONS:
        assert f" {c} |" in page
    for s, alpha in compare.ALPHA.items():
        assert f"(`{s}`) | {alpha} |" in page
    assert "asymmetric planar quadrilateral" in page and "centrally symmetric" in page
    assert max(len(line) for line in page.splitlines() if not line.startswith("|")) <= 120
    assert "runs in" in capsys.readouterr().out


# ------------------------------------------------------------------ calibration error


def test_miscalibrated_camera_gives_the_servo_the_believed_normalisation():
    """The controller's points are the believed model's normalisation of the true pixels, the goal's included;
    whether a point is in the image is judged on the true pixel."""
    camera, believed = compare.cameras("f ×0.8")
    sensor = sim.MiscalibratedCamera(camera, believed)
    r = sim.run(schemes.make("cartesian", 1.0), camera, compare.target(), start(**GENERAL), np.eye(4), duration=0.5,
                vision=sensor)
    P = np.asarray(r.target.points)
    for k in (0, 10, len(r.history.uv) - 1):
        T = np.linalg.inv(np.asarray(r.history.pose)[k]) @ np.asarray(r.target.pose)
        Pc = P @ T[:3, :3].T + T[:3, 3]
        true_pixels = camera.project(Pc[:, :2] / Pc[:, 2:])
        np.testing.assert_allclose(r.history.uv[k], believed.normalize(true_pixels), rtol=0, atol=1e-12)
        np.testing.assert_allclose(r.history.uv[k], 1.25 * Pc[:, :2] / Pc[:, 2:], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(r.uv_desired, believed.normalize(camera.project(r.uv_desired * 0.8)), atol=1e-12)
    # distortion ignored: the controller's points are the distorted ones
    camera, believed = compare.cameras("k1 ignored")
    assert camera.distortion != "none" and believed.distortion == "none"
    r = sim.run(schemes.make("cartesian", 1.0), camera, compare.target(), start(**GENERAL), np.eye(4), duration=0.1,
                vision=sim.MiscalibratedCamera(camera, believed))
    x = np.asarray(r.history.uv)[0]
    T = np.linalg.inv(np.asarray(r.history.pose)[0]) @ np.asarray(r.target.pose)
    Pc = np.asarray(r.target.points) @ T[:3, :3].T + T[:3, 3]
    xt = Pc[:, :2] / Pc[:, 2:]
    np.testing.assert_allclose(x, xt * (1 + compare.K1 * np.sum(xt**2, axis=1, keepdims=True)), rtol=0, atol=1e-12)


def test_miscalibrated_camera_refuses_and_pickles():
    camera, believed = compare.cameras("f ×0.9")
    with pytest.raises(TypeError, match="believed"):
        sim.MiscalibratedCamera(camera, np.eye(3))
    with pytest.raises(TypeError, match="camera"):
        sim.MiscalibratedCamera("camera", believed)
    with pytest.raises(ValueError, match="noise"):
        sim.MiscalibratedCamera(camera, believed, noise=-1.0)
    back = pickle.loads(pickle.dumps(sim.MiscalibratedCamera(camera, believed, noise=0.5)))
    assert back.believed == believed and back.noise == 0.5 and "believed" in repr(back)


@pytest.mark.parametrize("calibration", ["f ×0.8", "f ×1.25", "c +(24, −16) px"])
def test_calibration_error_teaches_every_law_the_goal_image(calibration):
    """Teach by showing through the wrong model: IBVS's error is zero only at the taught image; PBVS and 2.5-D aim
    at the pose the pose depth mode estimates from the goal's image, so their error is zero where the current
    image's estimate equals it, i.e. where the image is the goal's: all three end at the true goal, with the goal's
    image (pixels). The bias sits in that estimate of the goal, by what the estimate of a planar target does: a focal
    length s times the true one shows the fronto-parallel target at s Z* (s = 0.8: 2.4 m for 3 m; a PBVS given the
    true goal pose would end where the estimate is Z*, at Z* / s), a principal point offset d (px) shifted sideways
    by Z* d / f."""
    scale, (du, dv), _ = compare.CALIBRATIONS[calibration]
    want = compare.DEPTH * abs(scale - 1) if scale != 1 else compare.DEPTH * np.hypot(du, dv) / compare.FOCAL
    for s in ("cartesian", "pbvs", "2.5d"):
        r = compare.run(s, start(**GENERAL), calibration=calibration)
        row = compare.summarise("calibration", calibration, s, r)
        assert row.converged and row.reached, row
        assert row.final_translation_error < 1e-5 and row.final_rotation_error < 1e-5, row
        last = np.asarray(r.history.measured)[-1].reshape(-1, 2)
        np.testing.assert_allclose(last, np.asarray(r.measured_desired), rtol=0, atol=1e-3)  # pixels
    # the goal as the controller knows it: PlanarPose of the goal's image through the wrong model
    cdMo_hat, _, degenerate = ibvs.PlanarPose(np.asarray(r.target.points)).estimate(r.uv_desired)
    assert not degenerate
    cdMo = np.asarray(r.target.pose)  # the goal camera is the world origin
    assert np.linalg.norm(cdMo_hat[:3, 3] - cdMo[:3, 3]) == pytest.approx(want, rel=2e-3)
    assert r.measurements_desired[2] == pytest.approx(np.asarray(r.target.points)[0] @ cdMo_hat[2, :3]
                                                      + cdMo_hat[2, 3], rel=1e-9)  # 2.5-D's Z*: the estimate's


@pytest.mark.parametrize("scheme", ["pbvs", "pbvs_object", "2.5d", "moments"])
def test_estimated_goal_is_the_true_one_for_an_exact_image(scheme):
    """With an exact camera the pose depth mode's estimate of the goal is the true goal: the sources' desired
    measurements and the run are those of the true goal pose (the exact depth mode's goal) to 1e-9."""
    setup = compare.scenario()
    target = schemes.target_for(scheme, setup.target)
    runs = {d: sim.run(schemes.make(scheme, compare.GAIN), setup.camera, target, start(**GENERAL), np.eye(4),
                       duration=2.0, depth=d, tolerance=compare.TOLERANCE) for d in ("exact", "pose")}
    np.testing.assert_allclose(runs["pose"].measurements_desired, runs["exact"].measurements_desired, rtol=0,
                               atol=1e-9)
    np.testing.assert_allclose(runs["pose"].history.pose, runs["exact"].history.pose, rtol=0, atol=1e-9)


def test_the_calibration_table_of_the_docs_is_the_commands():
    """docs/compare.md's calibration rows of three schemes, rerun: the page is the command's (ibvs compare --docs)."""
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "docs" / "compare.md").read_text()
    setup = compare.scenario()
    rows = [compare.summarise("calibration", c, s, compare.run(s, offset(compare.DEPTH_START), 1.0, setup, c))
            for c in compare.CALIBRATIONS for s in ("cartesian", "2.5d", "pbvs")]
    table = compare.calibration_table(rows).splitlines()
    assert table[0] in page
    for line in table[2:]:
        assert line in page
