"""Dask plugins of prehension's local clusters (imported only when a cluster is made)."""

from __future__ import annotations

import signal
import threading

from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["IgnoreCtrlC"]


class IgnoreCtrlC(WorkerPlugin):
    """The worker process ignores Ctrl-C (SIGINT) and a hang-up (SIGHUP).

    A terminal sends Ctrl-C (and, when it closes, SIGHUP) to every process of the
    foreground group: without this, each worker process of a local cluster prints a
    traceback or dies while the command itself stops the run cleanly.  A plugin registered
    on the client is set up on every worker, also on those started later to replace a lost
    one.
    """

    name = "prehension-ignore-ctrl-c"

    def setup(self, worker) -> None:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            if hasattr(signal, "SIGHUP"):
                signal.signal(signal.SIGHUP, signal.SIG_IGN)
