"""The assignment search (issue 30): enumeration, the symmetry rule, span proofs, and the
search against solving every assignment alone."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fk_tasks import build_fk_case
from tiny_tasks import pincer_task
from prehension.assignment import (
    AssignmentOptions,
    Impossible,
    OpenContact,
    OpenTask,
    assignment_seed,
    check_span_proof,
    concrete_task,
    enumerate_assignments,
    prove_by_span,
    search_assignments,
)
from prehension.assignment.solving import solve_alone
from prehension.errors import InvalidTask
from prehension.hands.sa_hand import schunk_sa_hand
from prehension.tasks.model import Contact

SA_TIPS = ("thumb_tip", "index_tip", "middle_tip", "ring_tip")


def open_like(task, candidates=None, fingers=None) -> OpenTask:
    """``task`` with the hand side of every contact open (``candidates``; ``None``: any)."""
    contacts = tuple(OpenContact(c.object_region, candidates) for c in task.contacts)
    return OpenTask(task.name, task.hand, task.object, contacts, fingers)


# -- enumeration --------------------------------------------------------------------------
def test_counts_are_the_injective_assignments():
    case = build_fk_case(schunk_sa_hand(), np.random.default_rng(1), fingers=("thumb", "index", "middle"), palm=False)
    for k in range(1, 6):
        cands = (*SA_TIPS, "palm")[:k]
        if k < 3:
            with pytest.raises(InvalidTask, match="only .* candidate hand region"):
                open_like(case.task, cands)
            continue
        got = enumerate_assignments(open_like(case.task, cands))
        assert len(got) == math.perm(k, 3)
        assert len({a.hand_regions for a in got}) == len(got)
        assert all(len(set(a.hand_regions)) == 3 for a in got)


def test_interchangeable_contacts_are_enumerated_once():
    """Two open contacts on one object region with the same candidates: order is irrelevant."""
    case = build_fk_case(schunk_sa_hand(), np.random.default_rng(2), fingers=("thumb", "index"), palm=False)
    o0, o1 = (c.object_region for c in case.task.contacts)
    contacts = (OpenContact(o0, SA_TIPS), OpenContact(o0, SA_TIPS), OpenContact(o1, SA_TIPS))
    got = enumerate_assignments(OpenTask("sym", case.task.hand, case.task.object, contacts))
    assert len(got) == math.perm(4, 3) // 2  # each unordered pair on o0 once
    for a in got:
        assert SA_TIPS.index(a.hand_regions[0]) < SA_TIPS.index(a.hand_regions[1])
    # different candidates: not interchangeable, nothing pruned
    contacts = (OpenContact(o0, SA_TIPS), OpenContact(o0, SA_TIPS[:3]), OpenContact(o1, SA_TIPS))
    injective = [(x, y, z) for x in SA_TIPS for y in SA_TIPS[:3] for z in SA_TIPS if len({x, y, z}) == 3]
    assert len(enumerate_assignments(OpenTask("asym", case.task.hand, case.task.object, contacts))) == len(injective) == 18


def test_fixed_contacts_keep_their_region_and_fingers_follow_the_links():
    case = build_fk_case(schunk_sa_hand(), np.random.default_rng(3), fingers=("thumb", "index"), palm=False)
    c0, c1 = case.task.contacts
    task = OpenTask("mixed", case.task.hand, case.task.object, (Contact("thumb_tip", c0.object_region), OpenContact(c1.object_region)))
    got = enumerate_assignments(task)
    assert {a.hand_regions[0] for a in got} == {"thumb_tip"}
    assert "thumb_tip" not in {a.hand_regions[1] for a in got}
    assert len(got) == len(task.hand.regions) - 1
    concrete = concrete_task(task, next(a for a in got if a.hand_regions[1] == "ring_tip"))
    assert concrete.fingers == ("ring", "thumb")  # the hand's finger order
    palm = concrete_task(task, next(a for a in got if a.hand_regions[1] == "palm"))
    assert palm.fingers == ("thumb",)


def test_given_fingers_limit_any():
    case = build_fk_case(schunk_sa_hand(), np.random.default_rng(4), fingers=("thumb", "index"), palm=False)
    task = open_like(case.task, None, fingers=("thumb", "index"))
    assert set(task.usable_regions) == {"thumb_tip", "index_tip", "palm"}
    assert len(enumerate_assignments(task)) == 3 * 2
    with pytest.raises(InvalidTask, match="ring_tip.*does not take part"):
        open_like(case.task, ("ring_tip", "thumb_tip"), fingers=("thumb", "index"))


# -- bad input ------------------------------------------------------------------------------
def test_bad_open_tasks_are_named():
    case = build_fk_case(schunk_sa_hand(), np.random.default_rng(5), fingers=("thumb", "index"), palm=False)
    with pytest.raises(InvalidTask, match="hand region 'pinky_tip' not found; regions are: .*thumb_tip"):
        open_like(case.task, ("thumb_tip", "pinky_tip"))
    with pytest.raises(InvalidTask, match="object region|not found"):
        OpenTask("x", case.task.hand, case.task.object, (OpenContact("nowhere"),))
    with pytest.raises(InvalidTask, match="at least one candidate"):
        OpenContact("o0", ())
    from dataclasses import replace

    bare = replace(case.task.hand, regions={})
    with pytest.raises(InvalidTask, match="'hand: any'.*has no contact regions"):
        OpenTask("x", bare, case.task.object, (OpenContact("o0"),))


# -- span proofs -----------------------------------------------------------------------------
def test_span_proof_of_the_pincer():
    far = pincer_task(200.0)
    report = search_assignments(open_like(far), AssignmentOptions(complete_time_s=0))
    assert report.total == 2 and not report.feasible and not report.undecided
    for item in report.infeasible:
        assert isinstance(item, Impossible)
        assert item.proof.gap_mm > item.proof.reach_mm
        holds, detail = check_span_proof(concrete_task(report.open_task, item.assignment), item.proof.to_dict())
        assert holds, detail
    near = pincer_task(40.0)
    assert prove_by_span(near) is None
    proof = report.infeasible[0].proof.to_dict()
    # the same proof does not hold for the near task (its regions are within reach)
    assert not check_span_proof(near, proof)[0]


@pytest.mark.parametrize("seed", range(12))
def test_span_never_prunes_a_forward_built_task(seed):
    """Soundness: a task that holds at a known configuration is never proven impossible,
    whichever of its assignments it is (the built one is feasible)."""
    rng = np.random.default_rng(100 + seed)
    case = build_fk_case(schunk_sa_hand(), rng)
    assert prove_by_span(case.task) is None
    # ... nor are the built contacts, renamed through an open task
    task = open_like(case.task, None)
    built = next(a for a in enumerate_assignments(task) if a.hand_regions == tuple(c.hand_region for c in case.task.contacts))
    assert prove_by_span(concrete_task(task, built)) is None


# -- the search against solving each assignment alone ------------------------------------
@pytest.mark.parametrize("d", [30.0, 46.0, 60.0])
def test_search_agrees_with_solving_alone(d):
    task = open_like(pincer_task(d))
    options = AssignmentOptions(complete_time_s=20.0, chunk_size=2)
    report = search_assignments(task, options)
    verdicts = {o.assignment.label: "solved" for o in report.feasible}
    verdicts |= {a.label: "infeasible" for a, _ in report.infeasible}
    verdicts |= {a.label: "undecided" for a, _ in report.undecided}
    assert len(verdicts) == report.total == 2
    for a in enumerate_assignments(task):
        alone = solve_alone(concrete_task(task, a), assignment_seed(options.seed, a), options)
        span = prove_by_span(concrete_task(task, a))
        expected = "infeasible" if span is not None else {"solved": "solved", "infeasible": "infeasible"}.get(alone.status, "undecided")
        assert verdicts[a.label] == expected, (a.label, alone.message)
        if span is not None:
            assert alone.status != "solved"  # the span proof never contradicts a solver
    assert ("pad->A, tip->B" in verdicts and verdicts["pad->A, tip->B"] == "solved") == (d < 47.0)


def test_every_assignment_is_accounted_for_under_a_time_limit():
    """A search stopped by its time limit still names every assignment: what no solver
    finished is undecided, saying why."""
    case = build_fk_case(schunk_sa_hand(), np.random.default_rng(7), fingers=("thumb", "index", "middle"), palm=False)
    task = open_like(case.task, SA_TIPS)
    report = search_assignments(task, AssignmentOptions(complete_time_s=5.0, time_limit_s=0.05, chunk_size=4))
    assert report.total == 24
    labels = [o.assignment.label for o in report.feasible] + [a.label for a, _ in report.infeasible]
    labels += [a.label for a, _ in report.undecided]
    assert sorted(labels) == sorted(a.label for a in enumerate_assignments(task))
    assert any("time limit" in reason for _, reason in report.undecided)
    assert all(u.result is not None and u.result.status == "gave_up" for u in report.undecided)


@pytest.mark.parametrize("seed", [11, 12])
def test_search_agrees_with_solving_each_of_24_alone(seed):
    """Every assignment of a forward-built three-contact task over four fingertips, solved
    one by one (local solver, same seeds): the same verdicts and the same grasps as the
    search in chunks, here and on an executor; the built assignment is feasible."""
    from concurrent.futures import ThreadPoolExecutor

    case = build_fk_case(schunk_sa_hand(), np.random.default_rng(seed), fingers=("thumb", "index", "middle"), palm=False)
    task = open_like(case.task, SA_TIPS)
    options = AssignmentOptions(complete_time_s=0, chunk_size=5, seed=seed)
    alone = {}
    for a in enumerate_assignments(task):
        r = solve_alone(concrete_task(task, a), assignment_seed(seed, a), options)
        alone[a.label] = r.solutions[0].q if r.success else None
    with ThreadPoolExecutor(2) as pool:
        for report in (search_assignments(task, options), search_assignments(task, AssignmentOptions(
                complete_time_s=0, chunk_size=7, seed=seed, executor=pool))):  # fmt: skip
            found = {o.assignment.label: o.result.solutions[0].q for o in report.feasible}
            assert set(found) == {k for k, q in alone.items() if q is not None}
            for label, q in found.items():
                np.testing.assert_array_equal(q, alone[label])
            assert len(report.feasible) + len(report.infeasible) + len(report.undecided) == 24
            scores = [o.score for o in report.feasible]  # ranked: force closure, then epsilon
            assert scores == sorted(scores, reverse=True)
            assert all(o.quality == o.qualities[o.best] and "epsilon" in o.quality for o in report.feasible)
    built = ", ".join(f"{c.hand_region}->{c.object_region}" for c in case.task.contacts)
    assert alone[built] is not None
