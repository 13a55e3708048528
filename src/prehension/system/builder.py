"""Incremental construction of a canonical :class:`~.canonical.System`.

A :class:`Builder` hands out variables with bounds, collects linear equations and
inequalities over *linear expressions* (:class:`Lin`), and creates the auxiliary
variables of eqs. 27-28 (``x_k = x_i^2``, ``x_k = x_i x_j``) and 32 (Bernstein forms) on
demand, each once.  Every variable also records how its value follows from the
variables created before it, so that a known configuration can be *embedded* as a point
of the system (:meth:`Builder.complete_point`): the property tests use this to check that
a known solution satisfies every equation and lies in the initial box.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..geometry.bezier import bernstein
from .canonical import AngleCoupling, BernsteinEquation, System

__all__ = ["Lin", "Builder"]


@dataclass
class Lin:
    """A linear expression ``const + sum_i coeffs[i] x_i``."""

    coeffs: dict[int, float] = field(default_factory=dict)
    const: float = 0.0

    @staticmethod
    def var(i: int, c: float = 1.0) -> "Lin":
        return Lin({i: c})

    @staticmethod
    def constant(c: float) -> "Lin":
        return Lin({}, float(c))

    def __add__(self, other) -> "Lin":
        other = other if isinstance(other, Lin) else Lin.constant(other)
        out = dict(self.coeffs)
        for i, c in other.coeffs.items():
            out[i] = out.get(i, 0.0) + c
        return Lin(out, self.const + other.const)

    def __sub__(self, other) -> "Lin":
        return self + (other if isinstance(other, Lin) else Lin.constant(other)) * -1.0

    def __mul__(self, s: float) -> "Lin":
        return Lin({i: c * s for i, c in self.coeffs.items()}, self.const * s)

    __rmul__ = __mul__

    def bounds(self, lower: np.ndarray, upper: np.ndarray) -> tuple[float, float]:
        lo = hi = self.const
        for i, c in self.coeffs.items():
            a, b = c * lower[i], c * upper[i]
            lo, hi = lo + min(a, b), hi + max(a, b)
        return lo, hi

    def value(self, x: np.ndarray) -> float:
        return self.const + sum(c * x[i] for i, c in self.coeffs.items())

    def single(self) -> tuple[int, float] | None:
        """``(i, c)`` when the expression is ``c x_i`` with ``c = +-1``."""
        terms = [(i, c) for i, c in self.coeffs.items() if c != 0.0]
        if self.const == 0.0 and len(terms) == 1 and abs(terms[0][1]) == 1.0:
            return terms[0]
        return None


def lin_sum(terms) -> Lin:
    out = Lin()
    for t in terms:
        out = out + t
    return out


class Builder:
    """Collects variables and equations; :meth:`build` returns the frozen System."""

    def __init__(self):
        self.names: list[str] = []
        self.lower: list[float] = []
        self.upper: list[float] = []
        self.recipes: list[tuple] = []  # how each variable follows from earlier ones
        self.eq_rows: list[Lin] = []
        self.ineq_rows: list[Lin] = []
        self.squares: list[tuple[int, int]] = []
        self.products: list[tuple[int, int, int]] = []
        self.bernstein: list[BernsteinEquation] = []
        self.couplings: list[AngleCoupling] = []
        self._square_of: dict[int, int] = {}
        self._product_of: dict[tuple[int, int], int] = {}

    # -- variables ------------------------------------------------------------------
    def var(self, name: str, lo: float, hi: float, recipe=("base",)) -> int:
        if not lo <= hi:
            raise ValueError(f"variable {name}: empty bounds [{lo}, {hi}]")
        self.names.append(name)
        self.lower.append(float(lo))
        self.upper.append(float(hi))
        self.recipes.append(recipe)
        return len(self.names) - 1

    def bounds_of(self, expr: Lin) -> tuple[float, float]:
        return expr.bounds(np.asarray(self.lower), np.asarray(self.upper))

    def as_var(self, expr: Lin, name: str) -> tuple[int, float]:
        """A variable equal to ``expr`` (reused when ``expr`` is +-x_i): ``(index, sign)``."""
        single = expr.single()
        if single is not None:
            return single
        lo, hi = self.bounds_of(expr)
        k = self.var(name, lo, hi, ("linear", expr))
        self.equation(expr - Lin.var(k))
        return k, 1.0

    def as_var_bounded(self, expr: Lin, name: str, lo: float, hi: float) -> int:
        """A new variable equal to ``expr``, bounded by ``[lo, hi]`` and by expr's own range."""
        elo, ehi = self.bounds_of(expr)
        lo, hi = max(lo, elo), min(hi, ehi)
        k = self.var(name, lo, max(lo, hi), ("linear", expr))
        self.equation(expr - Lin.var(k))
        return k

    def square(self, i: int) -> int:
        if i not in self._square_of:
            lo, hi = self.lower[i], self.upper[i]
            sq_lo = 0.0 if lo <= 0.0 <= hi else min(lo * lo, hi * hi)
            k = self.var(f"({self.names[i]})^2", sq_lo, max(lo * lo, hi * hi), ("square", i))
            self.squares.append((k, i))
            self._square_of[i] = k
        return self._square_of[i]

    def product(self, i: int, j: int) -> int:
        if i == j:
            return self.square(i)
        key = (min(i, j), max(i, j))
        if key not in self._product_of:
            corners = [a * b for a in (self.lower[i], self.upper[i]) for b in (self.lower[j], self.upper[j])]
            k = self.var(f"{self.names[i]}*{self.names[j]}", min(corners), max(corners), ("product", i, j))
            self.products.append((k, i, j))
            self._product_of[key] = k
        return self._product_of[key]

    def bilinear(self, a: tuple[int, float], b: tuple[int, float]) -> Lin:
        """``(s_a x_a) (s_b x_b)`` as a linear expression in a product variable."""
        return Lin.var(self.product(a[0], b[0]), a[1] * b[1])

    def dot(self, u: list[tuple[int, float]], v: list[tuple[int, float]]) -> Lin:
        return lin_sum(self.bilinear(a, b) for a, b in zip(u, v))

    def bernstein_var(self, name: str, i: int, j: int, coeffs: np.ndarray) -> int:
        coeffs = np.asarray(coeffs, dtype=float)
        k = self.var(name, float(coeffs.min()), float(coeffs.max()), ("bernstein", i, j, coeffs))
        self.bernstein.append(BernsteinEquation(k, i, j, coeffs))
        return k

    # -- constraints ----------------------------------------------------------------
    def coupling(self, coupling: AngleCoupling) -> None:
        """An angle coupling (see :class:`~.canonical.AngleCoupling`)."""
        self.couplings.append(coupling)

    def equation(self, expr: Lin) -> None:
        """``expr = 0``."""
        self.eq_rows.append(expr)

    def inequality(self, expr: Lin) -> None:
        """``expr <= 0``."""
        self.ineq_rows.append(expr)

    # -- output ---------------------------------------------------------------------
    @staticmethod
    def _matrix(rows: list[Lin], n: int) -> tuple[sp.csr_matrix, np.ndarray]:
        data, ri, ci = [], [], []
        for r, row in enumerate(rows):
            for i, c in row.coeffs.items():
                if c != 0.0:
                    data.append(c)
                    ri.append(r)
                    ci.append(i)
        M = sp.csr_matrix((data, (ri, ci)), shape=(len(rows), n))
        return M, np.array([-row.const for row in rows])

    def build(self) -> System:
        n = len(self.names)
        A, b = self._matrix(self.eq_rows, n)
        G, h = self._matrix(self.ineq_rows, n)
        return System(
            tuple(self.names), np.array(self.lower), np.array(self.upper), A, b, G, h,
            np.array(self.squares, dtype=int).reshape(-1, 2),
            np.array(self.products, dtype=int).reshape(-1, 3),
            tuple(self.bernstein), tuple(self.couplings),
        )  # fmt: skip

    def complete_point(self, base_values: dict[int, float]) -> np.ndarray:
        """Every variable's value, given the values of the base variables."""
        x = np.zeros(len(self.names))
        for k, recipe in enumerate(self.recipes):
            kind = recipe[0]
            if kind == "base":
                x[k] = base_values[k]
            elif kind == "linear":
                x[k] = recipe[1].value(x)
            elif kind == "square":
                x[k] = x[recipe[1]] ** 2
            elif kind == "product":
                x[k] = x[recipe[1]] * x[recipe[2]]
            else:  # bernstein
                _, i, j, coeffs = recipe
                dp, dq = coeffs.shape[0] - 1, coeffs.shape[1] - 1
                x[k] = bernstein(dp, np.atleast_1d(x[i]))[0] @ coeffs @ bernstein(dq, np.atleast_1d(x[j]))[0]
        return x
