"""The sweep's progress bar on stderr (tqdm when installed, else a line of its own)."""

from __future__ import annotations

import sys
import time


class Progress:
    """Episodes done of total, with rate and time left; disabled = silent."""

    def __init__(self, total: int, done: int, enabled: bool, stream=None):
        self.total, self.done, self.enabled = total, done, enabled and total > 0
        self.stream = stream or sys.stderr
        self.t0 = time.perf_counter()
        self.start = done
        self.last = 0.0
        self.bar = None
        if self.enabled:
            try:
                from tqdm import tqdm  # optional

                self.bar = tqdm(total=total, initial=done, unit="ep", file=self.stream, desc="sweep")
            except ImportError:
                pass

    def update(self, n: int) -> None:
        self.done += n
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(n)
            return
        now = time.perf_counter()
        if now - self.last < 0.2 and self.done < self.total:
            return
        self.last = now
        rate = (self.done - self.start) / max(now - self.t0, 1e-9)
        eta = (self.total - self.done) / rate if rate > 0 else float("inf")
        width = 30
        fill = int(width * self.done / self.total)
        print(f"\rsweep [{'#' * fill}{'.' * (width - fill)}] {self.done}/{self.total} episodes"
              f"  {rate:.0f} ep/s  eta {eta:.0f} s ", end="", file=self.stream, flush=True)

    def close(self) -> None:
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.close()
        else:
            print(file=self.stream, flush=True)
