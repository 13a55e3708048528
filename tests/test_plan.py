"""Grasps planned on a bare mesh (issue 30, item 2): the hand side, the proposal, the planner."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.errors import PrehensionError
from prehension.hands.reach import span_bound_mm
from prehension.objects.distance import MeshDistance
from prehension.objects.meshes import Mesh
from prehension.objects.solid import MeshFileSolid
from prehension.planning import (
    MeshSurface, NoGraspError, PlanOptions, ProposalOptions, hand_side, plan_grasps, propose_points, propose_regions,
)  # fmt: skip
from prehension.quality import QualityOptions
from prehension.quality.measures import force_closure
from prehension.quality.wrenches import primitive_wrenches
from prehension.tasks.format.tasks import resolve_hand


@pytest.fixture(scope="module")
def sa():
    return resolve_hand("sa")


def box_mesh(extents) -> Mesh:
    import trimesh

    box = trimesh.creation.box(extents=extents)
    return Mesh(np.asarray(box.vertices, float), np.asarray(box.faces))


def box_file(tmp_path, extents, name="box.stl"):
    import trimesh

    path = tmp_path / name
    trimesh.creation.box(extents=extents).export(path)
    return path


def test_hand_side_of_the_sa_hand(sa):
    side = hand_side(sa, 3)
    assert set(side.regions) == {"thumb_tip", "index_tip", "middle_tip", "ring_tip"}
    assert side.opposing == ("thumb_tip",) and side.candidates(True) == ("thumb_tip",)
    assert "thumb_tip" not in side.candidates(False) and len(side.candidates(False)) == 3
    thumb, index = sa.regions["thumb_tip"], sa.regions["index_tip"]
    (ct, rt), (ci, ri) = thumb.region.ball(), index.region.ball()
    expected = span_bound_mm(sa, thumb.link, ct, index.link, ci, tol_mm=2.0) + rt + ri
    assert side.span_mm("index_tip", "thumb_tip") == pytest.approx(expected)
    assert side.gap_mm == pytest.approx(2 * 13.0)  # two 13 mm pads side by side
    assert hand_side(sa, 3, oppose=False).candidates(True) == side.regions
    assert "palm" in hand_side(sa, 3, palm=True).regions


def test_hand_side_refuses_bad_finger_counts(sa):
    with pytest.raises(PrehensionError, match=r"5 contacts asked for, but hand 'schunk-sa' has 4 fingertip regions \(.*thumb_tip"):
        hand_side(sa, 5)
    with pytest.raises(PrehensionError, match="integer >= 2"):
        hand_side(sa, 1)
    assert len(hand_side(sa, 5, palm=True).regions) == 5  # the palm makes a fifth


def _sets_hold(proposal, mesh: Mesh, side, friction: float):
    distance = MeshDistance(mesh.vertices, mesh.faces)
    for cand in proposal.sets:
        for region in cand.regions:
            params = region.sample_params(5)
            points, normals = region.evaluate(params)
            assert np.abs(distance.signed_distance(points)).max() < 0.5  # on the surface
            assert (distance.signed_distance(points + 0.05 * normals) > 0).all()  # normals point out
        p, n = cand.points, cand.normals
        d = np.linalg.norm(p[:, None] - p[None], axis=2)
        assert d.max() <= side.max_span_mm  # within the hand's proven span
        same_side = (n @ n.T > 0) & ~np.eye(len(p), dtype=bool)
        assert (d[same_side] >= side.gap_mm - 1e-9).all()  # two pads side by side fit
        centre = mesh.vertices.mean(axis=0)
        radius = np.linalg.norm(mesh.vertices - centre, axis=1).max()
        w = primitive_wrenches(p, -n, centre, radius, QualityOptions(friction=friction)).reshape(-1, 6)
        assert force_closure(w).force_closure


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_proposed_regions_lie_on_the_mesh_face_outwards_and_fit_the_hand(sa, seed):
    mesh = box_mesh([70.0, 45.0, 30.0])
    side = hand_side(sa, 3)
    options = ProposalOptions(samples=300, attempts=300, candidates=8, seed=seed)
    proposal = propose_regions(mesh, side, 3, options)
    assert len(proposal.sets) >= 4 and proposal.pairs > 0
    scores = [c.score for c in proposal.sets]
    assert scores == sorted(scores, reverse=True)
    _sets_hold(proposal, mesh, side, options.friction)
    again = propose_regions(mesh, side, 3, options)  # seeded: the same sets
    assert all(np.array_equal(a.points, b.points) for a, b in zip(proposal.sets, again.sets))


def test_proposed_sets_are_distinct(sa):
    mesh = box_mesh([70.0, 45.0, 30.0])
    side = hand_side(sa, 3)
    found = propose_points(MeshSurface(mesh), side, 3, ProposalOptions(samples=300, attempts=300, candidates=10))
    limit = 2.0 * found.patch_mm
    for a in range(len(found.sets)):
        for b in range(a):
            d = np.linalg.norm(found.points[list(found.sets[a])][:, None] - found.points[list(found.sets[b])][None], axis=2)
            assert max(d.min(axis=1).max(), d.min(axis=0).max()) >= limit


def test_two_finger_pairs_are_antipodal(sa):
    mesh = box_mesh([60.0, 40.0, 30.0])
    side = hand_side(sa, 2)
    proposal = propose_regions(mesh, side, 2, ProposalOptions(samples=200, candidates=5))
    for cand in proposal.sets:
        u = (cand.points[1] - cand.points[0]) / np.linalg.norm(cand.points[1] - cand.points[0])
        cone = np.cos(np.arctan(0.6))
        assert -cand.normals[0] @ u >= cone - 1e-12 and cand.normals[1] @ u >= cone - 1e-12


def test_an_object_too_large_for_the_hand_is_refused_with_the_bound(sa):
    side = hand_side(sa, 3)
    mesh = box_mesh([600.0, 500.0, 450.0])
    with pytest.raises(NoGraspError, match=r"smallest width across any antipodal pair .* is (\S+) mm; .* at most (\S+) mm") as info:
        propose_regions(mesh, side, 3, ProposalOptions(samples=200))
    import re

    width, span = map(float, re.search(r"is (\S+) mm; .* at most (\S+) mm", str(info.value)).groups())
    assert width > span == pytest.approx(side.max_span_mm, rel=1e-3)


def test_plan_grasps_are_verified_and_distinct(sa, tmp_path):
    from prehension import evaluate

    path = box_file(tmp_path, [70.0, 45.0, 30.0])
    options = PlanOptions(grasps=2, proposal=ProposalOptions(samples=300, attempts=300, candidates=12))
    report = plan_grasps(MeshFileSolid(str(path), 1.0, "mm"), sa, options)
    assert len(report.grasps) == 2 and report.tried >= 2
    sets = {g.set_index for g in report.grasps}
    assert len(sets) == 2
    for g in report.grasps:
        result = g.outcome.result
        assert result.status == "solved"
        for s in result.solutions:
            assert evaluate(result.task, s.configuration()).ok
        assert g.outcome.assignment.hand_regions[0] == "thumb_tip"  # the opposition rule


def test_hand_side_of_a_urdf_hand():
    from conftest import SHARED

    urdf = SHARED / "hands" / "allegro_hand" / "allegro_hand_right.urdf"
    if not urdf.is_file():
        pytest.skip("shared/hands not present beside the checkout")
    allegro = resolve_hand(str(urdf))
    side = hand_side(allegro, 3)
    assert set(side.regions) == {"index_tip", "middle_tip", "ring_tip", "thumb_tip"} and side.opposing == ("thumb_tip",)
    assert all(span > 100.0 for span in side.spans_mm.values())
    with pytest.raises(PrehensionError, match=r"has 4 fingertip regions .*give --fingers 2\.\.4$"):
        hand_side(allegro, 5)  # no palm region: no hint to add --palm
    with pytest.raises(PrehensionError, match="has no region on its palm"):
        hand_side(allegro, 3, palm=True)
