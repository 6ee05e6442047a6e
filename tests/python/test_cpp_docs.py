"""docs/cpp.md against the C++ headers: the umbrella headers include what the page says they include, its
table lists every public header, and every name the table says a header declares is in that header (or in what
it includes), so a renamed or removed API shows up here."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
INCLUDE = ROOT / "cpp/include"
PAGE = (ROOT / "docs/cpp.md").read_text()
# Internal headers (namespace ibvs::detail), named as such by the page rather than in its table.
INTERNAL = {"pixel_front_end.hpp"}


def headers() -> list[str]:
    """Every header under cpp/include/ibvs, relative to it (version.hpp is generated from version.hpp.in)."""
    found = [str(p.relative_to(INCLUDE / "ibvs")) for p in (INCLUDE / "ibvs").rglob("*.hpp")]
    return sorted(found + ["version.hpp"])


def text(header: str) -> str:
    path = INCLUDE / "ibvs" / header
    return path.read_text() if path.exists() else (ROOT / "cpp/include/ibvs" / (header + ".in")).read_text()


def closure(header: str) -> set[str]:
    """The ibvs headers `header` includes, directly or not (itself included)."""
    seen, todo = set(), [header]
    while todo:
        h = todo.pop()
        if h not in seen:
            seen.add(h)
            todo += re.findall(r'^#include "ibvs/([\w/]+\.hpp)"', text(h), flags=re.M)
    return seen


def table() -> dict[tuple[str, ...], str]:
    """The page's header table: (headers of a row) -> what the row says they declare."""
    start = PAGE.index("| header | what it declares |")
    rows = {}
    for line in PAGE[start:].splitlines()[2:]:
        if not line.startswith("|"):
            break
        _, names, what, _ = line.split("|")
        rows[tuple(re.findall(r"`([\w/]+\.hpp)`", names))] = what
    return rows


def test_umbrella_headers_include_what_the_page_says():
    public = [h for h in headers() if h not in INTERNAL]
    core = closure("ibvs.hpp")
    missing = [h for h in public if not h.startswith("sim/") and h not in core]
    assert not missing, f"ibvs/ibvs.hpp does not include {missing}"
    sim = closure("sim/sim.hpp")
    missing = [h for h in public if h.startswith("sim/") and h not in sim]
    assert not missing, f"ibvs/sim/sim.hpp does not include {missing}"
    assert "`#include <ibvs/ibvs.hpp>`" in PAGE and "`#include <ibvs/sim/sim.hpp>`" in PAGE


def test_table_lists_every_public_header():
    listed = {h for row in table() for h in row}
    public = set(headers()) - INTERNAL
    assert public - listed == set(), f"headers missing from docs/cpp.md's table: {sorted(public - listed)}"
    assert listed - public == set(), f"the table lists headers that do not exist: {sorted(listed - public)}"
    for h in INTERNAL:
        assert f"`{h}` is internal" in PAGE


def test_every_name_in_the_table_is_declared_where_it_says():
    stale = []
    for row, what in table().items():
        source = "\n".join(text(h) for h0 in row for h in closure(h0))
        for code in (c for c in re.findall(r"`([^`]+)`", what) if not c.endswith(".hpp")):
            for name in re.findall(r"[A-Za-z_]\w*", code.split("(")[0]):
                if not re.search(rf"\b{name}\b", source):
                    stale.append(f"{'/'.join(row)}: {name}")
    assert not stale, f"names in docs/cpp.md's table that its headers do not declare: {stale}"
