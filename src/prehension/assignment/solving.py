"""Solving the concrete tasks of many assignments: the local solver's batch path, then the
complete solver on each task it left undecided.

A chunk of tasks (one hand) goes to :func:`~prehension.solvers.local.solve_local_batch`
in one call, each task with its own seed: its answer is, bit for bit, the one
:func:`prehension.solve.solve` gives it alone with that seed (the batch changes nothing
but speed; see :mod:`prehension.batch.solving`).  Every answer is re-verified by the
residual function (:meth:`~prehension.solvers.local.LocalRecord.to_result`).  A task the
local solver did not solve goes to :func:`prehension.solve.complete_after_local` -- the
one ``auto`` policy -- with ``complete_time_s`` for the complete solver: it ends solved,
proven infeasible, or gave up (undecided).  :func:`solve_alone` is the same for one task,
without the batch: what the agreement test compares with.
"""

from __future__ import annotations

import time
from typing import Sequence

from ..results import SolveResult
from ..solve import SolveOptions, complete_after_local, solve
from ..tasks.model import Task

__all__ = ["solve_tasks", "solve_alone", "solve_options_for"]


def solve_options_for(options, seed: int, local_seconds: float = 0.0) -> SolveOptions:
    """The :class:`~prehension.solve.SolveOptions` of one assignment under ``options`` (an
    :class:`~.search.AssignmentOptions`): ``auto`` with its seed and local options, and a
    time limit that leaves the complete solver ``complete_time_s`` after ``local_seconds``."""
    method = "auto" if options.complete_time_s > 0 else "local"
    limit = local_seconds + options.complete_time_s if options.complete_time_s > 0 else None
    return SolveOptions(method=method, seed=seed, time_limit_s=limit, local_options=options.local_options)


def solve_alone(task: Task, seed: int, options) -> SolveResult:
    """One assignment's task solved by itself (:func:`prehension.solve.solve`): the local
    solver, then ``complete_time_s`` of the complete solver."""
    if options.complete_time_s <= 0:
        return solve(task, solve_options_for(options, seed))
    local = solve(task, SolveOptions(method="local", seed=seed, local_options=options.local_options))
    if local.success:
        return local
    return complete_after_local(task, local, solve_options_for(options, seed, local.seconds))


def solve_tasks(tasks: Sequence[Task], seeds: Sequence[int], options) -> list[SolveResult]:
    """Every task of ``tasks`` (one hand) with its seed: the local solver on all of them in
    one call, then the complete solver on each one it did not solve (module docstring)."""
    from ..solvers.local import LocalOptions, solve_local_batch

    if not tasks:
        return []
    local_options = options.local_options or LocalOptions()
    started = time.perf_counter()
    batch = solve_local_batch(list(tasks), local_options, None, list(seeds))
    share = (time.perf_counter() - started) / len(tasks)
    out = []
    for task, seed, record in zip(tasks, seeds, batch):
        result = record.to_result(task, local_options, share)
        if not result.success and options.complete_time_s > 0:
            result = complete_after_local(task, result, solve_options_for(options, seed, result.seconds))
        out.append(result)
    return out
