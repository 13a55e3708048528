"""Branch and prune over boxes (Rosales et al. 2011, sec. 4.2), with verified answers.

Each box is *processed*: shrunk (contraction, then linear programs over the relaxations,
:func:`.shrink.shrink_box`), and discarded when an enclosure proves that every
configuration in it puts the hand into the object (:mod:`.collision`, after the
contraction and again after the LPs); if not empty, a point read from it is refined on the original
constraints and judged by the residual function (:func:`prehension.results.make_solution`);
if that fails, the box is split through its widest scaled interval (or a rotation's
quaternion, :mod:`.branching`) -- or, once it is
narrower than ``sigma``, kept as an *unverified* solution box (never called a solution).

Depth-first order stops at the first verified solution; breadth-first collects every
solution box (``all_solutions``).  When every box is pruned the answer is **infeasible**,
with the numbers of boxes and linear programs as its certificate -- for an object that
collides, "no penetration-free solution" when the collision prune discarded any box
(``stats["collision_pruned"]``), and "no self-collision-free solution" when the
self-collision prune did (:mod:`.self_collision`, ``stats["self_collision_pruned"]``).  With
``require="force-closure"`` only force-closure solutions count and a box is also discarded
when :mod:`.closure` certifies that none of its configurations is force closure: "no
force-closure grasp" (``stats["closure_pruned"]``).

Boxes are independent, so :func:`solve_complete` can process them on any
``concurrent.futures.Executor`` (a process pool, a Dask cluster's executor): workers
process the next boxes of the one-process order ahead of time, and outcomes are taken in
that order, so every executor and worker count gives the same boxes, counts and answer.
The open boxes can be saved to a checkpoint file and the search resumed from it.
"""

from __future__ import annotations

import time
import zlib
from collections import deque
from concurrent.futures import Executor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Literal

import numpy as np

from ...deadline import deadline_after, scope
from ...errors import PrehensionError
from ...results import Solution, SolveResult, Status, make_solution
from ...tasks.model import Task
from ...verification.residuals import Tolerances
from ...system.embedding import configuration_from_point, embed
from ...system.formulation import Formulation, build_system
from ...quality import QualityOptions, grasp_quality
from .branching import scaled_widths, shrink_variables, split_variable
from .checkpoint import SearchState, load_state, options_record, save_state, search_fingerprint
from .closure import closure_prune
from .collision import collision_prune
from .self_collision import self_collision_prune
from .witnesses import makeable_pairs
from .pair import congruence_test
from .contract import contract
from .shrink import ShrinkOptions, cut_rotations, shrink_box
from .verifier import BoxVerifier

__all__ = ["ALL_SOLUTIONS_MAX_BOXES", "PAIR_TEST_LATE", "BranchAndPruneOptions", "solve_complete", "process_box", "BoxOutcome"]

#: Default box budget of the solution-set mode (``all_solutions`` with neither ``max_boxes``
#: nor ``time_limit_s``).  A cover of a ``d``-dimensional solution set by boxes narrower
#: than ``sigma`` takes at least ``(1/sigma)^d`` boxes, and grasp problems have large ``d``
#: (scalpel-upholding: 87 base variables, ``d = 11``, ~1.5 s per box on one core: no
#: ``sigma < 1`` ends in minutes), so the description stops after this many boxes and
#: reports the boxes still open as the rest of the cover (each verified for a solution
#: inside it).  scalpel-upholding: 100 boxes in 157 s on one core (200 took 9.5 min on a loaded machine).
ALL_SOLUTIONS_MAX_BOXES = 100

#: Boxes without a verified solution after which the pair test runs with its full budget.
PAIR_TEST_LATE = 16

#: While a pair near the reach frontier (``CongruenceResult.near``, measured by the first run)
#: stops at its budget, the pair test runs again after ``PAIR_TEST_NEAR`` boxes with
#: ``NEAR_BUDGETS[0]`` times ``pair_test_boxes``, and at :data:`PAIR_TEST_LATE` with
#: ``NEAR_BUDGETS[1]`` times (docs/complete-solver.md, "Pair test").
PAIR_TEST_NEAR = 4
NEAR_BUDGETS = (2, 8)


@dataclass(frozen=True)
class BranchAndPruneOptions:
    """Options of the complete solver.

    Attributes:
        sigma: a box whose base variables are all narrower than ``sigma`` (relative to
            the initial box) is a solution box and is not split further.
        order: ``"depth"`` (stop at the first verified solution) or ``"breadth"``.
        all_solutions: keep searching after a verified solution (solution-set mode).
        max_boxes: stop (``gave_up``) after this many boxes.  In the solution-set mode
            (``all_solutions``) without it, the search stops after
            :data:`ALL_SOLUTIONS_MAX_BOXES` boxes (or at ``time_limit_s``, if sooner).
        time_limit_s: stop (``gave_up``) after this many seconds.
        shrink: box-shrinking options.
        verify_starts: points of each box the verification starts from: its centre and
            ``verify_starts - 1`` pseudo-random points (seeded by the box's bounds, so a
            box is verified the same way in every process).
        verifier: the local iterations that verify a box (:class:`.verifier.BoxVerifier`,
            given by the caller: :func:`prehension.solve` gives the local solver's,
            :class:`prehension.solvers.local.verifier.LocalVerifier`); recorded by its
            options, as ``"refine"``.  None: no box is verified (the search still prunes
            and proves infeasibility; a box narrower than ``sigma`` is kept unverified).
        tolerances: what counts as a verified solution (strict by default).
        pair_test_boxes: box budget of the pose-free pair test
            (:func:`.pair.congruence_test`): a proof that two contacts cannot be
            made together whatever the object's pose ends the search as infeasible.  It
            runs with a tenth of this budget when the first box holds no verified
            solution, and again with all of it after :data:`PAIR_TEST_LATE` boxes
            without one (unless the first run met a witness: a box of the pair's
            variables narrower than 1e-7 that satisfies its conditions); near the reach
            frontier earlier, with more (:data:`PAIR_TEST_NEAR`); pairs whose two-contact
            sub-task the verifier solves are skipped (:mod:`.witnesses`).  0 turns it off.
            A budget in boxes, not seconds, so that the search is the same on every machine.
        collision_prune: discard a box when an enclosure proves that every
            configuration in it puts a link deeper into the object than
            ``tolerances.object_penetration_mm`` (:mod:`.collision`; only for an object
            that collides).  ``False``: such boxes are searched until ``sigma``.
        self_collision_prune: discard a box when an enclosure proves that every
            solution in it has two capsules of the hand deeper into each other than
            ``tolerances.penetration_mm`` (:mod:`.self_collision`).  ``False``: such
            boxes are searched until ``sigma``.
        require: ``"force-closure"``: only force-closure grasps count as solutions (with
            the friction model ``quality``), and a box is discarded when a certificate
            proves that none of its configurations is force closure (:mod:`.closure`); an
            ``infeasible`` answer then proves that the task has no force-closure grasp.
            ``None``: any grasp.
        quality: the friction model of ``require``.
    """

    sigma: float = 0.1
    order: Literal["depth", "breadth"] = "depth"
    all_solutions: bool = False
    max_boxes: int | None = None
    time_limit_s: float | None = None
    shrink: ShrinkOptions = field(default_factory=ShrinkOptions)
    verify_starts: int = 8
    verifier: BoxVerifier | None = None
    tolerances: Tolerances = field(default_factory=Tolerances)
    pair_test_boxes: int = 200_000
    collision_prune: bool = True
    self_collision_prune: bool = True
    require: Literal["force-closure"] | None = None
    quality: QualityOptions = field(default_factory=QualityOptions)

    def __post_init__(self):
        if not 0.0 < self.sigma < 1.0:
            raise PrehensionError(f"sigma must lie in (0, 1) (a fraction of the initial box), got {self.sigma}")
        if not (isinstance(self.verify_starts, int) and self.verify_starts >= 1):
            raise PrehensionError(f"verify_starts must be an integer >= 1, got {self.verify_starts!r}")
        if not (isinstance(self.pair_test_boxes, int) and self.pair_test_boxes >= 0):
            raise PrehensionError(f"pair_test_boxes must be an integer >= 0, got {self.pair_test_boxes!r}")
        if self.order not in ("depth", "breadth"):
            raise PrehensionError(f"order must be 'depth' or 'breadth', got {self.order!r}")
        if self.require not in (None, "force-closure"):
            raise PrehensionError(f"require must be 'force-closure' or None (any grasp), got {self.require!r}")
        if not isinstance(self.quality, QualityOptions):
            raise PrehensionError(f"quality must be a QualityOptions, got {type(self.quality).__name__}")
        if self.verifier is not None and not isinstance(self.verifier, BoxVerifier):
            raise PrehensionError("verifier must be a BoxVerifier (a callable (task, starts) with its options, e.g. "
                                  f"prehension.solvers.local.verifier.LocalVerifier()), got {type(self.verifier).__name__}")


@dataclass(frozen=True, eq=False)
class BoxOutcome:
    """What processing one box gave."""

    kind: Literal["empty", "solution", "small", "split"]
    lower: np.ndarray
    upper: np.ndarray
    depth: int
    n_lps: int
    solution: Solution | None = None
    children: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
    best: tuple = (float("inf"), float("inf"))  # (contact_mm, normal_deg) the verification came closest to
    by_collision: bool = False  # "empty" because every configuration in it penetrates the object
    by_self_collision: bool = False  # "empty" because every solution in it collides with the hand itself
    by_closure: bool = False  # "empty" because no configuration in it is force closure (require="force-closure")


def _verification_points(lower: np.ndarray, upper: np.ndarray, n: int) -> np.ndarray:
    """The box centre, then ``n - 1`` points drawn in the box's middle half (deterministic)."""
    seed = zlib.crc32(np.ascontiguousarray(lower).tobytes() + np.ascontiguousarray(upper).tobytes())
    u = np.random.default_rng(seed).uniform(0.25, 0.75, (n - 1, lower.size))
    return np.vstack([0.5 * (lower + upper), lower + u * (upper - lower)])


def _verification_starts(form: Formulation, options: BranchAndPruneOptions, lower=None, upper=None) -> list:
    """The configurations a box (by default the initial box) is verified from."""
    lower = form.system.lower if lower is None else lower
    upper = form.system.upper if upper is None else upper
    points = _verification_points(lower, upper, options.verify_starts)
    return [configuration_from_point(form, x) for x in points]


def _verify(
    form: Formulation, lower, upper, options: BranchAndPruneOptions, *, in_box: bool = False
) -> tuple[Solution | None, tuple]:
    """A verified solution reached by local iterations from points of the box (or None),
    and how close the closest of them came: ``(contact_mm, normal_deg)``.

    The iterations (``options.verifier``, :mod:`.verifier`) work on the original
    constraints and may leave the box; whatever they reach is judged by
    :func:`make_solution` alone, so a returned solution is a solution of the task.
    ``in_box``: only a solution inside the box counts (describing the solution set).
    Without a verifier, none (and no best residual).
    """
    if options.verifier is None:
        return None, (float("inf"), float("inf"))
    reached = options.verifier(form.task, _verification_starts(form, options, lower, upper))
    for config in reached.configurations:
        if config is not None:
            solution = make_solution(form.task, config, options.tolerances)
            if solution is not None and (not in_box or _inside(form, solution, lower, upper)) and _required(form, solution, options):
                return solution, reached.best()
    return None, reached.best()


def process_box(form: Formulation, lower, upper, depth: int, options: BranchAndPruneOptions) -> BoxOutcome:
    """Contract, try to verify, shrink, then split or keep one box (a pure function).

    Looking for one solution, verification comes before the linear programs: in the
    large solution sets of grasp problems local iterations from a few points of the box
    often succeed at once (a few ms), far less than a round of LPs.  Describing the
    solution set (``all_solutions``), boxes are split down to ``sigma`` and only those
    leaves are verified, by a solution that lies in the leaf itself, so that each
    solution box reports its own solution.

    ``options.time_limit_s`` is, here, the time the search has left (:func:`_box_options`):
    no LP of the box starts after it (the box is then shrunk less, which is safe).
    """
    lower, upper, empty = contract(form.system, lower, upper, tol=options.shrink.contract_tol,
                                   max_iter=options.shrink.contract_max_iter)  # fmt: skip
    if empty:
        return BoxOutcome("empty", lower, upper, depth, 0)
    if _penetrates(form, lower, upper, options):
        return BoxOutcome("empty", lower, upper, depth, 0, by_collision=True)
    if _self_collides(form, lower, upper, options):
        return BoxOutcome("empty", lower, upper, depth, 0, by_self_collision=True)
    if _never_closure(form, lower, upper, options):
        return BoxOutcome("empty", lower, upper, depth, 0, by_closure=True)
    best = (float("inf"), float("inf"))
    if not options.all_solutions:
        solution, best = _verify(form, lower, upper, options)
        if solution is not None:
            return BoxOutcome("solution", lower, upper, depth, 0, solution, best=best)
    shrunk = shrink_box(form.system, lower, upper, replace(options.shrink, variables=shrink_variables(form)),
                        deadline=deadline_after(options.time_limit_s), rotations=cut_rotations(form, options.shrink))
    if shrunk.empty:
        return BoxOutcome("empty", shrunk.lower, shrunk.upper, depth, shrunk.n_lps, best=best)
    lo, hi = shrunk.lower, shrunk.upper
    if _penetrates(form, lo, hi, options):
        return BoxOutcome("empty", lo, hi, depth, shrunk.n_lps, best=best, by_collision=True)
    if _self_collides(form, lo, hi, options):
        return BoxOutcome("empty", lo, hi, depth, shrunk.n_lps, best=best, by_self_collision=True)
    if _never_closure(form, lo, hi, options):
        return BoxOutcome("empty", lo, hi, depth, shrunk.n_lps, best=best, by_closure=True)
    widths = scaled_widths(form, lo, hi)
    if widths.max() < options.sigma:
        if options.all_solutions:
            solution, best = _verify(form, lo, hi, options, in_box=True)
            if solution is not None:
                return BoxOutcome("solution", lo, hi, depth, shrunk.n_lps, solution, best=best)
        return BoxOutcome("small", lo, hi, depth, shrunk.n_lps, best=best)
    k = split_variable(form, lo, hi, options.shrink)
    mid = 0.5 * (lo[k] + hi[k])
    left_hi, right_lo = hi.copy(), lo.copy()
    left_hi[k], right_lo[k] = mid, mid
    return BoxOutcome("split", lo, hi, depth, shrunk.n_lps, children=((lo, left_hi), (right_lo, hi)), best=best)


def _penetrates(form: Formulation, lower, upper, options: BranchAndPruneOptions) -> bool:
    """Whether every configuration of the box puts a link into the object (:mod:`.collision`)."""
    if not options.collision_prune:
        return False
    return collision_prune(form, lower, upper, options.tolerances) is not None


def _self_collides(form: Formulation, lower, upper, options: BranchAndPruneOptions) -> bool:
    """Whether every solution of the box collides with the hand itself (:mod:`.self_collision`)."""
    if not options.self_collision_prune:
        return False
    return self_collision_prune(form, lower, upper, options.tolerances) is not None
# -- require="force-closure" (kept apart: :mod:`.closure` proves, these two apply it) --------------
def _never_closure(form: Formulation, lower, upper, options: BranchAndPruneOptions) -> bool:
    """Whether a certificate proves that no configuration of the box is force closure (:mod:`.closure`)."""
    return options.require == "force-closure" and closure_prune(form, lower, upper, options.quality) is not None


def _required(form: Formulation, solution: Solution, options: BranchAndPruneOptions) -> bool:
    """Whether a verified solution also meets ``options.require``."""
    return options.require is None or grasp_quality(form.task, solution, options.quality).force_closure


def _inside(form: Formulation, solution: Solution, lower, upper) -> bool:
    """Whether a solution's base coordinates lie in the box (to rounding)."""
    x = embed(form, solution.configuration())
    base = form.base_indices
    slack = 1e-9 * np.maximum(form.system.upper - form.system.lower, 1.0)[base]
    return bool(np.all(x[base] >= lower[base] - slack) and np.all(x[base] <= upper[base] + slack))


# -- the driver -------------------------------------------------------------------------
def _record(state: SearchState, out: BoxOutcome, options: BranchAndPruneOptions) -> None:
    state.boxes += 1
    state.lps += out.n_lps
    state.best = min(state.best, out.best, key=lambda b: max(b))
    state.max_depth = max(state.max_depth, out.depth)
    state.collision_pruned += out.by_collision
    state.self_collision_pruned += out.by_self_collision
    state.closure_pruned += out.by_closure
    if out.kind == "solution":
        state.solutions.append(out.solution)
    elif out.kind == "small":
        state.small.append((out.lower, out.upper))
    elif out.kind == "split":
        children = [(lo, hi, out.depth + 1) for lo, hi in out.children]
        if options.order == "depth":
            state.open.extend(reversed(children))  # the first child is processed next
        else:
            state.open.extendleft(children)


def _done(state: SearchState, options: BranchAndPruneOptions) -> bool:
    return bool(state.solutions) and not options.all_solutions


def _box_budget(options: BranchAndPruneOptions) -> int | None:
    """``max_boxes``, or the solution-set mode's default budget when no box limit is given
    (a time limit still applies beside it: whichever comes first)."""
    if options.max_boxes is None and options.all_solutions:
        return ALL_SOLUTIONS_MAX_BOXES
    return options.max_boxes


def _limits_hit(state: SearchState, options: BranchAndPruneOptions, started: float) -> str:
    budget = _box_budget(options)
    if budget is not None and state.boxes >= budget:
        default = " (the default of the solution-set mode)" if options.max_boxes is None else ""
        return f"box limit ({budget}){default} reached"
    if options.time_limit_s is not None and time.perf_counter() - started > options.time_limit_s:
        return f"time limit ({options.time_limit_s:g} s) reached"
    return ""


def solve_complete(
    task: Task,
    options: BranchAndPruneOptions = BranchAndPruneOptions(),
    *,
    executor: Executor | None = None,
    workers: int = 1,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    progress: Callable[[dict], None] | None = None,
) -> SolveResult:
    """Solve ``task`` by branch and prune (see the module docstring).

    Args:
        task: the task.
        options: :class:`BranchAndPruneOptions`.
        executor: where boxes are processed (default: in this process); ``workers``
            boxes are kept in flight on it.
        checkpoint: file where the open boxes are saved when the search stops early or
            is interrupted (Ctrl-C; on the command line also SIGTERM and SIGHUP,
            :mod:`prehension.cli.terminate`); with ``resume=True`` the search starts from it.
        progress: called after each box with counters (boxes, open, depth, lps), and with
            ``"pair test"`` when the pair test starts (it can take a minute).
    """
    started = time.perf_counter()
    with scope(deadline_after(options.time_limit_s, started)):  # the hand's span bounds stop at it
        form = build_system(task, options.shrink.quaternions, options.shrink.angles)
    fingerprint = search_fingerprint(form, options) if checkpoint is not None else {}
    if resume:
        state = load_state(form, options, checkpoint)
    else:
        state = SearchState(deque([(form.system.lower.copy(), form.system.upper.copy(), 0)]))
    try:
        stop = _run(form, state, options, executor, max(1, workers), started, progress)
    except KeyboardInterrupt as exc:  # Ctrl-C; in the CLI also SIGTERM and SIGHUP (str(exc): the signal's name)
        save_state(checkpoint, state, fingerprint)
        how = f" ({exc})" if str(exc) else ""
        return _result(task, form, state, options, started, f"interrupted{how}" + _saved_note(checkpoint))
    if stop:
        save_state(checkpoint, state, fingerprint)
        stop += _saved_note(checkpoint)
    in_open = _verify_open_boxes(form, state, options) if stop and options.all_solutions else ()
    return _result(task, form, state, options, started, stop, in_open)


def _verify_open_boxes(form: Formulation, state: SearchState, options: BranchAndPruneOptions) -> tuple[Solution, ...]:
    """A stopped description of the solution set: the boxes still open complete the cover
    (the pruned boxes hold no solution); each is verified for a solution inside it, so a
    stopped run still answers with the verified solutions it can.  They are not added to
    the search state (a resumed search finds them again in the leaves)."""
    found = []
    for lower, upper, _ in state.open:
        solution, _ = _verify(form, lower, upper, options, in_box=True)
        if solution is not None:
            found.append(solution)
    return tuple(found)


def _saved_note(checkpoint) -> str:
    return f"; search state saved to {checkpoint} (resume with --resume)" if checkpoint else ""


def _run(form, state, options, executor, workers, started, progress) -> str:
    """Process boxes until done; returns why it stopped early ('' when it finished).

    The boxes are taken in the order of the one-process search (the right end of
    ``state.open``), and each outcome is recorded in that order, so the search visits
    the same boxes and returns the same answer with any executor and any number of
    workers.  An executor only works *ahead*: the next ``workers`` boxes in that order
    are submitted before their turn (speculatively: in depth-first order they may be
    needed later than the boxes their predecessors split into, or not at all once a
    solution is found).
    """
    ahead: dict[int, object] = {}  # id of an entry of state.open -> its future
    try:
        while state.open:
            if _done(state, options):
                return ""
            reason = _limits_hit(state, options, started)
            if reason:
                return reason
            entry = state.open[-1]
            if executor is None:
                outcome = process_box(form, *entry, _box_options(options, started))
            else:
                _submit_ahead(form, state, _box_options(options, started), executor, workers, ahead)
                outcome = ahead.pop(id(entry)).result()
            state.open.pop()
            _record(state, outcome, options)
            if not state.solutions and state.open and options.pair_test_boxes:
                _pair_test(form, state, options, started, progress)
            _report(progress, state, len(ahead))
        return ""
    finally:
        for future in ahead.values():
            future.cancel()


def _box_options(options: BranchAndPruneOptions, started: float) -> BranchAndPruneOptions:
    """The options a box is processed with: ``time_limit_s`` is what the search has left."""
    if options.time_limit_s is None:
        return options
    return replace(options, time_limit_s=max(options.time_limit_s - (time.perf_counter() - started), 1e-3))


def _pair_test(form: Formulation, state: SearchState, options: BranchAndPruneOptions, started: float,
               progress: Callable[[dict], None] | None = None) -> None:  # fmt: skip
    """The pose-free pair test at its two moments (see ``pair_test_boxes``); when it proves
    two contacts incompatible no box can hold a solution: the open (and small) boxes are
    discarded and the proof kept in the state.  It stops with the search's time limit and
    says on ``progress`` that it runs (it can take a minute)."""
    planned = _pair_test_plan(form, state, options)
    if planned is None:
        return
    budget, makeable = planned
    seconds = None
    if options.time_limit_s is not None:
        seconds = options.time_limit_s - (time.perf_counter() - started)
        if seconds <= 0.0:
            return
    if progress is not None:
        progress({"boxes": state.boxes, "open": len(state.open), "pair test": f"running (up to {budget} boxes)"})
    proof = congruence_test(form.task, max_boxes=budget, time_limit_s=seconds, makeable=makeable)
    state.pair_test = proof
    if proof.proved:
        state.open.clear()
        state.small.clear()


def _pair_test_plan(form: Formulation, state: SearchState, options: BranchAndPruneOptions):
    """``(budget, makeable pairs)`` of the pair test due after this box, or None."""
    if state.boxes == 1:
        return options.pair_test_boxes // 10, makeable_pairs(form.task, options.verifier, _verification_starts(form, options))
    last = state.pair_test
    if last is None:
        return None
    if state.boxes == PAIR_TEST_NEAR and last.undecided_near():
        return NEAR_BUDGETS[0] * options.pair_test_boxes, last.skipped
    if state.boxes == PAIR_TEST_LATE and any(outcome.stopped == "budget" for _, outcome in last.outcomes):
        # (not when every pair met a witness, was makeable or had no test: more boxes would not prove it)
        return (NEAR_BUDGETS[1] if last.undecided_near() else 1) * options.pair_test_boxes, last.skipped
    return None


def _submit_ahead(form, state: SearchState, options, executor: Executor, workers: int, ahead: dict) -> None:
    """Make sure the next ``workers`` boxes in the search order are submitted."""
    for k in range(1, min(workers, len(state.open)) + 1):
        entry = state.open[-k]
        if id(entry) not in ahead:
            ahead[id(entry)] = executor.submit(process_box, form, *entry, options)


def _report(progress, state: SearchState, in_flight: int) -> None:
    if progress is not None:
        best = f"{state.best[0]:.3g} mm, {state.best[1]:.3g} deg" if np.isfinite(max(state.best)) else "-"
        progress({"boxes": state.boxes, "open": len(state.open) + in_flight, "depth": state.max_depth, "lps": state.lps,
                  "best residual": best})  # fmt: skip


def _result(task, form, state: SearchState, options, started: float, stop: str, in_open: tuple = ()) -> SolveResult:
    seconds = time.perf_counter() - started
    stats = {"boxes": state.boxes, "lps": state.lps, "max_depth": state.max_depth, "open_boxes": len(state.open),
             "n_variables": form.system.n, "n_equations": form.system.n_equations, "options": _options_dict(options),
             "best_residual": {"contact_mm": state.best[0], "normal_deg": state.best[1]} if np.isfinite(max(state.best)) else None}  # fmt: skip
    small = tuple(state.small)
    if options.all_solutions and stop and (state.solutions or in_open):
        status = Status.SOLVED
        msg = (f"partial description of the solution set (stopped: {stop}): {len(state.solutions)} solution box(es) "
               f"with a verified solution and {len(small)} without, and {len(state.open)} open box(es) wider than sigma, "
               f"{len(in_open)} of them with a verified solution inside, after {state.boxes} boxes and {state.lps} LPs")  # fmt: skip
    elif state.solutions and options.all_solutions:
        status = Status.SOLVED
        msg = (f"{len(state.solutions)} solution box(es) with a verified solution and {len(small)} without, "
               f"after {state.boxes} boxes and {state.lps} LPs")  # fmt: skip
    elif state.solutions:
        status, msg = Status.SOLVED, f"verified solution found after {state.boxes} boxes and {state.lps} LPs"
    elif stop:
        status, msg = Status.GAVE_UP, f"stopped: {stop}"
    elif small:
        status = Status.GAVE_UP
        msg = f"{len(small)} box(es) narrower than sigma hold no verified solution; try a smaller sigma"
    elif state.pair_test is not None and state.pair_test.proved:
        a, b = state.pair_test.pair
        status = Status.INFEASIBLE
        msg = (f"infeasible: contacts {task.contacts[a].name} and {task.contacts[b].name} cannot be made together "
               f"whatever the object's pose (pair test: {state.pair_test.boxes} boxes pruned, after {state.boxes} "
               f"box(es) and {state.lps} LPs of the search)")  # fmt: skip
    elif state.closure_pruned:
        status = Status.INFEASIBLE
        msg = (f"infeasible: no force-closure grasp: all {state.boxes} boxes pruned, {state.closure_pruned} of them by a "
               f"certificate that no configuration in them is force closure ({_friction(options.quality)}; "
               f"{state.collision_pruned} for hand-object collision, {state.self_collision_pruned} for self-collision, "
               f"{state.lps} linear programs)")  # fmt: skip
    elif state.collision_pruned or state.self_collision_pruned:
        status = Status.INFEASIBLE
        msg = _collision_message(state)
    else:
        status = Status.INFEASIBLE
        msg = f"infeasible: all {state.boxes} boxes pruned ({state.lps} linear programs)"
    stats["open_box_solutions"] = len(in_open)
    stats["open_share"] = state.open_share()
    stats["collision_pruned"] = state.collision_pruned
    stats["self_collision_pruned"] = state.self_collision_pruned
    if options.require is not None:
        stats["closure_pruned"] = state.closure_pruned
    if state.resumed is not None:
        stats["resumed"] = dict(state.resumed)
        if status == Status.INFEASIBLE:
            msg += _resumed_note(state.resumed)
    if state.pair_test is not None:
        stats["pair_test"] = {"proved": state.pair_test.proved, "boxes": state.pair_test.boxes,
                              "pair": list(state.pair_test.pair) if state.pair_test.pair else None,
                              "makeable": sorted(map(list, state.pair_test.skipped))}  # fmt: skip
    return SolveResult(task, "complete", status, msg, tuple(state.solutions) + in_open, seconds, stats, small)


def _collision_message(state: SearchState) -> str:
    """The certificate of a search that pruned boxes for collision: with the object ("no
    penetration-free solution"), with the hand itself ("no self-collision-free solution"),
    or both ("no collision-free solution")."""
    why = []
    if state.collision_pruned:
        why.append(f"{state.collision_pruned} of them because every configuration in them puts the hand into the object")
    if state.self_collision_pruned:
        why.append(f"{state.self_collision_pruned} of them because every solution in them has the hand collide with itself")
    what = {(True, False): "penetration-free", (False, True): "self-collision-free"}.get(
        (bool(state.collision_pruned), bool(state.self_collision_pruned)), "collision-free")
    return f"infeasible: no {what} solution: all {state.boxes} boxes pruned, {', '.join(why)} ({state.lps} linear programs)"


def _friction(quality: QualityOptions) -> str:
    soft = f", torsion {quality.torsion_mm:g} mm" if quality.torsion_mm else ""
    return f"friction {quality.friction:g}, {quality.cone_edges} cone edges{soft}"


def _resumed_note(resumed: dict) -> str:
    """Says that part of a proof came from a checkpoint (see :mod:`.checkpoint`)."""
    return (f"; resumed from checkpoint {resumed['checkpoint']}: {resumed['boxes']} of these boxes were pruned "
            "before it was saved, so part of this proof rests on the checkpoint (prehension check re-proves it "
            "from the initial box)")  # fmt: skip


def _options_dict(options: BranchAndPruneOptions) -> dict:
    d = options_record(options)
    d.pop("tolerances", None)
    if options.require is None:
        d.pop("quality", None)  # the friction model only matters to the requirement
    else:
        d["quality"] = options.quality.to_dict()
    return d
