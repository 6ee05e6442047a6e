"""The sweep's progress on stderr (tqdm when installed, else a line of its own), counted in episodes as
the user asks for them: an episode is one start set-up, run with every scheme (one CSV row per scheme),
and is done when all its rows are."""

from __future__ import annotations

import sys
import time
from collections import Counter
from typing import Iterable

# Nothing public: the progress line of a sweep, used inside ibvs only.
__all__: list[str] = []


def count(episodes: int, schemes: int, rows: int, complete: int) -> str:
    """"N of E episodes (M of R rows: K schemes each)": complete episodes of `episodes`, rows of
    episodes * schemes."""
    each = f"{schemes} scheme{'s' if schemes != 1 else ''} each"
    return f"{complete} of {episodes} episodes ({rows} of {episodes * schemes} rows: {each})"


def tally(indices: Iterable[int], schemes: int) -> tuple[int, int]:
    """(rows, complete episodes) of the episode indices of some rows (one index per row)."""
    per = Counter(indices)
    return sum(per.values()), sum(1 for n in per.values() if n >= schemes)


class Progress:
    """Episodes done of `episodes` (each `schemes` rows), with the rows, rate and time left;
    disabled = silent. done: the episode index of every row already in the file."""

    def __init__(self, episodes: int, schemes: int, done: Iterable[int], enabled: bool, stream=None):
        self.episodes, self.schemes = episodes, max(1, schemes)
        self.per = Counter(done)
        self.rows = sum(self.per.values())
        self.complete = sum(1 for n in self.per.values() if n >= self.schemes)
        self.enabled = enabled and episodes > 0
        self.stream = stream or sys.stderr
        self.t0 = time.perf_counter()
        self.start = self.complete
        self.last = 0.0
        self.bar = None
        if self.enabled:
            try:
                from tqdm import tqdm  # optional

                self.bar = tqdm(total=episodes, initial=self.complete, unit="ep", file=self.stream, desc="sweep")
                self.bar.set_postfix_str(self._rows(), refresh=False)
            except ImportError:
                pass

    def _rows(self) -> str:
        return f"{self.rows} of {self.episodes * self.schemes} rows: {self.schemes} schemes each"

    def update(self, indices: Iterable[int]) -> None:
        """Rows finished, given by their episode indices."""
        before = self.complete
        for i in indices:
            self.rows += 1
            self.per[i] += 1
            if self.per[i] == self.schemes:
                self.complete += 1
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.set_postfix_str(self._rows(), refresh=False)
            self.bar.update(self.complete - before)
            return
        now = time.perf_counter()
        if now - self.last < 0.2 and self.complete < self.episodes:
            return
        self.last = now
        rate = (self.complete - self.start) / max(now - self.t0, 1e-9)
        eta = f"eta {(self.episodes - self.complete) / rate:.0f} s" if rate > 0 else "eta n/a (no episode done yet)"
        width = 30
        fill = int(width * self.complete / self.episodes)
        print(f"\rsweep [{'#' * fill}{'.' * (width - fill)}] "
              f"{count(self.episodes, self.schemes, self.rows, self.complete)}  {rate:.0f} ep/s  {eta} ",
              end="", file=self.stream, flush=True)

    def close(self) -> None:
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.close()
        else:
            print(file=self.stream, flush=True)
