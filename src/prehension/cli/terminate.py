"""SIGTERM and SIGHUP stop a command as Ctrl-C does: what Ctrl-C saves, they save.

Ctrl-C raises ``KeyboardInterrupt`` in the main thread, and every command that keeps work
handles it: the complete search writes its checkpoint and a partial result, a batch writes
the chunks it finished and leaves a journal that resumes.  ``kill`` (SIGTERM: a job
scheduler's time limit, ``systemctl stop``, a container's stop) and a closed terminal or
ssh session (SIGHUP) would otherwise end the process at once and lose all of it.  Inside
:func:`termination_as_interrupt` either signal raises :class:`Terminated`, a
``KeyboardInterrupt``, so the same code saves the same things (atomically, as for Ctrl-C).

Choices, so that the signals keep their meaning:

* a **second** SIGTERM or SIGHUP ends the process at once (the default action is restored
  when the first arrives): whoever sends it does not want the saving to finish;
* a signal **ignored** when the command starts stays ignored (``nohup prehension ...``
  keeps running after the terminal closes, as ``nohup`` promises);
* only the main thread can install handlers: elsewhere (a command run from a worker
  thread) nothing changes.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Iterator

__all__ = ["Terminated", "termination_as_interrupt", "SIGNALS"]

SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, delivered as Ctrl-C is; ``str()`` is the signal's name."""

    def __init__(self, signum: int):
        self.signum = signum
        super().__init__(signal.Signals(signum).name)


def _raise(signum, frame) -> None:
    for s in SIGNALS:
        signal.signal(s, signal.SIG_DFL)  # a second one ends the process at once
    raise Terminated(signum)


@contextlib.contextmanager
def termination_as_interrupt() -> Iterator[None]:
    """SIGTERM and SIGHUP raise :class:`Terminated` while inside (see the module docstring)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in SIGNALS}
    for s, handler in previous.items():
        if handler is not signal.SIG_IGN:
            signal.signal(s, _raise)
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)
