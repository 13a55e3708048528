"""Progress of a long command, visible wherever its output goes.

On a terminal: one live line (rich), redrawn in place.  Otherwise (output piped or
redirected to a log): a plain line on stderr every ``interval`` seconds -- also while one
step takes long -- and the same line to the ``prehension`` logger, so that a run in a
batch system's log is never silent.  ``--quiet`` turns both off.
"""

from __future__ import annotations

import logging
import sys
import threading
import time

from rich.console import Console
from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

__all__ = ["LiveProgress", "describe"]

LOG = logging.getLogger("prehension")


def describe(info: dict, started: float, time_limit_s: float | None) -> str:
    """One line: the stage, its counters, the elapsed time and how long it may still take."""
    info = dict(info)
    stage = info.pop("stage", "solving")
    text = "  ".join(f"{k} {v}" for k, v in info.items())
    elapsed = time.perf_counter() - started
    eta = f"; stops within {max(time_limit_s - elapsed, 0):.0f} s (time limit)" if time_limit_s else ""
    return f"{stage}: {text}{eta}" if text else f"{stage}{eta}"


class LiveProgress:
    """A context manager yielding ``update(info: dict)`` (or ``None`` when disabled).

    Args:
        console: where the live line goes on a terminal.
        enabled: ``False`` for ``--quiet``.
        interval: seconds between plain lines when not on a terminal.
        time_limit_s: shown as "stops within N s" (an upper bound of the time left).
        stream: where plain lines go (default: stderr).
    """

    def __init__(self, console: Console, *, enabled: bool = True, interval: float = 5.0,
                 time_limit_s: float | None = None, stream=None):  # fmt: skip
        self.enabled = enabled
        self.live = enabled and console.is_terminal
        self.console = console
        self.interval = interval
        self.time_limit_s = time_limit_s
        self.stream = stream if stream is not None else sys.stderr
        self.info: dict = {"stage": "starting"}
        self.started = time.perf_counter()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._bar: Progress | None = None

    def __enter__(self):
        if not self.enabled:
            return None
        self.started = time.perf_counter()
        if self.live:
            self._bar = Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                                 console=self.console, transient=True)  # fmt: skip
            self._bar.__enter__()
            self._id = self._bar.add_task("starting", total=None)
        else:
            self._thread = threading.Thread(target=self._tick, name="prehension-progress", daemon=True)
            self._thread.start()
        return self.update

    def update(self, info: dict) -> None:
        self.info = dict(info) if "stage" in info else {**{"stage": self.info.get("stage", "solving")}, **info}
        if self._bar is not None:
            self._bar.update(self._id, description=describe(self.info, self.started, self.time_limit_s))

    def line(self) -> str:
        """The plain line now: ``[elapsed s] stage: counters``."""
        return f"[{time.perf_counter() - self.started:7.1f} s] {describe(self.info, self.started, self.time_limit_s)}"

    def _tick(self) -> None:
        while not self._stop.wait(self.interval):
            text = self.line()
            LOG.info(text)
            print(text, file=self.stream, flush=True)

    def __exit__(self, *exc):
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self._bar is not None:
            self._bar.__exit__(*exc)
        return False
