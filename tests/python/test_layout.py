"""The package's layout: python/ibvs imports form no cycle, no module takes a private name from
another, and the module names that moved still work for one release, with a DeprecationWarning.

The import graph is read from the source (ast), so that every import counts: those at the top
of a module and those inside functions (the lazy ones: sim.Result.plot importing ibvs.viz, the
command line importing what each command needs). Importing a module also imports the packages
above it (their __init__ runs first), so an import of ibvs.viz.drawing from outside ibvs.viz
is an edge to ibvs.viz as well.

Private names are those starting with one underscore. Two kinds of import of one are allowed:
  - from the compiled module ibvs._core (its sim submodule is ibvs._core.sim; sim.run calls
    its _run), whose Python face is ibvs and ibvs.sim;
  - by a package's own __init__ from its children (the package re-exporting what is inside it).
Every other module uses only public names of the others (a name in a module's __all__ or not
starting with an underscore), whether imported (from m import _x) or reached as an attribute
(m._x), and imports no private module.
"""

from __future__ import annotations

import ast
import importlib
import sys
import warnings
from pathlib import Path

import pytest

import ibvs

PACKAGE = Path(ibvs.__file__).resolve().parent
NATIVE = "ibvs._core"


def module_name(path: Path) -> str:
    parts = ("ibvs",) + path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def is_package(name: str) -> bool:
    return MODULES.get(name, Path()).name == "__init__.py"


def is_private(name: str) -> bool:
    return name.startswith("_") and not name.endswith("__")


def resolve(importer: str, node: ast.ImportFrom) -> str:
    """The absolute module name of a `from ... import` (relative ones resolved against the importer)."""
    if not node.level:
        return node.module or ""
    base = importer.split(".")
    package = base if is_package(importer) else base[:-1]
    package = package[: len(package) - (node.level - 1)]
    return ".".join(package + ([node.module] if node.module else []))


def imports(name: str):
    """(target module, imported name or None, bound name or None) of every import in a module of ibvs."""
    tree = ast.parse(MODULES[name].read_text(), str(MODULES[name]))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "ibvs" or alias.name.startswith("ibvs."):
                    # `import ibvs.x.y` binds ibvs; `import ibvs.x.y as m` binds m to ibvs.x.y
                    yield alias.name, None, alias.asname or "ibvs"
        elif isinstance(node, ast.ImportFrom):
            module = resolve(name, node)
            if module != "ibvs" and not module.startswith("ibvs."):
                continue
            for alias in node.names:
                sub = f"{module}.{alias.name}"
                if sub in MODULES or sub == NATIVE:  # `from . import viz`: a module
                    yield sub, None, alias.asname or alias.name
                else:  # `from .drawing import frustum`: a name in a module
                    yield module, alias.name, alias.asname or alias.name


def ancestors(name: str) -> list:
    parts = name.split(".")
    return [".".join(parts[:k]) for k in range(1, len(parts))]


def graph() -> dict:
    """Module -> the ibvs modules its imports run (ibvs._core included, as a leaf)."""
    edges: dict = {}
    for name in MODULES:
        out = edges.setdefault(name, set())
        for target, _, _ in imports(name):
            # the packages above the target run first, unless they are already running (above the importer)
            for t in ancestors(target) + [target]:
                if t != name and t not in ancestors(name):
                    out.add(t)
    return edges


def test_every_module_is_read():
    assert {"ibvs", "ibvs.sim", "ibvs.vision", "ibvs.viz", "ibvs.study", "ibvs.study.sweep", "ibvs.cli"} <= set(MODULES)
    assert all(t in MODULES or t == NATIVE for out in graph().values() for t in out), "an import of a missing module"


def test_no_import_cycle():
    edges = graph()
    state: dict = {}  # module -> "open" while its imports are explored, "done" after

    def visit(name, path):
        state[name] = "open"
        for t in sorted(edges.get(name, ())):
            if state.get(t) == "open":
                cycle = path[path.index(t):] + [t]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if t not in state:
                visit(t, path + [t])
        state[name] = "done"

    for name in sorted(edges):
        if name not in state:
            visit(name, [name])


def test_no_private_name_across_modules():
    bad = []
    for name in MODULES:
        bound = {}  # local name -> the ibvs module it is
        for target, imported, local in imports(name):
            if target == NATIVE or target.startswith(NATIVE + "."):
                continue  # the compiled module: exception 1
            own_child = is_package(name) and target.startswith(name + ".")  # exception 2
            if any(is_private(part) for part in target.split(".")) and not own_child:
                bad.append(f"{name} imports the private module {target}")
            if imported is not None and is_private(imported) and not own_child and target != name:
                bad.append(f"{name} imports {imported} from {target}")
            if imported is None:
                bound[local] = target
        tree = ast.parse(MODULES[name].read_text())
        for node in ast.walk(tree):  # m._x, where m names an ibvs module
            chain, base = [], node
            while isinstance(base, ast.Attribute):
                chain.append(base.attr)
                base = base.value
            if not (isinstance(node, ast.Attribute) and isinstance(base, ast.Name) and base.id in bound):
                continue
            module = bound[base.id] if base.id != "ibvs" else "ibvs"
            for attr in reversed(chain):
                if module == NATIVE or f"{module}.{attr}" == NATIVE:
                    break
                if f"{module}.{attr}" in MODULES:
                    module = f"{module}.{attr}"
                    continue
                if is_private(attr) and module != name:
                    bad.append(f"{name} uses {module}.{attr}")
                break
    assert not bad, "\n".join(sorted(set(bad)))


# --------------------------------------------------------------------------- the old module names

#: Old module -> new module, and the public names the old one offered (ibvs 0.1.0).
MOVED = {
    "ibvs.plots": ("ibvs.viz", ["AXIS_COLOURS", "COORDINATE_STYLES", "TWIST_LABELS", "animate", "compare",
                                "episode", "image_limits", "image_limits_paths", "square_perimeter_r",
                                "sweep_summary"]),
    "ibvs.animation": ("ibvs.viz.animation", ["FPS", "check_path", "frame_count", "write"]),
    "ibvs.sweep": ("ibvs.study.sweep", ["COLUMNS", "CONNECT_TIMEOUT", "DEFAULT_RANGES", "DEPTH_MODES",
                                        "MAX_EPISODES", "MAX_JOBS", "PARAMETERS", "ROTATION_BINS", "SCHEMES",
                                        "Scenario", "SweepSpec", "aggregate", "bins_for", "builtin", "episode_id",
                                        "figure", "format_table", "load", "load_scenario", "outcomes",
                                        "register_scheme", "resolve", "run_episode", "samples", "sweep"]),
    "ibvs.scenario": ("ibvs.study.scenario", ["ANGLE_WRAPS", "DEFAULTS", "DEFAULT_RANGES", "DEPTH_MODES", "LIMITS",
                                              "MAX_DURATION", "MAX_GAIN", "PARAMETERS", "ROBOTS", "SWEEP_KEYS",
                                              "Scenario", "builtin", "load", "offset"]),
    "ibvs.schemes": ("ibvs.study.schemes", ["PAPER", "SCHEMES", "TITLES", "automatic", "cartesian", "cylindrical",
                                            "hybrid", "make", "partitioned", "polar", "stacked"]),
    "ibvs.reproduce": ("ibvs.study.reproduce", ["CASES", "DEFAULT_CASE", "DEPTH", "DURATION", "FIGURES", "GAIN",
                                                "PAPER_CASES", "Row", "SCHEMES", "SCHEME_TITLES", "TOLERANCE",
                                                "claims", "make_case", "reproduce", "run_one", "summarise",
                                                "wrap_label", "wrap_sentence", "write_summary"]),
}
#: Names an old module offered that live in another new module than the rest.
ELSEWHERE = {("ibvs.sweep", "builtin"): ("ibvs.study.scenario", "builtin"),
             ("ibvs.sweep", "load_scenario"): ("ibvs.study.scenario", "load")}


@pytest.mark.parametrize("old", sorted(MOVED))
def test_old_module_name_warns_once_and_gives_the_same_objects(old, monkeypatch):
    new, names = MOVED[old]
    monkeypatch.delitem(sys.modules, old, raising=False)  # imported afresh, so that its body runs (and warns)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        __import__(old)
    module = sys.modules[old]
    assert [w.category for w in caught] == [DeprecationWarning], [str(w.message) for w in caught]
    message = str(caught[0].message)
    assert f"{old} is deprecated" in message and f"import {new} instead" in message
    assert caught[0].filename == __file__  # the code that imported it, where Python's default filters look
    for name in names:
        where, attr = ELSEWHERE.get((old, name), (new, name))
        assert getattr(module, name) is getattr(importlib.import_module(where), attr), name


def test_the_package_uses_no_old_module_name():
    users = {name: target for name in MODULES if name not in MOVED
             for target, _, _ in imports(name) if target in MOVED}
    assert not users, users


def test_the_new_packages_offer_what_the_old_modules_did():
    """ibvs.vision and ibvs.sim kept their names (no alias: they are packages now, with the same API)."""
    import ibvs.sim
    import ibvs.vision

    for name in ["DotTracker", "ImageSensor", "KINDS", "Renderer", "TagDetector", "Track", "check_image",
                 "draw_points", "image_camera", "write_video"]:
        assert hasattr(ibvs.vision, name), name
    for name in ibvs.sim.__all__:
        assert hasattr(ibvs.sim, name), name
    assert ibvs.sim.run.__module__ == "ibvs.sim.episode" and ibvs.sim.Result.__module__ == "ibvs.sim.result"
