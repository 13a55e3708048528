"""The pair test by matching ranges (solvers/complete/pair/matching.py): each side's ranges contain
the invariants' values, boxes around a known solution always match, forward-built pairs are
never proved infeasible, and a pair past reach is proved."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.solvers.complete import pair as cg
from prehension.solvers.complete.pair import matching as mt
from prehension.solvers.complete.region_kinds import patch_remainders
from test_congruence import _pair_problems, _pinch_task, _true_values


def _invariants(d, v_a, v_b):
    """Exact ``(distance, angle_a, angle_b, between, dihedral)`` of rows of ``d, v_a, v_b (B, 3)``."""
    length = np.linalg.norm(d, axis=1)
    u = d / length[:, None]
    angle = [np.arccos(np.clip(np.einsum("bi,bi->b", u, v), -1, 1)) for v in (v_a, v_b)]
    between = np.arccos(np.clip(np.einsum("bi,bi->b", v_a, v_b), -1, 1))
    s = length * np.einsum("bi,bi->b", d, np.cross(v_a, v_b))
    c = np.einsum("bi,bi->b", np.cross(d, v_a), np.cross(d, v_b))
    return length, angle, between, np.arctan2(s, c)


def _random_boxes(rng, lower, upper, B, around=None):
    width = (upper - lower) * 10.0 ** rng.uniform(-6, 0, (B, 1))
    if around is None:
        lo = lower + rng.uniform(0, 1, (B, len(lower))) * (upper - lower - width)
    else:
        lo = np.maximum(lower, around - rng.uniform(0, 1, (B, len(lower))) * width)
    hi = np.minimum(upper, lo + width)
    return lo, hi if around is None else np.maximum(hi, around)


def _inside(value, rng_lo, rng_hi, slack=1e-9):
    return np.all((value >= rng_lo - slack) & (value <= rng_hi + slack))


def _on_circle(value, lo, hi, known):
    """``value`` within ``[lo, hi]`` up to a turn, where ``known``."""
    shifted = lo + np.mod(value - lo + 1e-9, 2 * np.pi) - 1e-9
    return np.all(~known | (shifted <= hi + 1e-9))


@pytest.mark.parametrize("case", range(5))
def test_both_sides_ranges_contain_the_invariants_on_random_boxes(case):
    """Seeded random boxes of each side (from the whole domain down to 1e-6 of it), 10 points
    each: every invariant's value lies in its range."""
    task, _ = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    rng = np.random.default_rng(40 + case)
    B, sa, so = 200, pp.slices[0], slice(pp.slices[1].start, pp.n_dims)
    h_lo, h_hi = _random_boxes(rng, pp.lower[sa], pp.upper[sa], B)
    o_lo, o_hi = _random_boxes(rng, pp.lower[so], pp.upper[so], B)
    hand, _ = mt.hand_ranges(pp, h_lo, h_hi)
    obj, _ = mt.object_ranges(pp, o_lo, o_hi)
    for _ in range(10):
        z = np.empty((B, pp.n_dims))
        z[:, sa] = h_lo + rng.uniform(0, 1, h_lo.shape) * (h_hi - h_lo)
        z[:, so] = o_lo + rng.uniform(0, 1, o_lo.shape) * (o_hi - o_lo)
        d_h, m_a, m_b, d_o, n_a, n_b = _true_values(pp, z)
        for ranges, values in ((hand, _invariants(d_h, m_a, m_b)), (obj, _invariants(d_o, n_a, n_b))):
            length, angle, between, dihedral = values
            assert _inside(length, *ranges.distance, slack=1e-9 * length.max())
            for s in (0, 1):
                assert _inside(angle[s], *ranges.angle[s], slack=1e-7)
                assert _inside(np.cos(angle[s]), *ranges.axial[s])
            assert _inside(between, *ranges.between, slack=1e-7)
            assert _on_circle(dihedral, *ranges.dihedral)


@pytest.mark.parametrize("case", [2, 3, 4])
def test_boxes_around_a_known_solution_always_match(case):
    """Forward-built tasks: every hand box holding the solution's angles matches every object
    box holding its parameters, whatever their sizes (no solution is ever lost)."""
    task, config = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    sa, so = pp.slices[0], slice(pp.slices[1].start, pp.n_dims)
    z = np.concatenate([config.joint_angles[pp.kin.problem.sources]] + [np.atleast_1d(config.contact_params[i][1]) for i in (0, 1)])
    rng = np.random.default_rng(case)
    hand, _ = mt.hand_ranges(pp, *_random_boxes(rng, pp.lower[sa], pp.upper[sa], 150, around=z[sa]))
    obj, _ = mt.object_ranges(pp, *_random_boxes(rng, pp.lower[so], pp.upper[so], 150, around=z[so]))
    assert mt.compatible(hand, obj, pp.betas).all()


def test_forward_built_pairs_are_never_proved_infeasible_by_matching():
    for task, _ in _pair_problems()[2:]:
        assert not mt.prove_pair_by_matching(cg.pair_problem(task, 0, 1), max_boxes=3000).proved


def test_a_pinch_past_reach_is_proved_by_matching_and_one_within_it_is_not():
    assert mt.prove_pair_by_matching(cg.pair_problem(_pinch_task(400.0), 0, 1), max_boxes=3000).proved
    assert not mt.prove_pair_by_matching(cg.pair_problem(_pinch_task(60.0), 0, 1), max_boxes=3000).proved


@pytest.mark.parametrize("case", range(5))
def test_contraction_keeps_every_point_of_the_hull(case):
    """Seeded random boxes of each side narrowed to a hull (:func:`contract_to`): every sampled
    point of the box whose invariants lie in the hull stays in the narrowed box; the hull is
    that of three of the samples, so some points always qualify."""
    task, _ = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    rng = np.random.default_rng(70 + case)
    sa, so = pp.slices[0], slice(pp.slices[1].start, pp.n_dims)
    checked = 0
    for hand, dims in ((True, sa), (False, so)):
        lo, hi = _random_boxes(rng, pp.lower[dims], pp.upper[dims], 40)
        for b in range(len(lo)):
            z = np.repeat(pp.lower[None], 12, axis=0)
            z[:, dims] = lo[b] + rng.uniform(0, 1, (12, hi.shape[1])) * (hi[b] - lo[b])
            d_h, m_a, m_b, d_o, n_a, n_b = _true_values(pp, z)
            length, angle, _, _ = _invariants(d_h, m_a, m_b) if hand else _invariants(d_o, n_a, n_b)
            pick = slice(0, 3)
            hull = mt.Hull((length[pick].min(), length[pick].max()),
                           tuple((angle[s][pick].min(), angle[s][pick].max()) for s in (0, 1)))
            new_lo, new_hi = mt.contract_to(pp, lo[b:b + 1], hi[b:b + 1], hull, hand=hand)
            inside = (length >= hull.distance[0]) & (length <= hull.distance[1])
            for s in (0, 1):
                inside &= (angle[s] >= hull.angle[s][0]) & (angle[s] <= hull.angle[s][1])
            pts = z[inside][:, dims]
            checked += len(pts)
            slack = 1e-12 * (1.0 + np.abs(pts))
            assert np.all((pts >= new_lo - slack) & (pts <= new_hi + slack))
    assert checked >= 3 * 80


def test_contraction_narrows_a_box_far_from_the_hull():
    """A hull of distances the hand cannot reach empties every box; a hull at the solution of a
    forward-built task keeps its angles and parameters."""
    task, config = _pair_problems()[2]
    pp = cg.pair_problem(task, 0, 1)
    sa, so = pp.slices[0], slice(pp.slices[1].start, pp.n_dims)
    far = mt.Hull((1e4, 2e4), ((0.0, np.pi), (0.0, np.pi)))
    lo, hi = mt.contract_to(pp, pp.lower[None, sa], pp.upper[None, sa], far, hand=True)
    assert np.any(lo > hi)
    z = np.concatenate([config.joint_angles[pp.kin.problem.sources]] + [np.atleast_1d(config.contact_params[i][1]) for i in (0, 1)])
    d_h, m_a, m_b, d_o, n_a, n_b = _true_values(pp, z[None])
    for hand, dims, values in ((True, sa, (d_o, n_a, n_b)), (False, so, (d_h, m_a, m_b))):
        length, angle, _, _ = _invariants(*values)  # the other side's invariants, widened by beta
        betas = pp.betas
        hull = mt.Hull((length[0], length[0]), tuple((max(angle[s][0] - betas[s], 0.0), min(angle[s][0] + betas[s], np.pi)) for s in (0, 1)))
        new_lo, new_hi = mt.contract_to(pp, pp.lower[None, dims], pp.upper[None, dims], hull, hand=hand)
        assert np.all((z[dims] >= new_lo[0] - 1e-9) & (z[dims] <= new_hi[0] + 1e-9))


@pytest.mark.parametrize("case", range(5))
def test_the_object_sides_extremes_contain_every_sampled_value(case):
    """:func:`object_extremes` (small budgets, so its searches stop early as well as on
    convergence): the invariants at 2,000 seeded points of the regions' parameters lie in its
    single row of ranges, and so in any box's ranges clipped to it (:func:`clip_to`)."""
    task, _ = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    rng = np.random.default_rng(90 + case)
    so = slice(pp.slices[1].start, pp.n_dims)
    tight, boxes = mt.object_extremes(pp, max_boxes=200)
    assert boxes >= 1
    z = np.repeat(pp.lower[None], 2000, axis=0)
    z[:, so] = pp.lower[so] + rng.uniform(0, 1, (2000, so.stop - so.start)) * (pp.upper[so] - pp.lower[so])
    _, _, _, d_o, n_a, n_b = _true_values(pp, z)
    length, angle, between, _ = _invariants(d_o, n_a, n_b)
    clipped = mt.clip_to(mt.object_ranges(pp, z[:, so], z[:, so])[0], tight)
    for ranges in (tight, clipped):
        assert _inside(length, *ranges.distance, slack=1e-9 * length.max())
        for s in (0, 1):
            assert _inside(angle[s], *ranges.angle[s], slack=1e-7)
            assert _inside(np.cos(angle[s]), *ranges.axial[s])
        assert _inside(between, *ranges.between, slack=1e-7)


@pytest.mark.parametrize("case", [2, 3, 4])
def test_the_hand_stage_keeps_a_known_solution(case):
    """Forward-built tasks: the hand boxes left by :func:`hand_against` (against the object
    side's extremes) hold the solution's angles; the stage never proves them infeasible."""
    task, config = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    z = config.joint_angles[pp.kin.problem.sources]
    tight, _ = mt.object_extremes(pp, max_boxes=300)
    proved, lo, hi, boxes = mt.hand_against(pp, tight, max_boxes=2000)
    assert not proved and 1 <= boxes <= 2000
    slack = 1e-9 * (1.0 + np.abs(z))
    assert np.any(np.all((lo <= z + slack) & (z - slack <= hi), axis=1))


@pytest.mark.parametrize("case", [1, 4])
def test_a_patchs_local_remainders_bound_its_taylor_remainder(case):
    """``region_kinds.patch_remainders``: on seeded random sub-boxes (the whole patch down
    to 1e-4 of it), a point and unit normal at 50 sampled parameters each differ from the
    first-order Taylor form at the box's centre by at most the bound, and the bound is never
    looser than the whole patch's (``region_curvature``)."""
    task, _ = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    rng = np.random.default_rng(110 + case)
    patches = [side for side in (0, 1) if hasattr(pp.objects[side][0], "patch")]
    assert patches  # both cases have Bézier regions on the object
    for side in patches:
        region, (m_point, m_normal) = pp.objects[side]
        lo, hi = _random_boxes(rng, np.zeros(2), np.ones(2), 60)
        r_point, r_normal = patch_remainders(region.patch, lo, hi)
        reach = 0.5 * (hi - lo).sum(axis=1)
        assert np.all(r_point <= 0.5 * m_point * reach**2 * (1 + 1e-6) + 1e-12)
        for b in range(len(lo)):
            c, h = 0.5 * (lo[b] + hi[b]), 0.5 * (hi[b] - lo[b])
            o, nu = region.evaluate(c[None])
            do, dnu = region.jacobian(c[None])
            t = rng.uniform(-1, 1, (50, 2)) * h
            O, N = region.evaluate(c + t)
            assert np.all(np.linalg.norm(O - o - t @ do[0].T, axis=1) <= r_point[b] * (1 + 1e-6) + 1e-12)
            assert np.all(np.linalg.norm(N - nu - t @ dnu[0].T, axis=1) <= r_normal[b] * (1 + 1e-6) + 1e-12)
