"""The canonical polynomial system of eq. 29 (Rosales et al. 2011, sec. 4.1).

.. math::

    \\Lambda(x) = 0: \\; A x = b, \\qquad G x \\le h, \\qquad x \\in [l, u],

    \\Psi(x) = 0: \\; x_k = x_i^2 \\;(30), \\quad x_k = x_i x_j \\;(31), \\quad
    x_k = f(x_i, x_j) \\;(32),

where each ``f`` is a polynomial in Bernstein form on the unit square: its two arguments
are Bézier-patch parameters whose initial bounds lie inside ``[0, 1]``.  A :class:`System`
is a plain frozen value; the formulation (:mod:`.formulation`) builds it from a task, and
the complete solver's relaxations, box shrinking and search
(:mod:`prehension.solvers.complete`) consume it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

__all__ = ["BernsteinEquation", "System"]


@dataclass(frozen=True, eq=False)
class BernsteinEquation:
    """``x[k] = sum_pq coeffs[p, q] B_{p,dp}(x[i]) B_{q,dq}(x[j])`` with ``x[i], x[j]`` in [0, 1]."""

    k: int
    i: int
    j: int
    coeffs: np.ndarray  # (dp + 1, dq + 1)


@dataclass(frozen=True, eq=False)
class System:
    """Variables with an initial box, linear equations/inequalities and the Psi equations.

    Attributes:
        names: (n,) variable names (for people and for mapping back to a task).
        lower, upper: (n,) the initial box.
        A, b: sparse (m, n) and (m,): linear equations ``A x = b``.
        G, h: sparse (p, n) and (p,): linear inequalities ``G x <= h``.
        squares: (ns, 2) int rows ``(k, i)``: ``x_k = x_i^2``.
        products: (np, 3) int rows ``(k, i, j)``: ``x_k = x_i x_j`` (i != j).
        bernstein: the ``x_k = f(x_i, x_j)`` equations.
    """

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    A: sp.csr_matrix
    b: np.ndarray
    G: sp.csr_matrix
    h: np.ndarray
    squares: np.ndarray
    products: np.ndarray
    bernstein: tuple[BernsteinEquation, ...] = ()

    def __post_init__(self):
        n = len(self.names)
        for attr in ("lower", "upper", "b", "h"):
            object.__setattr__(self, attr, np.asarray(getattr(self, attr), dtype=float))
        for attr in ("A", "G"):
            object.__setattr__(self, attr, sp.csr_matrix(getattr(self, attr), shape=(getattr(self, attr).shape[0], n)))
        object.__setattr__(self, "squares", np.asarray(self.squares, dtype=int).reshape(-1, 2))
        object.__setattr__(self, "products", np.asarray(self.products, dtype=int).reshape(-1, 3))
        if self.lower.shape != (n,) or self.upper.shape != (n,) or np.any(self.lower > self.upper):
            raise ValueError("System: lower/upper must have shape (n,) with lower <= upper")

    @property
    def n(self) -> int:
        return len(self.names)

    @property
    def n_equations(self) -> int:
        """Linear equations plus Psi equations (the inequalities are not counted)."""
        return self.A.shape[0] + len(self.squares) + len(self.products) + len(self.bernstein)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """All equation residuals at ``x (n,)`` (linear, squares, products, Bernstein)."""
        from ..geometry.bezier import bernstein

        out = [self.A @ x - self.b]
        if len(self.squares):
            out.append(x[self.squares[:, 0]] - x[self.squares[:, 1]] ** 2)
        if len(self.products):
            out.append(x[self.products[:, 0]] - x[self.products[:, 1]] * x[self.products[:, 2]])
        for eq in self.bernstein:
            dp, dq = eq.coeffs.shape[0] - 1, eq.coeffs.shape[1] - 1
            f = bernstein(dp, np.atleast_1d(x[eq.i]))[0] @ eq.coeffs @ bernstein(dq, np.atleast_1d(x[eq.j]))[0]
            out.append(np.array([x[eq.k] - f]))
        return np.concatenate(out)

    def jacobian(self, x: np.ndarray) -> sp.csr_matrix:
        """Jacobian of :meth:`residuals` at ``x``, sparse (n_equations, n)."""
        from ..geometry.bezier import bernstein, bernstein_derivative

        rows = [sp.csr_matrix(self.A)]
        n = self.n
        for k, i in self.squares:
            rows.append(sp.csr_matrix(([1.0, -2.0 * x[i]], ([0, 0], [k, i])), shape=(1, n)))
        for k, i, j in self.products:
            rows.append(sp.csr_matrix(([1.0, -x[j], -x[i]], ([0, 0, 0], [k, i, j])), shape=(1, n)))
        for eq in self.bernstein:
            dp, dq = eq.coeffs.shape[0] - 1, eq.coeffs.shape[1] - 1
            bi, bj = bernstein(dp, np.atleast_1d(x[eq.i]))[0], bernstein(dq, np.atleast_1d(x[eq.j]))[0]
            di = bernstein_derivative(dp, np.atleast_1d(x[eq.i]))[0] @ eq.coeffs @ bj
            dj = bi @ eq.coeffs @ bernstein_derivative(dq, np.atleast_1d(x[eq.j]))[0]
            rows.append(sp.csr_matrix(([1.0, -di, -dj], ([0, 0, 0], [eq.k, eq.i, eq.j])), shape=(1, n)))
        return sp.vstack(rows, format="csr")

    def solution_dimension(self, x: np.ndarray, tol: float = 1e-8) -> int:
        """``n - rank(J(x))``: the dimension of the solution set near a solution ``x``."""
        J = self.jacobian(x).toarray()
        return self.n - int(np.linalg.matrix_rank(J, tol=tol * max(1.0, np.abs(J).max())))

    def inequality_violation(self, x: np.ndarray) -> float:
        """Largest violation of ``G x <= h`` and of the box (0 when satisfied)."""
        worst = float(np.max(self.G @ x - self.h, initial=0.0))
        return max(worst, float(np.max(self.lower - x, initial=0.0)), float(np.max(x - self.upper, initial=0.0)))
