"""The README is a front page: the two commands CI runs come first, then what ibvs is, the picture, the
installation, three examples, the comparison and the links; at most 200 lines of at most 120 characters, and every
link it holds leads somewhere. Its code blocks are run or matched by test_docs_blocks.py."""

from __future__ import annotations

import re
import runpy
from pathlib import Path

try:
    import tomllib
except ImportError:  # Python < 3.11
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text()
COMMANDS = ['pip install ".[test,plot,cpp]" && ibvs reproduce', 'pip install ".[test,plot,cpp]" && python -m pytest']


def sections() -> dict[str, str]:
    parts = re.split(r"(?m)^## ", README)
    return {p.split("\n", 1)[0].strip(): p for p in parts[1:]}


def test_the_two_commands_come_first():
    lines = README.splitlines()
    assert lines[0] == "# ibvs" and lines[2] == "```bash"
    assert [line.split("  #")[0].strip() for line in lines[3:5]] == COMMANDS  # what .ci/run runs
    assert lines[5] == "```"


def test_a_front_page_not_a_manual():
    lines = README.splitlines()
    assert len(lines) <= 200
    long = [(i + 1, len(line)) for i, line in enumerate(lines) if len(line) > 120]
    assert not long, f"lines over 120 characters: {long}"
    assert "![" in README and "docs/figures/z_rotation.gif" in README
    assert list(sections())[:2] == ["Installation", "Examples"]
    for name in ("Installation", "Examples", "Documentation", "Development"):
        assert name in sections()


def test_installation_names_prerequisites_every_extra_and_the_build_time():
    install = sections()["Installation"]
    assert "C++17 compiler" in install and "Python ≥ 3.9" in install
    assert re.search(r"about\s+\d+\s+minutes?\s+on\s+an\s+idle\s+2-core\s+machine", install)  # across line breaks
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    listed = re.findall(r"(?m)^\| `(\w+)` \|", install)
    assert sorted(listed) == sorted(extras), "the table lists every extra of pyproject.toml, and only those"
    assert "TODO" not in README


def test_three_examples():
    examples = sections()["Examples"]
    assert len(re.findall(r"```python\n", examples)) == 2 and "```cpp\n" in examples and "```cmake\n" in examples
    assert "update_pixels" in examples and "JointMapping" in examples  # from pixels to an arm's joints


def test_python_example_is_the_quickstart_and_runs(capsys):
    src = (ROOT / "tests/consumer/quickstart.py").read_text()
    assert f"```python\n{src}```" in README
    runpy.run_path(str(ROOT / "tests/consumer/quickstart.py"))
    out = capsys.readouterr().out
    assert out.startswith("status 0 velocity") and len(out.split()) == 9


def test_comparison_with_visp_and_the_machine_vision_toolbox():
    table = next(v for k, v in sections().items() if "ViSP" in k and "Machine Vision Toolbox" in k)
    rows = [line for line in table.splitlines() if line.startswith("|")]
    assert rows[0].count("|") == 5 and 6 <= len(rows) <= 14  # ibvs, ViSP, MVTB; short
    assert "licence" in table and "BSD-3-Clause" in table and "GPL" in table and "MIT" in table


def _slug(heading: str) -> str:
    """The anchor MkDocs (and, for these headings, GitHub) gives a heading."""
    text = re.sub(r"[^\w\s-]", "", heading.strip().lower())
    return re.sub(r"[\s]+", "-", text).strip("-")


def test_links_lead_somewhere():
    links = re.findall(r"\]\(([^)\s]+)\)", README) + re.findall(r"(?m)^\[[\w-]+\]: (\S+)$", README)
    local = [link for link in links if not re.match(r"https?://", link)]
    assert {"docs/index.md", "docs/api/ibvs.md", "docs/cpp.md", "LICENSE", "CITATION.cff"} <= set(local)
    for link in local:
        path, _, anchor = link.partition("#")
        target = ROOT / path
        assert target.exists(), f"README links to {path}, which does not exist"
        if anchor:
            headings = re.findall(r"(?m)^#+ (.+)$", target.read_text())
            assert anchor in {_slug(h) for h in headings}, f"README links to {link}: no such heading"
    docs = {str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md")}
    assert docs - {"docs/installation.md"} <= set(local), "the README links every page of the guide"


def about() -> str:
    """The "about" paragraph (also the docs site's front page, through its snippet markers)."""
    return README.split("<!-- --8<-- [start:about] -->\n", 1)[1].split("<!-- --8<-- [end:about] -->", 1)[0]


def sentences(text: str) -> list[str]:
    """Sentences of a paragraph: a '.', '!' or '?' then a space and a capital (or the end) closes one."""
    return [s for s in re.split(r"(?<=[.!?])\s+(?=[A-Z*])", " ".join(text.split())) if s]


def test_about_is_three_sentences():
    assert sentences("One. Two is *here* (IROS 2009). Three, e.g. this.") == [
        "One.", "Two is *here* (IROS 2009).", "Three, e.g. this."]
    found = sentences(about())
    assert len(found) == 3, f"the about paragraph has {len(found)} sentences: {found}"
    assert found[0].startswith("ibvs ") and all(s.endswith(".") for s in found)


def test_comparison_names_only_features_ibvs_has():
    """The "other features" cell of ibvs: a dash only when ibvs has no feature block besides points; every kind it
    names is a feature block of an ibvs.Task (an ibvs.Feature subclass)."""
    import ibvs

    row = next(line for line in README.splitlines() if line.startswith("| other features |"))
    cell = row.split("|")[2].strip()
    blocks = [n for n in dir(ibvs) if isinstance(getattr(ibvs, n), type) and issubclass(getattr(ibvs, n), ibvs.Feature)
              and getattr(ibvs, n) is not ibvs.Feature]
    assert (cell == "—") == (not blocks), f"other features: {cell!r}, while ibvs has {blocks}"
    kinds = {"lines": "LineFeature", "segments": "SegmentFeature", "ellipses": "EllipseFeature",
             "moments": "MomentsFeature", "2.5-D": "Point25DFeature", "PBVS": "PbvsFeature", "yours": "FunctionFeature"}
    named = [k.strip() for k in cell.split(",")]
    for k in named:
        assert k in kinds and kinds[k] in blocks, f"other features names {k!r}, which is not a feature block of ibvs"
