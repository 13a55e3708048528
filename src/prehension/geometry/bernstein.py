r"""Bernstein polynomials and Bézier control nets: basis, derivatives, products, subdivision.

The univariate algebra under :mod:`prehension.geometry.bezier` (and the complete solver's
relaxations): the Bernstein basis :math:`B_{i,n}(t) = \binom{n}{i} t^i (1-t)^{n-i}`, its
derivatives, the product of two patches' control nets and the restriction of a control
net to a parameter box.

*Derivatives.*  :math:`\frac{d^k}{dt^k} B_{i,n} = \frac{n!}{(n-k)!}
\sum_{j=0}^{k} (-1)^{k-j}\binom{k}{j} B_{i-j,n-k}`.

*Products* (eq. 19, Yamaguchi 1997).  The product of two Bernstein polynomials of
degrees :math:`m_1, m_2` is one of degree :math:`m_1 + m_2`:

.. math::

    B_{i_1,m_1} B_{i_2,m_2} = \frac{\binom{m_1}{i_1}\binom{m_2}{i_2}}
    {\binom{m_1+m_2}{i_1+i_2}} B_{i_1+i_2, m_1+m_2},

so the cross product of two 3-D patches is exactly a patch (:func:`cross_nets`).

*Subdivision* (eq. 33).  Restricting a degree-:math:`n` Bernstein polynomial to
:math:`[a, b]` and re-parameterising to :math:`[0, 1]` keeps the degree; by blossoming,
the new control points are :math:`c_k = \sum_i S_{ki} b_i` with

.. math::

    S_{ki} = \sum_{j} B_{j,n-k}(a)\, B_{i-j,k}(b),

which is valid for any real :math:`a \ne b` (and reverses the direction if
:math:`a > b`).  For a patch the matrices act on each parameter separately
(:func:`subdivide_nets`).
"""

from __future__ import annotations

from functools import lru_cache
from math import comb

import numpy as np

from prehension.errors import InvalidGeometry

__all__ = ["bernstein", "bernstein_derivative", "subdivision_matrix", "subdivide_nets", "cross_nets", "check_degree"]


def check_degree(degree: int, name: str = "degree") -> int:
    """``degree`` as an int; :class:`InvalidGeometry` naming ``name`` unless a non-negative integer."""
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 0:
        raise InvalidGeometry(f"{name} must be a non-negative integer, got {degree!r}")
    return int(degree)


@lru_cache(maxsize=None)
def _binomials(n: int) -> np.ndarray:
    """Binomial coefficients C(n, i), i = 0..n, shape (n+1,) (cached; read-only)."""
    out = np.array([comb(n, i) for i in range(n + 1)], dtype=np.float64)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=None)
def _difference(n: int, k: int) -> tuple[float, np.ndarray]:
    """``(n!/(n-k)!, D)`` of the k-th derivative of degree-n Bernstein polynomials, with
    ``D (n-k+1, n+1)`` the signed binomial difference matrix (cached; read-only)."""
    diff = np.zeros((n - k + 1, n + 1))
    rows = np.arange(n - k + 1)
    for j in range(k + 1):
        diff[rows, rows + j] = (-1.0) ** (k - j) * comb(k, j)
    diff.setflags(write=False)
    return comb(n, k) * np.prod(np.arange(1, k + 1), dtype=np.float64), diff


def bernstein(degree: int, t: np.ndarray) -> np.ndarray:
    """Bernstein basis polynomials of one degree at a batch of parameters.

    Args:
        degree: Polynomial degree ``n >= 0``.
        t: Parameters, shape ``(B,)`` (any shape ``(...)`` is accepted), unitless.
            Values outside ``[0, 1]`` evaluate the polynomial extension.

    Returns:
        Array of shape ``(B, n+1)`` (``(..., n+1)``) with entry ``[b, i] =
        B_{i,n}(t[b]) = C(n, i) t^i (1 - t)^(n - i)``.
    """
    n = check_degree(degree)
    t = np.asarray(t, dtype=np.float64)[..., None]
    i, rest = _exponents(n)
    return _binomials(n) * t**i * (1.0 - t) ** rest


@lru_cache(maxsize=None)
def _exponents(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(i, n - i)`` for i = 0..n (cached; read-only)."""
    i = np.arange(n + 1)
    rest = n - i
    i.setflags(write=False)
    rest.setflags(write=False)
    return i, rest


def bernstein_derivative(degree: int, t: np.ndarray, order: int = 1) -> np.ndarray:
    """Derivatives of the Bernstein basis polynomials with respect to the parameter.

    Uses ``d^k/dt^k B_{i,n} = n!/(n-k)! * sum_j (-1)^(k-j) C(k, j) B_{i-j, n-k}``.

    Args:
        degree: Polynomial degree ``n >= 0``.
        t: Parameters, shape ``(B,)`` (any shape ``(...)`` is accepted), unitless.
        order: Derivative order ``k >= 0`` (0 returns :func:`bernstein`).

    Returns:
        Array of shape ``(B, n+1)`` with entry ``[b, i] = d^k B_{i,n} / dt^k (t[b])``;
        identically zero when ``k > n``.
    """
    n = check_degree(degree)
    k = check_degree(order, "order")
    t = np.asarray(t, dtype=np.float64)
    if k > n:
        return np.zeros(t.shape + (n + 1,))
    lower = bernstein(n - k, t)
    scale, diff = _difference(n, k)
    return scale * (lower @ diff)


@lru_cache(maxsize=None)
def _sum_index_tensor(p: int, q: int) -> np.ndarray:
    """One-hot tensor ``E[i, j, i + j] = 1``, shape ``(p+1, q+1, p+q+1)`` (cached; read-only:
    every patch check of a task file asks for the same few degrees)."""
    e = np.zeros((p + 1, q + 1, p + q + 1))
    i, j = np.meshgrid(np.arange(p + 1), np.arange(q + 1), indexing="ij")
    e[i, j, i + j] = 1.0
    e.setflags(write=False)
    return e


def subdivision_matrix(degree: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Change of basis restricting Bernstein polynomials to ``[a, b]``.

    If ``f(t) = sum_i c_i B_{i,n}(t)`` then ``f(a + s (b - a)) = sum_k c'_k B_{k,n}(s)``
    with ``c' = S @ c``.  Exact (blossoming) for any real ``a, b``.

    Args:
        degree: Polynomial degree ``n >= 0``.
        a: Interval starts, shape ``(K,)`` (or scalar), unitless.
        b: Interval ends, shape ``(K,)`` (or scalar), unitless.

    Returns:
        Array ``S`` of shape ``(K, n+1, n+1)`` (``(n+1, n+1)`` for scalar ``a, b``),
        ``S[..., k, i] = sum_j B_{j,n-k}(a) B_{i-j,k}(b)``.
    """
    n = check_degree(degree)
    a, b = np.broadcast_arrays(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))
    rows = []
    for k in range(n + 1):
        outer = bernstein(n - k, a)[..., :, None] * bernstein(k, b)[..., None, :]
        rows.append(np.einsum("...jl,jli->...i", outer, _sum_index_tensor(n - k, k)))
    return np.stack(rows, axis=-2)


def cross_nets(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Control net of the cross product of two 3-D Bézier patches.

    Args:
        a: Control net of degree ``(ma, na)``, shape ``(ma+1, na+1, 3)``.
        b: Control net of degree ``(mb, nb)``, shape ``(mb+1, nb+1, 3)``.

    Returns:
        Control net of ``a x b``, degree ``(ma+mb, na+nb)``, shape
        ``(ma+mb+1, na+nb+1, 3)``.
    """
    ma, na = a.shape[0] - 1, a.shape[1] - 1
    mb, nb = b.shape[0] - 1, b.shape[1] - 1
    a_w = a * np.multiply.outer(_binomials(ma), _binomials(na))[..., None]
    b_w = b * np.multiply.outer(_binomials(mb), _binomials(nb))[..., None]
    pairs = np.cross(a_w[:, :, None, None, :], b_w[None, None, :, :, :])
    summed = np.einsum(
        "ajbkd,abx,jky->xyd", pairs, _sum_index_tensor(ma, mb), _sum_index_tensor(na, nb)
    )
    return summed / np.multiply.outer(_binomials(ma + mb), _binomials(na + nb))[..., None]


def subdivide_nets(net: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Control nets of one patch restricted to a batch of parameter boxes.

    Args:
        net: Control net, shape ``(M+1, N+1, D)``.
        boxes: Boxes ``(u0, u1, v0, v1)``, shape ``(K, 4)``.

    Returns:
        Restricted control nets, shape ``(K, M+1, N+1, D)``.
    """
    su = subdivision_matrix(net.shape[0] - 1, boxes[:, 0], boxes[:, 1])
    sv = subdivision_matrix(net.shape[1] - 1, boxes[:, 2], boxes[:, 3])
    rows = (su @ net.reshape(net.shape[0], -1)).reshape(len(boxes), su.shape[1], net.shape[1], net.shape[2])
    return sv[:, None] @ rows  # two matrix products: several times faster than one einsum
