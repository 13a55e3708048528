"""What ``prehension batch`` adds per task for grasp quality: the best of many, the physics test.

:func:`solve_task` solves one task as ``solve`` or ``solve --best N`` would;
:func:`physics_records` runs the physics test on each of its solutions (``--simulate``);
:func:`hold_task` keeps the first candidate that holds, as ``solve --hold`` does
(``--hold``).  They run on the Dask worker that solves the task (see
:mod:`prehension.batch.solving`), so the physics tests of a batch are spread over the
cluster with the tasks.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from .errors import PrehensionError
from .results import SolveResult
from .tasks.model import Task

__all__ = ["solve_task", "physics_records", "HeldTask", "hold_task"]


def solve_task(task: Task, options, best=None) -> SolveResult:
    """``solve(task, options)`` (``best is None``), or :func:`~prehension.best.solve_best`
    with ``best`` (:class:`~prehension.best.BestOptions`) bounded by the options' time
    limit (``options``: a :class:`~prehension.solve.SolveOptions`)."""
    from .solve import solve

    if best is None:
        return solve(task, options)
    from .best import solve_best
    from .solvers.complete.search import BranchAndPruneOptions

    limit = options.time_limit_s
    return solve_best(task, replace(best, time_limit_s=limit),
                      replace(options, complete_options=BranchAndPruneOptions(time_limit_s=limit)))  # fmt: skip


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


@dataclass(frozen=True, eq=False)
class HeldTask:
    """What ``batch --hold`` records of one task (:func:`hold_task`).

    Attributes:
        result: the result as ``solve --hold`` answers it (:func:`prehension.hold.hold_first`).
        physics: per solution, its stored verdict (``"physics"`` in the result, as a
            ``solve --hold`` result file stores it); ``None``: no verdict.
        held: some candidate held in all six pushes; ``None``: not judged (no solution,
            or the physics test is unavailable for this task).
    """

    result: SolveResult
    physics: tuple | None
    held: bool | None


def hold_task(result: SolveResult, options, seed: int, closure_time_s: float | None = None) -> HeldTask:
    """``solve --hold`` on a solved task's candidates (``options``: a
    :class:`~prehension.sim.SimOptions`; ``closure_time_s``: the force-closure search's
    budget, ``None``: :data:`prehension.hold.CLOSURE_TIME_S`).  Without solutions nothing is judged; a task the
    physics test cannot run (e.g. an object without a solid) keeps its solutions, unjudged,
    its message saying why -- the solutions stand, only the verdict is missing."""
    from .hold import hold_first

    if not result.solutions:
        return HeldTask(result, None, None)
    try:
        outcome = hold_first(result, options, seed, closure_time_s=closure_time_s)
    except PrehensionError as exc:
        stats = {**result.stats, "hold": {"held": None, "unavailable": str(exc)}}
        return HeldTask(replace(result, stats=stats, message=f"{result.message}; physics test unavailable: {exc}"), None, None)
    return HeldTask(outcome.result, outcome.physics, outcome.held)
