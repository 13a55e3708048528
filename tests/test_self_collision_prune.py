"""The complete solver's self-collision prune (issue 32): sound enclosures of the distance
between two capsules over a box, no box holding a self-collision-free solution ever
discarded, boxes whose solutions all collide discarded, and a task infeasible only through
self-collision certified so and re-proved by ``prehension check``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fk_tasks import box_around, build_fk_case, perturbed, search_path
from prehension.geometry.regions import PointRegion
from prehension.hands.collision import capsule_clearances, collision_pairs
from prehension.hands.kinematics import forward_kinematics
from prehension.objects.model import GraspObject
from prehension.results import Status, write_result
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.solvers.complete.search import BranchAndPruneOptions, process_box, solve_complete
from prehension.solvers.complete.self_collision import pair_distance_bounds, self_collision_pairs, self_collision_prune
from prehension.system.embedding import embed
from prehension.system.formulation import build_system
from prehension.tasks.model import Contact, Task
from prehension.verification.residuals import Tolerances, evaluate
from prehension.verification import verify_result_file
from prehension.solvers.local.verifier import LocalVerifier

TOLS = Tolerances()  # strict: no self-penetration at all
SEEDS = tuple(range(9100, 9124))


def _segment_distances(form, config) -> np.ndarray:
    """(K,) the distance between the two segments of each pair of ``self_collision_pairs``
    at ``config``, by forward kinematics (clearance + the two radii)."""
    pairs = self_collision_pairs(form)
    hand = form.task.hand
    clearance, names = capsule_clearances(hand, forward_kinematics(hand, config.joint_angles))
    tested = collision_pairs(hand)
    index = [k for k, (a, b) in enumerate(tested.names) if a in form.R_object_link and b in form.R_object_link]
    assert [tested.names[k] for k in index] == list(pairs.links)
    return clearance[0, index] + pairs.limit


def _self_collides(task, config) -> float:
    """The residual function's deepest self-penetration [mm] of ``config``."""
    return max((c.value for c in evaluate(task, config).checks if c.kind == "collision"), default=0.0)


@pytest.fixture(scope="module")
def cases(sa_hand):
    """Forward-built tasks of the SA hand (2-4 fingertips, no palm) with their known solution."""
    out = []
    for seed in SEEDS:
        case = build_fk_case(sa_hand, np.random.default_rng(seed), palm=False)
        form = build_system(case.task)
        if self_collision_pairs(form) is not None:
            out.append((case.task, case.config, form))
    return out


def test_both_kinds_of_forward_built_solutions_are_drawn(cases):
    colliding = sum(_self_collides(task, config) > 0.0 for task, config, _ in cases)
    assert len(cases) >= 20 and 3 <= colliding <= len(cases) - 8


def test_the_bounds_hold_every_configuration_of_seeded_random_boxes(cases):
    """Boxes holding several configurations (contacts not made: the chain's enclosure
    alone, no tolerances): each pair's bound lies above its segment distance in all of them."""
    rng = np.random.default_rng(21)
    checked = 0
    for task, config, form in cases:
        for _ in range(4):
            size = 10.0 ** rng.uniform(-4, -0.5)
            configs = [config] + [perturbed(rng, config, size) for _ in range(3)]
            lower, upper = box_around(rng, form, np.array([embed(form, c) for c in configs]), 10.0 ** rng.uniform(-6, -1))
            bounds = pair_distance_bounds(form, lower, upper)
            for c in configs:
                assert np.all(bounds >= _segment_distances(form, c) - 1e-9), task.name
                checked += 1
    assert checked == len(cases) * 16


def test_the_bounds_through_the_contacts_hold_the_solution_and_are_tighter(cases):
    """Boxes of every size around a known solution (its contacts made): the bounds with the
    contact anchors still lie above its distances, never above the chain's, and are
    smaller on many boxes."""
    rng = np.random.default_rng(22)
    tighter = total = 0
    for task, config, form in cases:
        x = embed(form, config)
        true = _segment_distances(form, config)
        for _ in range(4):
            lower, upper = box_around(rng, form, x[None], 10.0 ** rng.uniform(-7, -0.3))
            through = pair_distance_bounds(form, lower, upper, TOLS)
            assert np.all(through >= true - 1e-9), task.name
            chain = pair_distance_bounds(form, lower, upper)
            assert np.all(through <= chain + 1e-9)  # an intersection
            near = chain < 2.0 * self_collision_pairs(form).limit
            tighter += bool(np.sum(through[near]) < np.sum(chain[near]))
            total += 1
    assert tighter >= total // 4  # (on point-like boxes both are the distance itself)


def test_a_box_holding_a_self_collision_free_solution_is_never_pruned(cases):
    """Around each known solution free of self-collision: the point box, the initial box
    and seeded random boxes between them are never pruned; nor is any box of the search's
    own path down to it (contracted, shrunk, split)."""
    rng = np.random.default_rng(23)
    tried = 0
    for task, config, form in cases:
        if _self_collides(task, config) > 0.0:
            continue
        x = embed(form, config)
        boxes = [(x, x), (form.system.lower, form.system.upper)]
        boxes += [box_around(rng, form, x[None], 10.0 ** rng.uniform(-9, 0)) for _ in range(10)]
        for lower, upper in boxes:
            assert self_collision_prune(form, lower, upper, TOLS) is None, task.name
        tried += 1
    assert tried >= 8
    task, config, form = next(c for c in cases if _self_collides(c[0], c[1]) == 0.0 and len(c[0].contacts) == 2)
    for out in search_path(form, embed(form, config)):
        assert not out.by_self_collision


def test_boxes_whose_configurations_all_collide_are_pruned(cases):
    """At a single configuration the prune is the residual function's verdict (it fires
    when two capsules of system links are more than 0.01 mm into each other, and only when
    they are into each other), and small boxes around the colliding ones are pruned too."""
    rng = np.random.default_rng(24)
    fired = 0
    for task, config, form in cases:
        x = embed(form, config)
        deepest = float(np.max(self_collision_pairs(form).limit - _segment_distances(form, config)))
        proof = self_collision_prune(form, x, x, TOLS)
        if proof is not None:
            assert _self_collides(task, config) > 0.0 and deepest > 0.0
            assert proof.bound_mm < proof.limit_mm
            fired += 1
        if deepest > 0.01:
            assert proof is not None, task.name
        if deepest > 1.0:
            lower, upper = box_around(rng, form, x[None], 1e-5)
            assert self_collision_prune(form, lower, upper, TOLS) is not None, task.name
    assert fired >= 3


def test_no_prune_without_a_finite_tolerance(cases):
    task, config, form = next(c for c in cases if _self_collides(c[0], c[1]) > 1.0)
    x = embed(form, config)
    assert self_collision_prune(form, x, x, Tolerances(penetration_mm=float("inf"))) is None
    options = BranchAndPruneOptions(verifier=LocalVerifier(), self_collision_prune=False, all_solutions=True)
    assert not process_box(form, x, x, 0, options).by_self_collision


# -- a task infeasible only through self-collision --------------------------------------
def crossed_pinch(hand, gap_mm: float = 10.0) -> Task:
    """Thumb and index fingertips on two points ``gap_mm`` apart whose normals face each
    other: the pads' centres are then 26 - gap mm apart, closer than the distal capsules'
    radii add up to (20 mm) -- every solution has the two fingertips inside each other."""
    obj = GraspObject("crossed", {"a": PointRegion((0, 0, 0), (1, 0, 0)), "b": PointRegion((gap_mm, 0, 0), (-1, 0, 0))})
    return Task("crossed-pinch", hand, obj, (Contact("thumb_tip", "a"), Contact("index_tip", "b")), ("thumb", "index"))


def test_a_task_infeasible_only_through_self_collision_is_certified_and_re_proved(sa_hand, tmp_path, capsys):
    from prehension.cli import EXIT_INFEASIBLE, main

    task = crossed_pinch(sa_hand)
    result = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=60))
    assert result.status == Status.INFEASIBLE and not result.solutions
    assert "no self-collision-free solution" in result.message and result.stats["self_collision_pruned"] > 0
    out = tmp_path / "crossed.json"
    write_result(result, out, quality_entries(result), approach_entries_of(result))
    assert json.loads(out.read_text())["stats"]["self_collision_pruned"] == result.stats["self_collision_pruned"]
    assert main(["check", str(out)]) == EXIT_INFEASIBLE
    capsys.readouterr()
    again = next(f for f in verify_result_file(out).findings if f.what == "infeasibility re-proved")
    assert again.ok and "for self-collision: no self-collision-free solution" in again.detail
    off = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=3, self_collision_prune=False, verify_starts=1))
    assert off.status == Status.GAVE_UP and off.stats["self_collision_pruned"] == 0


def test_the_same_pinch_apart_is_not_pruned_at_its_first_box(sa_hand):
    """The points 30 mm apart (the pads' centres at x = 13 and 17: 4 mm apart, still inside
    each other) and 60 mm apart (centres 34 mm apart): only the second's initial box
    survives the prune."""
    for gap, pruned in ((30.0, True), (60.0, False)):
        form = build_system(crossed_pinch(sa_hand, gap))
        proof = self_collision_prune(form, form.system.lower, form.system.upper, TOLS)
        assert (proof is not None) == pruned, gap
