"""Small compiled linear algebra for the kernel: 3-vectors, 3x3 matrices, damped least squares.

The step of :mod:`._kernel` is damped least squares on column-scaled unknowns,

.. math::

    \\Delta x = -D^{-1} \\tilde J^T (\\tilde J \\tilde J^T + \\mu^2 I)^{-1} f,
    \\qquad \\tilde J = J D^{-1},

with frozen unknowns (an active set) as zero columns: :func:`dls_dense`, for the contact
rows and for stacks of contact and inequality rows.  ``J~ J~^T`` is assembled densely:
at the kernel's sizes (24 rows, 27 unknowns for four fingertips) the dense products,
vectorised, cost less than gathering only the columns two contacts share (measured: one
step 5.4-9 us block by block, 4.1 us dense, in the same process).
"""

from __future__ import annotations

import math

from ...kernels.chain import mat_mat, mat_vec, rot  # the 3x3 products forward kinematics compiles too
from ...kernels.jit import njit

__all__ = ["copy", "fill", "dot", "rot", "mat_mat", "mat_vec", "cross", "cholesky_solve", "dls_dense", "refresh_column", "dls_again"]

# The sums of the damped step may be reordered (vectorised) and divisions turned into
# products with a reciprocal; NaN and infinity keep their meaning (no "nnan"/"ninf"), so a
# matrix that is not positive definite is still recognised.  Measured: the Cholesky
# solve of 24 rows 2.37 -> 1.83 us, of 44 rows 10.3 -> 6.7 us (same answers to 1e-15).
FAST = {"reassoc", "contract", "nsz", "arcp"}


@njit(cache=True)
def copy(src, dst):
    """``dst[...] = src`` for C-contiguous arrays of one size (an explicit loop: slice
    assignment compiles to much more code)."""
    a = src.reshape(src.size)
    b = dst.reshape(dst.size)
    for i in range(a.size):
        b[i] = a[i]


@njit(cache=True)
def fill(dst, value):
    """``dst[...] = value`` for a C-contiguous array."""
    b = dst.reshape(dst.size)
    for i in range(b.size):
        b[i] = value


@njit(cache=True)
def dot(a, b):
    """``a . b`` of two 3-vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def cross(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(cache=True, fastmath=FAST)
def cholesky_solve(A, b, n, L, y):
    """Solve ``A y = b`` (symmetric positive definite, first ``n`` rows); False if it fails."""
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not (s > 0.0):
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    for i in range(n):  # forward
        s = b[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):  # backward
        s = y[i]
        for k in range(i + 1, n):
            s -= L[k, i] * y[k]
        y[i] = s / L[i, i]
    return True


@njit(cache=True)
def _scale_columns(J, n, col_scale, frozen, Js):
    """``Js = J D^-1`` over the first ``n`` rows, frozen columns zero."""
    for k in range(J.shape[1]):
        d = 0.0 if frozen[k] else col_scale[k]
        for r in range(n):
            Js[r, k] = J[r, k] * d


@njit(cache=True, fastmath=FAST)
def _back(Js, y, n, col_scale, frozen, dx):
    """``dx = -D^-1 Js^T y`` over the first ``n`` rows (frozen unknowns stay put)."""
    for k in range(dx.shape[0]):
        s = 0.0
        for r in range(n):
            s += Js[r, k] * y[r]
        dx[k] = -s * (0.0 if frozen[k] else col_scale[k])


@njit(cache=True)
def _add_damping(A, n, mu2, rel):
    """``A += (mu2 + rel * mean diag) I``: damping plus a relative floor against round-off."""
    scale = 0.0
    for i in range(n):
        scale += A[i, i]
    scale = scale / n if n > 0 else 1.0
    for i in range(n):
        A[i, i] += mu2 + rel * scale


@njit(cache=True, fastmath=FAST)
def dls_dense(M, g, n, scaling, mu2, out):
    """Damped step for the first ``n`` rows of a stack ``M`` (the contact rows, or the
    contact rows and inequality rows), ``M~ M~^T`` assembled densely.

    Args:
        M, g: (m, nx) Jacobian and (m,) rows, of which the first ``n`` are used.
        scaling: ``(col_scale (nx,), frozen (nx,))``: ``D^-1`` and the frozen unknowns.
        mu2: damping ``mu^2`` [mm^2].
        out: ``(A, L, y, dx, Ms)`` scratch, the step in ``dx`` (nx,).
    """
    col_scale, frozen = scaling
    A, Ms = out[0], out[4]
    _scale_columns(M, n, col_scale, frozen, Ms)
    nx = M.shape[1]
    for i in range(n):
        for j in range(i, n):
            s = 0.0
            for k in range(nx):
                s += Ms[i, k] * Ms[j, k]
            A[i, j] = s
            A[j, i] = s
    _add_damping(A, n, mu2, 1e-12)
    return dls_again(g, n, scaling, out)


@njit(cache=True, fastmath=FAST)
def refresh_column(M, n, k, d, A, Ms):
    """Column ``k`` of ``M`` or its scale ``d`` changed (``d = 0``: frozen) since
    :func:`dls_dense`: ``Ms`` and ``A = M~ M~^T + damping`` (first ``n`` rows) follow, by
    taking the column's old outer product out and its new one in -- O(n^2) per column
    instead of a new O(n^2 nx) product (only the rows where the column is not zero)."""
    for i in range(n):
        a = Ms[i, k]
        if a != 0.0:
            for j in range(n):
                A[i, j] -= a * Ms[j, k]
    for r in range(n):
        Ms[r, k] = M[r, k] * d
    for i in range(n):
        a = Ms[i, k]
        if a != 0.0:
            for j in range(n):
                A[i, j] += a * Ms[j, k]


@njit(cache=True, fastmath=FAST)
def dls_again(g, n, scaling, out):
    """:func:`dls_dense` again after :func:`refresh_column` changes: factor and solve only."""
    col_scale, frozen = scaling
    A, L, y, dx, Ms = out
    if not cholesky_solve(A, g, n, L, y):
        fill(dx, 0.0)
        return False
    _back(Ms, y, n, col_scale, frozen, dx)
    return True
