"""Sweeps over blob sources: ibvs.sim.FunctionSource, the features it names and the targets holding it
pickle (by the callable and the feature; a BlobMeasure by its arguments), the copies run the same
episodes bit for bit, a callable that does not pickle is named in a TypeError, and a sweep over a blob
source on two worker processes that receive the target pickled (forkserver) gives the serial rows."""

from __future__ import annotations

import multiprocessing
import pickle
from types import SimpleNamespace

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ibvs
import ibvs.study.sweep as sw
from ibvs import sim
from ibvs.study import compare, schemes
from ibvs.study.scenario import Scenario
from ibvs.study.sweep import local

pytest.importorskip("cv2")
from ibvs import vision  # noqa: E402

START = sim.pose(t=(0.06, -0.04, -0.3), r=(0.05, -0.08, 0.6))  # tests/python/test_vision_blobs.py's


def disc(radius=0.3, n=16, pose=None):
    a = 2 * np.pi * np.arange(n) / n
    return sim.Target(np.column_stack([radius * np.cos(a), radius * np.sin(a), np.zeros(n)]),
                      sim.pose(t=(0, 0, 3)) if pose is None else pose)


def ellipse_servo(gain=1.0, n_points=16):
    task = ibvs.Task().add(ibvs.EllipseFeature())
    task.dof = ["Tx", "Ty", "Tz", "wx", "wy"]  # a circle's image is blind to the turn about its axis
    return ibvs.Servo(task, gain=gain)


def same_run(a, b):
    """Two sim.Results equal bit for bit: status, measurements, every history array."""
    assert repr(a.status) == repr(b.status)
    np.testing.assert_array_equal(a.measurements_desired, b.measurements_desired)
    for name in ("pose", "error", "twist", "measurements", "uv"):
        x, y = getattr(a.history, name), getattr(b.history, name)
        assert x.shape == y.shape and x.shape[0] > 10
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("case", ["ellipse", "moments_distorted"])
def test_pickled_blob_target_runs_the_same_episode(case):
    """A Target holding a blob source, pickled and unpickled, runs the same episode bit for bit as the
    original (fresh from the same arguments: a noisy renderer's noise restarts at its seed in both)."""
    if case == "ellipse":  # the free camera (imaged by a 640x480 pinhole), a noisy, blurred rendering
        cam = sim.cases.general_motion().camera
        target = disc()
        servo, goal = ellipse_servo, sim.pose(t=(0.08, -0.05, 0.0), r=(0.08, -0.06, 0.0))
        start = goal @ sim.pose(t=(0.1, 0.05, -0.3), r=(0.03, 0.04, 0.3))
        make = lambda: target.with_features([vision.blob_source(cam, target, "ellipse", noise=4.0, seed=5,  # noqa
                                                                blur=0.5)])
    else:  # the gantry's camera (lens distortion: the undistortion maps rebuilt), the moments' a*, Z* cache
        g = sim.cases.gantry_general_motion()
        cam = g.camera  # the compared quadrilateral scaled to 0.5 m ahead: the same image as at 3 m
        target = sim.Target(compare.target().points * (0.5 / compare.DEPTH), sim.pose(t=(0, 0, 0.5)))
        servo, goal, start = schemes.moments, np.eye(4), sim.pose(t=(0.01, -0.01, -0.05), r=(0.03, -0.02, 0.3))
        make = lambda: target.with_features([vision.blob_source(cam, target, "moments")])  # noqa: E731
    original = make()
    data = pickle.dumps(original)
    assert len(data) < 5000  # the blob pickles by its arguments, not its renderer's textures (megabytes)
    copy = pickle.loads(data)
    assert repr(copy) == repr(original)
    src, src_copy = original.features[0], copy.features[0]
    assert type(src_copy) is sim.FunctionSource and type(src_copy.measure) is vision.BlobMeasure
    assert src_copy.measure is not src.measure and repr(src_copy.measure) == repr(src.measure)
    run = dict(duration=0.5)
    a = sim.run(servo(1.0), cam, original, start, goal, **run)
    b = sim.run(servo(1.0), cam, copy, start, goal, **run)
    same_run(a, b)
    assert np.ptp(a.history.error[:, 0]) > 0  # the episode moved: the copies were compared on something
    # a second pickle of the used original runs as the first copy did (noise restarted, the cache rebuilt)
    same_run(a, sim.run(servo(1.0), cam, pickle.loads(pickle.dumps(original)), start, goal, **run))


def test_features_pickle_with_their_arguments():
    """Every feature kind a FunctionSource may name pickles as its class called with its arguments."""
    for f in (ibvs.EllipseFeature(), ibvs.LineFeature(), ibvs.SphericalPointFeature(), ibvs.Point25DFeature(),
              ibvs.SphericalPolarFeature(0.25), ibvs.PbvsFeature("object"), ibvs.SegmentFeature(False),
              ibvs.MomentsFeature("points", "s", "second_order", ["xn", "an", "alpha"]), ibvs.MomentsFeature()):
        c = pickle.loads(pickle.dumps(f))
        assert type(c) is type(f) and repr(c) == repr(f) and c.rows == f.rows and c.size == f.size
    m = pickle.loads(pickle.dumps(ibvs.MomentsFeature("points", "s", "second_order", ["an", "xn"])))
    assert (m.source, m.invariants, m.alpha, m.row_names) == ("points", "s", "second_order", ["xn", "an"])
    assert pickle.loads(pickle.dumps(ibvs.SphericalPolarFeature(0.25))).min_sin == 0.25
    assert pickle.loads(pickle.dumps(ibvs.PbvsFeature("object"))).target == "object"
    assert pickle.loads(pickle.dumps(ibvs.SegmentFeature(False))).normalized is False
    # a block of your own: by rows, size, callable and name (a callable that does not pickle is named)
    f = pickle.loads(pickle.dumps(ibvs.FunctionFeature(2, 3, np.add, "mine")))
    assert (f.rows, f.size, f.fn, f.name) == (2, 3, np.add, "mine")
    with pytest.raises(TypeError, match="FunctionFeature's fn <function .*<lambda>.* does not pickle") as e:
        pickle.dumps(sim.FunctionSource(ibvs.FunctionFeature(2, 3, lambda m: None), _local_measure))
    assert e.value.__cause__ is not None
    # the copy feeds the same blocks: a FunctionSource of it fits the Task of the original kind
    src = pickle.loads(pickle.dumps(sim.FunctionSource(ibvs.SegmentFeature(False), np.zeros_like)))
    assert src.size == 6 and src.measure is np.zeros_like


def _local_measure(*args):
    return None


def test_a_callable_that_does_not_pickle_is_named():
    """A lambda or a local function: TypeError "FunctionSource's callable ..." (the pickle error its cause),
    from the source and from a Target holding it; never a crash. The source still runs in this process."""
    def local_fn(*args):
        return None

    for fn, name in ((lambda *a: None, "<lambda>"), (local_fn, "local_fn")):
        src = sim.FunctionSource(ibvs.EllipseFeature(), fn)
        t = disc().with_features([src])
        for obj in (src, t):
            with pytest.raises(TypeError, match=f"FunctionSource's callable <function .*{name}.* does not pickle"
                                                ) as e:
                pickle.dumps(obj)
            assert e.value.__cause__ is not None  # pickle's own error, chained
    # a module-level function pickles by reference
    assert pickle.loads(pickle.dumps(sim.FunctionSource(ibvs.EllipseFeature(), _local_measure))).measure \
        is _local_measure
    # a callable whose own pickling raises: named too
    class Unpicklable:
        def __call__(self, *args):
            return None

        def __reduce__(self):
            raise RuntimeError("no")

    with pytest.raises(TypeError, match="FunctionSource's callable"):
        pickle.dumps(sim.FunctionSource(ibvs.EllipseFeature(), Unpicklable()))


FEATURES = [ibvs.EllipseFeature, ibvs.LineFeature, ibvs.SphericalPointFeature, ibvs.Point25DFeature,
            lambda: ibvs.SphericalPolarFeature(0.1), lambda: ibvs.PbvsFeature("object"),
            lambda: ibvs.SegmentFeature(False), lambda: ibvs.MomentsFeature("points", "s", "second_order", ["an"])]
CALLABLES = [_local_measure, np.zeros_like, functools.partial(_local_measure, 1), lambda *a: None,
             functools.partial(lambda *a: None, 2), print, object(), 3, None, "measure"]


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(range(len(FEATURES))), st.sampled_from(range(len(CALLABLES))), st.booleans())
def test_function_source_pickles_or_names_its_callable(kind, which, in_target):
    """Any feature kind and any object as measure: refused by the constructor (not callable), or pickled with
    a copy of the same class, size and callable, or a TypeError naming the callable; never a crash."""
    fn = CALLABLES[which]
    try:
        src = sim.FunctionSource(FEATURES[kind](), fn)
    except TypeError as e:
        assert "measure must be callable" in str(e) and not callable(fn)
        return
    obj = disc().with_features([src]) if in_target else src
    try:
        copy = pickle.loads(pickle.dumps(obj))
    except TypeError as e:
        assert str(e).startswith("FunctionSource's callable ") and e.__cause__ is not None
        assert "lambda" in repr(fn)
        return
    c = copy.features[0] if in_target else copy
    assert type(c) is sim.FunctionSource and repr(c) == repr(src) and c.size == src.size
    assert c.measure == fn or (isinstance(fn, functools.partial) and c.measure.func is fn.func)


def test_sweep_over_a_blob_source_on_worker_processes(tmp_path, monkeypatch):
    """The moments task on the blob's rendered moments, swept over 4 starts: on 2 worker processes started
    by a forkserver (the target reaches them pickled, as under Dask or Python 3.14's default) the rows are
    the serial run's."""
    quad = compare.target()
    cam = sim.cases.z_rotation().camera
    target = quad.with_features([vision.blob_source(cam, quad, "moments")])
    setup = Scenario(camera=cam, target=target, goal=np.eye(4), ranges={"rz_deg": (0, 40), "tz": (-0.1, 0.1)},
                     duration=0.4, gain=1.0, name="blob")
    # the moments task on the target's own (blob) source: a scheme without a target function
    monkeypatch.setitem(schemes.SCHEMES, "blob_moments", schemes.moments)
    run = dict(scenario=setup, episodes=4, seed=2, schemes=["blob_moments"], progress=False)
    serial = sw.sweep(tmp_path / "serial.csv", jobs=1, **run)
    forkserver = multiprocessing.get_context("forkserver")
    monkeypatch.setattr(local, "multiprocessing", SimpleNamespace(get_context=lambda: forkserver))
    parallel = sw.sweep(tmp_path / "parallel.csv", jobs=2, batch=1, **run)
    assert len(serial) == 4 and repr(parallel) == repr(serial)
    assert {r["outcome"] for r in serial} <= {"timeout", "converged"}  # the blob measured all along
    assert len({r["path_length"] for r in serial}) == 4  # four different episodes


def test_a_blob_sources_options_enter_the_sweeps_config_hash():
    """A sweep's row ids (resuming a CSV) hash the scenario: two blob sources that differ only in their
    renderer's options give different keys, the same arguments the same key, and a source
    whose callable does not pickle is keyed by the callable's name."""
    quad = compare.target()
    cam = sim.cases.z_rotation().camera

    def key(source):
        return Scenario(camera=cam, target=quad.with_features([source]), goal=np.eye(4),
                        ranges={"tz": (-0.1, 0.1)}, name="blob").key()

    plain = key(vision.blob_source(cam, quad, "moments"))
    assert key(vision.blob_source(cam, quad, "moments")) == plain
    assert key(vision.blob_source(cam, quad, "moments", noise=2.0)) != plain
    assert key(vision.blob_source(cam, quad, "moments", blur=1.5)) != plain
    by_name = key(sim.FunctionSource(ibvs.MomentsFeature("region"), lambda *a: None))
    assert by_name != plain and by_name == key(sim.FunctionSource(ibvs.MomentsFeature("region"), lambda *a: None))
    # the feature by its arguments, not its repr (which rounds, and names a block of your own by its rows only)
    keys = {key(sim.FunctionSource(f, _local_measure)) for f in (
        ibvs.FunctionFeature(2, 2, np.add), ibvs.FunctionFeature(2, 2, np.subtract), ibvs.FunctionFeature(2, 3, np.add),
        ibvs.SphericalPolarFeature(0.2), ibvs.SphericalPolarFeature(0.2000001))}
    assert len(keys) == 5


class _Measure:  # a callable instance whose repr holds its address
    def __call__(self, *args):
        return None


def test_the_config_hash_of_an_unpicklable_callable_instance_is_the_same_in_every_process():
    """A callable instance that does not pickle is hashed by its class, not its repr (its address), so a sweep
    resumed in another process finds its rows."""
    code = ("import numpy as np, ibvs; from ibvs import sim; from ibvs.study import compare; "
            "from ibvs.study.scenario import Scenario; from tests.python.test_sweep_blobs import _Measure; "
            "m = _Measure(); m.lock = __import__('threading').Lock(); "
            "src = sim.FunctionSource(ibvs.MomentsFeature('region'), m); "
            "print(Scenario(camera=sim.cases.z_rotation().camera, target=compare.target().with_features([src]), "
            "goal=np.eye(4), ranges={'tz': (-0.1, 0.1)}, name='blob').key())")
    import os
    import subprocess
    import sys
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.getcwd(), *sys.path]))
    keys = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
                           ).stdout.strip() for _ in range(2)}
    assert len(keys) == 1 and len(keys.pop()) == 10


def test_a_noisy_blob_episode_does_not_depend_on_the_episodes_before_it():
    """A noisy blob's noise restarts at every episode's goal and start (from the seed and the pose): an episode
    run after another one is the same bit for bit as run first by a fresh measure, and two starts get
    different noise."""
    quad = compare.target()
    cam = sim.cases.z_rotation().camera

    def episode(measure, rz):
        target = quad.with_features([sim.FunctionSource(ibvs.MomentsFeature("region"), measure)])
        return sim.run(schemes.moments(1.0), cam, target, sim.pose(t=(0.02, 0.0, 0.05), r=(0.0, 0.0, rz)),
                       np.eye(4), duration=0.3)

    noisy = dict(noise=3.0, seed=5)
    shared = vision.BlobMeasure(cam, quad, "moments", **noisy)
    first = episode(shared, 0.3)
    second = episode(shared, 0.5)
    same_run(second, episode(vision.BlobMeasure(cam, quad, "moments", **noisy), 0.5))
    same_run(first, episode(shared, 0.3))  # and again after the other one
    quiet = episode(vision.BlobMeasure(cam, quad, "moments"), 0.5)
    assert not np.array_equal(second.history.measurements, quiet.history.measurements)  # the noise is there
