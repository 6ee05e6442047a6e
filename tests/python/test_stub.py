"""python/ibvs/_core.pyi matches the native module: the same names at the top level, in
every class and in the sim submodule (declared as a namespace class in the stub), and the
same parameter names, in order, with the same defaulted / required split."""

import ast
import inspect
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


def is_enum(node: ast.ClassDef) -> bool:
    return any(isinstance(b, ast.Attribute) and b.attr == "Enum" for b in node.bases)


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
    if is_enum(node):  # enum.Enum provides name and value in the stub
        runtime -= {"name", "value"}
    stub = {n for n in declared(stub_names(node.body)) if not n.startswith("_")}
    assert stub == {n for n in runtime if not n.startswith("_")}
    for dunder in ("__len__", "__call__"):  # the protocols the stub promises exist
        if dunder in stub_names(node.body):
            assert dunder in vars(cls)


def runtime_parameters(func) -> list:
    """(name, has_default) of a pybind11 function, from the signature line of its docstring."""
    line = func.__doc__.strip().splitlines()[0]
    inside = line[line.index("(") + 1 : line.rindex(") ->")]
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
    return [(p.split(":")[0].strip(), "=" in p.split(":", 1)[-1]) for p in parts]


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
            elif isinstance(node, ast.ClassDef) and name != "sim" and not is_enum(node):
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
    if node.name.startswith("__"):  # operators are called positionally: pybind11 names them arg0...
        runtime, stub = [d for _, d in runtime], [d for _, d in stub]
    assert runtime == stub
