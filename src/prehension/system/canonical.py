"""The canonical polynomial system of eq. 29 (Rosales et al. 2011, sec. 4.1).

.. math::

    \\Lambda(x) = 0: \\; A x = b, \\qquad G x \\le h, \\qquad x \\in [l, u],

    \\Psi(x) = 0: \\; x_k = x_i^2 \\;(30), \\quad x_k = x_i x_j \\;(31), \\quad
    x_k = f(x_i, x_j) \\;(32),

where each ``f`` is a polynomial in Bernstein form on the unit square: its two arguments
are Bézier-patch parameters whose initial bounds lie inside ``[0, 1]``.

One constraint kind goes beyond eq. 29: an :class:`AngleCoupling` ``theta_d = r theta_s +
o`` between two joint angles, each known to the system by its cosine and sine variables
and to lie within its joint's limits.  For a ratio ``r = p / q`` with small ``p, q`` the
formulation also writes it exactly as polynomial equations (multiple-angle identities);
the coupling itself is kept for every ratio, as a constraint the solver enforces through
interval reasoning on the angles (:mod:`prehension.solvers.complete.couplings`).  A :class:`System`
is a plain frozen value; the formulation (:mod:`.formulation`) builds it from a task, and
the complete solver's relaxations, box shrinking and search
(:mod:`prehension.solvers.complete`) consume it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

__all__ = ["AngleCoupling", "BernsteinEquation", "System"]


@dataclass(frozen=True, eq=False)
class BernsteinEquation:
    """``x[k] = sum_pq coeffs[p, q] B_{p,dp}(x[i]) B_{q,dq}(x[j])`` with ``x[i], x[j]`` in [0, 1]."""

    k: int
    i: int
    j: int
    coeffs: np.ndarray  # (dp + 1, dq + 1)


@dataclass(frozen=True)
class AngleCoupling:
    """``theta_d = ratio theta_s + offset`` [rad] between two joint angles.

    ``(x[cos_d], x[sin_d]) = (cos theta_d, sin theta_d)`` with ``theta_d`` in
    ``range_d = (lower, upper)`` (the joint's limits, any width), and likewise for the
    source ``s``.
    """

    cos_d: int
    sin_d: int
    cos_s: int
    sin_s: int
    ratio: float
    offset: float
    range_d: tuple[float, float]
    range_s: tuple[float, float]


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
        couplings: the :class:`AngleCoupling` constraints.
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
    couplings: tuple[AngleCoupling, ...] = ()

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

    def coupling_violation(self, x: np.ndarray) -> float:
        """Largest violation [rad] of the angle couplings at ``x`` (0 when satisfied).

        Each angle is read as ``atan2(sin, cos)`` plus the multiple of ``2 pi`` that puts it
        in its range (every such choice is tried when the range is wider than ``2 pi``).
        """
        worst = 0.0
        for c in self.couplings:
            d = _angles_in_range(np.arctan2(x[c.sin_d], x[c.cos_d]), c.range_d)
            s = _angles_in_range(np.arctan2(x[c.sin_s], x[c.cos_s]), c.range_s)
            if not len(d) or not len(s):
                return float("inf")
            worst = max(worst, float(np.abs(d[:, None] - (c.ratio * s[None, :] + c.offset)).min()))
        return worst


def _angles_in_range(theta: float, bounds: tuple[float, float], slack: float = 1e-9) -> np.ndarray:
    """Every ``theta + 2 pi k`` within ``[lower - slack, upper + slack]``."""
    lo, hi = bounds
    k = np.arange(np.floor((lo - slack - theta) / (2 * np.pi)), np.ceil((hi + slack - theta) / (2 * np.pi)) + 1)
    out = theta + 2 * np.pi * k
    return out[(out >= lo - slack) & (out <= hi + slack)]
