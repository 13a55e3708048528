"""Pairs shown makeable by a solution of their two-contact sub-task (solvers/complete/witnesses.py):
the pair test skips them -- never a pair that cannot be made, and the proofs stay."""

from __future__ import annotations

from prehension.geometry.regions import PointRegion
from prehension.hands.sa_hand import schunk_sa_hand
from prehension.objects.model import GraspObject
from prehension.results import Status, make_solution
from prehension.solvers.complete import pair as cg
from prehension.solvers.complete.search import BranchAndPruneOptions, _verification_starts, solve_complete
from prehension.solvers.complete.witnesses import makeable_pairs, pair_task
from prehension.solvers.local.verifier import LocalVerifier
from prehension.system.formulation import build_system
from prehension.tasks.library import load_builtin_task
from prehension.tasks.model import Contact, Task


def _three_points(width_mm: float) -> Task:
    """Thumb on ``a``, index and middle on ``b`` and ``c`` (20 mm apart side by side, facing
    away from ``a``), ``width_mm`` from ``a``: past the thumb and index's span at 180 mm
    (219.6 mm between their centres, the normals facing away), within the thumb and
    middle's (241 mm)."""
    obj = GraspObject("three-points", {"a": PointRegion((0, 0, 0), (-1, 0, 0)),
                                       "b": PointRegion((width_mm, 0, 0), (1, 0, 0)),
                                       "c": PointRegion((width_mm, 0, 20.0), (1, 0, 0))})  # fmt: skip
    contacts = (Contact("thumb_tip", "a"), Contact("index_tip", "b"), Contact("middle_tip", "c"))
    return Task("three", schunk_sa_hand(), obj, contacts, ("thumb", "index", "middle"))


def _makeable(task: Task) -> frozenset:
    options = BranchAndPruneOptions(verifier=LocalVerifier())
    return makeable_pairs(task, options.verifier, _verification_starts(build_system(task), options))


def test_a_pair_past_reach_is_never_makeable_and_the_pair_test_proves_it_alone():
    """The thumb 180 mm from the index and the middle: (thumb, index) cannot be made, the
    other two pairs are makeable; the search's pair test skips them and proves (thumb,
    index), as it did testing every pair."""
    task = _three_points(180.0)
    assert _makeable(task) == {(0, 2), (1, 2)}
    result = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=50))
    assert result.status == Status.INFEASIBLE, result.message
    assert "cannot be made together whatever the object's pose" in result.message
    stats = result.stats["pair_test"]
    assert stats["proved"] and stats["makeable"] == [[0, 2], [1, 2]] and stats["pair"] == [0, 1]


def test_every_pair_of_a_feasible_task_is_makeable_by_a_strict_solution_of_its_sub_task():
    """scalpel-handling (three contacts): each pair's sub-task is solved from the initial
    box's verification points, and a solution found again for it is strict.  (Finding a
    witness is a search: teapot-service's (0, 1) is makeable -- the task is solved -- but not
    from those points since the SA palm was redrawn; a pair not shown makeable is only
    tested, never wrongly skipped.)"""
    task = load_builtin_task("scalpel-handling")
    makeable = _makeable(task)
    assert makeable == {(0, 1), (0, 2), (1, 2)}
    for a, b in makeable:
        sub = pair_task(task, a, b)
        assert [c.name for c in sub.contacts] == [task.contacts[a].name, task.contacts[b].name]
        result = solve_complete(sub, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=2))
        assert result.status == Status.SOLVED
        assert make_solution(sub, result.solutions[0].configuration()) is not None


def test_the_pair_test_skips_the_makeable_pairs_and_gives_their_budget_to_the_others():
    task = load_builtin_task("teapot-service")
    skipped = frozenset({(0, 1), (0, 2)})
    result = cg.congruence_test(task, max_boxes=3000, makeable=skipped)
    assert [pair for pair, _ in result.outcomes] == [(1, 2)] and result.skipped == skipped
    assert not result.proved
    every = cg.congruence_test(task, max_boxes=3000)
    assert [pair for pair, _ in every.outcomes] == [(0, 1), (0, 2), (1, 2)] and not every.skipped


def test_no_pair_is_skipped_with_two_contacts_or_without_a_verifier():
    task = load_builtin_task("guitar-tuning")
    assert _makeable(task) == frozenset()
    three = load_builtin_task("teapot-service")
    assert makeable_pairs(three, None, _verification_starts(build_system(three), BranchAndPruneOptions())) == frozenset()


# -- the pair test's moments near the reach frontier ----------------------------------------------
def _outcome(stopped: str) -> cg.PairOutcome:
    return cg.PairOutcome(False, 10, 0.1, stopped)


def test_a_pair_near_the_frontier_that_stops_at_its_budget_gets_earlier_and_larger_runs():
    from types import SimpleNamespace

    from prehension.solvers.complete import search

    options = BranchAndPruneOptions(verifier=LocalVerifier(), pair_test_boxes=1000)
    near = cg.CongruenceResult(False, None, (((0, 1), _outcome("budget")),), frozenset({(2, 3)}), frozenset({(0, 1)}))
    far = cg.CongruenceResult(False, None, (((0, 1), _outcome("budget")),), frozenset(), frozenset())
    met = cg.CongruenceResult(False, None, (((0, 1), _outcome("witness")),), frozenset(), frozenset({(0, 1)}))
    plan = lambda boxes, last: search._pair_test_plan(None, SimpleNamespace(boxes=boxes, pair_test=last), options)  # noqa: E731
    assert near.undecided_near() and not far.undecided_near() and not met.undecided_near()
    assert plan(search.PAIR_TEST_NEAR, near) == (search.NEAR_BUDGETS[0] * 1000, frozenset({(2, 3)}))
    assert plan(search.PAIR_TEST_NEAR, far) is None
    assert plan(search.PAIR_TEST_LATE, near) == (search.NEAR_BUDGETS[1] * 1000, frozenset({(2, 3)}))
    assert plan(search.PAIR_TEST_LATE, far) == (1000, frozenset())
    assert plan(search.PAIR_TEST_LATE, met) is None  # a witness: more boxes would not prove it
    assert plan(7, near) is None


def test_the_pair_test_marks_the_pairs_whose_floor_comes_within_five_percent_of_the_span():
    """Two points with normals facing away, 60 mm apart (the fingertip centres 86 mm apart, far
    from the thumb and index's 212.5 mm) and 180 mm (206 mm: within 10.6 mm of it): only the
    second is near."""
    from prehension.solvers.complete.pair.span import pair_span_mm, span_test

    for width, expected in ((60.0, False), (180.0, True)):
        obj = GraspObject("two", {"a": PointRegion((0, 0, 0), (-1, 0, 0)), "b": PointRegion((width, 0, 0), (1, 0, 0))})
        task = Task("pinch", schunk_sa_hand(), obj, (Contact("thumb_tip", "a"), Contact("index_tip", "b")), ("thumb", "index"))
        pp = cg.pair_problem(task, 0, 1)
        _, floor, _, _ = span_test(pp, task.hand, 1000)
        span = pair_span_mm(pp, task.hand)
        assert (span - floor <= cg.congruence.NEAR_SPAN_FRACTION * span) == expected
        result = cg.congruence_test(task, max_boxes=2000)
        assert ((0, 1) in result.near) == expected
