"""A general solver on the same problems: scipy's ``least_squares`` from the same initial poses.

Used by ``benchmarks/fig9.py`` to *measure* how much the local solver gains over a
well-known general method.  For every problem and every initial pose of the sequence
(the same ``Obtain_Initial_Conf`` as the local solver: anchor contact held, ``psi``
aligned), :func:`scipy.optimize.least_squares` (trust-region reflective, analytic
Jacobian, bounds for the joint limits and the patch parameters; a sphere cap's cone is
not a box, so its parameters only get their bounding box) minimises the same residual
(contact points and weighted normals).  Its answer is judged by the same checks
(the foundation's residuals, limits, couplings, self-collision) and the next initial
pose is tried when it fails, as in Algorithm 1.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from . import _kernel as K
from ...kernels.jit import njit
from ._linalg import mat_mat, mat_vec, rot
from .options import LocalOptions
from .problems import PointProblems
from .sequence import InitialPoseSequence, default_sequence
from ._checks import check, contact_checks_points
from ._starts import pose_index
from ._waves import run_kernel

__all__ = ["least_squares_batch"]


@njit(cache=True)
def _fun_jac(z, R0, cp0, data, model, out):
    """Residual and exact Jacobian at ``z`` where the twist entries are a rotation vector
    ``w`` and a shift ``v`` of the pivot from the initial pose ``(R0, pivot cp0)``.
    ``model = (hand, lay, opt, obj)``, ``out = (f, J, R, t)``."""
    f, J, R, t = out
    lay = model[1]
    nf = lay.nf
    piv = data[lay.pivot_offset : lay.pivot_offset + 3]
    w0, w1, w2 = z[nf], z[nf + 1], z[nf + 2]
    th = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    Rw = np.eye(3)
    if th > 0.0:
        rot(w0 / th, w1 / th, w2 / th, th, Rw)
    mat_mat(Rw, R0, R)
    pv = np.empty(3)
    mat_vec(R, piv, pv)
    for i in range(3):
        t[i] = cp0[i] + z[nf + 3 + i] - pv[i]
    K.residual_at(z, R, t, data, model, f, J)
    # the kernel's twist columns are derivatives along a left increment; d Rot(w) = [J_l(w) dw]x Rot(w)
    Jl = np.eye(3)
    if th > 1e-12:
        a = (1.0 - math.cos(th)) / (th * th)
        b = (th - math.sin(th)) / (th * th * th)
        Wx = np.array([[0.0, -w2, w1], [w2, 0.0, -w0], [-w1, w0, 0.0]])
        Jl = np.eye(3) + a * Wx + b * (Wx @ Wx)
    for r in range(f.shape[0]):
        c0, c1, c2 = J[r, nf], J[r, nf + 1], J[r, nf + 2]
        for k in range(3):
            J[r, nf + k] = c0 * Jl[0, k] + c1 * Jl[1, k] + c2 * Jl[2, k]


def least_squares_batch(
    problems: PointProblems,
    options: LocalOptions = LocalOptions(),
    sequence: InitialPoseSequence | None = None,
    rng=None,
    max_nfev: int = 100,
) -> dict:
    """Solve point problems one by one with ``least_squares`` from the local solver's initial poses.

    Returns a dict of arrays: ``solved_with`` (P,) 1-based initial pose or 0,
    ``seconds`` (P,) wall time per problem, ``level`` (P,) 2 strict / 1 d_min / 0,
    ``nfev`` (P,) function evaluations, and ``time_after`` (i_max,) the mean time per
    problem had ``i_max`` been 1, 2, ...
    """
    sequence = sequence if sequence is not None else default_sequence(problems.hand)
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(0 if rng is None else rng)
    fit = _Fit(problems, options, sequence, max_nfev)
    P, imax = len(problems), options.i_max
    solved_with = np.zeros(P, dtype=np.int64)
    level = np.zeros(P, dtype=np.int64)
    seconds = np.zeros(P)
    nfev = np.zeros(P, dtype=np.int64)
    per_pose_time = np.zeros((P, imax))
    for p in range(P):
        t_p = time.perf_counter()
        for i in range(imax):
            t_i = time.perf_counter()
            lam = sequence.lambdas[i : i + 1] if (options.initial == "sequence" and i < len(sequence)) else rng.uniform(0, 1, (1, 2))
            lev, evaluations = fit.run(p, lam)
            nfev[p] += evaluations
            per_pose_time[p, i] = time.perf_counter() - t_i
            if lev > 0:
                solved_with[p] = i + 1
                level[p] = lev
                break
        seconds[p] = time.perf_counter() - t_p
    # mean time per problem had i_max been 1..imax: a problem solved at pose s costs its
    # first min(s, i) poses; an unsolved one its first i
    time_after = np.array([per_pose_time[:, : i + 1].sum(axis=1).mean() for i in range(imax)])
    return {"solved_with": solved_with, "level": level, "seconds": seconds, "nfev": nfev, "time_after": time_after}


class _Fit:
    """One ``least_squares`` run of one problem from one initial pose, judged by the local
    solver's checks (:func:`._checks.check`)."""

    def __init__(self, problems: PointProblems, options: LocalOptions, sequence: InitialPoseSequence, max_nfev: int):
        self.problems, self.options, self.sequence, self.max_nfev = problems, options, sequence, max_nfev
        self.group = group = problems.group(options.joint_scale_mm)
        self.pidx = pose_index(group, sequence)
        self.use = self.pidx >= 0
        self.start_only = replace(options, k_max=0, polish=False, repair_iterations=0)
        self.kopt = options.kernel_options()
        nf = group.nf
        lo, hi = group.layout.lo.copy(), group.layout.hi.copy()
        lo[nf : nf + 6], hi[nf : nf + 6] = -np.inf, np.inf
        self.lo, self.hi = lo, np.maximum(hi, lo + 1e-12)

    def contacts(self, idx, pose, T, prm):
        return contact_checks_points(self.problems, idx, pose, T, prm)

    def run(self, p: int, lam: np.ndarray) -> tuple[int, int]:
        """``(level, function evaluations)`` of problem ``p`` from the pose of ``lam`` (1, 2)."""
        group, lo, hi = self.group, self.lo, self.hi
        nx, nf, C = group.nx, group.nf, len(group.contacts)
        data = group.pdata[p]
        piv = data[group.layout.pivot_offset : group.layout.pivot_offset + 3]
        x0 = group.x_default[None].copy()
        x0[:, self.use] = self.sequence.poses(lam)[:, self.pidx[self.use]]
        init = run_kernel(group, np.array([p]), x0, self.start_only)
        R0 = init.R[0].copy()
        cp0 = R0 @ piv + init.t[0]
        z0 = np.clip(init.x[0], lo, hi)
        buffers = (np.zeros(6 * C), np.zeros((6 * C, nx)), np.zeros((3, 3)), np.zeros(3))
        cache = {}

        def evaluate(z):
            key = z.tobytes()
            if key not in cache:
                cache.clear()
                _fun_jac(z, R0, cp0, data, (group.arrays, group.layout, self.kopt, group.obj), buffers)
                cache[key] = tuple(b.copy() for b in buffers)
            return cache[key]

        sol = least_squares(
            lambda z: evaluate(z)[0], z0, jac=lambda z: evaluate(z)[1], bounds=(lo, hi), method="trf",
            xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=self.max_nfev,
        )  # fmt: skip
        _, _, R, t = evaluate(sol.x)
        x = sol.x.copy()
        x[nf : nf + 6] = 0.0
        lev = check(group, self.contacts, np.array([p]), x[None], R[None], t[None], self.options).level[0]
        return lev, sol.nfev
