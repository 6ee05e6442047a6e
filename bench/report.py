"""Markdown tables from several benchmark runs (median over runs of each figure).

    ibvs-bench --json > run1.json; ...; python -m ibvs.bench --json > py1.json; ...
    python bench/report.py run*.json py*.json

Each file holds the one JSON line printed by `ibvs-bench --json` or
`python -m ibvs.bench --json`; files of the same kind are merged case by case.
"""

from __future__ import annotations

import json
import statistics
import sys
from collections import defaultdict


def _median(runs: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in runs)


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
    for section in ("components", "growth"):
        rows = [(k, v) for k, v in cases.items() if k[0] == section]
        if not rows:
            continue
        lines += [f"### {section}", "", "| case | layout | median µs | p99 µs | max µs | steps/s | allocs/call |",
                  "|---|---|---:|---:|---:|---:|---:|"]
        for (sec, name, layout, n, m), v in rows:
            lines.append(f"| {name} | {layout}({n}) {m}×6 | {_median(v, 'median_us'):.3f} | {_median(v, 'p99_us'):.3f} "
                         f"| {_median(v, 'max_us'):.1f} | {_median(v, 'steps_per_s'):,.0f} | "
                         f"{max(c['allocs_per_call'] for c in v):g} |")
        lines.append("")
    paced = _group(runs, "paced", ("rate_hz", "realtime", "spin_us"))
    if paced:
        lines += ["### paced", "", ("| rate | duration | priority | steps | misses | lateness median µs | p99 µs "
                                    "| max µs | step median µs | step max µs |"),
                  "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
        for (rate, rt, spin), v in paced.items():
            lines.append(f"| {rate:g} Hz | {v[0]['duration_s']:g} s | {'SCHED_FIFO' if rt else 'normal'}"
                         f"{f', spin {spin:g} µs' if spin else ''} | {sum(c['steps'] for c in v)} | "
                         f"{sum(c['misses'] for c in v)} | {_median(v, 'lateness_median_us'):.1f} | "
                         f"{_median(v, 'lateness_p99_us'):.1f} | {max(c['lateness_max_us'] for c in v):.1f} | "
                         f"{_median(v, 'step_median_us'):.2f} | {max(c['step_max_us'] for c in v):.1f} |")
        lines.append("")
    episodes = _group(runs, "episodes", ("name",))
    if episodes:
        lines += ["### episodes", "", "| case | frames | median ms | p99 ms | max ms | episodes/s | µs/frame | allocs/run |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|"]
        for (name,), v in episodes.items():
            lines.append(f"| {name} | {v[0]['frames']} | {_median(v, 'median_ms'):.3f} | {_median(v, 'p99_ms'):.3f} | "
                         f"{max(c['max_ms'] for c in v):.3f} | {_median(v, 'episodes_per_s'):.0f} | "
                         f"{_median(v, 'us_per_frame'):.2f} | {max(c['allocs_per_episode'] for c in v):g} |")
        lines.append("")
    return "\n".join(lines)


def py_tables(runs: list[dict]) -> str:
    r0 = runs[0]
    lines = [(f"Python `python -m ibvs.bench`: median of {len(runs)} runs, {r0['iterations']} iterations per case, "
              f"Python {r0['python']}, numpy {r0['numpy']}"), "",
             "| case | layout | median µs | p99 µs | max µs | calls/s | ratio |", "|---|---|---:|---:|---:|---:|---:|"]
    for (name, layout, n, m), v in _group(runs, "cases", ("name", "layout", "n", "rows")).items():
        ratio = f"numpy / ibvs {_median(v, 'numpy_ratio'):.0f}×" if "numpy_ratio" in v[0] and v[0]["implementation"] == "ibvs" else ""
        if "default_over_tuned" in v[0]:
            ratio = f"default / tuned {_median(v, 'default_over_tuned'):.2f}×"
        lines.append(f"| {name} | {layout}({n}) {m}×6 | {_median(v, 'median_us'):.2f} | {_median(v, 'p99_us'):.2f} | "
                     f"{_median(v, 'max_us'):.1f} | {_median(v, 'calls_per_s'):,.0f} | {ratio} |")
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
