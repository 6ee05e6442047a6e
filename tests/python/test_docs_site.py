"""The documentation site and its API reference.

- `mkdocs build --strict` succeeds offline, in a temporary directory: mkdocs.yml turns every unrecognised link, missing
  page or file and missing anchor into a warning, which --strict makes an error; the built pages load nothing from the
  network. Needs the `docs` extra: skipped without MkDocs.
- Every public name of ibvs, ibvs.sim, ibvs.vision, ibvs.study, ibvs.viz and ibvs.ros (its __all__, or its public definitions)
  has a non-empty docstring and a place in the API reference; so has every public member of the compiled classes,
  read from the stub _core.pyi as the reference reads it.
"""

from __future__ import annotations

import html
import importlib
import importlib.util
import inspect
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODULES = ["ibvs", "ibvs.calibration", "ibvs.sim", "ibvs.sim.cases", "ibvs.vision", "ibvs.viz", "ibvs.study",
           "ibvs.study.schemes", "ibvs.study.scenario", "ibvs.study.sweep", "ibvs.study.reproduce",
           "ibvs.study.hand_eye", "ibvs.ros"]
# The API pages: which module each documents (::: directives).
PAGES = {"api/ibvs": ["ibvs"], "api/calibration": ["ibvs.calibration"], "api/sim": ["ibvs.sim", "ibvs.sim.cases"],
         "api/vision": ["ibvs.vision"], "api/viz": ["ibvs.viz"], "api/ros": ["ibvs.ros"],
         "api/study": ["ibvs.study", "ibvs.study.schemes", "ibvs.study.scenario", "ibvs.study.sweep",
                       "ibvs.study.reproduce", "ibvs.study.hand_eye"]}
# Any attempt to reach the network goes to a closed local port and fails.
PROXIES = ("HTTP_PROXY", "HTTPS_PROXY", "ALL_PROXY", "http_proxy", "https_proxy")
NO_NETWORK = {**{k: "http://127.0.0.1:9" for k in PROXIES},
              "NO_PROXY": "", "no_proxy": "", "NO_MKDOCS_2_WARNING": "1"}


def public_names(module) -> list[str]:
    """__all__, or the public classes, functions and constants a module defines itself (not what it imports)."""
    if hasattr(module, "__all__"):
        return list(module.__all__)
    source = inspect.getsource(module)
    names = []
    for name, value in vars(module).items():
        if name.startswith("_") or inspect.ismodule(value):
            continue
        if inspect.isclass(value) or inspect.isfunction(value):
            if value.__module__ == module.__name__:
                names.append(name)
        elif re.search(rf"(?m)^{name}\s*(:[^=\n]+)?=", source):
            names.append(name)
    return names


def _has_tool(name: str) -> bool:
    return importlib.util.find_spec(name) is not None


needs_mkdocs = pytest.mark.skipif(
    not all(_has_tool(m) for m in ("mkdocs", "material", "mkdocstrings_handlers.python")),
    reason='the docs extra is not installed (pip install ".[docs]")')
needs_griffe = pytest.mark.skipif(not _has_tool("griffe"), reason='the docs extra is not installed (griffe)')


@pytest.mark.parametrize("name", MODULES)
def test_public_modules_classes_and_functions_have_docstrings(name):
    """At run time, as help() shows them."""
    module = importlib.import_module(name)
    assert (module.__doc__ or "").strip(), f"{name} has no module docstring"
    for attr in public_names(module):
        obj = getattr(module, attr)
        if inspect.ismodule(obj) or inspect.isclass(obj) or callable(obj):
            assert (inspect.getdoc(obj) or "").strip(), f"{name}.{attr} has no docstring"


def _griffe_package():
    import griffe

    extensions = griffe.load_extensions(str(ROOT / "docs/_griffe/ibvs_docs.py") + ":IbvsDocs")
    loader = griffe.GriffeLoader(search_paths=[str(ROOT / "python")], allow_inspection=False, extensions=extensions)
    package = loader.load("ibvs")
    loader.resolve_aliases(implicit=False, external=False)
    return package


def _target(obj):
    return obj.final_target if obj.is_alias else obj


@needs_griffe
def test_every_public_name_is_documented_in_the_reference():
    """Statically, as the API reference reads them: constants by their `#:` comment, the compiled classes by the
    stub. Every name of each module's public set has a non-empty docstring."""
    package = _griffe_package()
    missing = []
    for name in MODULES:
        module = package if name == "ibvs" else package[name[len("ibvs."):]]
        for attr in public_names(importlib.import_module(name)):
            obj = _target(module[attr])
            if not (obj.docstring and obj.docstring.value.strip()):
                missing.append(f"{name}.{attr}")
    assert not missing, f"public names without a docstring: {missing}"


@needs_griffe
def test_compiled_classes_are_documented_member_by_member():
    """Every public class, function, method and property of the stub _core.pyi has a docstring (enum members are
    described by their class)."""
    package = _griffe_package()
    missing = []

    def walk(obj, enum: bool = False):
        for member_name, member in obj.members.items():
            if member.is_alias or (member_name.startswith("_") and member_name != "__version__"):
                continue
            if not (enum and member.is_attribute) and not (enum and member_name in ("name", "value")):
                if not (member.docstring and member.docstring.value.strip()):
                    missing.append(member.path)
            if member.is_class:
                walk(member, enum=member_name in ("Status", "Representation"))

    walk(package["_core"])
    assert not missing, f"members of the stub without a docstring: {missing}"


@needs_mkdocs
def test_site_builds_strict_offline_with_every_link_checked(tmp_path):
    site = tmp_path / "site"
    start = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)], cwd=ROOT,
                         env=dict(os.environ, **NO_NETWORK), capture_output=True, text=True, timeout=600)
    seconds = time.perf_counter() - start
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-5000:]
    assert "WARNING" not in run.stderr, run.stderr[-5000:]
    print(f"mkdocs build --strict: {seconds:.1f} s")

    pages = list(site.rglob("*.html"))
    assert len(pages) >= 20
    remote = re.compile(r"<(?:script|link|img)[^>]+(?:src|href)=\"(?:https?:)?//", re.I)
    loading = [str(p.relative_to(site)) for p in pages if remote.search(p.read_text())]
    assert not loading, f"pages that load something from the network: {loading}"

    # The API reference: an anchor for every public name, and the compiled classes with their docstrings.
    for page, modules in PAGES.items():
        ids = set(re.findall(r'id="([\w.]+)"', (site / page / "index.html").read_text()))
        for name in modules:
            module = importlib.import_module(name)
            absent = [f"{name}.{a}" for a in public_names(module) if f"{name}.{a}" not in ids]
            assert not absent, f"{page}: not in the reference: {absent}"
    api = (site / "api/ibvs/index.html").read_text()
    for doc in ("Which feature blocks are stacked, in which row order.", "J(f*, z*)",
                "Classic IBVS: (u_i, v_i) for each of n points, 2n x 6."):
        assert doc in api.replace("&#42;", "*")
    sim = (site / "api/sim/index.html").read_text()
    assert "Points (N, 3) in the target frame" in sim  # ibvs.sim.Target, a compiled class named by assignment

    # The C++ page and the home page show the files they include.
    def text(page: str) -> str:
        return html.unescape(re.sub(r"<[^>]+>", "", (site / page).read_text()))

    cpp = text("cpp/index.html")
    assert "int main() {" in cpp and "find_package(ibvs 0.1 CONFIG REQUIRED)" in cpp
    assert "Combining Cartesian and polar coordinates in IBVS" in text("index.html")
    assert "world <- target" in text("api/sim/index.html") and "world \\<- target" not in text("api/sim/index.html")


@needs_mkdocs
def test_strict_build_fails_on_a_broken_link_or_anchor(tmp_path):
    """mkdocs.yml's validation settings, applied to a page with a broken link and a broken anchor, fail the build."""
    validation = re.search(r"(?ms)^validation:\n(?:  .*\n)+", (ROOT / "mkdocs.yml").read_text()).group(0)
    for broken in ("[x](missing.md)", "[x](other.md#no-such-heading)", "[x](#nowhere)"):
        (tmp_path / "docs").mkdir(exist_ok=True)
        (tmp_path / "docs" / "index.md").write_text(f"# Home\n\n{broken}\n")
        (tmp_path / "docs" / "other.md").write_text("# Other\n\n## A heading\n")
        (tmp_path / "mkdocs.yml").write_text(f"site_name: t\nnav: [index.md, other.md]\n{validation}")
        run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "s")],
                             cwd=tmp_path, env=dict(os.environ, **NO_NETWORK), capture_output=True, text=True,
                             timeout=120)
        assert run.returncode != 0, f"{broken} passed --strict"
