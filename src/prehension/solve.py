"""One entry point for both solvers: :func:`solve`.

``method="auto"`` runs the local solver first (milliseconds when it succeeds) and falls
back to the complete solver, which always finds a solution when one exists and can prove
that none does; the result's message says which solver answered.

"solved" means the same everywhere: every constraint within the strict default
:class:`~prehension.tasks.residuals.Tolerances`.  A looser answer (the local solver's
``d_min`` acceptance) is returned only when ``LocalOptions(approximate=True)`` asks for it,
with the status ``"approximate"``; ``auto`` then still runs the complete solver first and
returns the approximate answer only when the complete solver neither solves the task nor
proves it infeasible.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Callable, Literal

from .errors import InvalidTask, PrehensionError
from .results import SolveResult, Status
from .tasks.model import Task

__all__ = ["solve", "check_sequence"]


def solve(
    task: Task,
    method: Literal["auto", "local", "complete"] = "auto",
    *,
    complete_options=None,
    local_options=None,
    seed: int = 0,
    executor=None,
    workers: int = 1,
    checkpoint=None,
    resume: bool = False,
    progress: Callable[[dict], None] | None = None,
    sequence=None,
    time_limit_s: float | None = None,
    require: str | None = None,
    quality=None,
) -> SolveResult:
    """Solve ``task`` with the chosen method (see the module docstring).

    ``time_limit_s``: the whole run's limit [s] (``None``: none but the options' own).  The
    local solver stops at it (:attr:`LocalOptions.time_limit_s`), and the complete solver
    gets what is left (at most its own ``time_limit_s``); when nothing is left the answer
    is the local solver's ``gave_up``, saying so.

    ``require="force-closure"``: only a force-closure grasp (friction model ``quality``, a
    :class:`~prehension.quality.QualityOptions`; default the stored quality's) is an
    answer.  The local solver's solutions that are not force closure are dropped (``auto``
    then runs the complete solver, ``local`` gives up); the complete solver searches for
    force-closure grasps only and proves, when it answers ``infeasible``, that the task
    has none (:mod:`prehension.solvers.complete.closure`).

    ``sequence``: the local solver's initial poses (an
    :class:`~prehension.solvers.local.InitialPoseSequence`, e.g. from ``prehension
    offline``); it must have been made for the task's hand (checked by
    :func:`check_sequence`).  Default: the hand's shipped sequence, else the default one.

    ``complete_options``: a :class:`~prehension.solvers.complete.search.BranchAndPruneOptions`,
    or a zero-argument callable that makes one, called only if the complete solver runs
    (so that ``auto`` does not import the complete solver when the local one succeeds).
    """
    if method not in ("auto", "local", "complete"):
        raise PrehensionError(f"method must be 'auto', 'local' or 'complete', got {method!r}")
    if require not in (None, "force-closure"):
        raise PrehensionError(f"require must be 'force-closure' or None (any grasp), got {require!r}")
    if sequence is not None:
        check_sequence(sequence, task.hand)
    started = time.perf_counter()
    if time_limit_s is not None and not time_limit_s > 0:
        raise PrehensionError(f"time_limit_s must be a number of seconds > 0 or None, got {time_limit_s!r}")
    if method in ("auto", "local"):
        if progress is not None:
            progress({"stage": "local solver"})
        local = _solve_local(task, local_options, seed, sequence, time_limit_s)
        if require is not None:
            local = _meeting(local, quality)
        if local.success or method == "local":
            return local
    from .solvers.complete.search import BranchAndPruneOptions, solve_complete
    from .solvers.local.verifier import LocalVerifier

    if callable(complete_options):
        complete_options = complete_options()
    complete_options = _within(complete_options or BranchAndPruneOptions(), time_limit_s, started, method == "complete")
    if complete_options is None and method == "auto":
        note = f"{local.message}; the time limit ({time_limit_s:g} s) was reached before the complete solver could start"
        return replace(local, message=note, seconds=time.perf_counter() - started)
    if complete_options.verifier is None:  # the complete solver verifies its boxes with the local solver's iterations
        complete_options = replace(complete_options, verifier=LocalVerifier())
    if require is not None:
        complete_options = replace(complete_options, require=require, quality=quality or complete_options.quality)
    if progress is not None:
        progress({"stage": "complete solver"})
    result = solve_complete(
        task, complete_options, executor=executor, workers=workers, checkpoint=checkpoint, resume=resume,
        progress=progress,
    )  # fmt: skip
    if method == "auto":
        seconds = time.perf_counter() - started
        if local.status == Status.APPROXIMATE and result.status == Status.GAVE_UP:
            note = f"{local.message}; the complete solver neither solved nor disproved the task: {result.message}"
            return replace(local, message=note, seconds=seconds, stats=dict(local.stats, complete=dict(result.stats)))
        note = f"the local solver found no solution ({local.message}); complete solver: {result.message}"
        stats = dict(result.stats, local=dict(local.stats))
        result = replace(result, message=note, seconds=seconds, stats=stats)
    return result


def _meeting(local: SolveResult, quality) -> SolveResult:
    """``local`` with only its force-closure solutions; ``gave_up`` when none is left."""
    from .quality import QualityOptions, grasp_quality

    quality = quality or QualityOptions()
    kept = tuple(s for s in local.solutions if grasp_quality(local.task, s, quality).force_closure)
    if len(kept) == len(local.solutions):
        return local
    if kept:
        return replace(local, solutions=kept)
    dropped = len(local.solutions)
    return replace(local, status=Status.GAVE_UP, solutions=(),
                   message=f"{local.message}; none of its {dropped} solution(s) is force closure (required)")  # fmt: skip


def _solve_local(task: Task, options, seed: int, sequence=None, time_limit_s: float | None = None) -> SolveResult:
    from .solvers.local import LocalOptions, solve_local

    options = options or LocalOptions()
    if time_limit_s is not None and (options.time_limit_s is None or options.time_limit_s > time_limit_s):
        options = replace(options, time_limit_s=float(time_limit_s))
    return solve_local(task, options, sequence, seed=seed)


def _within(options, time_limit_s: float | None, started: float, alone: bool = False):
    """The complete solver's options with at most the time left of ``time_limit_s``
    (``None`` when none is left after the local solver; ``alone``: it runs anyway)."""
    if time_limit_s is None:
        return options
    left = time_limit_s - (time.perf_counter() - started)
    if left <= 0 and not alone:
        return None
    left = max(math.floor(left * 100) / 100, 1e-3)  # in messages: "time limit (4.21 s) reached"
    if options.time_limit_s is not None and options.time_limit_s <= left:
        return options
    return replace(options, time_limit_s=left)


def check_sequence(sequence, hand) -> None:
    """Raise :class:`InvalidTask` unless ``sequence`` was made for ``hand``: the same hand
    name, and every pose component it names is one of the hand's (angles and fingertips)."""
    from .solvers.local.sequence import pose_space

    if sequence.hand != hand.name:
        raise InvalidTask(
            f"the initial-pose sequence was made for hand {sequence.hand!r}, not for the task's hand {hand.name!r}; "
            f"make one with: prehension offline HAND -o seq.json"
        )
    names = set(pose_space(hand)[0])
    unknown = [n for n in sequence.names if n not in names]
    if unknown:
        raise InvalidTask(
            f"the initial-pose sequence names pose components hand {hand.name!r} does not have: "
            f"{', '.join(unknown[:5])}{' ...' if len(unknown) > 5 else ''}; it was made for another version of the hand"
        )
