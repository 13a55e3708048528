"""The search's solving step in rounds: every undecided assignment gets its next block of
initial poses in turn, then the complete solver gets what no pose solved.

Round 1 tries the first ``B`` initial poses (:attr:`~.search.AssignmentOptions.round_poses`)
of every assignment, round 2 the next ``B``, each later round as many as all the rounds
before it (:func:`round_ranges`), of every assignment no earlier pose solved, a chunk at a time through the local solver's batch path
(:func:`.solving.local_round`); an assignment's answer is, bit for bit, the one it gets
alone from the first pose with its seed (the poses and draws of a wave do not depend on
the earlier waves: ``solve_local_batch(poses=...)``), so the feasible set does not depend
on the round size, the chunking nor the executor -- only *when* each is found does:
assignments solved by their first poses are found first, and a time limit leaves the
others undecided with "k of N initial poses tried".

:class:`Driver` runs the calls, here or on an executor, at most ``slots`` at a time:
local calls first (the survivors of a round are gathered by round into chunks again),
complete-solver calls when no local work waits.  Past the deadline, what no call
finished is undecided.
"""

from __future__ import annotations

import time
from collections import deque
from concurrent.futures import FIRST_COMPLETED, Future, wait
from typing import Callable

__all__ = ["round_ranges", "Driver"]


def round_ranges(i_max: int, round_poses: int | None) -> list[tuple[int, int] | None]:
    """The pose ranges of the rounds: ``B`` poses, ``B`` more, then twice as many as all
    the rounds before (``(0, 8), (8, 16), (16, 32), (32, 64)`` for ``B = 8`` and 64 poses:
    the first poses of every assignment early, and few rounds -- each costs a call per
    chunk --), up to ``i_max``; ``[None]`` (one round, every pose) without
    ``round_poses`` or when it covers them all."""
    if not round_poses or round_poses >= i_max:
        return [None]
    out, start = [], 0
    while start < i_max:
        stop = min(start + max(round_poses, start), i_max)
        out.append((start, stop))
        start = stop
    return out


class Driver:
    """Runs calls ``(key, function, args)`` -- ``done(key, answer)`` gets each answer, and
    may queue more with :meth:`local` / :meth:`later` / :meth:`gather` -- here (one at a
    time) or on ``executor`` (``slots`` at a time), until nothing is left or ``deadline``
    (a :func:`time.time` instant; ``None``: none) passes; then ``out_of_time(items)``
    gets the items of every call not finished (a key is a list of items)."""

    def __init__(self, executor, deadline: float | None, slots: int, out_of_time: Callable[[list], None]):
        self.executor, self.deadline, self.slots, self.out_of_time = executor, deadline, max(1, slots), out_of_time
        self._local: deque = deque()
        self._later: deque = deque()
        self._gathered: dict[int, list] = {}  # round -> items waiting to be chunked
        self._chunk: Callable[[int, list], tuple] | None = None
        self._size = 1

    def local(self, call: tuple, done: Callable) -> None:
        """Queue a call of the local solver (run before any :meth:`later` one)."""
        self._local.append((call, done))

    def later(self, call: tuple, done: Callable) -> None:
        """Queue a call run when no local call waits (the complete solver's)."""
        self._later.append((call, done))

    def chunking(self, size: int, make: Callable[[int, list], tuple], done: Callable) -> None:
        """How :meth:`gather`-ed items become calls: chunks of ``size``, ``make(round, items)``."""
        self._size, self._chunk, self._chunk_done = max(1, size), make, done

    def gather(self, round_: int, items: list) -> None:
        """Items for round ``round_``: queued as full chunks as they gather; a partial
        chunk when no local call waits."""
        pool = self._gathered.setdefault(round_, [])
        pool.extend(items)
        while len(pool) >= self._size:
            self.local(self._chunk(round_, pool[: self._size]), self._chunk_done)
            del pool[: self._size]

    def _next(self):
        if not self._local:
            for round_ in sorted(self._gathered):
                pool = self._gathered.pop(round_)
                if pool:
                    self.local(self._chunk(round_, pool), self._chunk_done)
                    break
        if self._local:
            return self._local.popleft()
        return self._later.popleft() if self._later else None

    def _late(self) -> bool:
        return self.deadline is not None and time.time() >= self.deadline

    def _submit(self, call) -> Future:
        key, function, args = call
        if self.executor is not None:
            return self.executor.submit(function, *args)
        future: Future = Future()
        future.set_result(function(*args))
        return future

    def run(self) -> bool:
        """Run until nothing is left (``True``) or the deadline passes (``False``: the
        items of every call not finished went to ``out_of_time``)."""
        pending: dict = {}
        try:
            while True:
                while len(pending) < self.slots and not self._late():
                    item = self._next()
                    if item is None:
                        break
                    (key, _, _), done = item
                    pending[self._submit(item[0])] = (key, done)
                if not pending:
                    if self._late() and self._left():
                        return self._stop(pending)
                    return True
                timeout = None if self.deadline is None else max(0.0, self.deadline - time.time())
                finished, _ = wait(list(pending), timeout=timeout, return_when=FIRST_COMPLETED)
                if not finished:
                    return self._stop(pending)
                for future in finished:
                    key, done = pending.pop(future)
                    done(key, future.result())
        finally:
            for future in pending:
                future.cancel()

    def _left(self) -> bool:
        return bool(self._local or self._later or any(self._gathered.values()))

    def _stop(self, pending: dict) -> bool:
        items = [i for key, _ in pending.values() for i in key]
        items += [i for (key, _, _), _ in (*self._local, *self._later) for i in key]
        items += [i for pool in self._gathered.values() for i in pool]
        self._local.clear(), self._later.clear(), self._gathered.clear()
        self.out_of_time(items)
        return False
