"""LICENSE and CITATION.cff: the licence pyproject.toml declares, and the version ibvs reports."""

from __future__ import annotations

import re
from pathlib import Path

import ibvs

ROOT = Path(__file__).resolve().parents[2]


def top_level(text: str, key: str) -> str:
    """A top-level scalar of a YAML file (CITATION.cff), without a YAML parser (not a test dependency)."""
    match = re.search(rf"^{key}:\s*\"?([^\"\n]+?)\"?\s*$", text, flags=re.M)
    assert match, f"CITATION.cff has no top-level {key}"
    return match.group(1)


def test_citation_version_is_the_package_version():
    cff = (ROOT / "CITATION.cff").read_text()
    assert top_level(cff, "cff-version") == "1.2.0"
    assert top_level(cff, "version") == ibvs.__version__
    assert re.search(r"^project\(ibvs VERSION " + re.escape(ibvs.__version__) + r"\b",
                     (ROOT / "CMakeLists.txt").read_text(), flags=re.M)


def test_citation_is_ibvs_and_the_paper_is_a_reference():
    """Citing ibvs cites the software (the top-level entry, no preferred-citation of something else); the paper
    whose laws it implements is listed under references."""
    cff = (ROOT / "CITATION.cff").read_text()
    assert top_level(cff, "type") == "software" and top_level(cff, "title").startswith("ibvs: ")
    assert "preferred-citation:" not in cff
    head, _, references = cff.partition("\nreferences:\n")
    assert references, "CITATION.cff has no top-level references"
    assert "Combining Cartesian" not in head
    entries = re.split(r"(?m)^  - ", references)[1:]
    paper = next(e for e in entries if 'title: "Combining Cartesian and polar coordinates in IBVS"' in e)
    assert paper.startswith("type: conference-paper")
    assert re.findall(r"family-names: (\w+)", paper) == ["Corke", "Spindler", "Chaumette"]
    assert "year: 2009" in paper and "start: 5962" in paper and "end: 5967" in paper


def test_licence_is_the_one_pyproject_declares():
    assert 'license = { text = "BSD-3-Clause" }' in (ROOT / "pyproject.toml").read_text()
    assert top_level((ROOT / "CITATION.cff").read_text(), "license") == "BSD-3-Clause"
    licence = (ROOT / "LICENSE").read_text()
    assert licence.startswith("BSD 3-Clause License") and "Copyright (c) 2026, the ibvs developers" in licence
    assert "Neither the name of the copyright holder" in licence
