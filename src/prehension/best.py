"""The best of many grasps: up to N distinct verified solutions, ranked by quality.

:func:`solve_best` collects verified solutions of one task from

1. the local solver's off-line sequence of initial poses (:func:`~prehension.solvers.local.solve_local`);
2. the local iterations from ``starts`` random starting configurations (joint angles
   uniform within the limits of the fingers taking part, couplings applied, contact
   parameters uniform in their regions' boxes; :func:`~prehension.solvers.local.refine_local`);
3. the complete solver's description of the solution set (``all_solutions``), when
   ``method="complete"``, or with ``method="auto"`` when the local phases found nothing --
   so that a task without a solution is still *proven* infeasible;

re-verifies each one with :func:`~prehension.results.make_solution` (strict tolerances),
measures its quality (:func:`~prehension.quality.grasp_quality`), sorts them by the ranking
(``"q1"``: epsilon, then volume; ``"volume"``: volume, then epsilon; ``"found"``: the order
found) and keeps, in that order, each solution that is *distinct* from every one kept
before it, up to ``2 n`` of them; then

4. **improves** each, in that order, by the quality ascent along the task's solution set
   (:func:`~prehension.ascent.improve_grasp`: contacts sliding in their regions, every
   step re-verified by the residual function), and keeps each improved grasp that is
   still distinct from the improved ones kept before it, up to ``n``; the kept grasps
   are ranked again by their improved quality (``"found"`` keeps the order found).
   ``ascent=None`` skips this step (the candidates as found).

Two solutions are the **same grasp** when every joint angle of the fingers taking part
differs by less than ``joint_deg``, the object positions by less than ``position_mm`` and
the object orientations by less than ``rotation_deg``; they are *distinct* when any of the
three is at least that far apart.  Ties in the ranking keep the order found, so a run is
deterministic for a given seed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable, Literal

import numpy as np

from .ascent import AscentOptions, improve_grasp
from .errors import PrehensionError
from .geometry.rotations import angle_between
from .quality import GraspQuality, QualityOptions, configuration_quality, grasp_quality
from .results import Solution, SolveResult, Status, make_solution
from .tasks.model import Configuration, Task

__all__ = ["BestOptions", "solve_best", "distinct", "RANKINGS"]

RANKINGS = ("q1", "volume", "found")


@dataclass(frozen=True)
class BestOptions:
    """Settings of :func:`solve_best` (see the module docstring).

    Attributes:
        n: most solutions returned (>= 1).
        rank: ``"q1"`` (default), ``"volume"`` or ``"found"``.
        starts: random starting configurations of the local iterations (>= 0).
        joint_deg, position_mm, rotation_deg: how far apart two solutions must be, in
            some joint angle [deg], the object position [mm] or its orientation [deg],
            to count as distinct (each > 0).
        quality: the friction model the ranking measures with (also the one stored).
        time_limit_s: stop collecting after this long [s] (``None``: no limit); the
            complete solver gets what is left, the ascent what is left then.
        ascent: the quality ascent applied to each kept grasp (``None``: none).
    """

    n: int = 5
    rank: Literal["q1", "volume", "found"] = "q1"
    starts: int = 100
    joint_deg: float = 5.0
    position_mm: float = 5.0
    rotation_deg: float = 5.0
    quality: QualityOptions = field(default_factory=QualityOptions)
    time_limit_s: float | None = None
    ascent: AscentOptions | None = field(default_factory=AscentOptions)

    def __post_init__(self):
        def need(ok: bool, message: str) -> None:
            if not ok:
                raise PrehensionError(f"best of many: {message}")

        need(_integer(self.n) and self.n >= 1, f"n must be an integer >= 1, got {self.n!r}")
        need(self.rank in RANKINGS, f"rank must be one of {', '.join(RANKINGS)}, got {self.rank!r}")
        need(_integer(self.starts) and self.starts >= 0, f"starts must be an integer >= 0, got {self.starts!r}")
        for name in ("joint_deg", "position_mm", "rotation_deg"):
            value = getattr(self, name)
            need(isinstance(value, (int, float)) and np.isfinite(value) and value > 0, f"{name} must be a positive number, got {value!r}")
        need(isinstance(self.quality, QualityOptions), "quality must be a QualityOptions")
        need(self.time_limit_s is None or self.time_limit_s > 0, f"time limit must be > 0 s, got {self.time_limit_s!r}")
        need(self.ascent is None or isinstance(self.ascent, AscentOptions), "ascent must be an AscentOptions or None")


def _integer(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool)


@dataclass(frozen=True, eq=False)
class _Candidate:
    config: Configuration
    quality: GraspQuality
    source: str
    order: int
    solution: Solution | None = None  # already verified (complete solver), else verified when kept
    ascent: dict | None = None  # what the quality ascent did to it (steps accepted and tried, epsilon before)


def distinct(a, b, task: Task, options: BestOptions = BestOptions(), active: np.ndarray | None = None) -> bool:
    """Whether grasps ``a`` and ``b`` of ``task`` (solutions or configurations) are distinct
    (see the module docstring); ``active``: the task's active mask, if already at hand."""
    active = task.active_mask if active is None else active
    qa, qb = _angles(a), _angles(b)
    dq = np.degrees(np.max(np.abs(qa - qb)[active], initial=0.0))
    dp = float(np.linalg.norm(a.T_palm_object[:3, 3] - b.T_palm_object[:3, 3]))
    dr = _rotation_deg(a.T_palm_object[:3, :3], b.T_palm_object[:3, :3])
    return bool(dq >= options.joint_deg or dp >= options.position_mm or dr >= options.rotation_deg)


def _angles(grasp) -> np.ndarray:
    return grasp.q if isinstance(grasp, Solution) else np.asarray(grasp.joint_angles, dtype=float)


def _rotation_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """Angle of the rotation ``Ra^T Rb`` [deg]."""
    R = Ra.T @ Rb
    axis_sin = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return float(np.degrees(np.arctan2(np.linalg.norm(axis_sin), 0.5 * (np.trace(R) - 1.0))))


# -- collecting -----------------------------------------------------------------------------
def random_starts(task: Task, count: int, rng: np.random.Generator) -> list[Configuration]:
    """``count`` random starting configurations (see the module docstring, step 2)."""
    hand = task.hand
    q = rng.uniform(hand.lower, hand.upper, size=(count, hand.n_dof))
    q = np.where(task.active_mask, q, task.idle_vector)
    for c in hand.couplings:
        q[:, hand.dof_index(c.dof)] = np.clip(c.ratio * q[:, hand.dof_index(c.source)] + c.offset,
                                              hand.lower[hand.dof_index(c.dof)], hand.upper[hand.dof_index(c.dof)])  # fmt: skip
    regions = [(task.hand_region(c).region, task.object_region(c)) for c in task.contacts]
    starts = []
    for s in range(count):
        params = tuple(tuple(rng.uniform(*r.param_bounds()) for r in pair) for pair in regions)
        starts.append(Configuration(q[s], np.eye(4), params))
    return starts


def _local_phase(task: Task, options: BestOptions, seed: int, deadline: float | None, sequence=None) -> tuple[list, dict]:
    """Configurations the local solver found from the off-line sequence and from the random
    starts (each met the strict tolerances in the solver's own checks): ``[(config, source)]``."""
    from .solvers.local import LocalOptions, refine_local, solve_local

    left = None if deadline is None else max(deadline - time.perf_counter(), 1e-3)
    first = solve_local(task, LocalOptions(time_limit_s=left), sequence, seed=seed).solutions
    found = [(s.configuration(), "local solver (off-line sequence)") for s in first]
    rng = np.random.default_rng(seed)
    starts = random_starts(task, options.starts, rng)
    tried = 0
    for first in range(0, len(starts), 25):  # in rounds, to honour the time limit
        if deadline is not None and time.perf_counter() > deadline:
            break
        chunk = starts[first : first + 25]
        reached = refine_local(task, chunk, LocalOptions())
        tried += len(chunk)
        found += [(config, f"local iterations from random start {first + k}")
                  for k, config in enumerate(reached.configurations) if config is not None]  # fmt: skip
    return found, {"random_starts_tried": tried}


def _complete_phase(task: Task, deadline: float | None, complete_options, executor, workers: int, progress):
    from .solvers.complete.search import BranchAndPruneOptions, solve_complete
    from .solvers.local.verifier import LocalVerifier

    base = complete_options or BranchAndPruneOptions()
    limit = None if deadline is None else max(deadline - time.perf_counter(), 1.0)
    if base.time_limit_s is not None:
        limit = base.time_limit_s if limit is None else min(limit, base.time_limit_s)
    options = replace(base, all_solutions=True, order="breadth", time_limit_s=limit, verifier=base.verifier or LocalVerifier())
    return solve_complete(task, options, executor=executor, workers=workers, progress=progress)


def _key(c: _Candidate, rank: str) -> tuple:
    q = c.quality
    return {"q1": (-q.epsilon, -q.volume, c.order), "volume": (-q.volume, -q.epsilon, c.order),
            "found": (c.order,)}[rank]  # fmt: skip


def _ranked(candidates: list[_Candidate], task: Task, options: BestOptions, most: int) -> tuple[list[_Candidate], int]:
    """The distinct candidates in rank order, each re-verified (:func:`make_solution`) as it
    is kept, up to ``most``; and how many distinct ones there were in all."""

    def key(c: _Candidate):
        return _key(c, options.rank)

    active = task.active_mask
    kept: list[_Candidate] = []
    n_distinct = 0
    for c in sorted(candidates, key=key):
        if not all(distinct(c.config, k.config, task, options, active) for k in kept):
            continue
        n_distinct += 1
        if len(kept) < most:
            solution = c.solution or make_solution(task, c.config)
            if solution is None:  # never kept unverified
                n_distinct -= 1
                continue
            kept.append(replace(c, solution=solution))
    return kept, n_distinct


def solve_best(
    task: Task,
    options: BestOptions = BestOptions(),
    method: Literal["auto", "local", "complete"] = "auto",
    *,
    seed: int = 0,
    complete_options=None,
    executor=None,
    workers: int = 1,
    progress: Callable[[dict], None] | None = None,
    sequence=None,
) -> SolveResult:
    """Up to ``options.n`` distinct verified solutions of ``task``, best first (module docstring).

    ``sequence``: the local solver's off-line initial poses (default: the hand's own).

    Returns a :class:`~prehension.results.SolveResult` whose ``solutions`` are ranked and
    whose ``stats["best"]`` says how they were collected (candidates, distinct ones,
    each solution's source and quality).  Without any solution the status is the
    complete solver's (``"infeasible"`` with its proof, or ``"gave_up"``), or
    ``"gave_up"`` for ``method="local"``.
    """
    if method not in ("auto", "local", "complete"):
        raise PrehensionError(f"method must be 'auto', 'local' or 'complete', got {method!r}")
    started = time.perf_counter()
    deadline = None if options.time_limit_s is None else started + options.time_limit_s
    found, stats = [], {}
    if method in ("auto", "local"):
        if progress is not None:
            progress({"stage": f"best of {options.n}: local solver from {options.starts} random starts"})
        if sequence is not None:
            from .solve import check_sequence

            check_sequence(sequence, task.hand)
        found, stats = _local_phase(task, options, seed, deadline, sequence)
    complete = None
    if method == "complete" or (method == "auto" and not found):
        if progress is not None:
            progress({"stage": f"best of {options.n}: complete solver (solution set)"})
        complete = _complete_phase(task, deadline, complete_options, executor, workers, progress)
        found += [(s, "complete solver (solution set)") for s in complete.solutions]
    candidates = [_candidate(task, grasp, source, i, options.quality) for i, (grasp, source) in enumerate(found)]
    kept, n_distinct = _ranked(candidates, task, options, options.n if options.ascent is None else 2 * options.n)
    if options.ascent is not None:
        kept = _improved(kept, task, options, deadline)
    return _result(task, options, kept, n_distinct, len(candidates), stats, complete, time.perf_counter() - started)


def _improved(pool: list[_Candidate], task: Task, options: BestOptions, deadline: float | None) -> list[_Candidate]:
    """Step 4 of the module docstring: the pool's grasps improved by the ascent, the distinct
    ones kept (up to ``options.n``), ranked again."""
    active = task.active_mask
    kept: list[_Candidate] = []
    for c in pool:
        if len(kept) == options.n:
            break
        ascent = options.ascent
        if deadline is not None:
            left = deadline - time.perf_counter()
            ascent = replace(ascent, steps=0) if left <= 0.0 else replace(ascent, time_limit_s=left / (options.n - len(kept)))
        up = improve_grasp(task, c.solution, options.quality, ascent)
        done = {"accepted": up.accepted, "tried": up.tried, "epsilon_before": up.start.epsilon}
        better = replace(c, config=up.solution.configuration(), quality=up.quality, solution=up.solution, ascent=done)
        if all(distinct(better.config, k.config, task, options, active) for k in kept):
            kept.append(better)
    if options.rank != "found":
        kept.sort(key=lambda c: _key(c, options.rank))
    return kept


def _candidate(task: Task, grasp, source: str, order: int, quality: QualityOptions) -> _Candidate:
    if isinstance(grasp, Solution):
        return _Candidate(grasp.configuration(), grasp_quality(task, grasp, quality), source, order, grasp)
    return _Candidate(grasp, configuration_quality(task, grasp, quality), source, order)


def _result(task, options: BestOptions, chosen, n_distinct, n_candidates, stats, complete, seconds) -> SolveResult:
    best = {
        "requested": options.n, "rank": options.rank, "candidates": n_candidates, "distinct": n_distinct,
        "distinct_when": {"joint_deg": options.joint_deg, "position_mm": options.position_mm, "rotation_deg": options.rotation_deg},
        "random_starts": options.starts, "quality_options": options.quality.to_dict(),
        "sources": [c.source for c in chosen], "epsilon": [c.quality.epsilon for c in chosen],
        "force_closure": [c.quality.force_closure for c in chosen], "ascent": [c.ascent for c in chosen], **stats,
    }  # fmt: skip
    used_complete = complete is not None
    if not chosen:
        if complete is not None:
            return replace(complete, seconds=seconds, stats=dict(complete.stats, best=best))
        message = f"no solution found from the off-line sequence and {stats.get('random_starts_tried', 0)} random starts"
        return SolveResult(task, "local", Status.GAVE_UP, message, (), seconds, {"best": best})
    closed = sum(c.quality.force_closure for c in chosen)
    message = (f"{len(chosen)} distinct solution(s) of {n_candidates} found, ranked by {options.rank}"
               f" ({closed} force closure; best epsilon {chosen[0].quality.epsilon:.4g})")  # fmt: skip
    stats_out = {"best": best}
    if used_complete:
        stats_out["complete"] = dict(complete.stats)
    return SolveResult(task, "complete" if used_complete else "local", Status.SOLVED, message,
                       tuple(c.solution for c in chosen), seconds, stats_out)  # fmt: skip
