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
    """teapot-service (three fingertips on its handle): each pair's sub-task is solved from
    the initial box's verification points, and a solution found again for it is strict."""
    task = load_builtin_task("teapot-service")
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
