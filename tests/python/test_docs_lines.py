"""No line of the docs pages (docs/**/*.md) is longer than 120 characters, as in the README (test_readme.py), so
that the pages read in a terminal and in a diff as well as on the site.

Two kinds of line are exempt, because wrapping would break them:
- table rows (lines starting with "|"): a Markdown table row cannot continue on the next line;
- lines inside a ```text block: they quote a program's output verbatim (one printed line), and a wrapped quote
  would show output the program does not print.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGES = sorted((ROOT / "docs").rglob("*.md"))
LIMIT = 120
FENCE = re.compile(r"^\s*```(\w*)")


def long_lines(text: str) -> list[tuple[int, int]]:
    """(line number, length in characters) of every line over LIMIT that is not exempt."""
    found, fence = [], None  # fence: the language of the open code block, None outside one
    for number, line in enumerate(text.splitlines(), start=1):
        m = FENCE.match(line)
        if m:
            fence = m.group(1) if fence is None else None
            continue
        if len(line) <= LIMIT or line.startswith("|") or fence == "text":
            continue
        found.append((number, len(line)))
    return found


def test_the_rule_itself():
    long = "x" * (LIMIT + 1)
    assert long_lines(long) == [(1, LIMIT + 1)]
    assert long_lines("é" * LIMIT) == []  # characters, not bytes
    assert long_lines(f"| {long} |") == []
    assert long_lines(f"```text\n{long}\n```") == []
    assert long_lines(f"```python\n{long}\n```\n{long}") == [(2, LIMIT + 1), (4, LIMIT + 1)]


def test_no_docs_line_over_120_characters():
    assert PAGES, "no docs pages found"
    over = {str(p.relative_to(ROOT)): long_lines(p.read_text()) for p in PAGES}
    over = {page: lines for page, lines in over.items() if lines}
    assert not over, f"lines over {LIMIT} characters (page: [(line, length)]): {over}"
