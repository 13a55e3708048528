"""One entry point for both solvers, and the one ``auto`` policy: :func:`solve`.

``method="auto"`` runs the local solver first (milliseconds when it succeeds) and falls
back to the complete solver, which always finds a solution when one exists and can prove
that none does; the result's message says which solver answered.  The fallback is
:func:`complete_after_local`: ``prehension batch`` solves its tasks with the local solver
a chunk at a time and hands each answer that is not a solution to it, so that a task is
never solved by the local solver twice.

"solved" means the same everywhere: every constraint within the strict default
:class:`~prehension.verification.residuals.Tolerances`.  A looser answer (the local solver's
``d_min`` acceptance) is returned only when ``LocalOptions(approximate=True)`` asks for it,
with the status ``"approximate"``; ``auto`` then still runs the complete solver first and
returns the approximate answer only when the complete solver neither solves the task nor
proves it infeasible.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any, Callable, Literal

from .errors import InvalidTask, PrehensionError
from .results import SolveResult, Status
from .tasks.model import Task

__all__ = ["SolveOptions", "solve", "solve_locally", "complete_after_local", "complete_options_of", "check_sequence"]

METHODS = ("auto", "local", "complete")


@dataclass(frozen=True)
class SolveOptions:
    """How :func:`solve` solves a task (every field has a default: ``SolveOptions()`` is ``auto``).

    Attributes:
        method: ``"auto"`` (the local solver, then the complete one when it finds no
            solution), ``"local"`` or ``"complete"``.
        seed: seed of the local solver's random initial poses.
        time_limit_s: the whole run's limit [s] (``None``: none but the solvers' own
            options').  The local solver stops at it (:attr:`LocalOptions.time_limit_s`),
            and the complete solver gets what is left (at most its own ``time_limit_s``);
            when nothing is left ``auto`` answers with the local solver's ``gave_up``,
            saying so.
        require: ``"force-closure"``: only a force-closure grasp (friction model
            ``quality``) is an answer.  The local solver's solutions that are not force
            closure are dropped (``auto`` then runs the complete solver, ``local`` gives
            up); the complete solver searches for force-closure grasps only and proves,
            when it answers ``infeasible``, that the task has none
            (:mod:`prehension.solvers.complete.closure`).  ``None``: any grasp.
        quality: the :class:`~prehension.quality.QualityOptions` of ``require``
            (``None``: the complete solver's, else the defaults).
        sequence: the local solver's initial poses (an
            :class:`~prehension.solvers.local.InitialPoseSequence`, e.g. from ``prehension
            offline``); it must have been made for the task's hand (checked by
            :func:`check_sequence`).  ``None``: the hand's shipped sequence, else the
            default one.
        local_options: a :class:`~prehension.solvers.local.LocalOptions` (``None``: the
            defaults).
        complete_options: a
            :class:`~prehension.solvers.complete.search.BranchAndPruneOptions`, or a
            zero-argument callable that makes one, called only if the complete solver runs
            (so that ``auto`` does not import the complete solver when the local one
            succeeds); ``None``: the defaults.
        executor, workers: where the complete solver processes its boxes
            (:mod:`prehension.parallel`; ``None`` and 1: in this process).
        checkpoint, resume: the complete solver's checkpoint file, and whether to
            continue from it (:mod:`prehension.solvers.complete.checkpoint`).
        progress: called with a dict (``{"stage": ...}``, then the complete solver's
            counters) as the run goes, or ``None``.
    """

    method: Literal["auto", "local", "complete"] = "auto"
    seed: int = 0
    time_limit_s: float | None = None
    require: str | None = None
    quality: Any = None
    sequence: Any = None
    local_options: Any = None
    complete_options: Any = None
    executor: Any = None
    workers: int = 1
    checkpoint: Any = None
    resume: bool = False
    progress: Callable[[dict], None] | None = None

    def __post_init__(self):
        if self.method not in METHODS:
            raise PrehensionError(f"method must be 'auto', 'local' or 'complete', got {self.method!r}")
        if self.require not in (None, "force-closure"):
            raise PrehensionError(f"require must be 'force-closure' or None (any grasp), got {self.require!r}")
        limit = self.time_limit_s
        if limit is not None and not (isinstance(limit, (int, float)) and limit > 0):
            raise PrehensionError(f"time_limit_s must be a number of seconds > 0 or None, got {limit!r}")


def solve(task: Task, options: SolveOptions | str = SolveOptions()) -> SolveResult:
    """Solve ``task`` (see the module docstring and :class:`SolveOptions`).

    ``options``: a :class:`SolveOptions`, or a method name alone (``solve(task, "local")``
    is ``solve(task, SolveOptions(method="local"))``).
    """
    options = _as_options(options)
    started = time.perf_counter()
    if options.sequence is not None:
        check_sequence(options.sequence, task.hand)
    if options.method == "complete":
        return _run_complete(task, _complete_within(options, started, alone=True), options)
    local = solve_locally(task, options)
    if local.success or options.method == "local":
        return local
    return complete_after_local(task, replace(local, seconds=time.perf_counter() - started), options)


def _as_options(options: SolveOptions | str) -> SolveOptions:
    if isinstance(options, str):
        return SolveOptions(method=options)
    if not isinstance(options, SolveOptions):
        raise PrehensionError(f"solve: options must be a SolveOptions or a method name, got {type(options).__name__}")
    return options


def solve_locally(task: Task, options: SolveOptions) -> SolveResult:
    """The local solver's answer under ``options`` (its seed, sequence, time limit and
    ``require``): the first step of ``auto``."""
    from .solvers.local import LocalOptions, solve_local

    if options.progress is not None:
        options.progress({"stage": "local solver"})
    local = options.local_options or LocalOptions()
    limit = options.time_limit_s
    if limit is not None and (local.time_limit_s is None or local.time_limit_s > limit):
        local = replace(local, time_limit_s=float(limit))
    result = solve_local(task, local, options.sequence, seed=options.seed)
    return result if options.require is None else _meeting(result, options.quality)


def complete_after_local(task: Task, local: SolveResult, options: SolveOptions) -> SolveResult:
    """``auto`` after its local step: ``local`` itself when it is a solution, else the
    complete solver's answer, its message and stats saying what the local solver did.

    ``local.seconds`` counts as spent of ``options.time_limit_s``: the complete solver
    gets what is left (nothing left: ``local``, its message saying so).  An
    ``approximate`` local answer is returned only when the complete solver neither solves
    nor disproves the task.
    """
    if local.success:
        return local
    started = time.perf_counter() - local.seconds
    complete = _complete_within(options, started, alone=False)
    if complete is None:
        note = f"{local.message}; the time limit ({options.time_limit_s:g} s) was reached before the complete solver could start"
        return replace(local, message=note, seconds=time.perf_counter() - started)
    result = _run_complete(task, complete, options)
    seconds = time.perf_counter() - started
    if local.status == Status.APPROXIMATE and result.status == Status.GAVE_UP:
        note = f"{local.message}; the complete solver neither solved nor disproved the task: {result.message}"
        return replace(local, message=note, seconds=seconds, stats=dict(local.stats, complete=dict(result.stats)))
    note = f"the local solver found no solution ({local.message}); complete solver: {result.message}"
    return replace(result, message=note, seconds=seconds, stats=dict(result.stats, local=dict(local.stats)))


def complete_options_of(options: SolveOptions):
    """The complete solver's options ``options`` names (made now when it gives a callable;
    the defaults when ``None``), with ``require`` and its friction model applied, and the
    local solver's iterations as its box verifier when none is given.  The one place where
    the complete solver's options are built."""
    from .solvers.complete.search import BranchAndPruneOptions
    from .solvers.local.verifier import LocalVerifier

    complete = options.complete_options
    complete = (complete() if callable(complete) else complete) or BranchAndPruneOptions()
    if complete.verifier is None:  # the complete solver verifies its boxes with the local solver's iterations
        complete = replace(complete, verifier=LocalVerifier())
    if options.require is not None:
        complete = replace(complete, require=options.require, quality=options.quality or complete.quality)
    return complete


def _run_complete(task: Task, complete, options: SolveOptions) -> SolveResult:
    from .solvers.complete.search import solve_complete

    if options.progress is not None:
        options.progress({"stage": "complete solver"})
    return solve_complete(task, complete, executor=options.executor, workers=options.workers,
                          checkpoint=options.checkpoint, resume=options.resume, progress=options.progress)  # fmt: skip


def _complete_within(options: SolveOptions, started: float, alone: bool):
    """The complete solver's options with at most the time left of ``options.time_limit_s``
    since ``started`` (``None`` when none is left after the local solver; ``alone``: the
    complete solver runs anyway)."""
    complete = complete_options_of(options)
    limit = options.time_limit_s
    if limit is None:
        return complete
    left = limit - (time.perf_counter() - started)
    if left <= 0 and not alone:
        return None
    left = max(math.floor(left * 100) / 100, 1e-3)  # in messages: "time limit (4.21 s) reached"
    if complete.time_limit_s is not None and complete.time_limit_s <= left:
        return complete
    return replace(complete, time_limit_s=left)


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
