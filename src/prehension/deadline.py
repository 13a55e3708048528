"""Deadlines: every loop that samples, searches or retries stops at one.

A deadline is an instant on :func:`time.perf_counter`'s clock (``None``: none).  Work that
reaches it raises :class:`TimeLimitReached`, which is not an error of the input: the
caller turns it into a ``gave_up`` answer that says the time limit stopped it.  Searches
whose partial answer is still valid (a looser proven bound, a box shrunk less) stop at
the deadline and return it instead.

Most work takes its deadline as an argument.  Deep helpers that a pure, cached function
calls (the hand's span bounds, computed while the complete solver builds its system)
read the one of the enclosing :func:`scope` through :func:`current_deadline`, so that the
functions in between need not carry it; a scope does not reach other processes.
"""

from __future__ import annotations

import contextlib
import contextvars
import time
from typing import Iterator

__all__ = ["TimeLimitReached", "deadline_after", "seconds_left", "check_deadline", "passed", "scope", "current_deadline"]

_CURRENT: contextvars.ContextVar[float | None] = contextvars.ContextVar("prehension_deadline", default=None)


class TimeLimitReached(Exception):
    """A time limit ran out before the work was done (``what`` says which work)."""

    def __init__(self, what: str):
        super().__init__(what)  # args == (what,): pickles across processes as it is
        self.what = what

    def __str__(self) -> str:
        return f"time limit reached: {self.what}"


def deadline_after(seconds: float | None, started: float | None = None) -> float | None:
    """The instant ``seconds`` after ``started`` (default: now); ``None`` for no limit."""
    if seconds is None:
        return None
    return (time.perf_counter() if started is None else started) + float(seconds)


def seconds_left(deadline: float | None) -> float | None:
    """Seconds until ``deadline`` (negative once past it); ``None`` for no deadline."""
    return None if deadline is None else deadline - time.perf_counter()


def check_deadline(deadline: float | None, what: str) -> None:
    """Raise :class:`TimeLimitReached` (naming ``what``) once ``deadline`` has passed."""
    if passed(deadline):
        raise TimeLimitReached(what)


def passed(deadline: float | None) -> bool:
    """Whether ``deadline`` has passed (never, for ``None``)."""
    return deadline is not None and time.perf_counter() >= deadline


@contextlib.contextmanager
def scope(deadline: float | None) -> Iterator[None]:
    """Make ``deadline`` the :func:`current_deadline` inside the block (the earlier of it
    and an enclosing scope's)."""
    outer = _CURRENT.get()
    inner = deadline if outer is None else outer if deadline is None else min(outer, deadline)
    token = _CURRENT.set(inner)
    try:
        yield
    finally:
        _CURRENT.reset(token)


def current_deadline() -> float | None:
    """The deadline of the innermost :func:`scope` (``None`` outside any)."""
    return _CURRENT.get()
