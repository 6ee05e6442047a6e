"""Per-frame timing of the servo loop: capture-to-command latency, the loop's own overhead, late and
dropped frames; summarised at the end of a run (printed and written as the log's last line)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List

import numpy as np

__all__ = ["Timing"]


def _percentiles(xs: List[float]) -> Dict[str, float]:
    if not xs:
        return {"p50": float("nan"), "p99": float("nan"), "max": float("nan")}
    a = np.asarray(xs, dtype=np.float64)
    return {"p50": float(np.percentile(a, 50)), "p99": float(np.percentile(a, 99)), "max": float(a.max())}


@dataclass
class Timing:
    """The loop's timing, frame by frame.

    latency   seconds from a frame's capture (its stamp) to its command (sent or, dry run, computed), on
              the loop's clock
    overhead  seconds of the loop's own work per frame (tracker, servo, joint mapping, the driver call
              and logging; the source's read excluded), on the host's perf_counter
    late      frames whose latency exceeded the `late` threshold (seconds)
    dropped   frames the source skipped (gaps in the frame indices)
    missed    reads that returned no frame within one period (the watchdog's count)
    """

    late_threshold: float
    latency: List[float] = field(default_factory=list)
    overhead: List[float] = field(default_factory=list)
    late: int = 0
    dropped: int = 0
    missed: int = 0

    def frame(self, latency: float, overhead: float) -> bool:
        """Count one frame; True when it was late."""
        self.latency.append(latency)
        self.overhead.append(overhead)
        late = latency > self.late_threshold
        self.late += late
        return late

    def summary(self) -> Dict[str, object]:
        """{frames, late, dropped, missed, latency_ms {p50, p99, max}, overhead_ms {p50, p99, max}}."""
        ms = lambda d: {k: round(v * 1e3, 4) for k, v in d.items()}  # noqa: E731
        return {"frames": len(self.latency), "late": self.late, "dropped": self.dropped, "missed": self.missed,
                "late_threshold_ms": round(self.late_threshold * 1e3, 4),
                "latency_ms": ms(_percentiles(self.latency)), "overhead_ms": ms(_percentiles(self.overhead))}

    def text(self) -> str:
        """The summary as two lines for the terminal."""
        s = self.summary()
        lat, ovh = s["latency_ms"], s["overhead_ms"]
        return (f"frames {s['frames']}, late {s['late']} (> {s['late_threshold_ms']:g} ms), dropped "
                f"{s['dropped']}, missed reads {s['missed']}\n"
                f"capture-to-command latency p50 {lat['p50']:.2f} ms, p99 {lat['p99']:.2f} ms, max {lat['max']:.2f} ms;"
                f" loop overhead p50 {ovh['p50']:.3f} ms, p99 {ovh['p99']:.3f} ms")
