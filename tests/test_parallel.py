"""prehension.parallel: where work runs (the cluster itself is exercised in test_batch.py)."""

from __future__ import annotations

import pytest

from prehension.errors import PrehensionError
from prehension.parallel import check_where, cluster, default_workers, executor_for


def test_scheduler_and_workers_exclude_each_other():
    with pytest.raises(PrehensionError, match="either --scheduler .* or --workers"):
        check_where("tcp://head:8786", 2)
    with pytest.raises(PrehensionError, match="--workers must be an integer >= 1"):
        check_where(None, 0)
    with pytest.raises(PrehensionError, match="--scheduler needs an address"):
        check_where(" ", None)
    check_where(None, None)
    assert default_workers() >= 1


def test_one_worker_runs_inline():
    for workers in (None, 1):
        with executor_for(None, workers) as executor:
            assert executor is None


def test_an_unreachable_scheduler_is_bad_input():
    with pytest.raises(PrehensionError, match="cannot reach the Dask scheduler at foo:bar"):
        with cluster("foo:bar"):
            pass


def test_importing_prehension_does_not_import_dask():
    import subprocess
    import sys

    code = "import sys, prehension, prehension.batch, prehension.parallel, prehension.cli; print('distributed' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "False"


def test_the_interrupted_sync_noise_and_only_it_is_dropped():
    """distributed's ``sync`` cancel callback failing after a KeyboardInterrupt (a NameError
    raised in ``cancel`` of distributed/utils.py) is dropped; any other error record is kept."""
    import logging
    import sys

    from prehension.parallel import _InterruptedSyncNoise

    def record_of(filename: str, name: str, error: type) -> logging.LogRecord:
        namespace: dict = {}
        exec(compile(f"def {name}():\n    raise {error.__name__}('x')\n", filename, "exec"), namespace)
        try:
            namespace[name]()
        except Exception:  # noqa: BLE001 - the record carries it
            return logging.LogRecord("tornado.application", logging.ERROR, filename, 1, "callback", None, sys.exc_info())

    noise = _InterruptedSyncNoise()
    assert not noise.filter(record_of("/x/site-packages/distributed/utils.py", "cancel", NameError))
    assert noise.filter(record_of("/x/site-packages/distributed/utils.py", "cancel", ValueError))
    assert noise.filter(record_of("/x/site-packages/distributed/utils.py", "other", NameError))
    assert noise.filter(record_of("/x/mycode.py", "cancel", NameError))
    assert noise.filter(logging.LogRecord("tornado.application", logging.ERROR, "f", 1, "no exception", None, None))


def test_after_an_interrupt_tornados_callback_errors_are_dropped_for_a_while(monkeypatch):
    """An interrupt through a local cluster's client starts a bounded quiet period on
    tornado's application logger (late callback tracebacks of the closing cluster); before
    and after it, records pass."""
    import logging

    from prehension import parallel

    quiet = parallel._QuietAfterInterrupt()
    record = logging.LogRecord("tornado.application", logging.ERROR, "f", 1, "callback", None, None)
    assert quiet.filter(record)  # no interrupt yet
    clock = [100.0]
    monkeypatch.setattr(parallel.time, "monotonic", lambda: clock[0])
    monkeypatch.setattr(parallel, "_QUIET_AFTER_INTERRUPT", quiet)
    logger = logging.getLogger("tornado.application")
    try:
        parallel._quiet_interrupted_shutdown()
        assert quiet in logger.filters and not quiet.filter(record)
        clock[0] += parallel.INTERRUPTED_SHUTDOWN_S
        assert quiet.filter(record)  # the quiet period is over
    finally:
        logger.removeFilter(quiet)
