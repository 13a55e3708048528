"""The pair test of a task: every pair of contacts, through the span test, the matching and
the product test (the one entry point of :mod:`prehension.solvers.complete.pair`)."""

from __future__ import annotations

import time
from dataclasses import dataclass

from ....tasks.model import Task
from .matching import prove_pair_by_matching
from .problem import PairOutcome, PairProblem, pair_problem
from .product import prove_pair_infeasible
from .span import OUT_OF_SPAN_BOXES, pair_span_mm, span_test

__all__ = ["MATCHING_BOXES", "NEAR_FRONTIER_MM", "CongruenceResult", "congruence_test"]


#: A pair whose object side's floor of the fingertip centres' distance comes within this of
#: the hand's span [mm] is near the reach frontier: the matching gets the pair's whole budget
#: (at most :data:`MATCHING_BOXES`) instead of a quarter, so that the search's first pair
#: test (20,000 boxes) runs its extremes and hand stage (``matching.EXTREMES_FROM``) and
#: decides the frontier families at the first box instead of the sixteenth.  No pair of the
#: built-in tasks comes within 32 mm (their floors are 0-128 mm, their spans 150-241 mm).
NEAR_FRONTIER_MM = 10.0

#: A pair whose object side's floor comes within this fraction of the hand's span (or within
#: :data:`NEAR_FRONTIER_MM`) is marked *near* in :attr:`CongruenceResult.near`, for the
#: search's earlier and larger pair tests (``search.PAIR_TEST_NEAR``): the two-fingertip
#: families of ``frontier.py --random 20 --seed 1`` come within 6-10.2 mm (2.5-3% of spans of
#: 238-342 mm) a millimetre past their frontier; no pair of the built-in tasks within 13%.
NEAR_SPAN_FRACTION = 0.05

#: At most this many boxes (both sides) of the pair test by matching ranges (:mod:`.matching`)
#: per pair: on a pair that can be made, its boxes survive on both sides and matching them
#: costs more than linearly (guitar-holding, 100,000 boxes: 26 s more than the product test's);
#: the lid needs 21,166 at t* + 1 mm and 27,782 at t* + 0.5 mm.
MATCHING_BOXES = 40_000


# -- every pair of a task ---------------------------------------------------------------------------
@dataclass(frozen=True)
class CongruenceResult:
    """The pair test of a task: ``proved`` with the pair, or not, with the outcomes."""

    proved: bool
    pair: tuple[int, int] | None
    outcomes: tuple[tuple[tuple[int, int], PairOutcome], ...]
    skipped: frozenset[tuple[int, int]] = frozenset()  # pairs given as makeable: not tested
    near: frozenset[tuple[int, int]] = frozenset()  # pairs near the reach frontier (NEAR_SPAN_FRACTION)

    def undecided_near(self) -> bool:
        """Whether a pair near the reach frontier stopped at its budget (more boxes may prove it)."""
        return any(pair in self.near and outcome.stopped == "budget" for pair, outcome in self.outcomes)

    @property
    def boxes(self) -> int:
        return sum(o.boxes for _, o in self.outcomes)


def congruence_test(task: Task, *, max_boxes: int = 200_000, time_limit_s: float | None = None,
                    makeable: frozenset[tuple[int, int]] = frozenset()) -> CongruenceResult:  # fmt: skip
    """The pair test on every pair of contacts (until one is proved infeasible): first the
    object side against the hand's span (:func:`.span.prove_out_of_span`, at most
    :data:`.span.OUT_OF_SPAN_BOXES` boxes, not counted in ``max_boxes``), then, without a proof,
    the test by matching ranges (:mod:`.matching`, a quarter of the pair's budget, all of it
    near the reach frontier: :data:`NEAR_FRONTIER_MM`) and the
    product test (:func:`.product.prove_pair_infeasible`, the rest); the box budget ``max_boxes`` and the time limit are
    shared evenly by the pairs.  Pairs in ``makeable`` (``(a, b)``, ``a < b``: known to be
    makeable, e.g. by a solution of their two-contact sub-task, :mod:`..witnesses`) are not
    tested -- a sound test cannot prove them -- and their shares go to the others."""
    pairs = [(a, b) for a in range(len(task.contacts)) for b in range(a + 1, len(task.contacts))]
    skipped = frozenset(p for p in pairs if p in makeable)
    pairs = [p for p in pairs if p not in skipped]
    share = max(1, max_boxes // max(1, len(pairs)))
    seconds = None if time_limit_s is None else time_limit_s / max(1, len(pairs))
    outcomes, near = [], set()
    for a, b in pairs:
        pp = pair_problem(task, a, b)
        if pp is None:
            continue
        started = time.perf_counter()
        proved, floor, _, boxes = span_test(pp, task.hand, OUT_OF_SPAN_BOXES)
        if proved:  # the object side alone is out of the hand's span
            outcome = PairOutcome(True, boxes, time.perf_counter() - started)
        else:
            span = pair_span_mm(pp, task.hand)
            if span - floor <= max(NEAR_FRONTIER_MM, NEAR_SPAN_FRACTION * span):
                near.add((a, b))
            outcome = _matching_then_product(pp, share, seconds, floor, span)
        outcomes.append(((a, b), outcome))
        if outcome.proved:
            return CongruenceResult(True, (a, b), tuple(outcomes), skipped, frozenset(near))
    return CongruenceResult(False, None, tuple(outcomes), skipped, frozenset(near))


def _matching_then_product(pp: PairProblem, max_boxes: int, time_limit_s: float | None, floor_mm: float,
                           span_mm: float) -> PairOutcome:  # fmt: skip
    """The pair test by matching ranges (:func:`.matching.prove_pair_by_matching`) with a quarter
    of the budget, all of it near the reach frontier (:data:`NEAR_FRONTIER_MM`; at most
    :data:`MATCHING_BOXES`; its boxes cost more on small budgets:
    guitar-holding's first pair test) and half of the time, then, without a proof, the product test with the rest; the boxes
    of both are counted."""
    started = time.perf_counter()
    half_time = None if time_limit_s is None else 0.5 * time_limit_s
    near = span_mm - floor_mm <= NEAR_FRONTIER_MM  # the matching decides such pairs: give it all
    share = max_boxes if near else max_boxes // 4
    first = prove_pair_by_matching(pp, max_boxes=max(1, min(share, MATCHING_BOXES)), time_limit_s=half_time,
                                   distance_floor_mm=floor_mm)  # fmt: skip
    if first.proved:
        return first
    rest = None if time_limit_s is None else max(time_limit_s - (time.perf_counter() - started), 0.0)
    # the floor prunes only when the fingertips must be held wide apart (it costs a second
    # evaluation of the kinematics per box)
    floor_mm = floor_mm if floor_mm > 0.5 * span_mm else 0.0
    second = prove_pair_infeasible(pp, max_boxes=max(1, max_boxes - first.boxes), time_limit_s=rest, distance_floor_mm=floor_mm)
    return PairOutcome(second.proved, first.boxes + second.boxes, time.perf_counter() - started, second.stopped, second.witness)
