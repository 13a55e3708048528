"""Rotation cuts (``Z(R) = 4 q q^T``): every row holds for every rotation of its box.

Rows are checked *exactly* (``fractions.Fraction``) at float rotation matrices, which lie
within ~1e-15 of SO(3); the rows' padding (1e-12) is far above that, far below any
reduction they make.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from tiny_tasks import FEASIBLE_UP_TO_MM, pincer_task

from prehension.solvers.complete.rotation_cuts import (
    eigen_cuts,
    limit_cuts,
    limit_rows,
    quaternion_box,
    rotation_rows,
    rotation_structure,
    z_intervals,
    z_matrix,
)
from prehension.results import Status
from prehension.solvers.complete.checkpoint import _options_mapping
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.solvers.complete.shrink import ShrinkOptions
from prehension.solvers.local.verifier import LocalVerifier
from prehension.system.embedding import embed
from prehension.system.formulation import build_system

ONE_LINK = np.arange(9).reshape(1, 3, 3)
WIDTHS = np.array([0.0, 1e-12, 1e-6, 1e-3, 0.05, 0.3, 1.0, 2.0])


def rows_hold(block, x) -> bool:
    cols, coef, rhs = block
    for c, a, d in zip(cols, coef[:, 0, :], rhs[:, 0]):
        lhs = sum(Fraction(float(ak)) * Fraction(float(x[ck])) for ak, ck in zip(a, c))
        if lhs > Fraction(float(d)):
            return False
    return True


def random_box_around(rng, R):
    """A box of the 9 entries holding ``R``: thin, wide, or with ``R`` on a face."""
    flat = R.ravel()
    below = rng.choice(WIDTHS, 9) * rng.choice([0.0, 0.5, 1.0], 9)
    above = rng.choice(WIDTHS, 9) * rng.choice([0.0, 0.5, 1.0], 9)
    return np.maximum(-1.0, flat - below), np.minimum(1.0, flat + above)


def test_z_is_four_q_q_transpose_for_the_systems_rotation_convention():
    """``x_object = R x_link`` is scipy's active rotation; ``Z(R) = 4 q q^T`` with ``q = (w, x, y, z)``."""
    rotations = Rotation.random(500, random_state=3)
    q = rotations.as_quat()[:, [3, 0, 1, 2]]
    Z = z_matrix(rotations.as_matrix())
    assert np.allclose(Z, 4.0 * np.einsum("pa,pb->pab", q, q), atol=1e-14)
    assert np.all(np.linalg.eigvalsh(Z)[:, 0] > -1e-13)
    assert np.allclose(np.trace(Z, axis1=1, axis2=2), 4.0)


def test_z_of_a_matrix_outside_so3_is_not_psd():
    assert np.linalg.eigvalsh(z_matrix(-np.eye(3)))[0] == pytest.approx(-2.0)
    assert np.linalg.eigvalsh(z_matrix(np.diag([1.0, 1.0, -1.0])))[0] < -1.0  # a reflection


@pytest.mark.parametrize("seed", range(6))
def test_intervals_quaternion_box_and_rows_hold_for_rotations_in_random_boxes(seed):
    rng = np.random.default_rng(7000 + seed)
    rotations = Rotation.random(300, random_state=seed)
    matrices, quats = rotations.as_matrix(), rotations.as_quat()[:, [3, 0, 1, 2]]
    n_rows = 0
    for R, q in zip(matrices, quats):
        lo, hi = random_box_around(rng, R)
        zl, zh = z_intervals(lo, hi)
        Z = z_matrix(R)
        assert np.all(zl[0] <= Z) and np.all(Z <= zh[0])
        ql, qh = quaternion_box(zl, zh)
        assert any(np.all((ql[0] <= s * q) & (s * q <= qh[0])) for s in (1.0, -1.0))
        block = rotation_rows(ONE_LINK, lo, hi)
        if block is not None:
            n_rows += len(block[2])
            assert rows_hold(block, R.ravel())
    assert n_rows > 300  # the boxes do give rows (the test can fail)


@pytest.mark.parametrize("seed", range(3))
def test_rows_hold_for_every_rotation_of_a_box_not_only_its_centre(seed):
    """Other rotations inside the same box (a cluster around a centre) satisfy its rows."""
    rng = np.random.default_rng(7100 + seed)
    for centre in Rotation.random(20, random_state=100 + seed):
        near = centre * Rotation.from_rotvec(rng.normal(size=(40, 3)) * rng.choice([1e-4, 0.02, 0.2]))
        flat = near.as_matrix().reshape(-1, 9)
        lo, hi = flat.min(axis=0), flat.max(axis=0)
        block = rotation_rows(ONE_LINK, lo, hi)
        assert block is not None
        assert all(rows_hold(block, x) for x in flat)


def test_rows_cut_off_matrices_of_the_box_that_are_no_rotation():
    """On the full box ``[-1, 1]^9`` the PSD rows exclude ``-I`` and reflections."""
    lo, hi = -np.ones(9), np.ones(9)
    block = rotation_rows(ONE_LINK, lo, hi)
    assert rows_hold(block, np.eye(3).ravel())
    assert not rows_hold(block, -np.eye(3).ravel())
    assert not rows_hold(block, np.diag([1.0, 1.0, -1.0]).ravel())


def test_rows_close_in_on_a_small_box():
    """On a box 1e-3 wide around a rotation, the Z entries are known to about the box width."""
    R = Rotation.from_rotvec([0.3, -0.5, 0.8]).as_matrix().ravel()
    zl, zh = z_intervals(R - 5e-4, R + 5e-4)
    assert np.max(zh - zl) < 1e-2
    block = rotation_rows(ONE_LINK, R - 5e-4, R + 5e-4)
    assert block is not None and rows_hold(block, R)


def test_an_empty_rotation_box_shows_as_crossed_intervals():
    """Every entry at 0.9: no rotation (columns would not be unit) -- some Z interval is empty."""
    zl, zh = z_intervals(np.full(9, 0.9), np.full(9, 0.95))
    assert np.any(zl > zh)


@pytest.mark.parametrize("seed", range(3))
def test_eigen_cuts_separate_non_rotations_and_keep_every_rotation(seed):
    rng = np.random.default_rng(7200 + seed)
    points = rng.uniform(-1.0, 1.0, (30, 9))
    block = eigen_cuts(ONE_LINK, points, per_link=30)
    assert block is not None
    worst = points[np.argsort(np.linalg.eigvalsh(z_matrix(points.reshape(-1, 3, 3)))[:, 0])[0]]
    assert not rows_hold(block, worst)
    for R in Rotation.random(200, random_state=seed).as_matrix():
        assert rows_hold(block, R.ravel())


def test_eigen_cuts_skip_points_inside_the_hull():
    inside = np.vstack([np.eye(3).ravel(), 0.5 * np.eye(3).ravel(), Rotation.random(random_state=1).as_matrix().ravel()])
    assert eigen_cuts(ONE_LINK, inside) is None


# ----------------------------------------------------------------------------------
# Joint limits as balls
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(4))
def test_limit_rows_and_cuts_hold_at_forward_built_configurations(sa_hand, seed):
    """At a configuration within the joint limits (forward-built task), every static limit
    row and every cut taken at random points of the initial box holds exactly."""
    from fk_tasks import build_fk_case

    rng = np.random.default_rng(7300 + seed)
    case = build_fk_case(sa_hand, rng)
    form = build_system(case.task)
    x = embed(form, case.config)
    structure = rotation_structure(form)
    assert len(structure.limit_radius) > 0
    assert rows_hold(limit_rows(structure), x)
    points = rng.uniform(form.system.lower, form.system.upper, (40, form.system.n))
    cuts = limit_cuts(structure, points, per_joint=5)
    assert cuts is not None and rows_hold(cuts, x)
    assert rows_hold(rotation_rows(structure.rotations, form.system.lower, form.system.upper), x)
    assert rows_hold(eigen_cuts(structure.rotations, points, per_link=5), x)


def test_limit_ball_matches_the_systems_limit_row(sa_hand):
    """``|R_a x_a - R_b x_b| <= rho`` holds at configurations within the limits and fails
    beyond them: the ball is the limit, not a looser set."""
    from fk_tasks import build_fk_case

    case = build_fk_case(sa_hand, np.random.default_rng(7400))
    form = build_system(case.task)
    structure = rotation_structure(form)
    x = embed(form, case.config)
    R = x[structure.limit_cols]
    gap = (np.einsum("jik,jk->ji", R[:, :9].reshape(-1, 3, 3), structure.limit_vectors[:, 0])
           - np.einsum("jik,jk->ji", R[:, 9:].reshape(-1, 3, 3), structure.limit_vectors[:, 1]))
    assert np.all(np.linalg.norm(gap, axis=1) <= structure.limit_radius)
    # a point beyond the limit of angle 0: R_b negated, so R_b x_b flips
    far = x.copy()
    Rb = x[structure.limit_cols[0, 9:]].reshape(3, 3)
    far[structure.limit_cols[0, 9:]] = (-Rb).ravel()  # not a rotation: only the row is tested
    cut = limit_cuts(structure, far[None], per_joint=1)
    assert cut is not None and not rows_hold(cut, far)


def test_a_tiny_positive_diagonal_bound_does_not_flip_a_division():
    """``Z_aa`` known to be in ``(0, 1e-12]``: the padded lower end is not positive, so no
    division by it may narrow ``Z_bc`` or the quaternion (the true ``Z_bc`` is kept)."""
    q = np.array([1e-7, 0.6, 0.48, 0.0])
    q[3] = np.sqrt(1.0 - q @ q)
    Z = 4.0 * np.outer(q, q)
    zl, zh = (Z - 1e-9)[None], (Z + 1e-9)[None]
    zl[0, 0, 0], zh[0, 0, 0] = 1e-14, 1e-9  # Z_00 = 4e-14
    from prehension.solvers.complete import rotation_cuts as rc

    rc._narrow_off_diagonal(zl, zh)
    assert np.all(zl[0] <= Z) and np.all(Z <= zh[0])
    ql, qh = quaternion_box(zl, zh)
    assert any(np.all((ql[0] <= s * q) & (s * q <= qh[0])) for s in (1.0, -1.0))


@pytest.mark.parametrize("cuts", [True, False])
def test_the_search_with_and_without_the_cuts_decides_the_pincer_alike(cuts):
    """Off by default (ShrinkOptions); on, the search still solves the pincer within reach
    and proves it infeasible just past reach, and a checkpoint tells the two searches apart."""
    options = BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=120,
                                    shrink=ShrinkOptions(rotation_cuts=cuts, limit_cuts=cuts))
    assert solve_complete(pincer_task(FEASIBLE_UP_TO_MM - 1.0), options).status == Status.SOLVED
    assert solve_complete(pincer_task(FEASIBLE_UP_TO_MM + 1.0), options).status == Status.INFEASIBLE
    mapping = _options_mapping(options)
    assert ("shrink.rotation_cuts" in mapping) == cuts  # off: the fingerprint of the search before the cuts
    assert ShrinkOptions().rotation_cuts is False and ShrinkOptions().limit_cuts is False
