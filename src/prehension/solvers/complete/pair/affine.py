r"""Affine forms of vectors and scalars over boxes (batch), for the congruence test.

Over a box ``z = z_c + h * eps`` with ``eps in [-1, 1]^K``, a quantity is enclosed as

.. math::

    v(z) \in c + \sum_k A_k \varepsilon_k + \mathcal{B}(\rho),

a centre ``c``, one coefficient per box dimension and a remainder ball of radius ``rho``.
A first-order Taylor expansion at ``z_c`` with a bound ``M`` on the second derivatives
gives such a form (:func:`taylor_vector`): ``A_k = (dv/dz_k) h_k`` and
``rho = 1/2 sum_kl M_kl h_k h_l``.  Products are enclosed exactly up to their quadratic
terms, which go to the remainder:

.. math::

    u \cdot w \in u_c \cdot w_c + \sum_k (u_c \cdot W_k + w_c \cdot U_k)\,\varepsilon_k
    + \mathcal{B}\big(|u_c| \rho_w + |w_c| \rho_u + (\textstyle\sum_k |U_k| + \rho_u)
    (\sum_k |W_k| + \rho_w)\big),

and likewise for the cross product.  For the dot product the quadratic term
``sum_kl (U_k . W_l) eps_k eps_l`` is bounded term by term (:func:`_quadratic`) instead of
by the product of the two sums above: ``eps_k^2`` lies in ``[0, 1]``, so a diagonal term
``a_k eps_k^2`` (``a_k = U_k . W_k``) is ``a_k / 2 +- |a_k| / 2`` (half of it moves the
centre), and each pair ``k < l`` contributes ``|U_k . W_l + U_l . W_k|``, never more than
``|U_k| |W_l| + |U_l| |W_k|``: the enclosure lies inside the product bound's, and is
narrower where the two forms vary along different dimensions or directions (the pair
test's distance equation and cone conditions: 11-14% fewer boxes on the lid at t* + 1.5
and + 2 mm; the cross product keeps the product bound, where the same refinement costs
more than it saves).  Shapes: vectors ``c (B, 3)``, ``A (B, 3, K)``, ``rho (B,)``;
scalars ``c (B,)``, ``A (B, K)``, ``rho (B,)``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["Form", "taylor_vector", "dot", "cross", "sub", "neg", "spread", "contract_equal", "contract_at_least"]


class Form(NamedTuple):
    """``c + sum_k A[..., k] eps_k + B(rho)`` (vector or scalar, batched)."""

    c: np.ndarray
    A: np.ndarray
    rho: np.ndarray


def taylor_vector(value: np.ndarray, jacobian: np.ndarray, half: np.ndarray, curvature: np.ndarray) -> Form:
    """The form of a vector function from its value ``(B, 3)`` and Jacobian ``(B, 3, K)`` at the
    box centres, the half widths ``(B, K)`` and second-derivative bounds ``M (K, K)``."""
    rho = 0.5 * np.einsum("bk,kl,bl->b", half, curvature, half)
    return Form(value, jacobian * half[:, None, :], rho)


def _spread_vector(f: Form) -> np.ndarray:
    """``sum_k |A_k|``: how far the linear part can move the vector (B,)."""
    return np.linalg.norm(f.A, axis=1).sum(axis=1)


def dot(u: Form, w: Form) -> Form:
    c = np.einsum("bi,bi->b", u.c, w.c)
    A = np.einsum("bi,bik->bk", u.c, w.A) + np.einsum("bi,bik->bk", w.c, u.A)
    shift, radius = _quadratic(u.A, w.A)
    return Form(c + shift, A, _product_remainder(u, w) + radius)


def cross(u: Form, w: Form) -> Form:
    c = np.cross(u.c, w.c)
    A = np.cross(u.c[:, :, None], w.A, axis=1) + np.cross(u.A, w.c[:, :, None], axis=1)
    return Form(c, A, _product_remainder(u, w) + _spread_vector(u) * _spread_vector(w))


def _quadratic(u_A: np.ndarray, w_A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre shift and radius ``(B,), (B,)`` of ``(sum_k U_k eps_k) . (sum_l W_l eps_l)`` over
    ``eps in [-1, 1]^K`` (``u_A, w_A (B, 3, K)``): ``sum_k a_k eps_k^2 + sum_{k<l} b_kl eps_k eps_l``
    with ``a_k = U_k . W_k`` in ``a_k / 2 +- |a_k| / 2`` and ``b_kl = U_k . W_l + U_l . W_k``."""
    pairs = np.matmul(u_A.transpose(0, 2, 1), w_A)  # (B, K, K): U_k . W_l
    diagonal = np.einsum("bkk->bk", pairs)  # (B, K)
    both = np.abs(pairs + pairs.transpose(0, 2, 1)).sum(axis=(1, 2))  # every k != l twice, the diagonal as 2 |a_k|
    return 0.5 * diagonal.sum(axis=1), 0.5 * both - 0.5 * np.abs(diagonal).sum(axis=1)


def _product_remainder(u: Form, w: Form) -> np.ndarray:
    """The remainder of ``u * w`` but for the product of the linear parts (:func:`_quadratic`, or
    ``sum|U_k| sum|W_k|``): ``|u_c| rho_w + |w_c| rho_u + rho_u sum|W_k| + rho_w sum|U_k| + rho_u rho_w``."""
    nu, nw = np.linalg.norm(u.c, axis=1), np.linalg.norm(w.c, axis=1)
    return nu * w.rho + nw * u.rho + u.rho * _spread_vector(w) + w.rho * _spread_vector(u) + u.rho * w.rho


def sub(u: Form, w: Form) -> Form:
    return Form(u.c - w.c, u.A - w.A, u.rho + w.rho)


def neg(u: Form) -> Form:
    return Form(-u.c, -u.A, u.rho)


def spread(f: Form) -> np.ndarray:
    """``sum_k |A_k| + rho`` of a scalar form: its half range around ``c`` (B,)."""
    return np.abs(f.A).sum(axis=1) + f.rho


def contract_equal(f: Form, pad: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
    """Narrow ``eps`` intervals ``[lo, hi] (B, K)`` in place so that ``f = 0`` stays possible.

    ``sum_k a_k eps_k in [-c - rho - pad, -c + rho + pad]``; for each ``k`` the others span at
    most ``S - |a_k| |eps|`` (with the current intervals), which bounds ``a_k eps_k``.
    """
    _contract(f.A, -f.c - f.rho - pad, -f.c + f.rho + pad, lo, hi)


def contract_at_least(f: Form, pad: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
    """As :func:`contract_equal` for ``f >= 0``."""
    _contract(f.A, -f.c - f.rho - pad, np.full_like(f.c, np.inf), lo, hi)


def _contract(a: np.ndarray, row_lo: np.ndarray, row_hi: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
    t_lo, t_hi = np.minimum(a * lo, a * hi), np.maximum(a * lo, a * hi)  # (B, K) term ranges
    s_lo, s_hi = t_lo.sum(axis=1, keepdims=True), t_hi.sum(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        c_lo = row_lo[:, None] - (s_hi - t_hi)  # a_k eps_k >= c_lo
        c_hi = row_hi[:, None] - (s_lo - t_lo)  # a_k eps_k <= c_hi
        pos, neg_ = a > 0, a < 0
        new_lo = np.where(pos, c_lo / np.where(pos, a, 1.0), np.where(neg_, c_hi / np.where(neg_, a, 1.0), -np.inf))
        new_hi = np.where(pos, c_hi / np.where(pos, a, 1.0), np.where(neg_, c_lo / np.where(neg_, a, 1.0), np.inf))
        new_lo = new_lo - (1e-9 * np.abs(new_lo) + 1e-12)  # rounding of the divisions, outwards
        new_hi = new_hi + (1e-9 * np.abs(new_hi) + 1e-12)
    np.maximum(lo, np.where(np.isnan(new_lo), -np.inf, new_lo), out=lo)
    np.minimum(hi, np.where(np.isnan(new_hi), np.inf, new_hi), out=hi)
