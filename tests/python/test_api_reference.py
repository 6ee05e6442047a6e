"""Every public module and name of python/ibvs has its place in the API reference (docs/api/*.md, rendered by
mkdocstrings), found by walking the package rather than from a list kept by hand.

Each module whose name has no leading underscore is one of:
- documented: a `::: module` directive of docs/api/*.md renders its public names (its __all__, else its names
  without a leading underscore: mkdocstrings' `filters: public`), or, with `members: [...]`, those it lists;
- a part of a documented package: it declares __all__, and every name there is rendered where its package
  re-exports it (the same object) or by a directive that lists it;
- a deprecated alias (it calls ibvs.deprecation.warn_moved): the reference names only the new module;
- the command line (ibvs.cli and its modules): its reference is `ibvs COMMAND --help` (test_cli.py runs it
  for every command) and the guide's pages.
Every rendered name has a docstring (a `#:` comment for a constant), as the reference shows it.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import warnings
from pathlib import Path

import pytest

import ibvs

ROOT = Path(__file__).resolve().parents[2]
DIRECTIVE = re.compile(r"^::: ([\w.]+)\n((?:[ \t]+.*\n?)*)", re.M)
COMMAND_LINE = "ibvs.cli"


def directives() -> dict[str, list[str] | None]:
    """module -> the members its directive lists (None: all its public names), over every docs/api page."""
    found: dict[str, list[str] | None] = {}
    for page in sorted((ROOT / "docs/api").glob("*.md")):
        for m in DIRECTIVE.finditer(page.read_text()):
            listed = re.search(r"members:\s*\[([^\]]*)\]", m.group(2))
            found[m.group(1)] = [x.strip() for x in listed.group(1).split(",")] if listed else None
    return found


def modules() -> list[str]:
    """Every module of the package whose dotted name has no part with a leading underscore."""
    names = ["ibvs"] + [m.name for m in pkgutil.walk_packages(ibvs.__path__, "ibvs.")]
    return [n for n in names if not any(part.startswith("_") for part in n.split("."))]


def load(name: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return importlib.import_module(name)


def public(module) -> list[str]:
    """What mkdocstrings renders of a module without a members list: __all__, else its own public names."""
    if hasattr(module, "__all__"):
        return list(module.__all__)
    return [n for n, v in vars(module).items() if not n.startswith("_") and not inspect.ismodule(v)
            and getattr(v, "__module__", module.__name__) == module.__name__]


def rendered() -> dict[int, list[str]]:
    """id(object) -> where the reference renders it (module.name)."""
    out: dict[int, list[str]] = {}
    for name, members in directives().items():
        module = load(name)
        for attr in members if members is not None else public(module):
            out.setdefault(id(getattr(module, attr)), []).append(f"{name}.{attr}")
    return out


def is_deprecated_alias(module) -> bool:
    return module.__name__ != "ibvs.deprecation" and "warn_moved(" in inspect.getsource(module)


def test_the_walk_finds_the_package():
    found = modules()
    assert {"ibvs", "ibvs.sim", "ibvs.sim.ik", "ibvs.viz.drawing", "ibvs.cli.main", "ibvs.bench"} <= set(found)
    assert not any("._" in n for n in found)
    assert directives()["ibvs.sim.ik"] == ["MAX_TRANSLATION", "rotation_vector"]


def test_every_directive_names_a_module_and_its_members():
    for name, members in directives().items():
        module = load(name)
        for attr in members or []:
            assert hasattr(module, attr), f"docs/api: ::: {name} lists {attr}, which it does not have"
        assert not is_deprecated_alias(module), f"docs/api documents the deprecated {name}"


@pytest.mark.parametrize("name", modules())
def test_every_public_module_has_its_place_in_the_reference(name):
    module = load(name)
    docs = directives()
    if name in docs or name == COMMAND_LINE or name.startswith(COMMAND_LINE + "."):
        return
    if is_deprecated_alias(module):
        with pytest.warns(DeprecationWarning, match="is deprecated: import ibvs."):
            importlib.reload(module)
        return
    assert hasattr(module, "__all__"), (
        f"{name}: neither documented (a ::: directive in docs/api/*.md) nor declaring __all__ (what its package "
        f"re-exports)")
    where = rendered()
    missing = [attr for attr in module.__all__ if id(getattr(module, attr)) not in where]
    assert not missing, f"{name}.__all__ names what the API reference does not render: {missing}"


def _constant_comment(module, attr: str) -> bool:
    """A `#:` comment above the module-level assignment of attr, or above the block of assignments it is in
    (what the reference's griffe extension, docs/_griffe/ibvs_docs.py, reads as its docstring)."""
    lines = inspect.getsource(module).splitlines()
    for k, line in enumerate(lines):
        if re.match(rf"{attr}\s*(:[^=]+)?=", line):
            j = k - 1
            while j >= 0 and lines[j].strip() and not lines[j].startswith(("#", "def ", "class ", "@")):
                j -= 1  # the assignments (and their continuation lines) of the same block
            return j >= 0 and lines[j].startswith("#:")
    return False


def test_every_rendered_name_has_a_docstring():
    bare = []
    for name, members in directives().items():
        module = load(name)
        if name == "ibvs":
            continue  # the compiled names: their docstrings are the stub's (test_docs_site.py checks them)
        for attr in members if members is not None else public(module):
            obj = getattr(module, attr)
            home = load(getattr(obj, "__module__", None) or name) if callable(obj) else module
            if inspect.isclass(obj) or inspect.isfunction(obj) or inspect.ismodule(obj):
                ok = bool((inspect.getdoc(obj) or "").strip())
            else:
                homes = [module] + [load(m) for m in modules() if attr in vars(load(m)) and
                                    vars(load(m))[attr] is obj and not is_deprecated_alias(load(m))]
                ok = any(_constant_comment(h, attr) for h in homes) or callable(obj) and bool(inspect.getdoc(obj))
            if not ok:
                bare.append(f"{name}.{attr} ({getattr(home, '__name__', name)})")
    assert not bare, f"names the reference renders without a docstring or #: comment: {bare}"
