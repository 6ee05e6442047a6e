"""ibvs.viz.rerun and ibvs run --rerun: the recording read back from the .rrd file (rerun's chunk
reader, rerun.chunk.RrdReader) holds the expected entity paths, with the run's values at its frames."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import ibvs
from ibvs import sim

rr = pytest.importorskip("rerun", reason='the rerun extra is not installed (pip install ".[rerun]")')
import ibvs.viz  # noqa: E402


def read_rrd(path) -> dict:
    """{entity path: {column: [values in row order]}} of a recording (temporal and static rows), with
    the rows sorted by frame, static rows under "static:<column>"; times (the "time" timeline, log_time) as integer nanoseconds."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    out: dict = {}
    for chunk in RrdReader(str(path)).stream().to_chunks():
        batch = chunk.to_record_batch()
        entity = out.setdefault(chunk.entity_path, {})
        for name, column in zip(batch.schema.names, batch.columns):
            if pa.types.is_timestamp(column.type) or pa.types.is_duration(column.type):
                column = column.cast(pa.int64())
            key = f"static:{name}" if chunk.is_static else name  # static rows apart: no frame, no time
            entity.setdefault(key, []).extend(column.to_pylist())
    for entity in out.values():
        if "frame" in entity:
            order = np.argsort(entity["frame"], kind="stable")
            for name in [n for n in entity if not n.startswith("static:")]:
                entity[name] = [entity[name][i] for i in order]
    return out


def test_image_episode_in_rerun(tmp_path):
    pytest.importorskip("cv2", reason="the vision extra is not installed")
    from ibvs import vision

    case = sim.cases.gantry_general_motion()
    sensor = vision.ImageSensor.for_target(case.camera, case.target, "dots", keep_frames=True)
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=2.0), case.camera, case.target, case.start, case.goal,
                robot=case.robot, duration=0.3, depth="pose", vision=sensor)
    path = tmp_path / "run.rrd"
    ibvs.viz.rerun(r, path=path, labels=["gantry polar"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.rrd"]  # the partial file renamed
    data = read_rrd(path)
    root = "/runs/gantry_polar"
    expected = {f"{root}/{e}" for e in ("image/frame", "image/features", "image/desired", "world/target",
                                        "world/camera", "world/path", "world/mount", "error_norm", "sigma_min")}
    expected |= {f"{root}/twist/{c}" for c in ibvs.viz.rerun_log.TWIST_NAMES}
    assert expected <= set(data), sorted(expected - set(data))
    K = len(r.history)
    for i, name in enumerate(ibvs.viz.rerun_log.TWIST_NAMES):
        col = data[f"{root}/twist/{name}"]
        assert col["frame"] == list(range(K))
        np.testing.assert_array_equal([v[0] for v in col["Scalars:scalars"]], r.history.twist[:, i])
    np.testing.assert_array_equal(data[f"{root}/twist/Tx"]["time"], np.round(r.history.time * 1e9))  # simulated time
    feats = data[f"{root}/image/features"]
    np.testing.assert_allclose(np.array(feats["Points2D:positions"][3]), r.history.measured[3], rtol=1e-6)
    np.testing.assert_allclose(np.array(data[f"{root}/image/desired"]["static:Points2D:positions"][0]), r.measured_desired,
                               rtol=1e-6)  # float32 in Rerun
    assert len(data[f"{root}/image/frame"]["frame"]) == len(sensor.frames)
    cam = data[f"{root}/world/camera"]
    k = 4
    i = cam["frame"].index(k)
    np.testing.assert_allclose(np.ravel(cam["Transform3D:translation"][i]), r.history.pose[k, :3, 3], rtol=1e-6)
    np.testing.assert_allclose(np.array(data[f"{root}/world/target"]["static:Points3D:positions"][0]),
                               r.target.world_points(), rtol=1e-6)


def test_arm_and_several_runs(tmp_path):
    pytest.importorskip("pinocchio", reason="the robots extra is not installed")
    case = sim.cases.arm_general_motion("panda")
    runs = [sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=g), case.camera, case.target, case.start, case.goal,
                    robot=case.robot, duration=0.1, depth="pose") for g in (0.5, 1.0)]
    rec = ibvs.viz.rerun(runs, path=tmp_path / "arm.rrd", labels=["slow", "fast"])
    assert rec is not None
    data = read_rrd(tmp_path / "arm.rrd")
    for label, r in zip(("slow", "fast"), runs):
        arm = data[f"/runs/{label}/world/arm"]
        strips = arm["LineStrips3D:strips"]
        assert len(strips) == len(r.history)
        last = np.array(strips[-1][0])
        assert last.shape == (8, 3)  # the universe and the Panda's 7 joints
        np.testing.assert_allclose(data[f"/runs/{label}/error_norm"]["Scalars:scalars"][0][0],
                                   r.history.error_norm[0], rtol=1e-12)


def test_refusals(tmp_path):
    case = sim.cases.z_rotation()
    r = sim.run(ibvs.Servo(ibvs.Layout.polar(4), gain=1.0), case.camera, case.target, case.start, case.goal,
                duration=0.1)
    with pytest.raises(ValueError, match=r"path must end in \.rrd"):
        ibvs.viz.rerun(r, path=tmp_path / "x.mcap")
    with pytest.raises(TypeError, match="results must be an ibvs.sim.Result"):
        ibvs.viz.rerun([])
    rec = ibvs.viz.rerun(r)  # no path: a recording in memory, nothing written
    assert rec is not None and list(tmp_path.iterdir()) == []


def test_cli_run_rerun(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(Path(ibvs.__file__).resolve().parents[1]))
    out = subprocess.run([sys.executable, "-m", "ibvs", "run", "--duration", "0.2", "--rerun", "free.rrd"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    assert "free.rrd" in out.stdout, out.stdout + out.stderr
    data = read_rrd(tmp_path / "free.rrd")
    assert "/runs/free_z-rotation_polar/twist/wz" in data
    bad = subprocess.run([sys.executable, "-m", "ibvs", "run", "--rerun", "x.png"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120, env=env)
    assert bad.returncode == 2 and "argument --rerun: 'x.png' must end in .rrd" in bad.stderr
