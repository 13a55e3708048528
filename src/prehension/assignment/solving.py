"""Solving the concrete tasks of many assignments: the local solver's batch path on all of
them, then the complete solver on each one the local solver left undecided.

**Local, a chunk at a time** (:func:`solve_local_chunk`): a chunk of tasks (one hand) goes
to :func:`~prehension.solvers.local.solve_local_batch` in one call, each task with its own
seed: its answer is, bit for bit, the one :func:`prehension.solve.solve` gives it alone
with that seed (the batch changes nothing but speed; see :mod:`prehension.batch.solving`).
Every answer is re-verified by the residual function
(:meth:`~prehension.solvers.local.LocalRecord.to_result`).

**Complete, one at a time** (:func:`complete_one`): a task the local solver did not solve
goes to :func:`prehension.solve.complete_after_local` -- the one ``auto`` policy -- with
``complete_time_s`` for the complete solver (less when the search's deadline is nearer):
it ends solved, proven infeasible, or gave up (undecided).

:func:`solve_alone` is both steps for one task by itself, through :func:`prehension.solve.solve`:
what the agreement test compares the search with.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Sequence

from ..results import SolveResult, Status
from ..solve import SolveOptions, complete_after_local, solve
from ..tasks.model import Task

__all__ = ["solve_local_chunk", "complete_one", "solve_alone", "DEADLINE_NOTE"]

DEADLINE_NOTE = "the search's time limit was reached before the complete solver could run on it"


def _complete_options(options, seed: int, local_seconds: float, seconds: float) -> SolveOptions:
    """``auto``'s options for the complete step: ``seconds`` of it after ``local_seconds`` of local solving."""
    return SolveOptions(method="auto", seed=seed, time_limit_s=local_seconds + seconds, local_options=options.local_options)


def solve_alone(task: Task, seed: int, options) -> SolveResult:
    """One assignment's task solved by itself: :func:`prehension.solve.solve` with the
    local solver, then ``complete_time_s`` of the complete solver when it found nothing."""
    local = solve(task, SolveOptions(method="local", seed=seed, local_options=options.local_options))
    if local.success or options.complete_time_s <= 0:
        return local
    return complete_after_local(task, local, _complete_options(options, seed, local.seconds, options.complete_time_s))


def solve_local_chunk(tasks: Sequence[Task], seeds: Sequence[int], options, deadline: float | None = None) -> list[SolveResult]:
    """The local solver's verified answer for every task of ``tasks`` (one hand), each
    with its seed, in one call of the batch path; ``seconds`` is each task's share.  The
    call stops at ``deadline`` (a :func:`time.time` instant; ``None``: none): the tasks it
    did not finish give up, saying so."""
    from ..solvers.local import LocalOptions, solve_local_batch

    if not tasks:
        return []
    local_options = options.local_options or LocalOptions()
    if deadline is not None:
        left = max(deadline - time.time(), 1e-3)
        if local_options.time_limit_s is None or local_options.time_limit_s > left:
            local_options = replace(local_options, time_limit_s=left)
    started = time.perf_counter()
    batch = solve_local_batch(list(tasks), local_options, None, list(seeds))
    share = (time.perf_counter() - started) / len(tasks)
    return [record.to_result(task, local_options, share) for task, record in zip(tasks, batch)]


def complete_one(task: Task, local: SolveResult, seed: int, options, deadline: float | None = None) -> SolveResult:
    """``auto`` after the local answer ``local``: the complete solver for ``complete_time_s``
    at most, and not past ``deadline`` (a :func:`time.time` instant, the same on every
    worker of a machine; ``None``: none).  No time left: ``local``, saying so."""
    seconds = options.complete_time_s
    if deadline is not None:
        seconds = min(seconds, math.floor((deadline - time.time()) * 100) / 100)
    if seconds <= 0:
        return SolveResult(task, local.method, Status.GAVE_UP, f"{local.message}; {DEADLINE_NOTE}", (), local.seconds, local.stats)
    return complete_after_local(task, local, _complete_options(options, seed, local.seconds, seconds))
