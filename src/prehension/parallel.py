"""Running prehension on Dask distributed: a local cluster, or a running scheduler.

One option picks where work runs, for every command that runs much of it:

* ``scheduler="tcp://host:8786"``: a running Dask scheduler (``dask scheduler`` on one
  machine, ``dask worker tcp://host:8786`` on each of the others);
* else ``workers=N``: a :class:`distributed.LocalCluster` of ``N`` worker *processes* with
  one thread each (numba and numpy release the GIL only in parts, and every solver holds
  its state per process), ``N`` defaulting to the number of cores.

:func:`cluster` yields a :class:`distributed.Client`; :class:`DaskExecutor` wraps it as a
:class:`concurrent.futures.Executor` for code that takes one (the complete solver's box
search, the off-line sequence search); :func:`executor_for` does both for a command.
Dask distributed is imported here only, and only when a cluster is asked for.

Dask does the scheduling: work stealing, rescheduling the tasks of a lost worker
(``distributed.scheduler.allowed-failures`` deaths of one task before it gives up with
``KilledWorker``), and back-pressure is left to the caller (keep a bounded number of
futures in flight, see :mod:`prehension.batch`).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import threading
import time
from concurrent.futures import Executor
from typing import Iterator

from .errors import PrehensionError

__all__ = ["cluster", "DaskExecutor", "executor_for", "worker_count", "default_workers", "check_where"]

_CONNECT_TIMEOUT_S = 20


def _distributed():
    try:
        import distributed
    except ImportError:  # pragma: no cover - a declared dependency
        raise PrehensionError("running on a cluster needs Dask distributed: pip install 'dask[distributed]'") from None
    return distributed


def default_workers() -> int:
    """The cores this process may use (the default size of a local cluster)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def check_where(scheduler: str | None, workers: int | None) -> None:
    """Raise a :class:`PrehensionError` unless ``scheduler`` / ``workers`` make sense together."""
    if scheduler is not None and workers is not None:
        raise PrehensionError(
            "give either --scheduler (a running Dask cluster, whose workers are started with "
            "'dask worker') or --workers (a local cluster of N processes), not both"
        )
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise PrehensionError(f"--workers must be an integer >= 1, got {workers!r}")
    if scheduler is not None and not str(scheduler).strip():
        raise PrehensionError("--scheduler needs an address such as tcp://host:8786")


@contextlib.contextmanager
def cluster(scheduler: str | None = None, workers: int | None = None, *, dashboard: bool = False) -> Iterator:
    """A :class:`distributed.Client` on a running scheduler, or on a new local cluster.

    Args:
        scheduler: address of a running Dask scheduler (``tcp://host:8786``); the
            cluster's workers are whatever joined it.
        workers: size of the local cluster started when ``scheduler`` is ``None``
            (processes, one thread each; default: :func:`default_workers`).
        dashboard: Dask's dashboard on port 8787 (local cluster only; needs bokeh);
            else the scheduler's HTTP server takes a free port (several clusters at once).

    Raises:
        PrehensionError: both or bad arguments, or the scheduler cannot be reached.
    """
    check_where(scheduler, workers)
    distributed = _distributed()
    with _without_interrupted_sync_noise():
        if scheduler is not None:
            with _connect(distributed, str(scheduler).strip()) as client:
                yield client
            return
        from ._dask_plugins import IgnoreCtrlC, QuietLocalShutdown

        with _ctrl_c_ignored():  # the worker processes spawned now inherit it (see IgnoreCtrlC)
            local = distributed.LocalCluster(
                n_workers=workers or default_workers(), threads_per_worker=1, processes=True,
                dashboard_address=":8787" if dashboard else ":0", silence_logs=logging.ERROR,
            )  # fmt: skip
        with local, distributed.Client(local) as client:
            client.register_plugin(IgnoreCtrlC())  # and the workers started later, to replace a lost one
            client.register_plugin(QuietLocalShutdown())
            try:
                yield client
            except KeyboardInterrupt:  # Ctrl-C, SIGTERM, SIGHUP: the cluster is closed under the interrupt
                _quiet_interrupted_shutdown()
                raise


class _InterruptedSyncNoise(logging.Filter):
    """Drops the one error record distributed's ``sync`` leaves when a ``KeyboardInterrupt``
    (Ctrl-C, or SIGTERM/SIGHUP through :mod:`prehension.cli.terminate`) reaches the client
    while it waits: its ``cancel`` callback then reads a variable not yet assigned and
    tornado logs ``NameError ... 'future'`` with a traceback (seen with distributed
    2026.8).  The interrupt itself is handled (the batch keeps what finished); only that
    traceback, which says nothing to the user, is left out."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        if not isinstance(exc, NameError) or exc.__traceback__ is None:
            return True
        tb = exc.__traceback__
        while tb.tb_next is not None:
            tb = tb.tb_next
        code = tb.tb_frame.f_code
        return not (code.co_name == "cancel" and code.co_filename.replace("\\", "/").endswith("distributed/utils.py"))


@contextlib.contextmanager
def _without_interrupted_sync_noise():
    """:class:`_InterruptedSyncNoise` on tornado's application logger while inside."""
    logger, noise = logging.getLogger("tornado.application"), _InterruptedSyncNoise()
    logger.addFilter(noise)
    try:
        yield
    finally:
        logger.removeFilter(noise)


#: Seconds after an interrupt during which tornado's callback errors are dropped.
INTERRUPTED_SHUTDOWN_S = 30.0


class _QuietAfterInterrupt(logging.Filter):
    """Drops tornado's callback errors for :data:`INTERRUPTED_SHUTDOWN_S` after an interrupt
    reached a local cluster's client: its connections close under callbacks still pending
    in the IO loop's thread, which then log a closed comm or a cancelled future with a
    traceback -- during the cluster's closing or just after the command has returned (a
    race seen once in a run of ``tests/test_signals.py``).  The interrupt itself is handled
    (what finished is saved); those tracebacks say nothing to the user.  Afterwards the
    filter lets everything through (a program that catches the interrupt and goes on keeps
    tornado's errors)."""

    def __init__(self):
        super().__init__()
        self.until = 0.0

    def filter(self, record: logging.LogRecord) -> bool:
        return time.monotonic() >= self.until


_QUIET_AFTER_INTERRUPT = _QuietAfterInterrupt()


def _quiet_interrupted_shutdown() -> None:
    """Start (or extend) :class:`_QuietAfterInterrupt` on tornado's application logger."""
    logger = logging.getLogger("tornado.application")
    _QUIET_AFTER_INTERRUPT.until = time.monotonic() + INTERRUPTED_SHUTDOWN_S
    if _QUIET_AFTER_INTERRUPT not in logger.filters:
        logger.addFilter(_QUIET_AFTER_INTERRUPT)


@contextlib.contextmanager
def _ctrl_c_ignored():
    """Ignore Ctrl-C (SIGINT) and a hang-up (SIGHUP) in this process while a local cluster starts.

    An ignored signal stays ignored across ``exec``, and Python then installs no
    KeyboardInterrupt handler: the worker processes spawned meanwhile (and their helpers,
    such as multiprocessing's resource tracker) never print a traceback or die when a
    terminal sends Ctrl-C, or its hang-up, to the whole foreground group; the command
    stops them itself (see :mod:`prehension.cli.terminate`).  A Ctrl-C pressed during
    those seconds is lost (the command then takes the next one).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    quiet = [s for s in (signal.SIGINT, getattr(signal, "SIGHUP", None)) if s is not None]
    previous = {s: signal.signal(s, signal.SIG_IGN) for s in quiet}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _connect(distributed, address: str):
    try:
        return distributed.Client(address, timeout=f"{_CONNECT_TIMEOUT_S}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise PrehensionError(
            f"cannot reach the Dask scheduler at {address} ({exc}); start one with "
            "'dask scheduler' and its workers with 'dask worker tcp://HOST:8786', or drop --scheduler "
            "to run on a local cluster"
        ) from None


def worker_count(client) -> int:
    """Worker threads on the cluster now (at least 1, so that work can be queued before
    the workers of a remote cluster have joined)."""
    return max(1, sum(client.nthreads().values()))


class DaskExecutor(Executor):
    """``client.get_executor()`` with the standard ``shutdown`` signature and a worker count.

    Futures are :class:`concurrent.futures.Future` (``wait`` and ``as_completed`` from
    :mod:`concurrent.futures` work on them); calls are submitted with ``pure=False`` (no
    hashing of large arguments) and Dask retries ``retries`` times a call that raised.
    """

    def __init__(self, client, *, retries: int = 0):
        self.client = client
        self._inner = client.get_executor(pure=False, retries=retries)

    @property
    def max_workers(self) -> int:
        """Worker threads on the cluster now (see :func:`worker_count`)."""
        return worker_count(self.client)

    _max_workers = max_workers  # what ProcessPoolExecutor calls it

    def submit(self, fn, /, *args, **kwargs):
        return self._inner.submit(fn, *args, **kwargs)

    def map(self, fn, *iterables, timeout=None, chunksize=1):
        return self._inner.map(fn, *iterables, timeout=timeout)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._inner.shutdown(wait=wait and not cancel_futures)


@contextlib.contextmanager
def executor_for(scheduler: str | None, workers: int | None) -> Iterator[DaskExecutor | None]:
    """For a command that takes an Executor: ``None`` (run inline) when there is no
    scheduler and ``workers`` is ``None`` or 1, else a :class:`DaskExecutor` on
    :func:`cluster`; its ``max_workers`` says how many calls to keep in flight.

    Example (``prehension solve --scheduler``)::

        with executor_for(args.scheduler, args.workers) as ex:
            result = solve(task, SolveOptions(method="complete", executor=ex, workers=ex.max_workers if ex else 1))
    """
    check_where(scheduler, workers)
    if scheduler is None and (workers is None or workers == 1):
        yield None
        return
    with cluster(scheduler, workers) as client:
        ex = DaskExecutor(client)
        try:
            yield ex
        finally:
            ex.shutdown(cancel_futures=True)
