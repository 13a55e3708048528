"""The local cluster's worker plugins: what they silence, and only that."""

import logging

import pytest

pytest.importorskip("distributed")

from prehension._dask_plugins import QuietLocalShutdown  # noqa: E402


def _record(msg: str) -> logging.LogRecord:
    return logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, msg, (), None)


def test_a_local_worker_drops_only_the_heartbeat_to_a_gone_scheduler():
    logger = logging.getLogger("distributed.worker")
    before = list(logger.filters)
    try:
        QuietLocalShutdown().setup(worker=None)
        QuietLocalShutdown().setup(worker=None)  # a worker restarted in the same process: one filter
        added = [f for f in logger.filters if f not in before]
        assert len(added) == 1
        assert not logger.filter(_record("Failed to communicate with scheduler during heartbeat."))
        assert logger.filter(_record("Unexpected exception during heartbeat. Closing worker."))
        assert logger.filter(_record("Compute Failed"))
    finally:
        logger.filters[:] = before
