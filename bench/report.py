"""Markdown tables from several benchmark runs (median over runs of each figure).

    ibvs-bench --json > run1.json; ...; python -m ibvs.bench --json > py1.json; ...
    python bench/report.py run*.json py*.json

Each file holds the one JSON line printed by `ibvs-bench --json` or
`python -m ibvs.bench --json`; files of the same kind are merged case by case.
A cell with no number says "n/a", and a line under the table says why: a figure
that is null or not finite in every run is "not measured"; the Python table's
ratio compares two pairs of rows only.
"""

from __future__ import annotations

import json
import math
import statistics
import sys
from collections import defaultdict


def _median(runs: list[dict], key: str) -> float:
    """The median over the runs that measured `key` (a finite number); NaN when none did."""
    values = [r.get(key) for r in runs]
    values = [x for x in values if isinstance(x, (int, float)) and math.isfinite(x)]
    return statistics.median(values) if values else math.nan


def _max(runs: list[dict], key: str) -> float:
    """The largest finite `key` over the runs; NaN when none measured it."""
    values = [r.get(key) for r in runs]
    values = [x for x in values if isinstance(x, (int, float)) and math.isfinite(x)]
    return max(values) if values else math.nan


def _cell(x: float, spec: str) -> str:
    """One table cell: the number, or n/a when it was not measured (NaN: see NOT_MEASURED)."""
    return format(x, spec) if isinstance(x, (int, float)) and math.isfinite(x) else "n/a"


NOT_MEASURED = "n/a: not measured (null or not finite in every run's JSON)"
NO_RATIO = ("ratio n/a: only the damped ibvs step (numpy / ibvs: numpy's median over it) and the default step "
            "(default / tuned) have a counterpart to compare with")


def _with_reason(lines: list[str], first_row: int) -> list[str]:
    """Adds NOT_MEASURED under a table when one of its rows (from first_row on) has an n/a cell."""
    if any("| n/a |" in line for line in lines[first_row:]):
        lines += ["", NOT_MEASURED]
    return lines


def _group(runs: list[dict], list_key: str, id_keys: tuple[str, ...]) -> dict[tuple, list[dict]]:
    out: dict[tuple, list[dict]] = defaultdict(list)
    for run in runs:
        for c in run.get(list_key, []):
            out[tuple(c[k] for k in id_keys)].append(c)
    return out


def cpp_tables(runs: list[dict]) -> str:
    timed = [r for r in runs if r.get("cases")]
    head = timed[0] if timed else runs[0]
    lines = [(f"C++ `ibvs-bench`: median of {len(timed)} runs, {head['iterations']} iterations per case, "
              f"{head['cpu']}"), ""]
    cases = _group(runs, "cases", ("section", "name", "layout", "n", "rows"))
    for section in ("components", "tasks", "growth"):
        rows = [(k, v) for k, v in cases.items() if k[0] == section]
        if not rows:
            continue
        lines += [f"### {section}", "", "| case | layout | median µs | p99 µs | max µs | steps/s | allocs/call |",
                  "|---|---|---:|---:|---:|---:|---:|"]
        first = len(lines)
        for (sec, name, layout, n, m), v in rows:
            what = f"{layout} {m}×6" if sec == "tasks" else f"{layout}({n}) {m}×6"
            lines.append(f"| {name} | {what} | {_cell(_median(v, 'median_us'), '.3f')} | "
                         f"{_cell(_median(v, 'p99_us'), '.3f')} | {_cell(_median(v, 'max_us'), '.1f')} | "
                         f"{_cell(_median(v, 'steps_per_s'), ',.0f')} | {_cell(_max(v, 'allocs_per_call'), 'g')} |")
        _with_reason(lines, first).append("")
    paced = _group(runs, "paced", ("rate_hz", "realtime", "spin_us"))
    if paced:
        lines += ["### paced", "", ("| rate | duration | priority | steps | misses | lateness median µs | p99 µs "
                                    "| max µs | step median µs | step max µs |"),
                  "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
        first = len(lines)
        for (rate, rt, spin), v in paced.items():
            lines.append(f"| {rate:g} Hz | {v[0]['duration_s']:g} s | {'SCHED_FIFO' if rt else 'normal'}"
                         f"{f', spin {spin:g} µs' if spin else ''} | {sum(c['steps'] for c in v)} | "
                         f"{sum(c['misses'] for c in v)} | {_cell(_median(v, 'lateness_median_us'), '.1f')} | "
                         f"{_cell(_median(v, 'lateness_p99_us'), '.1f')} | {_cell(_max(v, 'lateness_max_us'), '.1f')} | "
                         f"{_cell(_median(v, 'step_median_us'), '.2f')} | {_cell(_max(v, 'step_max_us'), '.1f')} |")
        _with_reason(lines, first).append("")
    episodes = _group(runs, "episodes", ("name",))
    if episodes:
        lines += ["### episodes", "", "| case | frames | median ms | p99 ms | max ms | episodes/s | µs/frame | allocs/run |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|"]
        first = len(lines)
        for (name,), v in episodes.items():
            lines.append(f"| {name} | {v[0]['frames']} | {_cell(_median(v, 'median_ms'), '.3f')} | "
                         f"{_cell(_median(v, 'p99_ms'), '.3f')} | {_cell(_max(v, 'max_ms'), '.3f')} | "
                         f"{_cell(_median(v, 'episodes_per_s'), '.0f')} | {_cell(_median(v, 'us_per_frame'), '.2f')} | "
                         f"{_cell(_max(v, 'allocs_per_episode'), 'g')} |")
        _with_reason(lines, first).append("")
    return "\n".join(lines)


def py_tables(runs: list[dict]) -> str:
    r0 = runs[0]
    lines = [(f"Python `python -m ibvs.bench`: median of {len(runs)} runs, {r0['iterations']} iterations per case, "
              f"Python {r0['python']}, numpy {r0['numpy']}"), "",
             "| case | layout | median µs | p99 µs | max µs | calls/s | ratio |", "|---|---|---:|---:|---:|---:|---:|"]
    unmeasured = False
    for (name, layout, n, m), v in _group(runs, "cases", ("name", "layout", "n", "rows")).items():
        ratio = "n/a"
        if "default_over_tuned" in v[0]:
            x = _median(v, "default_over_tuned")
            ratio = f"default / tuned {x:.2f}×" if math.isfinite(x) else ratio
        elif "numpy_ratio" in v[0] and v[0]["implementation"] == "ibvs":
            x = _median(v, "numpy_ratio")
            ratio = f"numpy / ibvs {x:.0f}×" if math.isfinite(x) else ratio
        cells = [_cell(_median(v, "median_us"), ".2f"), _cell(_median(v, "p99_us"), ".2f"),
                 _cell(_median(v, "max_us"), ".1f"), _cell(_median(v, "calls_per_s"), ",.0f")]
        unmeasured = unmeasured or "n/a" in cells
        lines.append(f"| {name} | {layout}({n}) {m}×6 | {' | '.join(cells)} | {ratio} |")
    lines += ["", NO_RATIO] + ([NOT_MEASURED] if unmeasured else [])
    return "\n".join(lines) + "\n"


def main(paths: list[str]) -> int:
    runs = []
    for p in paths:
        with open(p) as f:
            runs.append(json.loads(f.read().strip().splitlines()[-1]))
    cpp = [r for r in runs if r.get("benchmark") == "ibvs-bench"]
    py = [r for r in runs if r.get("benchmark") == "ibvs.bench"]
    # Paced-only and episode-only runs are merged into the tables of the full runs.
    if cpp:
        print(cpp_tables(cpp))
    if py:
        print(py_tables(py))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
