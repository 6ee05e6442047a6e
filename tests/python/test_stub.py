"""python/ibvs/_core.pyi matches the native module.

mypy.stubtest compares the stub with the module (names, classes, properties against methods,
static methods, attribute types); what a stub cannot express is in stubtest_allowlist.txt, one
reason per entry. stubtest cannot read the signature of a pybind11 function and cannot compare the
sim submodule, which the stub declares as a namespace class (a one-file stub cannot declare a
submodule of an extension module), so the tests below check, from the stub's syntax tree: the same
names at the top level, in every class and in sim; the kind of every class member (static method,
method, read-only property, settable attribute); and the same parameter names, in order, with the
same defaulted / required split, read from the signature line of each pybind11 docstring."""

import ast
import inspect
import os
import subprocess
import sys
from pathlib import Path

import pytest

import ibvs
from ibvs import _core

STUB = ast.parse((Path(ibvs.__file__).parent / "_core.pyi").read_text())


def stub_names(body) -> dict:
    """Name -> node of what a stub body declares (functions, classes, annotated or assigned names)."""
    out = {}
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            out[node.name] = node
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            out[node.target.id] = node
        elif isinstance(node, ast.Assign):
            out.update({t.id: node for t in node.targets if isinstance(t, ast.Name)})
    return out


def declared(names) -> set:
    """What counts: public names and single-underscore ones such as sim._run; not dunders,
    not pybind11's _pybind11_conduit_v1_, not the stub's private aliases (_ArrayLike...)."""
    return {n for n in names if not (n.startswith("_") and n.endswith("_"))}


def runtime_members(obj) -> set:
    if inspect.ismodule(obj):
        return declared(dir(obj))
    return declared(k for k in vars(obj))  # defined on the class itself, not inherited


TOP = stub_names(STUB.body)
CLASSES = {name: node for name, node in TOP.items() if isinstance(node, ast.ClassDef) and name != "sim"}
SIM = stub_names(TOP["sim"].body)
SIM_CLASSES = {name: node for name, node in SIM.items() if isinstance(node, ast.ClassDef)}


def test_top_level_names():
    stub = {n for n in declared(TOP) if not n.startswith("_")} | {"__version__"}
    assert "__version__" in TOP
    assert stub == {n for n in runtime_members(_core) if not n.startswith("_")} | {"__version__"}


def test_sim_submodule_names():
    assert inspect.ismodule(_core.sim)
    assert declared(SIM) == runtime_members(_core.sim)
    assert "_run" in SIM and "Target" in SIM_CLASSES


@pytest.mark.parametrize(
    "owner, name, node",
    [pytest.param(_core, n, c, id=n) for n, c in CLASSES.items()]
    + [pytest.param(_core.sim, n, c, id=f"sim.{n}") for n, c in SIM_CLASSES.items()],
)
def test_class_members(owner, name, node):
    cls = getattr(owner, name)
    runtime = runtime_members(cls)
    stub = {n for n in declared(stub_names(node.body)) if not n.startswith("_")}
    assert stub == {n for n in runtime if not n.startswith("_")}
    for dunder in ("__len__", "__call__"):  # the protocols the stub promises exist
        if dunder in stub_names(node.body):
            assert dunder in vars(cls)


def runtime_parameters(func) -> list:
    """(name, has_default) of a pybind11 function, from the signature line of its docstring."""
    line = func.__doc__.strip().splitlines()[0]
    inside = line[line.index("(") + 1 : line.rindex(") ->") if ") ->" in line else line.rindex(")")]
    parts, depth, quote, cur = [], 0, None, ""
    for ch in inside:  # split on top-level commas (types hold brackets and quoted strings)
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "[(":
            depth += 1
        elif ch in "])":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        cur += ch
    if cur.strip():
        parts.append(cur)
    params = [(p.split(":")[0].strip(), "=" in p.split(":", 1)[-1]) for p in parts]
    return [(n, d) for n, d in params if n not in ("/", "*")]  # markers of positional- and keyword-only


def stub_parameters(node: ast.FunctionDef) -> list:
    args = node.args.posonlyargs + node.args.args
    defaults = [False] * (len(args) - len(node.args.defaults)) + [True] * len(node.args.defaults)
    return [(a.arg, d) for a, d in zip(args, defaults)]


def functions():
    """(runtime callable, stub node) of every function and method the stub declares."""
    out = []  # names missing at runtime are reported by the name tests above
    for owner, names in ((_core, TOP), (_core.sim, SIM)):
        for name, node in names.items():
            if not hasattr(owner, name):
                continue
            if isinstance(node, ast.FunctionDef):
                out.append(pytest.param(getattr(owner, name), node, id=f"{owner.__name__}.{name}"))
            elif isinstance(node, ast.ClassDef) and name != "sim":
                cls = getattr(owner, name)
                for m, sub in stub_names(node.body).items():
                    if not isinstance(sub, ast.FunctionDef) or not hasattr(cls, m):
                        continue
                    if not any(getattr(d, "id", None) == "property" for d in sub.decorator_list):
                        out.append(pytest.param(getattr(cls, m), sub, id=f"{name}.{m}"))
    return out


@pytest.mark.parametrize("func, node", functions())
def test_parameters(func, node):
    runtime, stub = runtime_parameters(func), stub_parameters(node)
    if [n for n, _ in runtime] == ["*args", "**kwargs"]:
        return  # pybind11's generic signature (an enum's __eq__ and __ne__): nothing to compare
    if node.name.startswith("__"):  # operators are called positionally: pybind11 names them arg0...
        runtime, stub = [d for _, d in runtime], [d for _, d in stub]
    assert runtime == stub


def stub_kind(node) -> str:
    if isinstance(node, ast.FunctionDef):
        decorators = {getattr(d, "id", None) for d in node.decorator_list}
        return "static method" if "staticmethod" in decorators else \
            "read-only property" if "property" in decorators else "method"
    return "attribute"  # an annotated name: readable and settable (Servo.gain) or a class constant


def runtime_kind(cls, name: str) -> str:
    value = inspect.getattr_static(cls, name)
    if isinstance(value, staticmethod):
        return "static method"
    if isinstance(value, property):  # pybind11's def_property(_readonly), def_readwrite
        return "read-only property" if value.fset is None else "attribute"
    return "method" if callable(value) else "attribute"


@pytest.mark.parametrize(
    "owner, name, node",
    [pytest.param(_core, n, c, id=n) for n, c in CLASSES.items()]
    + [pytest.param(_core.sim, n, c, id=f"sim.{n}") for n, c in SIM_CLASSES.items()],
)
def test_member_kinds(owner, name, node):
    """What stubtest checks in the top-level classes, for sim's as well (stubtest skips them)."""
    cls = getattr(owner, name)
    members = {n: m for n, m in stub_names(node.body).items() if not n.startswith("_") and n in vars(cls)}
    assert {n: stub_kind(m) for n, m in members.items()} == {n: runtime_kind(cls, n) for n in members}


def test_stubtest(tmp_path):
    """python -m mypy.stubtest ibvs._core passes, with the allowlist (each entry says why it is needed).
    It checks the ibvs these tests import (its directory first on the path); mypy's cache goes to tmp_path."""
    allowlist = Path(__file__).resolve().parent / "stubtest_allowlist.txt"
    path = os.pathsep.join([str(Path(ibvs.__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path, "MYPY_CACHE_DIR": str(tmp_path / "mypy")}
    out = subprocess.run([sys.executable, "-m", "mypy.stubtest", "ibvs._core", "--allowlist", str(allowlist)],
                         capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
