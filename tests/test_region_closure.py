"""--hold's proof without the hand: can any choice of points in the object regions be force closure?"""

from __future__ import annotations

import numpy as np
import pytest

from test_closure_prune import _fk_case  # forward-built tasks, random or around the four-finger box grasp
from prehension.quality import QualityOptions, configuration_quality, force_closure, primitive_wrenches, torque_reference
from prehension.region_closure import regions_closure

MODELS = (QualityOptions(friction=0.6, torsion_mm=20.0), QualityOptions(), QualityOptions(friction=0.3, torsion_mm=5.0))


def _sampled_closure(task, quality: QualityOptions, rng, n: int) -> int:
    """How many of ``n`` random choices of one point in each object region are force closure."""
    centre, rho = torque_reference(task, quality)
    regions = [task.object_region(c) for c in task.contacts]
    closed = 0
    for _ in range(n):
        points, inward = [], []
        for region in regions:
            lo, hi = region.param_bounds()
            p, normal = region.evaluate(rng.uniform(lo, hi)[None])
            points.append(p[0]), inward.append(-normal[0])
        closed += force_closure(primitive_wrenches(np.array(points), np.array(inward), centre, rho, quality)).force_closure
    return closed


def test_one_face_is_proven_and_the_four_finger_box_has_force_closure_points(one_face, four):
    for quality in MODELS:
        none = regions_closure(one_face[0], quality)
        assert none.status == "infeasible" and none.pruned == none.boxes >= 1 and none.witness is None
        some = regions_closure(four[0], quality)
        assert some.status == "witness" and len(some.witness) == len(four[0].contacts)
        assert regions_closure(one_face[0], quality).boxes == none.boxes  # deterministic: check re-derives it


@pytest.mark.parametrize("seed", range(3))
def test_a_proof_is_never_given_for_regions_with_force_closure_points(sa_hand, seed):
    """Forward-built tasks (seeded: random, and around a force-closure grasp; point, patch and
    cap object regions; three friction models): a task whose known grasp is force closure is
    never proven to admit none; every witness is force closure; regions proven to admit none
    show none in 300 random choices of points either."""
    rng = np.random.default_rng(9100 + seed)
    witnesses = 0
    for k in range(4):
        case = _fk_case(sa_hand, rng, near_box_grasp=bool(k % 2))
        quality = MODELS[(k + seed) % len(MODELS)]
        found = regions_closure(case.task, quality, time_limit_s=1.5)
        if configuration_quality(case.task, case.config, quality).force_closure:
            assert found.status != "infeasible"
        if found.status == "witness":
            witnesses += 1
            centre, rho = torque_reference(case.task, quality)
            at = [case.task.object_region(c).evaluate(np.asarray(u, float)[None]) for c, u in zip(case.task.contacts, found.witness)]
            wrenches = primitive_wrenches(np.array([p[0] for p, _ in at]), -np.array([n[0] for _, n in at]), centre, rho, quality)
            assert force_closure(wrenches).force_closure
        if found.status == "infeasible":
            assert _sampled_closure(case.task, quality, rng, 300) == 0
    assert witnesses >= 1  # the grasps near the box grasp have force-closure points, found at once


def test_point_regions_are_one_choice_decided_at_once(sa_hand):
    """Point regions only: nothing to split; the one choice of points is force closure
    (a witness), proven not to be, or -- the certificate failing on a choice that is not
    force closure -- undecided, never an error."""
    from fk_tasks import build_fk_case

    rng = np.random.default_rng(9200)
    for _ in range(4):
        case = build_fk_case(sa_hand, rng, fingers=("thumb", "index", "middle"), palm=False, kinds=["point"] * 3)
        for quality in MODELS:
            found = regions_closure(case.task, quality)
            assert found.boxes == 1 and found.status in ("infeasible", "witness", "gave_up")
            assert (found.status == "witness") == configuration_quality(case.task, case.config, quality).force_closure


def test_a_further_round_of_plain_starts_samples_no_points_and_keeps_force_closure_grasps(four, monkeypatch):
    """``aim=False`` (``--hold``'s further rounds): no points of the regions are sampled,
    and the grasps kept are force closure, each a verified solution of the task."""
    import prehension.region_closure as rc
    from prehension.verification.residuals import evaluate

    task, _ = four
    quality = QualityOptions(friction=0.6, torsion_mm=20.0)
    monkeypatch.setattr(rc, "_closure_points", lambda *a: pytest.fail("sampled points in a plain round"))
    found = rc.aimed_grasps(task, quality, 1, None, aim=False)
    assert 1 <= len(found) <= rc.AIMED_KEPT
    for solution in found:
        assert configuration_quality(task, solution.configuration(), quality).force_closure
        assert evaluate(task, solution.configuration()).ok


def test_aimed_starts_reach_grasps_near_their_point_verified_on_the_task_itself(four):
    """The aimed starts (``aim=True``): every grasp the restricted task gives is a verified
    solution of the task itself whose object parameters lie within ``AIM_HALF_WIDTH`` of the
    aimed point (the restriction's box), and the grasps kept are force closure."""
    import prehension.region_closure as rc
    from prehension.best import random_starts
    from prehension.verification.residuals import evaluate

    task, _ = four
    quality = QualityOptions(friction=0.6, torsion_mm=20.0)
    rng = np.random.default_rng(5)
    point = tuple(rng.uniform(0.3, 0.7, size=2) for _ in task.contacts)
    reached = [s for s in rc._aimed(task, point, random_starts(task, 20, rng)) if s is not None]
    assert reached  # the box grasp's faces are wide: some start reaches them
    for solution in reached:
        config = solution.configuration()
        assert evaluate(task, config).ok
        for (_, op), at in zip(config.contact_params, point):
            assert np.all(np.abs(np.asarray(op) - at) <= rc.AIM_HALF_WIDTH + 1e-9)
    found = rc.aimed_grasps(task, quality, 1, None, aim=True)
    assert 1 <= len(found) <= rc.AIMED_KEPT
    for solution in found:
        assert configuration_quality(task, solution.configuration(), quality).force_closure
        assert evaluate(task, solution.configuration()).ok
