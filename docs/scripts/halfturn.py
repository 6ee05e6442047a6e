"""Half-turn study (issue 11): eq. (13) point by point against the consistent angle wrap.

Free-flying camera, the paper's target, gain 1, 60 Hz, exact depth, 20 s, tolerance 1e-5.
Starts: rotation rz about the optical axis uniform in [165, 195] deg, no tilt, lateral offsets
+-0.05 m and depth offset +-0.1 m; noise 0 and 1e-3 (normalised units, about 1 px at f = 1000 px).
The same seeded starts for every scheme, wrap and noise level. "near": |rz - 180| <= 5 deg;
"10 deg away": 8 <= |rz - 180| <= 12 deg. Success: the run converges (error norm < 1e-5) or,
with noise (which keeps the error norm above 1e-5 and the camera jittering by a few cm), reaches
its timeout with the camera within 0.2 m and 5 deg of the goal (it turned round and stayed).
python docs/scripts/halfturn.py [EPISODES] [FIGURE.png] (docs/beyond.md section 7); about 3 min of CPU for
1200 episodes.
"""
import sys

import numpy as np

import ibvs.study.sweep as sw

SCHEMES = ("polar", "stacked", "hybrid", "cylindrical", "automatic")
WRAPS = ("per_point", "consistent")
NOISES = (0.0, 1e-3)
RANGES = {"rz_deg": (165.0, 195.0), "tilt_deg": (0.0, 0.0), "tx": (-0.05, 0.05), "ty": (-0.05, 0.05),
          "tz": (-0.1, 0.1)}


def study(episodes: int) -> dict:
    """Rows per (noise, wrap); each sweep's CSV (halfturn_NOISE_WRAP.csv) makes a re-run resume."""
    return {(noise, wrap): sw.sweep(f"halfturn_{noise:g}_{wrap}.csv", episodes=episodes, seed=11, schemes=SCHEMES,
                                    angle_wrap=wrap, ranges={**RANGES, "noise": (noise, noise)}, progress=False)
            for noise in NOISES for wrap in WRAPS}


def success(r: dict) -> bool:
    settled = r["final_translation_error"] < 0.2 and np.degrees(r["final_rotation_error"]) < 5.0
    return r["outcome"] == "converged" or (r["noise"] > 0 and r["outcome"] == "timeout" and settled)


def failures(group: list) -> str:
    """Outcomes of the failed runs, most frequent first."""
    names = [r["outcome"] if r["outcome"] != "timeout" else "timeout far" for r in group if not success(r)]
    return ", ".join(f"{n} {names.count(n)}" for n in sorted(set(names), key=names.count, reverse=True)) or "-"


def share(group: list) -> str:
    """Successful runs of a group, in %, or n/a for an empty group."""
    return f"{100.0 * np.mean([success(r) for r in group]):.0f} %" if group else "n/a"


def peaks(group: list) -> np.ndarray:
    return np.array([r["peak_linear_speed"] for r in group])


def spread(values: np.ndarray) -> str:
    """median · max, or n/a for no values."""
    return f"{np.median(values):.3g} · {values.max():.3g}" if len(values) else "n/a"


def table(rows: dict) -> None:
    print("| scheme | noise | wrap | n near | success | failures | peak ‖T‖ median · max (m/s) "
          "| path median · max (m) | 10° away: n · success · peak ‖T‖ median · max | max ratio |")
    print("|---|---|---|---:|---:|---|---:|---:|---:|---:|")
    for scheme in SCHEMES:
        for (noise, wrap), rs in rows.items():
            rs = [r for r in rs if r["scheme"] == scheme and r["outcome"] != "invalid_start"]
            off = np.array([abs(r["rz_deg"] - 180.0) for r in rs])
            near = [r for r, d in zip(rs, off) if d <= 5.0]
            away = [r for r, d in zip(rs, off) if 8.0 <= d <= 12.0]
            pk_near, pk_away = peaks(near), peaks(away)
            path = np.array([r["path_length"] for r in near])
            ratio = f"{pk_near.max() / pk_away.max():.2g}" if len(near) and len(away) else "n/a"
            print(f"| {scheme} | {noise:g} | {wrap.replace('_', '-')} | {len(near)} | {share(near)} | "
                  f"{failures(near)} | {spread(pk_near)} | {spread(path)} | "
                  f"{len(away)} · {share(away)} · {spread(pk_away)} | {ratio} |")


def figure(rows: dict, path: str) -> None:
    import matplotlib
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 4.6))
    axes = fig.subplots(1, 2, sharey=True)
    edges = np.arange(165.0, 195.01, 1.0)
    colours = dict(zip(SCHEMES, matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]))
    for ax, noise in zip(axes, NOISES):
        for wrap, style in zip(WRAPS, (":", "-")):
            for scheme in SCHEMES:
                rs = [r for r in rows[(noise, wrap)] if r["scheme"] == scheme and r["outcome"] != "invalid_start"]
                rz, pk = np.array([r["rz_deg"] for r in rs]), np.array([r["peak_linear_speed"] for r in rs])
                k = np.digitize(rz, edges) - 1
                top = [np.max(pk[k == b]) if np.any(k == b) else np.nan for b in range(len(edges) - 1)]
                ax.plot((edges[:-1] + edges[1:]) / 2, top, style, color=colours[scheme],
                        marker="x" if scheme == "automatic" else None, markersize=4,
                        label=f"{scheme}, {wrap.replace('_', '-')}")
        ax.set_yscale("log")
        ax.set_xlabel("start rotation about the optical axis (deg)")
        ax.set_title(f"noise {noise:g}" + (" (about 1 px)" if noise else ""))
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("largest peak ‖T‖ per 1° bin (m/s)")
    axes[1].legend(fontsize=7, ncol=2)
    fig.suptitle("Near the half-turn: per-point wrap (dotted) against the consistent wrap (solid); "
                 "automatic (x) = polar here")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


if __name__ == "__main__":
    rows = study(int(sys.argv[1]) if len(sys.argv) > 1 else 1500)
    table(rows)
    if len(sys.argv) > 2:
        figure(rows, sys.argv[2])
