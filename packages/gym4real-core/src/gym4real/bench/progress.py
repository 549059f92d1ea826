"""Progress of a long run: a bar on a terminal, a line at every tenth in a log, and the run's notices.

A bar redraws itself many times a second, which a terminal overwrites but a log file (CI, ``nohup``, ``| tee``)
keeps as thousands of lines: when the stream is not a terminal, :class:`ProgressDisplay` prints one line per tenth of
the work instead (``label: 40/130 episodes (31 %, 12 s)``; one per half minute when the total is not known),
and no estimate of the time left. The bar is
tqdm's (the ``bench`` extra); without it a terminal gets the lines too.

While a progress display is open, what the running code announces on the :data:`NOTICES` logger (a planner
about to plan for minutes, say) is printed above it, one line each.
"""

from __future__ import annotations

import logging
import sys
import time
from typing import Any, TextIO

#: The logger of what a long run announces while it runs (shown by an open :class:`ProgressDisplay`).
NOTICES = logging.getLogger("gym4real.notices")
NOTICES.setLevel(logging.INFO)
#: Seconds between two lines of a run whose total is not known (on a stream that is not a terminal).
UNKNOWN_TOTAL_EVERY = 30


class _Relay(logging.Handler):
    """Print each notice through a progress display (above its bar)."""

    def __init__(self, progress: ProgressDisplay) -> None:
        super().__init__(logging.INFO)
        self.progress = progress

    def emit(self, record: logging.LogRecord) -> None:
        self.progress.write(record.getMessage())


def _is_terminal(stream: TextIO) -> bool:
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


class ProgressDisplay:
    """Progress of ``total`` units of work (episodes, steps, runs), told to a person.

    Args:
        label: What is running (``gym4real/dam-v0``), the head of every line.
        total: How many units in all (None until :meth:`update` says).
        unit: The unit's name (``episode``).
        eta: Show tqdm's estimate of the time left (False where units differ in cost, as a planner's episodes).
        stream: Where to write (standard error).
        bar_format: tqdm's format of the bar (its default when None).
    """

    def __init__(
        self,
        label: str,
        total: float | None = None,
        unit: str = "",
        *,
        eta: bool = True,
        stream: TextIO | None = None,
        bar_format: str | None = None,
    ) -> None:
        self.label = label
        self.total = total
        self.unit = unit
        self.done = 0.0
        self.stream = stream if stream is not None else sys.stderr
        self.start = time.perf_counter()
        self.shown = -1  # the last tenth (or half minute) printed as a line: the first update prints one
        self.bar: Any = None
        if _is_terminal(self.stream):
            try:
                from tqdm.auto import tqdm
            except ImportError:  # no bench extra: lines on a terminal too
                tqdm = None
            if tqdm is not None:
                if bar_format is None and not eta:
                    bar_format = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} {unit} [{elapsed}]"
                self.bar = tqdm(total=total, desc=label, unit=unit or "it", file=self.stream, bar_format=bar_format)
        self._relay = _Relay(self)
        NOTICES.addHandler(self._relay)

    def update(self, done: float, total: float | None = None) -> None:
        """``done`` units of ``total`` (the total so far when None) are done."""
        if total is not None:
            self.total = total
        self.done = done
        if self.bar is not None:
            if total is not None:
                self.bar.total = total
            self.bar.update(done - self.bar.n)
            return
        elapsed = time.perf_counter() - self.start
        # a line per tenth of the total; without a total, a line per UNKNOWN_TOTAL_EVERY seconds
        mark = int(done * 10 // self.total) if self.total else int(elapsed // UNKNOWN_TOTAL_EVERY)
        if mark > self.shown:
            self.shown = mark
            of = f"/{self.total:g}" if self.total else ""
            share = f"{100 * done / self.total:.0f} %, " if self.total else ""
            unit = f" {self.unit}" if self.unit else ""
            self.write(f"{self.label}: {done:g}{of}{unit} ({share}{elapsed:.0f} s)")

    def advance(self, n: float = 1) -> None:
        """``n`` more units are done."""
        self.update(self.done + n)

    def describe(self, label: str) -> None:
        """Name what is running now (the bar's description; the head of the next lines)."""
        self.label = label
        if self.bar is not None:
            self.bar.set_description(label, refresh=False)

    def write(self, message: str) -> None:
        """Print a line (above the bar on a terminal)."""
        if self.bar is not None:
            self.bar.write(message, file=self.stream)
        else:
            print(message, file=self.stream, flush=True)

    def close(self) -> None:
        """Close the bar and stop relaying notices."""
        NOTICES.removeHandler(self._relay)
        if self.bar is not None:
            self.bar.close()
