"""One finiteness check, exact for NaN and +-inf at any position (issue 35, item 1).

C++ checks user and measured data with ibvs::finite_within (cpp/include/ibvs/finite.hpp): allFinite() and a
separate magnitude bound. A comparison of maxCoeff() (or minCoeff()) with a bound is not such a check: a
comparison with NaN is false and which entry maxCoeff() returns when one is NaN depends on where it sits, so a
NaN in the second entry passed (a FunctionFeature with s or L = [x, NaN] was accepted with a NaN twist). The
same holds in numpy for `np.abs(x).max() > bound` (NaN > bound is False): Python checks use finite() and a
bound. The pattern is forbidden everywhere in cpp/ and python/ but in the helper itself."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import ibvs

ROOT = Path(__file__).resolve().parents[2]
#: The one place allowed to compare a largest magnitude (it checks allFinite() first).
HELPERS = {ROOT / "cpp/include/ibvs/finite.hpp", ROOT / "python/ibvs/finite.py"}
CMP = r"\s*(<=|>=|<(?!<)|>(?!>))"
#: A largest or smallest coefficient compared with something: NaN-blind unless every entry is known finite.
CPP_PATTERN = re.compile(r"(max|min)Coeff\(\)" + CMP)
#: numpy's x.max() / np.max(x) / np.abs(x).max() compared with something, in a check of data.
PY_PATTERN = re.compile(r"(\.max\(\)|\bnp\.max\([^()]*(\([^()]*\))?[^()]*\))" + CMP)


def offenders(pattern, suffixes):
    found = []
    for d in ("cpp", "python"):
        for p in sorted((ROOT / d).rglob("*")):
            if p.suffix in suffixes and p.is_file() and p not in HELPERS:
                for i, line in enumerate(p.read_text(errors="replace").splitlines(), 1):
                    if pattern.search(line.split("//")[0] if p.suffix != ".py" else line.split("#")[0]):
                        found.append(f"{p.relative_to(ROOT)}:{i}: {line.strip()}")
    return found


def test_the_patterns_find_what_they_forbid():
    assert CPP_PATTERN.search("if (!(L.cwiseAbs().maxCoeff() <= max_matrix_entry))")
    assert CPP_PATTERN.search("if (x.cwiseAbs().maxCoeff() > bound) return false;")
    assert CPP_PATTERN.search("if (!(P.row(2).minCoeff() >= min_depth))")
    assert not CPP_PATTERN.search("tu.cwiseAbs().maxCoeff(&i);")
    assert PY_PATTERN.search("if np.abs(T[:3, 3]).max() > MAX_TRANSLATION:")
    assert PY_PATTERN.search("if len(P) < 3 or np.max(np.abs(P[:, 2])) > 1e-12:")
    assert not PY_PATTERN.search("big = np.abs(dq).max()")


def test_no_cpp_check_compares_max_coeff():
    found = offenders(CPP_PATTERN, {".cpp", ".hpp", ".h"})
    assert not found, "use ibvs::finite_within (cpp/include/ibvs/finite.hpp):\n" + "\n".join(found)


def test_no_python_check_compares_a_max():
    found = offenders(PY_PATTERN, {".py", ".pyi"})
    assert not found, "use ibvs.finite.finite_within (python/ibvs/finite.py):\n" + "\n".join(found)


def test_python_helper_is_exact_at_any_position():
    from ibvs.finite import finite_within

    for n in (1, 2, 3, 7, 16, 33):
        for i in range(n):
            for bad in (np.nan, np.inf, -np.inf, 2e6):
                x = np.zeros(n)
                x[i] = bad
                assert not finite_within(x, 1e6), (n, i, bad)
        assert finite_within(np.full(n, -1e6), 1e6)
    assert finite_within(np.zeros(0), 1.0)


_NONE, _NONE_Z = np.zeros((0, 2)), np.zeros(0)


@pytest.mark.parametrize("rows", [2, 3, 5])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, 1e200])
@pytest.mark.parametrize("what", ["s", "L"])
def test_function_feature_refuses_a_bad_entry_anywhere(rows, bad, what):
    """The reported bug: s or L with a NaN in its 2nd entry was accepted (status ok or singular, a NaN twist)."""
    size = rows if what == "s" else 6 * rows
    for i in range(size):
        s, L = np.full(rows, 0.1), np.eye(rows, 6) + 0.01

        def fn(m, i=i, s=s, L=L):
            (s if what == "s" else L.reshape(-1))[i] = bad
            return s, L

        servo = ibvs.Servo(ibvs.Task().add(ibvs.FunctionFeature(rows, 1, fn)), gain=1.0)
        with pytest.raises(ValueError, match=f"fn's {what} is not finite"):
            servo.update(_NONE, _NONE_Z, _NONE, measurements=[[0.5]], measurements_desired=[[0.4]])


def test_rigid_transform_checks_refuse_nan_anywhere():
    """Python checks of poses (ibvs.calibration) with a NaN or inf at any entry of the 4x4."""
    from ibvs.calibration import rigid

    for i in range(16):
        for bad in (np.nan, np.inf, -np.inf):
            T = np.eye(4)
            T.reshape(-1)[i] = bad
            with pytest.raises(ValueError):
                rigid.as_pose_stack([T], "poses")
