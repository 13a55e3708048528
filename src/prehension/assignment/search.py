"""The assignment search: every assignment of an open task decided, the feasible ones ranked.

:func:`search_assignments` runs three steps:

1. **enumerate** the injective assignments, symmetric duplicates pruned
   (:func:`~.model.enumerate_assignments`);
2. **prune by span**: an assignment whose object regions lie beyond its hand regions'
   reach is proven impossible on the spot (:mod:`.span`), without solving;
3. **solve** the others a chunk at a time: the local solver's batch path, then the
   complete solver, ``complete_time_s`` per assignment the local solver did not solve
   (:mod:`.solving`); chunks run here, or on ``executor`` (e.g. a Dask cluster's, as
   ``prehension batch`` uses: :func:`prehension.parallel.executor_for`).

Each assignment ends **feasible** (a verified grasp), **infeasible** (the span proof or
the complete solver's certificate), or **undecided** (the reason named).  Feasible ones
are ranked by the grasp quality of their best solution (force closure first, then the
epsilon measure; :mod:`prehension.quality`), or kept in enumeration order with
``rank=False``.  The outcome of an assignment does not depend on the chunking nor on the
executor: its seed is :func:`prehension.batch.task_seed` of the base seed and its label,
and the local solver's batch answers exactly as it does for the task alone.
"""

from __future__ import annotations

import logging
import math
import time
from collections import Counter
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Iterable, Mapping

from ..batch.solving import task_seed
from ..errors import PrehensionError
from ..results import SolveResult, Status
from ..tasks.model import Task
from .model import Assignment, OpenTask, concrete_task, enumerate_assignments
from .span import SpanProof, prove_by_span
from .resume import Earlier, resume_point
from .rounds import Driver, round_ranges
from .solving import complete_job, local_job, ship

__all__ = ["AssignmentOptions", "AssignmentOutcome", "Impossible", "Undecided", "AssignmentProgress", "AssignmentReport",
           "search_assignments", "assignment_seed"]  # fmt: skip

_LOG = logging.getLogger("prehension.assignment")
MAX_CHUNK = 32  # assignments per call of the local solver's batch path, at most (default)
DEFAULT_ROUND_POSES = 8  # initial poses per round (AssignmentOptions.round_poses)


@dataclass(frozen=True)
class AssignmentOptions:
    """How :func:`search_assignments` decides the assignments.

    Attributes:
        seed: base seed; assignment ``a`` is solved with ``assignment_seed(seed, a)``.
        local_options: the local solver's :class:`~prehension.solvers.local.LocalOptions`
            (its budget: initial poses, iterations; ``None``: the defaults).
        round_poses: initial poses of the first rounds (:mod:`.rounds`: ``B``, ``B``,
            then doubling): every assignment no earlier pose solved gets its next
            poses in turn, so the feasible
            ones are found first; an assignment's answer is the same for any value.
            ``None``: one round of every pose (also with ``initial="random"`` or
            ``approximate``, whose draws and retries carry from pose to pose).
        complete_time_s: the complete solver's time [s] on each assignment the local
            solver did not solve; 0: no complete solver (those stay undecided).
        span: prune by the hand's span (:mod:`.span`) before solving.
        rank: rank the feasible assignments by grasp quality (else enumeration order).
        quality: the :class:`~prehension.quality.QualityOptions` of the ranking
            (``None``: the defaults).
        hold: a :class:`~prehension.sim.SimOptions`: each feasible assignment's solutions
            are also tested in physics (``AssignmentOutcome.physics``); held grasps rank
            first.  ``None``: no physics.
        executor: a :class:`concurrent.futures.Executor` (e.g.
            :class:`prehension.parallel.DaskExecutor`) the chunks run on; ``None``: here.
        chunk_size: assignments per call of the local solver's batch path (``None``:
            enough for four chunks per worker -- progress and balance -- up to 32).
        time_limit_s: the whole search's limit [s] (``None``: none): checked as chunks
            finish; the assignments not solved by then are undecided, saying so.
    """

    seed: int = 0
    local_options: Any = None
    round_poses: int | None = DEFAULT_ROUND_POSES
    complete_time_s: float = 2.0
    span: bool = True
    rank: bool = True
    quality: Any = None
    hold: Any = None
    executor: Any = None
    chunk_size: int | None = None
    time_limit_s: float | None = None

    def __post_init__(self):
        if not (isinstance(self.seed, int) and self.seed >= 0):
            raise PrehensionError(f"assignment search: seed must be an integer >= 0, got {self.seed!r}")
        if not (isinstance(self.complete_time_s, (int, float)) and self.complete_time_s >= 0):
            raise PrehensionError(f"assignment search: complete_time_s must be >= 0 s, got {self.complete_time_s!r}")
        if self.round_poses is not None and not (isinstance(self.round_poses, int) and self.round_poses >= 1):
            raise PrehensionError(f"assignment search: round_poses must be an integer >= 1 or None, got {self.round_poses!r}")
        if self.chunk_size is not None and not (isinstance(self.chunk_size, int) and self.chunk_size >= 1):
            raise PrehensionError(f"assignment search: chunk_size must be an integer >= 1, got {self.chunk_size!r}")
        if self.time_limit_s is not None and not (isinstance(self.time_limit_s, (int, float)) and self.time_limit_s > 0):
            raise PrehensionError(f"assignment search: time_limit_s must be > 0 s or None, got {self.time_limit_s!r}")

    def without_executor(self) -> "AssignmentOptions":
        return replace(self, executor=None)


def assignment_seed(seed: int, assignment: Assignment) -> int:
    """The seed assignment ``assignment`` is solved with (:func:`prehension.batch.task_seed` of its label)."""
    return task_seed(seed, assignment.label)


@dataclass(frozen=True, eq=False)
class Impossible:
    """An assignment proven impossible: ``proof`` is a :class:`~.span.SpanProof` or the
    complete solver's ``infeasible`` :class:`~prehension.results.SolveResult`; ``task``
    the assignment's concrete task.  Unpacks as the pair ``(assignment, proof)``."""

    assignment: Assignment
    proof: SpanProof | SolveResult
    task: Task | None = None

    def __iter__(self):
        return iter((self.assignment, self.proof))


@dataclass(frozen=True, eq=False)
class Undecided:
    """An assignment neither solved nor disproved, why, and the last solver's answer
    (``gave_up``).  Unpacks as the pair ``(assignment, reason)``."""

    assignment: Assignment
    reason: str
    result: SolveResult | None = None

    def __iter__(self):
        return iter((self.assignment, self.reason))


@dataclass(frozen=True, eq=False)
class AssignmentOutcome:
    """A feasible assignment: its task, the solver's result (verified solutions), and the
    quality entry (:func:`prehension.quality.quality_entries`) of each solution; ``best``
    is the index of the best solution, ``quality`` its entry."""

    assignment: Assignment
    task: Task
    result: SolveResult
    qualities: tuple[dict, ...] = ()
    physics: tuple[dict, ...] = ()

    @property
    def best(self) -> int:
        if not self.qualities:
            return 0
        return max(range(len(self.qualities)), key=lambda k: _score(self.qualities[k], _physics_of(self.physics, k)))

    @property
    def quality(self) -> dict:
        return self.qualities[self.best] if self.qualities else {}

    @property
    def score(self) -> tuple:
        """What the ranking sorts by (largest first): held (with physics), force closure, epsilon."""
        return _score(self.quality, _physics_of(self.physics, self.best))


def _physics_of(physics: tuple[dict, ...], k: int) -> dict | None:
    return next((p for p in physics if p.get("solution") == k), None)


def _score(quality: dict, physics: dict | None) -> tuple:
    held = bool(physics and physics.get("held"))
    epsilon = quality.get("epsilon")
    return (held, bool(quality.get("force_closure")), float(epsilon) if isinstance(epsilon, (int, float)) else -1.0)


@dataclass(frozen=True)
class AssignmentProgress:
    """Where a search is: ``decided`` of ``total`` assignments, by verdict so far."""

    decided: int
    total: int
    counts: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class AssignmentReport:
    """What :func:`search_assignments` found.

    Attributes:
        open_task: the task searched.
        feasible: :class:`AssignmentOutcome` values, best first (or in enumeration order).
        infeasible: :class:`Impossible` ``(assignment, proof)`` pairs.
        undecided: :class:`Undecided` ``(assignment, reason)`` pairs.
        total: assignments enumerated (skipped ones included).
        skipped: assignments not decided in this run (``skip``: already decided, e.g. in a journal).
        seconds: wall-clock time of the search.
    """

    open_task: OpenTask
    feasible: list[AssignmentOutcome]
    infeasible: list[Impossible]
    undecided: list[Undecided]
    total: int
    skipped: int = 0
    seconds: float = 0.0

    @property
    def complete(self) -> bool:
        """Every assignment of this run is decided (none undecided, none skipped)."""
        return not self.undecided and not self.skipped


# -- the search -------------------------------------------------------------------------
class _Collect:
    """The verdicts as they come, with progress and the per-assignment callback."""

    def __init__(self, total: int, options: AssignmentOptions, progress, on_decided):
        self.options, self.progress, self.on_decided = options, progress, on_decided
        self.total, self.counts = total, Counter()
        self.feasible: list[AssignmentOutcome] = []
        self.infeasible: list[Impossible] = []
        self.undecided: list[Undecided] = []

    def report(self) -> None:
        decided = sum(self.counts.values())
        _LOG.info("assignments decided: %d / %d (%s)", decided, self.total,
                  ", ".join(f"{n} {k}" for k, n in sorted(self.counts.items())) or "starting")  # fmt: skip
        if self.progress is not None:
            self.progress(AssignmentProgress(sum(self.counts.values()), self.total, dict(self.counts)))

    def add(self, item) -> None:
        kind = {AssignmentOutcome: "feasible", Impossible: "infeasible", Undecided: "undecided"}[type(item)]
        getattr(self, kind).append(item)
        self.counts[kind] += 1
        if self.on_decided is not None:
            self.on_decided(item)

    def result(self, assignment: Assignment, task: Task, result: SolveResult) -> None:
        if result.success:
            self.add(_outcome(assignment, task, result, self.options))
        elif result.status == Status.INFEASIBLE:
            self.add(Impossible(assignment, result, task))
        else:
            self.add(Undecided(assignment, f"{result.status}: {result.message}", result))


def _outcome(assignment: Assignment, task: Task, result: SolveResult, options: AssignmentOptions) -> AssignmentOutcome:
    from ..quality import quality_entries

    physics = ()
    if options.hold is not None:
        from ..batch_extras import physics_records

        physics = tuple(physics_records(task, result, options.hold, assignment_seed(options.seed, assignment)))
    return AssignmentOutcome(assignment, task, result, tuple(quality_entries(result, options.quality)), physics)


def search_assignments(
    open_task: OpenTask,
    options: AssignmentOptions | None = None,
    *,
    progress: Callable[[AssignmentProgress], None] | None = None,
    skip: Iterable[str] = (),
    on_decided: Callable[[Any], None] | None = None,
    earlier: Mapping[str, Earlier] | None = None,
) -> AssignmentReport:
    """Decide every assignment of ``open_task`` (module docstring).

    Args:
        open_task: an :class:`~.model.OpenTask`.
        options: :class:`AssignmentOptions` (``None``: the defaults).
        progress: called with an :class:`AssignmentProgress` at the start and as
            assignments are decided (after the span step, then after each chunk).
        skip: labels of assignments not to decide in this run (already decided).
        on_decided: called with each verdict (:class:`AssignmentOutcome`,
            :class:`Impossible` or :class:`Undecided`) as it is reached (e.g. to append it
            to a journal).
        earlier: by label, what an earlier run left of undecided assignments
            (:func:`.resume.earlier_runs` of its journal): they go on after the initial
            poses it tried (:mod:`.resume`), with the same answer.

    Returns:
        An :class:`AssignmentReport`.
    """
    options = options or AssignmentOptions()
    started = time.perf_counter()
    skip = set(skip)
    every = enumerate_assignments(open_task)
    todo = [a for a in every if a.label not in skip]
    collect = _Collect(len(todo), options, progress, on_decided)
    collect.report()
    to_solve = _span_step(open_task, todo, options, collect)
    collect.report()
    _solve_step(open_task, to_solve, options, collect, started, earlier or {})
    feasible = sorted(collect.feasible, key=lambda o: o.score, reverse=True) if options.rank else collect.feasible
    return AssignmentReport(open_task, feasible, collect.infeasible, collect.undecided, len(every),
                            len(every) - len(todo), time.perf_counter() - started)  # fmt: skip


def _span_step(open_task: OpenTask, todo: list[Assignment], options: AssignmentOptions, collect: _Collect):
    """``(assignment, task)`` of the assignments the span does not rule out; the others
    go to ``collect`` with their proof."""
    out = []
    for assignment in todo:
        task = concrete_task(open_task, assignment)
        proof = prove_by_span(task) if options.span else None
        if proof is not None:
            collect.add(Impossible(assignment, proof, task))
        else:
            out.append((assignment, task))
    return out


def _solve_step(open_task: OpenTask, items: list[tuple[Assignment, Task]], options: AssignmentOptions, collect: _Collect,
                started: float, earlier: Mapping[str, Earlier]) -> None:  # fmt: skip
    """The local solver in rounds of initial poses on every assignment no earlier pose
    solved, a chunk at a time (:mod:`.rounds`); then the complete solver on each one no
    pose solved (one assignment a call), while the search's time limit allows.  Here, or
    on ``options.executor`` (the open task shipped pickled, unpickled once per worker:
    :func:`.solving.ship`).  An assignment in ``earlier`` goes on where that run left it
    (:mod:`.resume`)."""
    deadline = None if options.time_limit_s is None else time.time() + options.time_limit_s - (time.perf_counter() - started)
    workers = getattr(options.executor, "max_workers", 1) if options.executor is not None else 1
    size = options.chunk_size or max(1, min(MAX_CHUNK, math.ceil(len(items) / (4 * max(workers, 1)))))
    plain = options.without_executor()
    source = open_task if options.executor is None else ship(open_task)
    local = options.local_options
    rounds = options.round_poses if local is None or (local.initial == "sequence" and not local.approximate) else None
    ranges = round_ranges(_i_max(options), rounds)
    driver = Driver(options.executor, deadline, 2 * workers if options.executor is not None else 1,
                    lambda left: _out_of_time(left, collect))  # fmt: skip

    def chunk(round_, items):  # items: (assignment, task, record, result) of round round_
        part = _Part(items, round_)
        seeds = [assignment_seed(options.seed, a) for a, *_ in part]
        args = (source, [a for a, *_ in part], seeds, plain, deadline, ranges[round_], [r for _, _, r, _ in part])
        return part, local_job, args

    def local_done(part, answers):
        round_ = part.round_
        go_on = []
        for (assignment, task, _, before), (result, record) in zip(part, answers):
            result = _after(result, task, before)
            if not result.success and record.time_limit_s is not None and _past(deadline):
                _out_of_time([(assignment, task, record, result)], collect)  # the search's limit stopped it
            elif result.success or (round_ + 1 >= len(ranges) and options.complete_time_s <= 0):
                collect.result(assignment, task, result)
            elif round_ + 1 < len(ranges) and record.time_limit_s is None:
                go_on.append((assignment, task, record, result))
            elif options.complete_time_s <= 0:
                collect.result(assignment, task, result)
            else:
                to_complete(assignment, task, result)
        collect.report()
        driver.gather(round_ + 1, go_on)

    def to_complete(assignment, task, result):
        args = (source, assignment, replace(result, task=None), assignment_seed(options.seed, assignment), plain, deadline)
        driver.later(([(assignment, task, None, result)], complete_job, args), complete_done)

    def complete_done(part, result):
        assignment, task, _, _ = part[0]
        collect.result(assignment, task, replace(result, task=task))
        collect.report()

    driver.chunking(size, chunk, local_done)
    _start(driver, items, earlier if rounds is not None else {}, ranges, to_complete, collect)
    driver.run()


def _start(driver: Driver, items: list, earlier: Mapping[str, Earlier], ranges: list, to_complete: Callable,
           collect: _Collect) -> None:  # fmt: skip
    """Every assignment of ``items`` to round 1, or where ``earlier`` left it (same seed,
    as many initial poses)."""
    options, fresh = collect.options, []
    for assignment, task in items:
        gone_on = earlier.get(assignment.label)
        if gone_on is None or gone_on.seed != assignment_seed(options.seed, assignment) or gone_on.i_max != _i_max(options):
            fresh.append((assignment, task, None, None))
        else:
            _go_on(driver, (assignment, task, *resume_point(gone_on, ranges, task, options.local_options)), to_complete, collect)
    driver.gather(0, fresh)


def _after(result: SolveResult, task: Task, before: SolveResult | None) -> SolveResult:
    """A round's answer with its task, the seconds of the rounds ``before`` it added, and
    ``stats["resumed_at_pose"]`` kept (:mod:`.resume`)."""
    if before is None:
        return replace(result, task=task)
    stats = result.stats if "resumed_at_pose" not in before.stats else {**result.stats, "resumed_at_pose": before.stats["resumed_at_pose"]}
    return replace(result, task=task, seconds=result.seconds + before.seconds, stats=stats)


def _go_on(driver: Driver, resumed: tuple, to_complete: Callable, collect: _Collect) -> None:
    """An assignment an earlier run left undecided, ``(assignment, task, round, record,
    result)`` of :func:`.resume.resume_point`: to its round, else (every pose tried) to the
    complete solver, else (none in this search) decided as it was."""
    assignment, task, round_, record, result = resumed
    if round_ is not None:
        driver.gather(round_, [(assignment, task, record, result)])
    elif collect.options.complete_time_s > 0:
        to_complete(assignment, task, result)
    else:
        collect.result(assignment, task, result)


class _Part(list):
    """The items of one local call, and their round."""

    def __init__(self, items, round_: int):
        super().__init__(items)
        self.round_ = round_


def _past(deadline: float | None) -> bool:
    """``deadline`` has passed (within 50 ms: a worker's local solver stops at it by its own clock)."""
    return deadline is not None and time.time() >= deadline - 0.05


def _i_max(options: AssignmentOptions) -> int:
    from ..solvers.local import LocalOptions

    return (options.local_options or LocalOptions()).i_max


def _out_of_time(items, collect: _Collect) -> None:
    """The assignments no solver finished before the search's time limit: undecided,
    with the initial poses they had tried."""
    i_max = _i_max(collect.options)
    for assignment, task, _, local in items:
        tried = 0 if local is None else int(local.stats.get("initial_poses_tried", 0))
        reason = (f"the search's time limit ({collect.options.time_limit_s:g} s) was reached before it was decided "
                  f"({tried} of {i_max} initial poses tried)")  # fmt: skip
        result = local if local is not None else SolveResult(task, "local", Status.GAVE_UP, reason)
        collect.add(Undecided(assignment, reason, result))
    collect.report()
