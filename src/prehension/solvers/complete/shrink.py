r"""Box shrinking with linear programs and rigorous (safe) LP bounds (Rosales et al. 2011, sec. 4.3).

The LPs
-------
On the box ``B = [l, u]`` the solutions of the system satisfy ``M x in [row_lo, row_hi]``
with the stacked rows

.. math::

    M = \begin{pmatrix} A \\ G \\ G_{rel} \end{pmatrix}, \qquad
    row\_lo = (b, -\infty, -\infty), \qquad row\_hi = (b, h, h_{rel}),

where ``G_rel x <= h_rel`` are the relaxation rows of the Psi equations on ``B``
(:func:`.relaxations.relaxation_rows`), with the rows of the link rotations and joint limits
when ``shrink_box`` is given the system's ``rotations`` (:mod:`.rotation_cuts`; from the
second pass on also cuts at the previous pass's LP optima).  For each variable ``x_i`` (widest first) the
programs "minimise / maximise ``x_i`` subject to these rows and ``x in B``" (LP1/LP2 of
the paper) give new bounds.  A pass solves them all with ONE HiGHS model: only the
objective (and, as the box shrinks within the pass, the column bounds) change between
LPs, so every LP is warm-started from the previous basis.  Passes are repeated, after
an interval contraction (:mod:`.contract`) and with relaxation rows rebuilt on the smaller
box, while the box size drops below ``rho`` times its size at the start of the pass.

The LP is solved in shifted, scaled coordinates ``x = m + S z`` (``m`` the box centre,
``S`` the half widths) with rows scaled to unit max-norm, so HiGHS's absolute tolerances
stay meaningful on tiny boxes.  Its row bounds are outward enclosures of the shifted rows
(an equation becomes a range a few ulps wide), and variables whose width is at rounding
level (``lp_thin_width``) are constants of the LP whose range widens the rows; so the LP
stays a relaxation of the true problem.  The warm starts use the primal simplex (the
basis stays primal feasible when only the cost changes); a run that ends in anything but
Optimal or a verified infeasibility is retried cold with the dual simplex.  Within a pass,
"min x_j" / "max x_j" is skipped when an earlier Optimal LP point already (nearly) reached
that bound (``lp_filter_tol``; this only saves work).  The bounds themselves are computed
in the shifted coordinates ``d = x - m`` (see below) and never use HiGHS's objective value.

Safe bounds (Neumaier & Shcherbina 2004)
----------------------------------------
For *any* multipliers ``y`` and any ``x`` with ``M x in [row_lo, row_hi]``,
``x in [l, u]``::

    c^T x = y^T (M x) + r^T x,        r = c - M^T y,
    y^T (M x) >= sum_{y_r > 0} y_r row_lo_r + sum_{y_r < 0} y_r row_hi_r,
    r^T x     >= sum_j min(r_j l_j, r_j u_j).

Multipliers whose sign would meet an infinite row bound are set to 0 first, so the
right-hand side is a valid lower bound of ``c^T x`` over the feasible set whatever
``y`` is: HiGHS's row duals only make it *tight*.  It is evaluated rigorously:
``r`` is enclosed in ``[r_mid - rad, r_mid + rad]`` with ``rad = 2 (k + 2) eps (|c| +
|M|^T |y|) + tiny`` (``k`` = max nonzeros per column), every product is rounded towards
``-inf`` with ``np.nextafter``, the terms are added with :func:`math.fsum` (correctly
rounded) and the sum is rounded down once more.  The shifted rows
``M d in [row_lo - M m, row_hi - M m]`` use an outward enclosure of ``M m`` and the
shifted box ``[l - m, u - m]`` is rounded outwards.  With ``c = e_i`` this gives
``x_i >= m_i + bound`` (rounded down); with ``c = -e_i``, ``x_i <= m_i - bound``.

Safety rule (what may shrink, what is "empty")
----------------------------------------------
* A bound moves only to a safe bound from an LP that HiGHS reports ``Optimal`` (its row
  duals feed the formula above); any other status (error, time or iteration limit,
  unbounded, unknown, an exception) means *no reduction for this variable*.
* ``empty`` is reported only with a proof:
  (1) interval contraction with outward rounding produced an empty interval
  (``reason="contraction"``); or
  (2) a safe lower bound of some ``x_i`` exceeds its (safe) upper bound
  (``reason="lp-bound"``); or
  (3) HiGHS reports ``Infeasible`` and its dual ray ``y`` (either sign) verifies as a
  Farkas certificate: the safe lower bound of ``0^T x`` computed as above is ``> 0``
  (``reason="farkas"``).
  (``reason="input"`` flags a box given with ``lower > upper``.)
  An ``Infeasible`` status without a verified certificate stops the pass without any
  reduction and sets ``unverified_infeasible`` (the caller should split the box).

Rounding margins of the relaxation rows are described in :mod:`.relaxations`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import highspy
import numpy as np
import scipy.sparse as sp

from ...deadline import passed
from ...lp import quiet_highs
from .contract import contract
from .relaxations import EPS, TINY, down, relaxation_rows, up
from .rotation_cuts import RotationStructure, rotation_structure
from ...system.canonical import System
from ...system.formulation import QUATERNIONS

_MIN_ROW_NORM = 1e-200  # rows with a smaller scaled norm are not rescaled (no overflow)

__all__ = ["ShrinkOptions", "ShrinkResult", "safe_lower_bound", "farkas_infeasible", "shrink_box"]


@dataclass(frozen=True)
class ShrinkOptions:
    """Parameters of :func:`shrink_box`.

    Attributes:
        rho: Repeat passes while ``size(after) < rho * size(before)`` (paper's rho).
        max_passes: Maximum number of passes.
        size: ``"max"``: largest interval width relative to the system's initial box;
            ``"sum"``: sum of those relative widths.
        variables: Indices whose bounds are LP-shrunk (``None``: all).
        min_width: Variables at most this wide are not LP-shrunk.
        contract: Run interval contraction before each pass.
        contract_tol, contract_max_iter: Passed to :func:`.contract.contract`.
        lp_time_limit: Seconds per LP.
        lp_iteration_limit: Simplex iterations per LP.
        lp_thin_width: A variable whose half width is at most this times ``max(1, |centre|)``
            is a constant of the LP (its range widens the rows) and is not LP-shrunk.
        lp_filter_tol: Skip "min x_j" (resp. "max x_j") in a pass once an Optimal LP of
            that pass returned a point with ``x_j - l_j <= lp_filter_tol * (u_j - l_j)``
            (resp. ``u_j - x_j <= ...``): that LP could gain at most about this fraction of
            the width.  Negative: never skip.  (Skipping never affects safety.)
        midpoint_tangent: Add the midpoint tangent to each square's triangle.
        rotation_cuts: With the ``rotations`` of :func:`shrink_box`, add their quaternion-box
            rows and, from the second pass on, eigenvector cuts at the previous pass's LP
            optima (:mod:`.rotation_cuts`).
        limit_cuts: With the ``rotations`` of :func:`shrink_box`, add the ball rows of the
            joint limits and, from the second pass on, their cuts at the previous pass's LP
            optima.

        feasibility_first: Start each pass with one LP of zero objective: infeasible with a
            verified Farkas certificate, the box is empty at the cost of one LP.
        lp_order: ``"widest"``: bound the variables widest first (absolute widths);
            ``"narrowest"``: narrowest first, relative to the system's initial box (where
            the LPs of a box past a 3-4-contact frontier narrow most).
        stop_after, stop_gain: End a pass once ``stop_after`` LPs in a row narrowed their
            variable by less than ``stop_gain`` of its width (a failed LP counts as such);
            0: never (every variable is bounded).  Stopping early only keeps a box larger.

        Both cuts are off by default: sound and stronger per box (they empty most of the
        boxes past a 3-4-contact frontier that the LPs without them only narrow), but a box
        they do not empty costs 2-3x the CPU, and on the measured workloads the search
        decided no more with them (docs/complete-solver.md, "Rotation cuts": the random
        frontier families, the assignment search's 0.5 s proofs).

        quaternions: ``"palm"`` or ``"links"``: the system also carries the unit quaternion
            (``w >= 0``) of the palm's rotation or of every link's, with ``R = R(q)``, and a
            box is split through the widest quaternion component while its scaled width
            exceeds ``branch_width`` (:mod:`.branching`); ``"none"``: no quaternion.
        angles: the system also carries ``sin(theta - mid)`` of each joint angle of half
            range below 90 deg, the LPs bound it, and (after the quaternion) a box is split
            through the widest of them while its scaled width exceeds ``branch_width``.
        branch_width: see ``quaternions`` and ``angles``; in ``(0, 1]`` (1: those variables
            are split only when they are the widest base variables, as any other).
            (These three are splitting options kept with the shrink options: they shape the
            search's boxes as the others do, and travel with them to checkpoints and
            benchmarks.)  Off by default: past the undecided 3-4-contact frontiers they
            close 2-3x more of the tree in the first minute on some families, less on
            others, and decide none in 300 s (CHANGELOG, branch ``frontier6``).
    """

    rho: float = 0.9
    max_passes: int = 10
    size: str = "max"
    variables: tuple[int, ...] | None = None
    min_width: float = 0.0
    contract: bool = True
    contract_tol: float = 0.01
    contract_max_iter: int = 20
    lp_time_limit: float = 1.0
    lp_iteration_limit: int = 10_000
    lp_thin_width: float = 1e-11
    lp_filter_tol: float = 1e-3
    midpoint_tangent: bool = True
    rotation_cuts: bool = False
    limit_cuts: bool = False
    feasibility_first: bool = False
    lp_order: str = "widest"
    stop_after: int = 0
    stop_gain: float = 0.01
    quaternions: str = "none"
    angles: bool = False
    branch_width: float = 0.25

    def __post_init__(self):
        if not 0.0 < self.rho <= 1.0:
            raise ValueError(f"ShrinkOptions.rho must be in (0, 1], got {self.rho}")
        if self.size not in ("max", "sum"):
            raise ValueError(f"ShrinkOptions.size must be 'max' or 'sum', got {self.size!r}")
        if self.lp_order not in ("widest", "narrowest"):
            raise ValueError(f"ShrinkOptions.lp_order must be 'widest' or 'narrowest', got {self.lp_order!r}")
        if self.stop_after < 0 or not self.stop_gain >= 0.0:
            raise ValueError("ShrinkOptions: stop_after >= 0 and stop_gain >= 0 required")
        if self.quaternions not in QUATERNIONS:
            raise ValueError(f"ShrinkOptions.quaternions must be one of {', '.join(map(repr, QUATERNIONS))}, "
                             f"got {self.quaternions!r}")
        if not 0.0 < self.branch_width <= 1.0:
            raise ValueError(f"ShrinkOptions.branch_width must be in (0, 1] (a scaled width), got {self.branch_width}")
        if self.max_passes < 0 or self.lp_time_limit <= 0 or self.lp_iteration_limit <= 0:
            raise ValueError("ShrinkOptions: max_passes >= 0 and positive LP limits required")


@dataclass(frozen=True, eq=False)
class ShrinkResult:
    """Outcome of :func:`shrink_box`.

    Attributes:
        lower, upper: The shrunk box ``(n,)`` (meaningless when ``empty``).
        empty: The box provably contains no solution.
        n_lps: LPs solved.
        n_passes: LP passes run.
        n_failed_lps: LPs that gave no reduction because HiGHS did not report Optimal.
        n_skipped_lps: LPs skipped by the ``lp_filter_tol`` rule.
        reason: Proof of emptiness (``"contraction"``, ``"lp-bound"``, ``"farkas"``,
            ``"input"``) or ``""``.
        unverified_infeasible: HiGHS claimed infeasibility without a verifiable certificate.
    """

    lower: np.ndarray
    upper: np.ndarray
    empty: bool
    n_lps: int = 0
    n_passes: int = 0
    n_failed_lps: int = 0
    n_skipped_lps: int = 0
    reason: str = ""
    unverified_infeasible: bool = False


# ----------------------------------------------------------------------------------
# Neumaier-Shcherbina bounds
# ----------------------------------------------------------------------------------
def _min_products(r_lo, r_hi, lower, upper):
    """Rounded-down ``min r x`` over ``r in [r_lo, r_hi]``, ``x in [lower, upper]`` (0 inf = 0)."""
    with np.errstate(invalid="ignore", over="ignore"):
        prods = [np.where(r == 0, 0.0, r * x) for r in (r_lo, r_hi) for x in (lower, upper)]
    return down(np.minimum.reduce(prods))


class _DualBound:
    """Safe lower bounds of ``c^T x`` on ``{M x in [row_lo, row_hi], x in [lower, upper]}``."""

    def __init__(self, M: sp.spmatrix, row_lo: np.ndarray, row_hi: np.ndarray):
        self.MT = sp.csr_matrix(M).T.tocsr()
        self.absMT = abs(self.MT)
        counts = np.diff(self.MT.indptr)
        self.k = int(counts.max(initial=0))
        self.row_lo = np.asarray(row_lo, dtype=float)
        self.row_hi = np.asarray(row_hi, dtype=float)

    def __call__(self, c: np.ndarray, lower: np.ndarray, upper: np.ndarray, y: np.ndarray) -> float:
        y = np.where(np.isfinite(y), y, 0.0)
        y = np.where(((y > 0) & (self.row_lo == -np.inf)) | ((y < 0) & (self.row_hi == np.inf)), 0.0, y)
        rhs = np.where(y > 0, self.row_lo, self.row_hi)
        with np.errstate(invalid="ignore", over="ignore"):
            t_rows = np.where(y != 0, down(y * rhs), 0.0)
            r_mid = c - self.MT @ y
            rad = up(2.0 * (self.k + 2) * EPS * (np.abs(c) + self.absMT @ np.abs(y)) + TINY)
        t_cols = _min_products(down(r_mid - rad), up(r_mid + rad), lower, upper)
        terms = np.concatenate([t_rows, t_cols])
        if np.any(np.isnan(terms)) or np.any(terms == -np.inf):
            return -math.inf
        if np.any(terms == np.inf):
            return math.inf
        return float(down(math.fsum(terms)))


def safe_lower_bound(M, row_lower, row_upper, c, lower, upper, y) -> float:
    """Rigorous lower bound of ``c^T x`` over ``{row_lower <= M x <= row_upper, lower <= x <= upper}``.

    Valid for every ``y`` (typically the LP's row duals, HiGHS sign convention: ``y_r > 0``
    for a row at its lower bound in a minimisation); ``-inf`` when it cannot be bounded.

    Args:
        M: Sparse or dense ``(m, n)``.
        row_lower, row_upper: ``(m,)``, may contain ``-inf`` / ``+inf``.
        c: ``(n,)`` objective.
        lower, upper: ``(n,)`` box.
        y: ``(m,)`` multipliers.
    """
    bound = _DualBound(sp.csr_matrix(M), row_lower, row_upper)
    return bound(np.asarray(c, dtype=float), np.asarray(lower, dtype=float), np.asarray(upper, dtype=float),
                 np.asarray(y, dtype=float))


def farkas_infeasible(M, row_lower, row_upper, lower, upper, y) -> bool:
    """``True`` when ``y`` or ``-y`` rigorously proves the row/box system infeasible."""
    bound = _DualBound(sp.csr_matrix(M), row_lower, row_upper)
    return _farkas(bound, np.asarray(lower, dtype=float), np.asarray(upper, dtype=float), np.asarray(y, dtype=float))


def _farkas(bound: _DualBound, lower, upper, y) -> bool:
    zero = np.zeros(len(lower))
    return any(bound(zero, lower, upper, s * y) > 0 for s in (1.0, -1.0))


# ----------------------------------------------------------------------------------
# One HiGHS model per box
# ----------------------------------------------------------------------------------
class _BoxLP:
    """LPs ``min/max x_i`` over fixed rows on a box, solved warm by one HiGHS model."""

    def __init__(self, M: sp.csr_matrix, row_lo, row_hi, lower, upper, options: ShrinkOptions):
        self.options = options
        self.centre = np.clip(0.5 * lower + 0.5 * upper, lower, upper)
        half = 0.5 * (upper - lower)
        # columns at most ``lp_thin_width`` (relative) wide are constants in the LP: their
        # range is added to the row bounds instead (so the LP stays a relaxation), which
        # keeps HiGHS away from rows whose coefficients span many orders of magnitude
        self.thin = half <= options.lp_thin_width * np.maximum(1.0, np.abs(self.centre))
        self.scale = np.where(self.thin, 1.0, half)
        mc = M @ self.centre
        abs_m = abs(M)
        err = 2.0 * (np.diff(M.indptr) + 2) * EPS * (abs_m @ np.abs(self.centre)) + TINY
        with np.errstate(invalid="ignore"):
            shifted_lo = down(row_lo - up(mc + err))
            shifted_hi = up(row_hi - down(mc - err))
        self.bound = _DualBound(M, shifted_lo, shifted_hi)
        ms = sp.csr_matrix(M @ sp.diags(np.where(self.thin, 0.0, half)))
        row_max = np.asarray(abs(ms).max(axis=1).todense()).ravel()
        self.row_scale = 1.0 / np.where(row_max > _MIN_ROW_NORM, row_max, 1.0)
        a_lp = sp.csc_matrix(sp.diags(self.row_scale) @ ms)
        # The LP gets the *enclosures* of the shifted rows (equations become tiny ranges that
        # contain the real solutions even when the rounding of b - M c is amplified by the
        # scaling of a thin box; otherwise HiGHS may wrongly report infeasibility).
        widen = 2.0 * (abs_m @ np.where(self.thin, half, 0.0))
        col_lo = np.where(self.thin, 0.0, (lower - self.centre) / self.scale)
        col_hi = np.where(self.thin, 0.0, (upper - self.centre) / self.scale)
        self.highs = self._build(a_lp, self.row_scale * (shifted_lo - widen), self.row_scale * (shifted_hi + widen),
                                 col_lo, col_hi)
        self.costed: int | None = None
        self.point: np.ndarray | None = None  # x of the last Optimal LP (approximate)

    def _build(self, a, row_lo, row_hi, col_lo, col_hi):
        h = quiet_highs()
        h.setOptionValue("presolve", "off")
        h.setOptionValue("simplex_strategy", 4)  # primal: the basis stays feasible when the cost changes
        h.setOptionValue("simplex_iteration_limit", int(self.options.lp_iteration_limit))
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = a.shape[1], a.shape[0]
        lp.col_cost_ = np.zeros(a.shape[1])
        lp.col_lower_, lp.col_upper_ = col_lo, col_hi
        lp.row_lower_, lp.row_upper_ = row_lo, row_hi
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = a.indptr.astype(np.int32)
        lp.a_matrix_.index_ = a.indices.astype(np.int32)
        lp.a_matrix_.value_ = a.data.astype(float)
        h.passModel(lp)
        return h

    def set_bounds(self, i: int, lo: float, hi: float) -> None:
        if self.thin[i]:
            return
        c, s = self.centre[i], self.scale[i]
        self.highs.changeColBounds(i, (lo - c) / s, (hi - c) / s)

    def _run(self, i: int | None, sense: float):
        h = self.highs
        if self.costed is not None:
            h.changeColCost(self.costed, 0.0)
        if i is not None:
            h.changeColCost(i, sense)
        self.costed = i
        h.setOptionValue("time_limit", h.getRunTime() + self.options.lp_time_limit)
        h.run()
        return h.getModelStatus()

    def solve(self, i: int | None, sense: float, lower, upper) -> tuple[str, float]:
        """Bound ``x_i`` from below (``sense = +1``) or above (``-1``); ``i = None``: only
        whether the rows and the box have a point (a zero objective).

        Returns ``("bound", b)`` with the safe ``x_i >= b`` / ``x_i <= b``; ``("feasible",
        nan)`` (``i = None``, Optimal); ``("infeasible", verified)``; or ``("failed", nan)``.  A warm start that ends in
        anything but Optimal or a verified infeasibility is retried once from scratch with
        the dual simplex.
        """
        self.point = None
        d_lo = down(lower - self.centre)
        d_hi = up(upper - self.centre)
        outcome = self._attempt(i, sense, d_lo, d_hi)
        if outcome[0] not in ("bound", "feasible") and outcome != ("infeasible", True):
            # retry cold with the dual simplex (which also yields a dual ray on infeasibility)
            try:
                self.highs.clearSolver()
                self.highs.setOptionValue("simplex_strategy", 1)
                outcome = self._attempt(i, sense, d_lo, d_hi)
                self.highs.setOptionValue("simplex_strategy", 4)
            except Exception:  # noqa: BLE001
                return "failed", math.nan
        return outcome

    def _attempt(self, i: int | None, sense: float, d_lo, d_hi) -> tuple[str, float]:
        try:
            status = self._run(i, sense)
            ok = highspy.HighsModelStatus
            if status == ok.kOptimal:
                solution = self.highs.getSolution()
                z = np.asarray(solution.col_value, dtype=float)
                ok_shape = z.shape == self.centre.shape
                self.point = np.where(self.thin, self.centre, self.centre + self.scale * z) if ok_shape else None
                if i is None:
                    return "feasible", math.nan
                y = self.scale[i] * self.row_scale * np.asarray(solution.row_dual, dtype=float)
                c = np.zeros(len(d_lo))
                c[i] = sense
                b = self.bound(c, d_lo, d_hi, y)
                if not math.isfinite(b):
                    return "failed", math.nan
                return "bound", float(down(self.centre[i] + b) if sense > 0 else up(self.centre[i] - b))
            if status == ok.kInfeasible:
                has_ray, ray = self._dual_ray()
                return "infeasible", bool(has_ray and _farkas(self.bound, d_lo, d_hi, self.row_scale * ray))
        except Exception:  # noqa: BLE001 - any solver trouble means "no reduction"
            pass
        return "failed", math.nan

    def _dual_ray(self):
        _, has_ray, ray = self.highs.getDualRay()
        ray = np.asarray(ray, dtype=float)
        return has_ray and ray.shape == self.row_scale.shape, ray


# ----------------------------------------------------------------------------------
# Driver
# ----------------------------------------------------------------------------------
def _box_size(lower, upper, ref, kind: str) -> float:
    rel = (upper - lower) / ref
    return float(rel.max(initial=0.0) if kind == "max" else rel.sum())


@dataclass
class _Counters:
    n_lps: int = 0
    n_passes: int = 0
    n_failed: int = 0
    n_skipped: int = 0
    unverified: bool = False
    out_of_time: bool = False
    points: list = field(default_factory=list)  # LP optima of the last pass (eigenvector cuts)


def _lp_pass(system: System, lower, upper, options: ShrinkOptions, cnt: _Counters, deadline: float | None = None,
             rotations: RotationStructure | None = None) -> str:  # fmt: skip
    """One LP pass in place; returns ``""`` or the reason of emptiness.  Stops early (the box
    shrunk so far, which is safe) once ``deadline`` passes (``cnt.out_of_time``), and, with
    ``options.stop_after``, once that many LPs in a row narrowed their variable by less than
    ``options.stop_gain`` of its width (the next pass, if any, starts again)."""
    cut_points = np.array(cnt.points) if cnt.points else None
    cnt.points = []
    g_rel, h_rel = relaxation_rows(system, lower, upper, midpoint_tangent=options.midpoint_tangent,
                                   rotations=rotations, cut_points=cut_points, quaternion=options.rotation_cuts,
                                   limits=options.limit_cuts)
    M = sp.vstack([system.A, system.G, g_rel]).tocsr()
    row_lo = np.concatenate([system.b, np.full(len(system.h) + len(h_rel), -np.inf)])
    row_hi = np.concatenate([system.b, system.h, h_rel])
    lp = _BoxLP(M, row_lo, row_hi, lower, upper, options)
    if options.feasibility_first:
        reason = _feasibility(lp, lower, upper, cnt, rotations)
        if reason or cnt.unverified:
            return reason
    touched = {1.0: np.zeros(system.n, dtype=bool), -1.0: np.zeros(system.n, dtype=bool)}
    dull = 0  # LPs in a row that narrowed less than ``stop_gain``
    for i in _pass_order(system, lower, upper, options, lp.thin):
        for sense in (1.0, -1.0):
            if passed(deadline):
                cnt.out_of_time = True
                return ""
            if upper[i] - lower[i] <= options.min_width:
                break
            if touched[sense][i]:
                cnt.n_skipped += 1
                continue
            if options.stop_after and dull >= options.stop_after:
                return ""
            width = upper[i] - lower[i]
            kind, value = lp.solve(int(i), sense, lower, upper)
            cnt.n_lps += 1
            if kind == "bound":
                _keep_point(lp, lower, upper, options, cnt, rotations, touched)
                if sense > 0:
                    lower[i] = max(lower[i], value)
                else:
                    upper[i] = min(upper[i], value)
                if lower[i] > upper[i]:
                    return "lp-bound"
                dull = dull + 1 if upper[i] - lower[i] > (1.0 - options.stop_gain) * width else 0
                lp.set_bounds(int(i), lower[i], upper[i])
            elif kind == "infeasible":
                if value:
                    return "farkas"
                cnt.unverified = True
                return ""
            else:
                cnt.n_failed += 1
                dull += 1
    return ""


def _pass_order(system: System, lower, upper, options: ShrinkOptions, thin) -> np.ndarray:
    """The variables a pass bounds, in its order: widest first (absolute widths), or
    narrowest first relative to the system's initial box (``options.lp_order``)."""
    candidates = np.arange(system.n) if options.variables is None else np.asarray(options.variables, dtype=int)
    widths = upper[candidates] - lower[candidates]
    if options.lp_order == "widest":
        order = candidates[np.argsort(-widths, kind="stable")]
    else:
        ref = np.maximum(system.upper - system.lower, 1e-300)[candidates]
        order = candidates[np.argsort(widths / ref, kind="stable")]
    return order[~thin[order]]


def _feasibility(lp: _BoxLP, lower, upper, cnt: _Counters, rotations) -> str:
    """The pass's first LP with a zero objective: ``"farkas"`` when it is infeasible with a
    verified certificate (the box is empty), else ``""`` (``cnt.unverified`` when HiGHS
    said infeasible without one; its point joins the cut points when Optimal)."""
    kind, value = lp.solve(None, 0.0, lower, upper)
    cnt.n_lps += 1
    if kind == "infeasible":
        if value:
            return "farkas"
        cnt.unverified = True
    elif kind == "feasible" and lp.point is not None and rotations is not None:
        cnt.points.append(lp.point)
    elif kind == "failed":
        cnt.n_failed += 1
    return ""


def _keep_point(lp: _BoxLP, lower, upper, options: ShrinkOptions, cnt: _Counters, rotations, touched) -> None:
    """After an Optimal LP: its point joins the cut points (only where the cuts use them) and
    marks the bounds it (nearly) reaches, whose LPs the pass then skips (``lp_filter_tol``)."""
    if lp.point is None:
        return
    if rotations is not None:
        cnt.points.append(lp.point)
    if options.lp_filter_tol >= 0:
        slack = options.lp_filter_tol * (upper - lower)
        touched[1.0] |= lp.point - lower <= slack
        touched[-1.0] |= upper - lp.point <= slack


def cut_rotations(form, options: ShrinkOptions) -> RotationStructure | None:
    """The ``rotations`` of :func:`shrink_box` for the formulation ``form`` when ``options``
    asks for rotation or limit cuts, else None (nothing to build per box)."""
    return rotation_structure(form) if options.rotation_cuts or options.limit_cuts else None


def shrink_box(system: System, lower, upper, options: ShrinkOptions | None = None, *,
               deadline: float | None = None, rotations: RotationStructure | None = None) -> ShrinkResult:  # fmt: skip
    """Shrink ``[lower, upper]`` around the solutions of ``system`` (never losing one).

    Args:
        system: The canonical system of eq. 29.
        lower, upper: The box ``(n,)``, finite, inside ``system``'s initial box.
        options: :class:`ShrinkOptions` (defaults when ``None``).
        deadline: no LP is started after this :func:`time.perf_counter` instant: the box
            is returned as shrunk so far (still holding every solution).
        rotations: ``system``'s rotations and joint limits
            (:func:`.rotation_cuts.rotation_structure`): their cuts join the LPs
            (``options.rotation_cuts``, ``options.limit_cuts``).

    Returns:
        :class:`ShrinkResult`.  See the module docstring for the safety rule.
    """
    options = options or ShrinkOptions()
    lower = np.array(lower, dtype=float)
    upper = np.array(upper, dtype=float)
    cnt = _Counters()

    def result(empty: bool, reason: str = "") -> ShrinkResult:
        return ShrinkResult(lower, upper, empty, cnt.n_lps, cnt.n_passes, cnt.n_failed, cnt.n_skipped, reason,
                            cnt.unverified)

    if lower.shape != (system.n,) or upper.shape != (system.n,):
        raise ValueError(f"shrink_box: box must have shape ({system.n},)")
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        raise ValueError("shrink_box: the box must be finite")
    if np.any(lower > upper):
        return result(True, "input")
    ref = system.upper - system.lower
    ref = np.where(np.isfinite(ref) & (ref > 0), ref, 1.0)
    for _ in range(options.max_passes):
        size_before = _box_size(lower, upper, ref, options.size)
        if options.contract:
            lower, upper, empty = contract(system, lower, upper, tol=options.contract_tol,
                                           max_iter=options.contract_max_iter)
            if empty:
                return result(True, "contraction")
        cnt.n_passes += 1
        reason = _lp_pass(system, lower, upper, options, cnt, deadline, rotations)
        if reason:
            return result(True, reason)
        size_after = _box_size(lower, upper, ref, options.size)
        if cnt.unverified or cnt.out_of_time or size_before == 0 or size_after >= options.rho * size_before:
            break
    return result(False)
