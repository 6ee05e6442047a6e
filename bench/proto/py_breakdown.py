"""Where the time of a Python Servo.update call goes (prototype; docs/benchmarks.md).

Build with -DIBVS_BUILD_BENCH_PROTO=ON, then with the build's bench dir on sys.path:
    PYTHONPATH=build/bench-cpp/bench python bench/proto/py_breakdown.py
"""

import timeit

import ibvs  # first: registers Layout, which the prototype takes
import ibvs_py_proto as proto
import numpy as np
from ibvs.bench import make_frames

uv, z, uvd = make_frames(4, 1)[0]
L = ibvs.Layout.stacked(4)
real = ibvs.Servo(L, gain=0.5, damping=0.01, diagnostics=False)
p = proto.Servo(L, 0.5, 0.01, False)
p.keep_inputs(uv, z, uvd)
assert np.allclose(p.update(uv, z, uvd).velocity, real.update(uv, z, uvd).velocity, rtol=0, atol=1e-15)
assert np.allclose(p.update_velocity(uv, z, uvd), real.update(uv, z, uvd).velocity, rtol=0, atol=1e-15)
assert np.allclose(p.update_eager(uv, z, uvd).velocity, real.update(uv, z, uvd).velocity, rtol=0, atol=1e-15)
r = real.update(uv, z, uvd)
e = p.update_eager(uv, z, uvd)
g = {"real": real, "p": p, "uv": uv, "z": z, "uvd": uvd, "r": r, "e": e, "L": L}
rows = [
    ("ibvs: servo.update(uv, z, uvd)", "real.update(uv, z, uvd)"),
    ("ibvs: servo.update(uv=uv, depth=z, uv_desired=uvd)", "real.update(uv=uv, depth=z, uv_desired=uvd)"),
    ("ibvs: servo.update(uv, 1.0, uvd)  (scalar depth)", "real.update(uv, 1.0, uvd)"),
    ("ibvs: servo.update(uv, z, uvd).velocity", "real.update(uv, z, uvd).velocity"),
    ("ibvs: result.velocity (view with base)", "r.velocity"),
    ("ibvs: result.sigma_min (float)", "r.sigma_min"),
    ("A  proto copy of today's binding", "p.update(uv, z, uvd)"),
    ("B  convert + validate + step, return None", "p.step_none(uv, z, uvd)"),
    ("C  pybind11 call + C++ step, no conversion", "p.step_only()"),
    ("D  convert + step, return new (6,) twist", "p.update_velocity(uv, z, uvd)"),
    ("E  convert + step, eager result (3 arrays)", "p.update_eager(uv, z, uvd)"),
    ("E  eager result .velocity", "e.velocity"),
    ("E  update_eager(...).velocity", "p.update_eager(uv, z, uvd).velocity"),
]
for name, stmt in rows:
    n = 100000
    t = min(timeit.repeat(stmt, globals=g, number=n, repeat=7)) / n * 1e6
    print(f"  {name:55s} {t:6.3f} us")
