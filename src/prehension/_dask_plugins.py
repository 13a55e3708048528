"""Dask plugins of prehension's local clusters (imported only when a cluster is made)."""

from __future__ import annotations

import logging
import signal
import threading

from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["IgnoreCtrlC", "QuietLocalShutdown"]


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


class _SchedulerGone(logging.Filter):
    """Drops the worker's "Failed to communicate with scheduler during heartbeat" record."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith("Failed to communicate with scheduler during heartbeat")


class QuietLocalShutdown(WorkerPlugin):
    """A worker of a *local* cluster says nothing when its scheduler is gone.

    The scheduler of a local cluster lives in the command's own process: when the command
    stops (SIGTERM, Ctrl-C, the end of a run), a worker whose heartbeat falls between the
    scheduler's closing and its own logs "Failed to communicate with scheduler during
    heartbeat" with a traceback -- nothing a user can act on, printed to their terminal.
    Registered only on the local clusters :func:`prehension.parallel.cluster` starts (a
    worker of a running scheduler keeps every message: there it can mean a lost network).
    """

    name = "prehension-quiet-local-shutdown"

    def setup(self, worker) -> None:
        logger = logging.getLogger("distributed.worker")
        if not any(isinstance(f, _SchedulerGone) for f in logger.filters):
            logger.addFilter(_SchedulerGone())
