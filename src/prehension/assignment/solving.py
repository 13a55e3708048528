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

import hashlib
import math
import pickle
import time
from collections import OrderedDict
from dataclasses import replace
from typing import NamedTuple, Sequence

from ..results import SolveResult, Status
from ..solve import SolveOptions, complete_after_local, solve
from ..tasks.model import Task
from ..tasks.open_task import Assignment, OpenTask, concrete_task

__all__ = ["solve_local_chunk", "local_round", "complete_one", "solve_alone", "DEADLINE_NOTE", "Shipped", "ship", "local_job", "complete_job"]

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
    return [result for result, _ in local_round(tasks, seeds, options, deadline)]


def local_round(tasks: Sequence[Task], seeds: Sequence[int], options, deadline: float | None = None,
                poses: tuple[int, int] | None = None, earlier: Sequence | None = None) -> list[tuple]:  # fmt: skip
    """:func:`solve_local_chunk` over the initial poses ``poses = (start, stop)`` only
    (``None``: all), each task's ``(result, record)``.  ``earlier`` holds each task's
    :class:`~prehension.solvers.local.LocalRecord` of the poses before ``start`` (``None``:
    none): the answer is, bit for bit, the one a call over every pose from the first
    gives, and the record the two merged
    (:meth:`~prehension.solvers.local.LocalRecord.followed_by`; without its verified
    solution: pass it on as ``earlier`` to the next round)."""
    from ..solvers.local import LocalOptions, solve_local_batch

    if not tasks:
        return []
    local_options = options.local_options or LocalOptions()
    if deadline is not None:
        left = max(deadline - time.time(), 1e-3)
        if local_options.time_limit_s is None or local_options.time_limit_s > left:
            local_options = replace(local_options, time_limit_s=left)
    started = time.perf_counter()
    batch = solve_local_batch(list(tasks), local_options, None, list(seeds), poses=poses)
    share = (time.perf_counter() - started) / len(tasks)
    out = []
    for task, record, before in zip(tasks, batch, earlier or [None] * len(tasks)):
        record = record if before is None else before.followed_by(record)
        out.append((record.to_result(task, local_options, share), replace(record, verified=None)))
    return out


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


# -- jobs: what an executor runs ---------------------------------------------------------------
class Shipped(NamedTuple):
    """An open task as it travels to workers: pickled once by the client, with its digest."""

    key: str
    blob: bytes


def ship(task: OpenTask) -> Shipped:
    blob = pickle.dumps(task, protocol=pickle.HIGHEST_PROTOCOL)
    return Shipped(hashlib.sha256(blob).hexdigest(), blob)


_OPEN: OrderedDict = OrderedDict()  # per worker process: the open tasks it has unpickled, by digest
_OPEN_SIZE = 4


def _open(source: OpenTask | Shipped) -> OpenTask:
    """The open task of a job; a shipped one is unpickled once per worker process, so that
    its hand and object -- and the solvers' tables and distance grids made for them -- are
    the same objects from chunk to chunk."""
    if isinstance(source, OpenTask):
        return source
    task = _OPEN.get(source.key)
    if task is None:
        task = _OPEN[source.key] = pickle.loads(source.blob)
        while len(_OPEN) > _OPEN_SIZE:
            _OPEN.popitem(last=False)
    _OPEN.move_to_end(source.key)
    return task


def local_job(source, assignments: Sequence[Assignment], seeds: Sequence[int], options, deadline=None,
              poses: tuple[int, int] | None = None, earlier: Sequence | None = None) -> list[SolveResult]:  # fmt: skip
    """:func:`local_round` on the concrete tasks of ``assignments``: ``(result, record)``
    each, the result without its task (the caller holds it: nothing large travels back)."""
    task = _open(source)
    tasks = [concrete_task(task, a) for a in assignments]
    return [(replace(r, task=None), record) for r, record in local_round(tasks, seeds, options, deadline, poses, earlier)]


def complete_job(source, assignment: Assignment, local: SolveResult, seed: int, options, deadline=None) -> SolveResult:
    """:func:`complete_one` on one assignment, from its local answer (without its task);
    the answer without its task."""
    task = concrete_task(_open(source), assignment)
    return replace(complete_one(task, replace(local, task=task), seed, options, deadline), task=None)
