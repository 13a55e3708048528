r"""Cheap interval contraction of a box (HC4-style), with outward rounding.

Given the box ``[l, u]`` of a :class:`~prehension.system.System`, each constraint is used to
narrow the intervals of its variables; every constraint type is processed for all its
instances at once (vectorised, Jacobi style: candidates are computed from the box at
the start of the step and then intersected with it, several constraints on one
variable being intersected with ``np.fmax.at`` / ``np.fmin.at``):

* ``x_k = x_i^2``.  Forward: ``x_k in [min, max]`` of ``t^2`` over ``[l_i, u_i]``
  (``[0, max(l_i^2, u_i^2)]`` when ``0 in [l_i, u_i]``).  Backward: with
  ``r = [sqrt(max(l_k, 0)), sqrt(u_k)]``, ``x_i in hull(([-r_hi, -r_lo] U [r_lo, r_hi])
  ∩ [l_i, u_i])``.
* ``x_k = x_i x_j``.  Forward: interval product.  Backward: ``x_i in x_k / x_j`` when
  ``0 not in [l_j, u_j]`` (and symmetrically).
* ``x_k = f(x_i, x_j)``: ``x_k in [min, max]`` of the control points of ``f`` on the
  sub-box (convex-hull property), padded by their rounding bound.
* Angle couplings (:mod:`.couplings`): the interval of each coupled angle, narrowed by
  the other's, bounds its cosine and sine.
* Linear rows ``lo_r <= sum_j a_rj x_j <= hi_r`` (equations: ``lo = hi = b``;
  inequalities: ``lo = -inf``, ``hi = h``).  With the term intervals ``t_rj = a_rj
  [l_j, u_j]`` and the row sums ``S_r = sum_j t_rj``, the others' sum is
  ``S_r - t_rj`` and ``a_rj x_j in [lo_r, hi_r] - (S_r - t_rj)``; the row is infeasible
  when ``[S_r] ∩ [lo_r, hi_r] = ∅``.

Rounding.  Every once-rounded operation is followed by ``np.nextafter`` towards
``-inf`` (lower bounds) or ``+inf`` (upper bounds), which encloses its exact result.
Row sums of ``N`` terms are padded by ``2 (N + 1) eps sum |t|`` (twice the classical
``gamma_{N-1}`` bound) plus the smallest normal number (underflow).  Candidate bounds
that are NaN are ignored.  Consequently no real solution of the system in ``[l, u]``
is ever removed, and ``empty`` is only reported when some interval became empty,
i.e. when the box provably contains no solution.

The iteration stops when no interval shrinks by more than ``tol`` (relative to its
width) or after ``max_iter`` rounds.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from .couplings import contract_couplings
from .relaxations import EPS, TINY, bernstein_control_points, down, up
from ...system.canonical import System

__all__ = ["Contraction", "contract", "contract_linear"]


class Contraction(NamedTuple):
    """Result of :func:`contract`; unpacks as ``lower, upper, empty``."""

    lower: np.ndarray
    upper: np.ndarray
    empty: bool


def _tighten(lower, upper, idx, cand_lo, cand_hi) -> None:
    """Intersect ``[lower, upper][idx]`` with candidates in place (NaN candidates ignored)."""
    np.fmax.at(lower, idx, cand_lo)
    np.fmin.at(upper, idx, cand_hi)


def _is_empty(lower, upper) -> bool:
    return bool(np.any(lower > upper))


# ----------------------------------------------------------------------------------
# Psi equations
# ----------------------------------------------------------------------------------
def _contract_squares(squares, lower, upper) -> None:
    if not len(squares):
        return
    k, i = squares.T
    li, ui = lower[i], upper[i]
    lo2 = np.where(li > 0, li * li, np.where(ui < 0, ui * ui, 0.0))
    hi2 = np.maximum(li * li, ui * ui)
    _tighten(lower, upper, k, np.maximum(down(lo2), 0.0), up(hi2))
    lk, uk = lower[k], upper[k]
    with np.errstate(invalid="ignore"):
        r_hi = up(np.sqrt(uk))  # NaN when u_k < 0; then lower[k] >= 0 > upper[k]: empty
        r_lo = np.maximum(down(np.sqrt(np.maximum(lk, 0.0))), 0.0)
    pos_lo, pos_hi = np.maximum(li, r_lo), np.minimum(ui, r_hi)
    neg_lo, neg_hi = np.maximum(li, -r_hi), np.minimum(ui, -r_lo)
    pos_ok, neg_ok = pos_lo <= pos_hi, neg_lo <= neg_hi
    new_lo = np.where(neg_ok, neg_lo, np.where(pos_ok, pos_lo, np.inf))
    new_hi = np.where(pos_ok, pos_hi, np.where(neg_ok, neg_hi, -np.inf))
    valid = np.isfinite(r_hi)
    _tighten(lower, upper, i[valid], new_lo[valid], new_hi[valid])


def _interval_mul(al, ah, bl, bh):
    with np.errstate(over="ignore", invalid="ignore"):
        corners = np.stack([al * bl, al * bh, ah * bl, ah * bh])
    return down(corners.min(axis=0)), up(corners.max(axis=0))


def _interval_div(al, ah, bl, bh):
    """``[al, ah] / [bl, bh]`` for divisors excluding 0 (NaN elsewhere)."""
    ok = (bl > 0) | (bh < 0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        corners = np.stack([al / bl, al / bh, ah / bl, ah / bh])
    lo, hi = down(corners.min(axis=0)), up(corners.max(axis=0))
    return np.where(ok, lo, np.nan), np.where(ok, hi, np.nan)


def _contract_products(products, lower, upper) -> None:
    if not len(products):
        return
    k, i, j = products.T
    lo, hi = _interval_mul(lower[i], upper[i], lower[j], upper[j])
    _tighten(lower, upper, k, lo, hi)
    lk, uk = lower[k], upper[k]
    lo, hi = _interval_div(lk, uk, lower[j], upper[j])
    _tighten(lower, upper, i, lo, hi)
    lo, hi = _interval_div(lk, uk, lower[i], upper[i])
    _tighten(lower, upper, j, lo, hi)


def _bernstein_groups(equations):
    """Equations grouped by degree: ``[(k, i, j, coeffs (K, dp+1, dq+1)), ...]``."""
    groups: dict[tuple[int, int], list] = {}
    for eq in equations:
        groups.setdefault(np.shape(eq.coeffs), []).append(eq)
    return [
        (np.array([e.k for e in eqs]), np.array([e.i for e in eqs]), np.array([e.j for e in eqs]),
         np.stack([np.asarray(e.coeffs, dtype=float) for e in eqs]))
        for eqs in groups.values()
    ]


def _contract_bernstein(groups, lower, upper) -> None:
    for k, i, j, coeffs in groups:
        cp, err = bernstein_control_points(coeffs, lower[i], upper[i], lower[j], upper[j])
        _tighten(lower, upper, k, down(cp.min(axis=(1, 2)) - err), up(cp.max(axis=(1, 2)) + err))


# ----------------------------------------------------------------------------------
# Linear rows
# ----------------------------------------------------------------------------------
def contract_linear(M: sp.csr_matrix, row_lo, row_hi, lower, upper) -> bool:
    """One HC4 sweep of ``row_lo <= M x <= row_hi`` over the box, in place.

    Args:
        M: Sparse ``(m, n)`` (CSR).
        row_lo, row_hi: ``(m,)`` row bounds (``-inf``/``+inf`` allowed).
        lower, upper: ``(n,)`` box, modified in place.

    Returns:
        ``True`` when some row is proven infeasible on the box.
    """
    M = sp.csr_matrix(M)
    if M.nnz == 0:
        return bool(np.any((row_lo > 0) | (row_hi < 0)))
    rows = np.repeat(np.arange(M.shape[0]), np.diff(M.indptr))
    cols, a = M.indices, M.data
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        p1, p2 = a * lower[cols], a * upper[cols]
        t_lo, t_hi = down(np.minimum(p1, p2)), up(np.maximum(p1, p2))
        m = M.shape[0]
        nnz = np.diff(M.indptr)
        pad_lo = 2.0 * (nnz + 1) * EPS * np.bincount(rows, np.abs(t_lo), m) + TINY
        pad_hi = 2.0 * (nnz + 1) * EPS * np.bincount(rows, np.abs(t_hi), m) + TINY
        s_lo = down(np.bincount(rows, t_lo, m) - pad_lo)
        s_hi = up(np.bincount(rows, t_hi, m) + pad_hi)
        if np.any((s_lo > row_hi) | (s_hi < row_lo)):
            return True
        others_lo = down(s_lo[rows] - t_lo)
        others_hi = up(s_hi[rows] - t_hi)
        c_lo = down(row_lo[rows] - others_hi)  # a_rj x_j >= c_lo
        c_hi = up(row_hi[rows] - others_lo)  # a_rj x_j <= c_hi
        pos = a > 0
        cand_lo = np.where(pos, down(c_lo / np.where(pos, a, 1.0)), down(c_hi / np.where(pos, -1.0, a)))
        cand_hi = np.where(pos, up(c_hi / np.where(pos, a, 1.0)), up(c_lo / np.where(pos, -1.0, a)))
    nonzero = a != 0
    _tighten(lower, upper, cols[nonzero], cand_lo[nonzero], cand_hi[nonzero])
    return False


# ----------------------------------------------------------------------------------
# Driver
# ----------------------------------------------------------------------------------
def _widths(lower, upper):
    with np.errstate(invalid="ignore"):
        return upper - lower


def contract(
    system: System, lower: np.ndarray, upper: np.ndarray, *, tol: float = 0.01, max_iter: int = 20
) -> Contraction:
    """Contract ``[lower, upper]`` with every constraint of ``system`` to a (near) fixpoint.

    Args:
        system: The canonical system.
        lower, upper: The box, shape ``(n,)`` (not modified).
        tol: Stop when no interval shrinks by more than this fraction of its width.
        max_iter: Maximum number of rounds.

    Returns:
        :class:`Contraction` ``(lower, upper, empty)``; when ``empty`` the box contains no
        solution (the returned bounds are then meaningless).
    """
    lower = np.array(lower, dtype=float)
    upper = np.array(upper, dtype=float)
    if _is_empty(lower, upper):
        return Contraction(lower, upper, True)
    eq_lo = eq_hi = system.b
    ineq_lo, ineq_hi = np.full(len(system.h), -np.inf), system.h
    groups = _bernstein_groups(system.bernstein)
    for _ in range(max_iter):
        before = _widths(lower, upper)
        steps = (
            lambda: _contract_squares(system.squares, lower, upper),
            lambda: _contract_products(system.products, lower, upper),
            lambda: _contract_bernstein(groups, lower, upper),
            lambda: contract_linear(system.A, eq_lo, eq_hi, lower, upper),
            lambda: contract_linear(system.G, ineq_lo, ineq_hi, lower, upper),
            lambda: contract_couplings(system.couplings, lower, upper),
        )
        for step in steps:
            if step() or _is_empty(lower, upper):
                return Contraction(lower, upper, True)
        after = _widths(lower, upper)
        with np.errstate(invalid="ignore", divide="ignore"):
            gain = np.where(before > 0, (before - after) / before, 0.0)
        gain = np.where(np.isinf(before) & np.isfinite(after), 1.0, gain)
        if not np.any(gain > tol):
            break
    return Contraction(lower, upper, False)
