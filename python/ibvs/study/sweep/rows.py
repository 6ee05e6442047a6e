"""The sweep's CSV file: its columns, one row per episode read back (load) and appended as episodes
finish (RowWriter)."""

from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Optional, Union

from ..scenario import PARAMETERS

# What ibvs.study.sweep re-exports (and documents); the other names here are its own helpers.
__all__ = ["COLUMNS", "load"]

#: Columns of the CSV, in order.
COLUMNS = (
    "id", "config", "index", "scenario", "scheme", *PARAMETERS, "depth", "angle_wrap", "outcome", "frame",
    "point", "joint",
    "frames_to_converge", "time_to_converge", "camera_retreat", "path_length", "peak_linear_speed",
    "peak_angular_speed", "final_translation_error", "final_rotation_error", "peak_camera_linear_speed",
    "peak_camera_angular_speed",
)
#: The columns of files written before the camera's actual speeds were recorded: such a file is read
#: (those two columns NaN) and resumed in its own columns.
PREVIOUS_COLUMNS = COLUMNS[:-2]
#: Columns that a file of PREVIOUS_COLUMNS lacks.
ADDED_COLUMNS = COLUMNS[len(PREVIOUS_COLUMNS):]
#: Columns holding integers and strings (the others hold floats).
INT_COLUMNS = {"index", "latency", "frame", "point", "joint", "frames_to_converge"}
STR_COLUMNS = {"id", "config", "scenario", "scheme", "depth", "angle_wrap", "outcome"}


def _format(name: str, x) -> str:
    if name in STR_COLUMNS or name in INT_COLUMNS:
        return str(x)
    return repr(float(x))


def _parse(row: dict) -> dict:
    out = {}
    for k in COLUMNS:
        v = row.get(k, "nan")  # a column the file's version lacks (ADDED_COLUMNS)
        out[k] = v if k in STR_COLUMNS else int(v) if k in INT_COLUMNS else float(v)
    return out


def _header(path: Path) -> tuple:
    """The columns of an existing sweep file: COLUMNS, or PREVIOUS_COLUMNS for an older one."""
    with open(path, encoding="utf-8", errors="replace") as f:
        first = f.readline().rstrip("\n")
    return PREVIOUS_COLUMNS if first == ",".join(PREVIOUS_COLUMNS) else COLUMNS


def load(path: Union[str, os.PathLike], config: Optional[str] = None) -> list[dict]:
    """Rows of a sweep CSV (optionally of one config), sorted by (index, scheme); an
    incomplete last line (an interrupted write) is ignored."""
    path = Path(path)
    if not path.exists():
        return []
    rows = {}
    try:
        with open(path, newline="", encoding="utf-8") as f:
            text = raw_text = f.read()
    except UnicodeDecodeError:
        raise ValueError(f"out: {path} is not an ibvs sweep file (not text)") from None
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    reader = csv.DictReader(text.splitlines())
    header = ",".join(COLUMNS)
    first = raw_text.split("\n", 1)[0]
    if raw_text and first not in (header, ",".join(PREVIOUS_COLUMNS)) \
            and not ("\n" not in raw_text and header.startswith(first)):
        raise ValueError(f"out: {path} is not an ibvs sweep file of this version (its first line is not the "
                         f"header {COLUMNS[0]},{COLUMNS[1]},...)")
    for raw in reader:
        if None in raw.values() or None in raw:
            continue
        r = _parse(raw)
        if config is None or r["config"] == config:
            rows[r["id"]] = r
    return sorted(rows.values(), key=lambda r: (r["config"], r["index"], r["scheme"]))


class RowWriter:
    """Appends rows to the CSV, one flushed line each (after cutting a torn last line)."""

    def __init__(self, path: Optional[Path]):
        self.f = None
        if path is None:
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.exists() and path.stat().st_size > 0:
            with open(path, "rb+") as f:
                data = f.read()
                if not data.endswith(b"\n"):
                    f.truncate(data.rfind(b"\n") + 1)
        new = not path.exists() or path.stat().st_size == 0
        # a file of an older version goes on in its own columns, so that every line has the same ones
        self.columns = COLUMNS if new else _header(path)
        self.f = open(path, "a", newline="")
        self.w = csv.writer(self.f, lineterminator="\n")
        if new:
            self.w.writerow(COLUMNS)
            self.f.flush()

    def write(self, rows: list[dict]) -> None:
        if self.f is not None:
            for r in rows:
                self.w.writerow([_format(c, r[c]) for c in self.columns])
            self.f.flush()

    def close(self) -> None:
        if self.f is not None:
            self.f.close()
