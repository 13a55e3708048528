"""What ``prehension batch`` adds per task for grasp quality: the best of many, the physics test.

:func:`solve_task` solves one task as ``solve`` or ``solve --best N`` would;
:func:`physics_records` runs the physics test on each of its solutions.  Both run on the
Dask worker that solves the task (see :mod:`prehension.batch.solving`), so the physics
tests of a batch are spread over the cluster with the tasks.
"""

from __future__ import annotations

from dataclasses import replace

from .errors import PrehensionError
from .results import SolveResult
from .tasks.model import Task

__all__ = ["solve_task", "physics_records"]


def solve_task(task: Task, method: str, seed: int, time_limit_s: float | None, best=None, sequence=None) -> SolveResult:
    """``solve`` (``best is None``) or :func:`~prehension.best.solve_best` with ``best``
    (:class:`~prehension.best.BestOptions`), each bounded by ``time_limit_s``, the local
    solver starting from ``sequence`` (``None``: the hand's default)."""
    from .solve import solve
    from .solvers.complete.search import BranchAndPruneOptions

    complete = BranchAndPruneOptions(time_limit_s=time_limit_s)
    if best is None:
        return solve(task, method, complete_options=complete, seed=seed, sequence=sequence, time_limit_s=time_limit_s)
    from .best import solve_best

    return solve_best(task, replace(best, time_limit_s=time_limit_s), method, seed=seed, complete_options=complete,
                      sequence=sequence)  # fmt: skip


def physics_records(task: Task, result: SolveResult, options, seed: int) -> list[dict]:
    """The physics test of every solution (:meth:`~prehension.sim.PhysicsReport.to_dict`, plus
    ``"solution"``: its index); a solution that cannot be simulated (e.g. an object without
    a solid) gets ``{"solution": k, "unavailable": why}``."""
    from .sim import simulate_grasp

    out = []
    for k, solution in enumerate(result.solutions):
        try:
            out.append(dict(solution=k, **simulate_grasp(task, solution, options, seed).to_dict()))
        except PrehensionError as exc:
            out.append({"solution": k, "unavailable": str(exc)})
    return out
