"""The wide-field study (ibvs.study.wide): its runs are the simulator's, what a perspective feature
cannot see, the spherical features from there, the half-turn with spherical-polar features, and the
page `ibvs wide` writes."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import ibvs
from ibvs import sim
from ibvs.study import schemes, wide
from ibvs.study.scenario import DEFAULTS, offset

ROOT = Path(__file__).resolve().parents[2]


def start(**p) -> np.ndarray:
    return offset(dict(DEFAULTS, **p))


def _direct(scheme: str) -> tuple[ibvs.Servo, sim.Target]:
    """The servo and target of `scheme` made here, apart from ibvs.study.wide."""
    if scheme in ("cartesian", "polar", "stacked"):
        return schemes.make(scheme, wide.GAIN, 4), sim.Target.paper()
    kinds = {"spherical": [ibvs.SphericalPointFeature], "spherical_stacked": [ibvs.SphericalPointFeature,
                                                                               ibvs.SphericalPolarFeature]}[scheme]
    task, sources = ibvs.Task(), []
    for i in range(4):
        for k in kinds:
            task.add(k())
            sources.append(sim.SphericalSource(i))
    return ibvs.Servo(task, gain=wide.GAIN, damping=0.0), sim.Target.paper().with_features(sources)


@pytest.mark.parametrize("scheme, tilt", [("cartesian", 25.0), ("polar", 25.0), ("stacked", 25.0),
                                          ("spherical", 25.0), ("spherical_stacked", 25.0), ("spherical", 100.0)])
def test_a_run_is_the_simulators(scheme, tilt):
    """A run of the study is ibvs.sim.run's free camera (the study has no loop of its own): the same
    frames, twists and metrics as a direct call; the retreat as a distance from the poses. tilt 100: the
    target behind the image plane, in the lens's view (judged by its image circle)."""
    cam = wide.camera()
    T0 = wide.start_pose(dict(DEFAULTS, rz_deg=60.0, tilt_deg=tilt, tilt_dir_deg=30.0, tx=0.1, ty=-0.05, tz=-0.3))
    o, tr = wide.run(scheme, T0, cam, trace=True)
    servo, target = _direct(scheme)
    r = sim.run(servo, cam, target, T0, np.eye(4), duration=wide.DURATION, depth="exact", tolerance=wide.TOLERANCE)
    assert o.outcome == r.status.outcome == "converged"
    assert o.frames == r.metrics.frames_to_converge + 1 == len(r.history.twist)
    np.testing.assert_array_equal(tr.twist, r.history.twist)
    np.testing.assert_array_equal(tr.pose, r.history.pose)
    assert o.path_length == r.metrics.path_length and o.axial_retreat == r.metrics.camera_retreat
    assert o.peak_linear_speed == r.metrics.peak_commanded_linear_speed
    assert o.peak_angular_speed == r.metrics.peak_commanded_angular_speed
    assert o.final_translation_error == r.metrics.final_translation_error < 1e-3
    centre = np.array([0.0, 0.0, 3.0])
    d = [np.linalg.norm(T[:3, 3] - centre) for T in r.history.pose]
    assert o.camera_retreat == pytest.approx(max(d) - d[0], abs=1e-12)
    if tilt > 90:
        assert wide.cannot_see(T0) and wide.run("cartesian", T0)[0].outcome == "cannot_see"


def test_the_lens_sees_110_degrees_off_the_axis():
    cam = wide.camera()
    edge = cam.from_bearing([math.sin(wide.HALF_FOV), 0.0, math.cos(wide.HALF_FOV)])
    assert edge[0] == pytest.approx(wide.SENSOR, abs=1e-9) and edge[1] == pytest.approx(wide.SENSOR / 2)


def test_the_default_lens_is_the_220_degree_one():
    """fov's default is the study's 220-degree lens: the camera written apart (f = 512 px / 110 degrees, centred),
    and the same rows as the study run with fov=220 and with that camera."""
    K, D = wide.camera().to_opencv()[:2]
    f = (wide.SENSOR / 2) / math.radians(110.0)
    np.testing.assert_array_equal(K, [[f, 0, 512], [0, f, 512], [0, 0, 1]])
    assert wide.FOV == 220.0 and wide.HALF_FOV == math.radians(110.0)
    few = ("polar", "spherical")
    rows = wide.study(rotations=2, general=3, seed=1, schemes_=few)
    assert repr(rows) == repr(wide.study(rotations=2, general=3, seed=1, schemes_=few, fov=220))
    cam = ibvs.CameraModel.from_opencv(K, [0.0] * 4, 1024, 1024, fisheye=True, fps=wide.FPS)
    apart = [wide.summarise(st, label, s, T0, wide.run(s, T0, cam)[0]) for st, label, T0 in wide.starts(2, 3, 1)
             for s in few]
    assert repr(rows) == repr(apart)


@pytest.mark.parametrize("fov", [180.0, 260.0, 90.0])
def test_fov_sets_the_lens_image_circle(fov):
    """camera(fov): the directions fov/2 off the axis image onto the sensor's edges (the circle inscribed),
    those a little beyond it outside the sensor; the random starts keep every point inside that circle; the
    page names the lens."""
    cam, half = wide.camera(fov), math.radians(fov / 2)
    S = wide.SENSOR
    assert cam.px == pytest.approx((S / 2) / half, rel=1e-12)
    for phi in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi, 0.3):
        b = [math.sin(half) * math.cos(phi), math.sin(half) * math.sin(phi), math.cos(half)]
        u = cam.from_bearing(b)
        assert np.hypot(u[0] - S / 2, u[1] - S / 2) == pytest.approx(S / 2, abs=1e-9)  # on the inscribed circle
        a = half + math.radians(1.0)
        out = cam.from_bearing([math.sin(a) * math.cos(phi), math.sin(a) * math.sin(phi), math.cos(a)])
        assert np.hypot(out[0] - S / 2, out[1] - S / 2) > S / 2 + 1.0
    edge = cam.to_bearing([[S, S / 2], [S / 2, 0.0]])
    np.testing.assert_allclose(np.arccos(edge[:, 2]), half, rtol=0, atol=1e-12)
    every = wide.starts(2, 40, 0, fov=fov)
    worst = max(wide.off_axis(wide.in_camera(T, wide.target_points())).max() for st, _, T in every if st == "general")
    assert worst < half
    if fov < 220:  # the 220-degree lens's starts include some beyond this one's circle: they are drawn again
        default = wide.starts(2, 40, 0)
        assert max(wide.off_axis(wide.in_camera(T, wide.target_points())).max() for _, _, T in default) > half
        assert [lab for _, lab, _ in every] != [lab for _, lab, _ in default]
    rows = wide.study(rotations=2, general=0, schemes_=("spherical",), fov=fov)
    text = " ".join(wide.page(rows, [], 2, 0, 0, 1.0, fov=fov).split())
    assert f"on a {fov:g}° fisheye" in text and f"{fov / 2:g}° off the axis (a {fov:g}° lens)" in text


def test_fov_outside_its_range_is_refused(tmp_path, capsys):
    for bad in (89.0, 301.0, math.nan, math.inf, "220", True, None):
        with pytest.raises(ValueError, match=r"fov must be a number of degrees in \[90, 300\]"):
            wide.camera(bad)
    with pytest.raises(ValueError, match="fov"):
        wide.study(rotations=2, general=0, fov=400.0)
    with pytest.raises(ValueError, match="fov"):
        wide.starts(2, 1, 0, fov=0.0)
    for text in ("400", "nan", "wide", "-220"):
        with pytest.raises(SystemExit) as e:
            wide.main(["--out", str(tmp_path / "w"), "--fov", text])
        assert e.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--fov" in err[0] and "error" in err[0]
    assert not (tmp_path / "w").exists()  # refused before any work


def _outside_perspective(T_wc: np.ndarray) -> bool:
    """Written apart from ibvs.study.wide: some corner of the square behind the image plane, or with
    |X| or |Y| over ten times its depth."""
    R, t = T_wc[:3, :3], T_wc[:3, 3]
    for x in (-0.25, 0.25):
        for y in (-0.25, 0.25):
            X, Y, Z = R.T @ (np.array([x, y, 3.0]) - t)
            if Z <= 0 or abs(X) > 10 * Z or abs(Y) > 10 * Z:
                return True
    return False


def test_cannot_see_counts_the_starts_outside_the_perspective_domain():
    rows = wide.study(rotations=2, general=30, seed=3, schemes_=("cartesian", "spherical"))
    starts = {label: T for _, label, T in wide.starts(2, 30, 3)}
    blind = {label for label, T in starts.items() if _outside_perspective(T)}
    assert len(blind) >= 3  # the random starts reach behind the image plane
    assert {r.start for r in rows if r.scheme == "cartesian" and r.outcome == "cannot_see"} == blind
    assert {r.start for r in rows if r.cannot_see} == blind
    assert not any(r.outcome == "cannot_see" for r in rows if r.scheme == "spherical")
    # the spherical features converge from most of them
    assert sum(r.converged for r in rows if r.scheme == "spherical" and r.start in blind) >= len(blind) // 2


@pytest.mark.parametrize("scheme", ["spherical", "spherical_stacked"])
def test_spherical_features_converge_where_a_perspective_camera_cannot_see(scheme):
    T0 = wide.start_pose(dict(DEFAULTS, tilt_deg=100.0, tilt_dir_deg=40.0, rz_deg=30.0))
    centre = wide.in_camera(T0, wide.target_points()).mean(axis=0)
    assert math.degrees(math.acos(centre[2] / np.linalg.norm(centre))) > 95.0
    assert wide.cannot_see(T0) and wide.run("cartesian", T0)[0].outcome == "cannot_see"
    o, _ = wide.run(scheme, T0)
    assert o.outcome == "converged"
    assert o.final_translation_error < 1e-3 and o.final_rotation_error < 1e-3


@pytest.mark.parametrize("deg", [90.0, 150.0, 179.9, 180.1])
def test_spherical_polar_turns_about_the_axis_without_retreat(deg):
    o, tr = wide.run("spherical_polar", start(rz_deg=deg), trace=True)
    assert o.outcome == "converged" and o.final_rotation_error < 1e-3
    assert o.camera_retreat < 1e-6 and np.abs(tr.pose[:, :3, 3]).max() < 1e-6


def _spherical_polar_per_point() -> ibvs.Servo:
    task = ibvs.Task()
    for _ in range(4):
        task.add(ibvs.SphericalPolarFeature())
    return ibvs.Servo(task, gain=wide.GAIN, damping=0.0, angle_wrap="per_point")


def test_spherical_polar_half_turn_turns_about_the_axis_like_polar():
    """At exactly pi each feature's own wrap (eq. 13 per point) leaves one azimuth error on the other branch;
    the Servo's consistent wrap, which the azimuths join, puts all four on one: a pure rotation about the axis,
    the camera centre still, as with polar. With angle_wrap="per_point" the split stays and throws the camera."""
    T0 = np.asarray(sim.cases.z_rotation().start)
    cam = wide.camera()
    _, m = wide._measure("spherical_polar", cam, wide.in_camera(T0, wide.target_points()))
    _, g = wide._measure("spherical_polar", cam, wide.in_camera(np.eye(4), wide.target_points()))
    assert ibvs.SphericalPolarFeature().axis_angle_rows(m[:4], g[:4]) == [1]  # the azimuth joins the wrap
    none = np.zeros((0, 2))
    split = _spherical_polar_per_point().update(none, none[:, 0], none, measurements=m, measurements_desired=g)
    np.testing.assert_allclose(np.abs(split.error[1::2]), math.pi, rtol=0, atol=1e-12)
    assert split.error[1::2].min() < 0 < split.error[1::2].max()  # per point: not one branch
    assert np.linalg.norm(split.velocity[:3]) > 1.0
    out = wide.make("spherical_polar").update(none, none[:, 0], none, measurements=m, measurements_desired=g)
    e = out.error[1::2]
    np.testing.assert_allclose(np.abs(e), math.pi, rtol=0, atol=1e-12)
    assert e.max() - e.min() < 1e-12  # one branch
    np.testing.assert_allclose(out.error[0::2], split.error[0::2], rtol=0, atol=0)  # colatitudes untouched
    assert np.linalg.norm(out.velocity[:5]) < 1e-9 and abs(out.velocity[5]) > 0.5  # a pure rotation about z
    sp, tr = wide.run("spherical_polar", T0, trace=True)
    polar, _ = wide.run("polar", T0)
    for o in (sp, polar):
        assert o.outcome == "converged" and o.camera_retreat < 1e-6 and o.path_length < 1e-6
        assert o.final_translation_error < 1e-3 and o.final_rotation_error < 1e-3
    assert np.abs(tr.pose[:, :3, 3]).max() < 1e-6 and np.abs(tr.twist[:, :5]).max() < 1e-6
    pp, _ = wide.run("polar_per_point", T0)
    assert pp.outcome != "converged" and pp.path_length > 1.0


@pytest.mark.parametrize("rz, tilt, direction", [(178.0, 3.0, 30.0), (160.0, 10.0, 45.0)])
def test_spherical_polar_converges_where_polar_needs_its_consistent_wrap(rz, tilt, direction):
    """Near the axis, turned by most of a half-turn: polar and spherical-polar (its azimuths in the
    consistent wrap) converge without a retreat to speak of; polar with per-point wraps does not."""
    T0 = wide.start_pose(dict(DEFAULTS, rz_deg=rz, tilt_deg=tilt, tilt_dir_deg=direction))
    o = {s: wide.run(s, T0)[0] for s in ("polar", "polar_per_point", "spherical_polar")}
    for s in ("polar", "spherical_polar"):
        assert o[s].outcome == "converged" and o[s].camera_retreat < 0.05 and o[s].final_rotation_error < 1e-3
    assert o["polar_per_point"].outcome != "converged"


def test_spherical_cartesian_retreats_like_cartesian():
    runs = {s: wide.run(s, start(rz_deg=150.0))[0] for s in ("cartesian", "spherical", "stacked", "spherical_stacked")}
    assert runs["cartesian"].camera_retreat > 5.0
    assert runs["spherical"].camera_retreat == pytest.approx(runs["cartesian"].camera_retreat, rel=0.02)
    assert runs["spherical_stacked"].camera_retreat == pytest.approx(runs["stacked"].camera_retreat, rel=0.05)


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="scheme"):
        wide.make("fisheye")
    with pytest.raises(ValueError, match="start"):
        wide.run("spherical", np.full((4, 4), np.nan))
    with pytest.raises(ValueError, match="start"):
        wide.run("spherical", np.eye(3))
    with pytest.raises(ValueError, match="duration"):
        wide.run("spherical", np.eye(4), duration=-1.0)


# ------------------------------------------------------------------ the command and its page


def _paragraphs(text: str) -> list[str]:
    """The page's prose and headings (no tables, figures or bullets of findings), numbers masked, rewrapped."""
    out = []
    for block in text.split("\n\n"):
        block = " ".join(block.split())
        if not block or block.startswith(("|", "![", "- ")):
            continue
        out.append(re.sub(r"\d+(\.\d+)?(e-?\d+)?", "#", block))
    return out


def test_wide_command_writes_its_page_and_figures(tmp_path, capsys):
    from ibvs.cli.main import main

    assert main(["wide", "--out", str(tmp_path), "--rotations", "2", "--general", "2"]) == 0
    page = (tmp_path / "wide-study.md").read_text()
    for s in wide.SCHEMES:
        assert f"`{s}`" in page
    for name in ("wide_rotation.png", "wide_angle.png", "wide_traces.png"):
        assert (tmp_path / "figures" / name).stat().st_size > 1000 and f"figures/{name}" in page
    assert "runs in" in capsys.readouterr().out
    # docs/wide-study.md is this command's page: the same prose and headings, figures that exist
    docs = (ROOT / "docs" / "wide-study.md").read_text()
    assert _paragraphs(docs) == _paragraphs(page)
    for name in re.findall(r"\(figures/(wide_\w+\.png)\)", docs):
        assert (ROOT / "docs" / "figures" / name).is_file()
    assert all(f"`{s}`" in docs for s in wide.SCHEMES)


def test_wide_command_refuses_bad_arguments(tmp_path):
    with pytest.raises(SystemExit):
        wide.main(["--out", str(tmp_path), "--rotations", "1"])
