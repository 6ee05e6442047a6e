"""Writing a study's files: its rows as CSV, its page and figures to the output directory and, with --docs, to the
repository's docs/ (the commands `ibvs compare` and `ibvs wide`)."""

from __future__ import annotations

import argparse
import csv
from dataclasses import asdict
from pathlib import Path
from typing import Callable, Optional, Sequence

#: The repository's root when ibvs runs from a source checkout (docs/ and mkdocs.yml beside python/).
ROOT = Path(__file__).resolve().parents[3]


def docs_dir(parser: argparse.ArgumentParser, docs: bool) -> Optional[Path]:
    """The repository's docs/ when --docs was given (refused unless ibvs runs from a source checkout), else None."""
    if not docs:
        return None
    if not (ROOT / "mkdocs.yml").is_file():
        parser.error(f"--docs: {ROOT} is not the ibvs repository (run from a source checkout)")
    from ..cli.args import out_dir

    try:  # tried for writing now, before any work, as every output path of the command line
        out_dir(str(ROOT / "docs"))
    except argparse.ArgumentTypeError as e:
        parser.error(f"--docs: {e}")
    return ROOT / "docs"


def write(rows: Sequence, out: Path, docs: Optional[Path], csv_name: str, page_name: str,
          figures: Callable[[Path], list[str]], page: Callable[[list[str]], str]) -> None:
    """rows (dataclasses) to out/csv_name; then in out and in docs (if not None): figures(figure_dir) -> the names
    it wrote in figure_dir, and page(those names) -> the Markdown written to page_name."""
    out.mkdir(parents=True, exist_ok=True)
    with open(out / csv_name, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(asdict(rows[0])))
        w.writeheader()
        w.writerows(asdict(r) for r in rows)
    for d in [out] + ([docs] if docs is not None else []):
        fig_dir = d / "figures"
        fig_dir.mkdir(parents=True, exist_ok=True)
        (d / page_name).write_text(page(figures(fig_dir)))
