"""ibvs.viz: every figure for every world and servo kind, headless, without touching the
backend; labels, colours and legends; the animation's frames."""

from __future__ import annotations

import io
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import ibvs
from ibvs import sim, viz
from ibvs.study.schemes import make, points_only

Figure = pytest.importorskip("matplotlib.figure").Figure


def _free(scheme: str, duration: float = 3.0):
    c = sim.cases.general_motion()
    return sim.run(make(scheme, 1.0), c.camera, c.target, c.start, c.goal, duration=duration)


def _gantry(scheme: str, duration: float = 3.0):
    c = sim.cases.gantry_general_motion()
    return sim.run(make(scheme, 2.0), c.camera, c.target, c.start, c.goal, robot=c.robot, duration=duration,
                   depth="pose")


def _pixel_free_nonplanar(duration: float = 2.0):
    """A user's set-up: a pixel camera in free flight, five non-coplanar points."""
    cam = sim.Camera(600, 600, 320, 240, kud=-0.05, kdu=0.05, width=640, height=480, fps=30)
    pts = [[-0.05, -0.05, 0], [0.05, -0.05, 0], [0.05, 0.05, 0], [-0.05, 0.05, 0], [0, 0, -0.03]]
    target = sim.Target(pts, sim.pose(t=(0, 0, 0.5)))
    return sim.run(make("stacked", 1.0, 5), cam, target, sim.pose_deg((0.02, 0, -0.05), (0, 5, 40)), np.eye(4),
                   duration=duration)


RESULTS = {
    **{f"free-{s}": (lambda s=s: _free(s)) for s in points_only()},
    "gantry-stacked": lambda: _gantry("stacked"),
    "gantry-partitioned": lambda: _gantry("partitioned"),
    "free-pixel-nonplanar": _pixel_free_nonplanar,
}


@pytest.fixture(scope="module")
def results():
    return {k: f() for k, f in RESULTS.items()}


def _titles(fig) -> list:
    return [ax.get_title() for ax in fig.axes]


@pytest.mark.parametrize("name", list(RESULTS))
def test_episode_figure_for_every_world_and_servo(results, name):
    r = results[name]
    fig = r.plot()
    assert isinstance(fig, Figure)
    titles = _titles(fig)
    assert "feature error" in titles and "camera twist" in titles and "camera in the world" in titles
    pixel = name.startswith("gantry") or "pixel" in name
    assert ("camera image (pixels): o start, * end" in titles) == pixel
    assert ("joints within their limits (red)" in titles) == name.startswith("gantry")
    assert r.status.outcome in fig._suptitle.get_text()
    if name in ("free-stacked", "gantry-partitioned", "free-pixel-nonplanar"):  # drawing: one of each world
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=40)
        assert buf.getvalue()[:4] == b"\x89PNG"


def _error_axes(fig):
    return next(ax for ax in fig.axes if ax.get_title() == "feature error")


def test_error_lines_are_named_by_coordinate_and_point(results):
    """Stacked: u, v, r, theta of every point; one colour per point, one line style per coordinate."""
    ax = _error_axes(results["free-stacked"].plot())
    lines = {ln.get_label(): ln for ln in ax.get_lines() if not ln.get_label().startswith("_")}
    expected = {f"${c}_{{{i}}}$" for i in range(1, 5) for c in ("u", "v", "r", r"\theta")}
    assert set(lines) == expected
    for i in range(1, 5):
        colours = {lines[f"${c}_{{{i}}}$"].get_color() for c in ("u", "v", "r", r"\theta")}
        assert len(colours) == 1
    for c in ("u", "v", "r", r"\theta"):
        assert len({lines[f"${c}_{{{i}}}$"].get_linestyle() for i in range(1, 5)}) == 1
    assert len({lines[f"${c}_{{1}}$"].get_linestyle() for c in ("u", "v", "r", r"\theta")}) == 4
    # each point's colour is its colour in the image-plane panel
    img = next(a for a in results["free-stacked"].plot().axes if a.get_title().startswith("image plane"))
    point1 = next(ln for ln in img.get_lines() if ln.get_label() == "point 1")
    assert point1.get_color() == lines["$u_{1}$"].get_color()


@pytest.mark.parametrize("name, labels", [
    ("free-polar", {"$r_{1}$", r"$\theta_{4}$"}),
    ("free-cylindrical", {"$r_{2}$", r"$r\theta_{3}$"}),
    ("free-partitioned", {"$u_{1}$", "$v_{4}$"}),  # its history holds the Cartesian error
    ("free-hybrid", {"$u_{1}$", "$v_{2}$", "$r_{3}$", r"$\theta_{4}$"}),
])
def test_error_labels_follow_the_layout(results, name, labels):
    ax = _error_axes(results[name].plot())
    assert labels <= {ln.get_label() for ln in ax.get_lines()}


def test_legends_do_not_cover_the_data(results):
    fig = results["gantry-stacked"].plot()
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    checked = 0
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None or ax.name == "3d":
            continue
        a, b = ax.get_window_extent(renderer), leg.get_window_extent(renderer)
        overlap_x = min(a.x1, b.x1) - max(a.x0, b.x0)
        overlap_y = min(a.y1, b.y1) - max(a.y0, b.y0)
        assert overlap_x <= 1 or overlap_y <= 1, ax.get_title()
        checked += 1
    assert checked >= 4


def test_compare_overlays_runs(results):
    runs = [results["free-polar"], results["free-cartesian"], results["free-partitioned"]]
    fig = viz.compare(runs, ["polar", "cartesian", "partitioned"], title="same start")
    assert isinstance(fig, Figure)
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert [t.split(":")[0] for t in texts] == ["polar", "cartesian", "partitioned"]
    norm = next(ax for ax in fig.axes if ax.get_title() == "error norm")
    assert len(norm.get_lines()) == 3
    with pytest.raises(ValueError, match="labels"):
        viz.compare(runs, ["a"])
    with pytest.raises(TypeError, match="results"):
        viz.compare([1, 2])
    assert isinstance(viz.compare([results["gantry-stacked"], results["free-pixel-nonplanar"]]), Figure)


def test_image_limits_and_sweep_summary():
    fig = viz.image_limits()
    assert isinstance(fig, Figure)
    inside = {k: v for k, (_, v) in viz.image_limits_paths().items()}
    assert inside == {"A→B": True, "C→D": False}
    import ibvs.study.sweep as sw

    rows = sw.sweep(None, jobs=1, schemes=["polar"], grid={"rz_deg": [10, 100]}, duration=3.0, progress=False)
    fig = viz.sweep_summary(sw.aggregate(rows))
    titles = _titles(fig)
    for o in sim.OUTCOMES:
        assert f"{o} (%)" in titles
    assert "median peak commanded ‖T‖ (m/s)" in titles and "median peak camera ‖T‖ (m/s)" in titles
    with pytest.raises(ValueError, match="table"):
        viz.sweep_summary([])


def test_draws_into_a_given_figure(results):
    fig = Figure()
    assert viz.episode(results["free-polar"], fig=fig) is fig
    with pytest.raises(TypeError, match="fig"):
        viz.episode(results["free-polar"], fig="no")


def test_gif_has_the_expected_frames(tmp_path, results):
    from PIL import Image

    from ibvs.viz.animation import frame_count

    r = results["free-polar"]  # 3 s
    n = viz.animate(r, tmp_path / "run.gif", speed=2.0, fps=10)
    assert n == frame_count(r, 2.0, 10) == int(np.ceil(r.history.time[-1] * 10 / 2.0)) + 1
    with Image.open(tmp_path / "run.gif") as im:
        assert im.n_frames == n
    # two runs side by side, one of them on the gantry (joint bars)
    n2 = viz.animate([results["gantry-stacked"], r], tmp_path / "two.gif", labels=["gantry", "free"], fps=5)
    with Image.open(tmp_path / "two.gif") as im:
        assert im.n_frames == n2 == frame_count([results["gantry-stacked"], r], 1.0, 5)


def test_mp4_and_bad_arguments(tmp_path, results):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    r = results["free-pixel-nonplanar"]
    n = r.animate(tmp_path / "run.mp4", fps=10, hold=0)
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "run.mp4"))
    assert frames == n
    for kw, match in [({"speed": 0}, "speed"), ({"speed": float("nan")}, "speed"), ({"fps": 1000}, "fps"),
                      ({"hold": -1}, "hold"), ({"labels": ["a", "b"]}, "labels")]:
        with pytest.raises(ValueError, match=match):
            viz.animate(r, tmp_path / "x.gif", **kw)
    with pytest.raises(ValueError, match="path"):
        viz.animate(r, tmp_path / "x.avi")
    assert not (tmp_path / "x.gif").exists()


def test_backend_is_never_changed(tmp_path):
    """In a fresh interpreter with the user's backend chosen: importing ibvs.viz and every
    plotting call leave it as it was, and never import pyplot; a pyplot figure can be drawn into."""
    script = textwrap.dedent(f"""
        import sys
        import matplotlib
        matplotlib.use("svg")
        import ibvs.viz as viz, ibvs.study.sweep as sw
        from ibvs import sim
        from ibvs.study.schemes import make
        assert matplotlib.get_backend() == "svg"
        c = sim.cases.z_rotation()
        r = sim.run(make("polar", 1.0), c.camera, c.target, c.start, c.goal, duration=0.5)
        g = sim.cases.gantry_general_motion()
        rg = sim.run(make("cartesian", 2.0), g.camera, g.target, g.start, g.goal, robot=g.robot, duration=0.5)
        rows = sw.sweep(None, jobs=1, schemes=["polar"], grid={{"rz_deg": [10]}}, duration=1.0, progress=False)
        for call in (lambda: r.plot(), lambda: rg.plot(), lambda: viz.compare([r, rg]),
                     lambda: viz.image_limits(), lambda: viz.sweep_summary(sw.aggregate(rows)),
                     lambda: viz.animate([r, rg], r"{tmp_path / 'b.gif'}", fps=2),
                     lambda: r.plot().savefig(r"{tmp_path / 'b.png'}")):
            call()
            assert matplotlib.get_backend() == "svg", call
            assert "matplotlib.pyplot" not in sys.modules
        import matplotlib.pyplot as plt
        f = plt.figure()
        assert r.plot(fig=f) is f and plt.gcf() is f and matplotlib.get_backend() == "svg"
        print("ok")
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_pose_takes_radians_and_warns_on_degrees():
    np.testing.assert_allclose(sim.pose_deg((1, 2, 3), (10, 20, 170)),
                               sim.pose((1, 2, 3), np.radians([10, 20, 170])), atol=1e-15)
    np.testing.assert_array_equal(sim.pose(r=(0, 0, 90), degrees=True), sim.pose(r=(0, 0, np.pi / 2)))
    with pytest.warns(UserWarning, match="degrees"):
        sim.pose(r=(0, 0, 170))
    with pytest.warns(UserWarning, match="degrees"):
        sim.rotation(0, -7, 0)
    sim.pose(r=(0, 0, 2 * np.pi))  # a full turn in radians is fine (warnings are errors here)
    sim.pose_deg(r_deg=(0, 0, 720))
    with pytest.raises(ValueError, match="r must"):
        sim.pose(r=(0, 0))
    with pytest.raises(ValueError, match="t must"):
        sim.pose(t=(0, float("nan"), 0))
    assert "radians" in sim.pose.__doc__


def test_native_objects_pickle():
    import pickle

    c = sim.cases.gantry_general_motion()
    for obj in (c.camera, sim.Camera.normalized(0.25, fps=30), c.target, c.robot.with_limits(q_max=[1, 1, 1, 2, 2, 2])):
        back = pickle.loads(pickle.dumps(obj))
        assert type(back) is type(obj) and repr(back) == repr(obj)
    cam = pickle.loads(pickle.dumps(c.camera))
    np.testing.assert_array_equal(cam.project([[0.1, -0.2]]), c.camera.project([[0.1, -0.2]]))
    assert cam.bounds == c.camera.bounds
    robot = pickle.loads(pickle.dumps(c.robot))
    np.testing.assert_array_equal(robot.camera(c.start), c.robot.camera(c.start))
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), *(lambda z: (z.camera, z.target, z.start, z.goal))(
        sim.cases.z_rotation()), duration=0.5)
    back = pickle.loads(pickle.dumps(r))
    np.testing.assert_array_equal(back.history.twist, r.history.twist)
    assert back.servo == r.servo == "polar 8x6"
