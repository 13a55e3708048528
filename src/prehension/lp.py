"""HiGHS instances that print nothing: :func:`quiet_highs`, the one place prehension makes one.

HiGHS writes a banner ("Running HiGHS ... Copyright ...") to the process's standard
output when the first instance of a process is made, before any option can be set.
``prehension solve --json`` must print JSON only, so the first instance is made while
file descriptor 1 points to ``/dev/null`` (C's buffers flushed before and after), and
every instance gets ``output_flag`` off at once (no log on the console either).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import threading
from typing import Iterator

import highspy

__all__ = ["quiet_highs"]

_LOCK = threading.Lock()
_BANNER_SWALLOWED = [False]


def _flush_c_stdout() -> None:
    with contextlib.suppress(Exception):  # not every platform has a C library to flush
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def _stdout_to_devnull() -> Iterator[None]:
    """File descriptor 1 points to ``/dev/null`` inside the block (Python's and C's buffers flushed)."""
    with contextlib.suppress(Exception):  # a replaced sys.stdout may not flush
        sys.stdout.flush()
    _flush_c_stdout()
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        yield
    finally:
        _flush_c_stdout()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)


def quiet_highs() -> highspy.Highs:
    """A new :class:`highspy.Highs` with ``output_flag`` off; the process's first is made
    with standard output silenced, so its banner never reaches stdout."""
    with _LOCK:
        if not _BANNER_SWALLOWED[0]:
            with _stdout_to_devnull():
                h = highspy.Highs()
            _BANNER_SWALLOWED[0] = True
        else:
            h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    return h
