"""One step of the kernel: damped least squares with an active set (:mod:`._kernel`'s iterations).

:func:`active_set_step` solves the contact rows' damped step ``ws.dx``
(:func:`._linalg.dls_dense`) with the unknowns at a bound that the step pushes out frozen,
and the sphere caps pushed out of their rim held on it (their two columns turned into a
radial and a tangent one, the radial one frozen); the active set is warm-started from the
previous step's and the product ``J~ J~^T`` updated only for the columns that change.
:func:`stacked_step` is the repair's and the seeing iterations' step on the contact rows
stacked over the inequality rows; :func:`limit_step` caps a step's size;
:func:`contact_motion` measures how far the contacts moved (the paper's eq. 10).
"""

from __future__ import annotations

import math

from ...kernels.jit import njit
from . import _regions as RG
from ._layout import S_KIND, S_OFF, S_X
from ._linalg import dls_again, dls_dense, fill, refresh_column

__all__ = ["active_set_step", "stacked_step", "limit_step", "contact_motion"]


@njit(cache=True)
def _turn(ws, c, i0, ga, gg):
    """Turn the columns ``(alpha, gamma)`` of a cap of contact ``c`` into (radial, tangent)
    with the rim's unit gradient ``(ga, gg)``; ``(ga, -gg)`` turns them back."""
    for r in range(6 * c, 6 * c + 6):
        u, v = ws.J[r, i0], ws.J[r, i0 + 1]
        ws.J[r, i0], ws.J[r, i0 + 1] = ga * u + gg * v, -gg * u + ga * v


@njit(cache=True)
def _refresh(ws, k):
    """Column ``k`` was frozen, released or turned after the step's solve: the solve's
    product follows (:func:`._linalg.refresh_column`)."""
    d = 0.0 if ws.frozen[k] else ws.col_scale[k]
    refresh_column(ws.J, 6 * ws.lay.sides.shape[0], k, d, ws.A, ws.Js)


@njit(cache=True)
def _turn_rims(ws, data):
    """Before a step's first solve: the caps held on their rim by the previous step that
    are still on it get their columns turned again and the radial one frozen (the rim's
    part of the warm-started active set); the others are let go.  ``ws.rims[2 c + side]``
    is ``(held, g_a, g_g)``."""
    lay, margin = ws.lay, ws.opt.cap_margin
    for c in range(lay.sides.shape[0]):
        for side in range(2):
            slot, s = 2 * c + side, lay.sides[c, side]
            if ws.rims[slot, 0] == 0.0:
                continue
            i0 = s[S_X]
            on, ga, gg = RG.rim_gradient(s[S_KIND], s[S_OFF], data, ws.x, i0, margin)
            ws.rims[slot, 0], ws.rims[slot, 1], ws.rims[slot, 2] = (1.0 if on else 0.0), ga, gg
            if on:
                _turn(ws, c, i0, ga, gg)
                ws.frozen[i0] = True


@njit(cache=True)
def _update_caps(ws, data):
    """After a solve: hold a cap on its rim when the step pushes it out; let a held cap go
    when its radial column's unconstrained step ``-J^T y`` points inside.  True if
    anything changed."""
    lay, margin = ws.lay, ws.opt.cap_margin
    again = False
    for c in range(lay.sides.shape[0]):
        for side in range(2):
            slot, s = 2 * c + side, lay.sides[c, side]
            i0 = s[S_X]
            if ws.rims[slot, 0] != 0.0:
                d = 0.0
                for r in range(6 * c, 6 * c + 6):
                    d -= ws.J[r, i0] * ws.y[r]
                if d > 0.0:  # let go; this step's answer keeps it on the rim
                    _turn(ws, c, i0, ws.rims[slot, 1], -ws.rims[slot, 2])
                    dt = ws.dx[i0 + 1]
                    ws.dx[i0], ws.dx[i0 + 1] = -ws.rims[slot, 2] * dt, ws.rims[slot, 1] * dt
                    ws.frozen[i0], ws.rims[slot, 0] = False, 0.0
                    _refresh(ws, i0)
                    _refresh(ws, i0 + 1)
                continue
            on, ga, gg = RG.rim_gradient(s[S_KIND], s[S_OFF], data, ws.x, i0, margin)
            if on and ga * ws.dx[i0] + gg * ws.dx[i0 + 1] < 0.0:
                _turn(ws, c, i0, ga, gg)
                ws.dx[i0], ws.dx[i0 + 1] = 0.0, -gg * ws.dx[i0] + ga * ws.dx[i0 + 1]  # the step's tangent part
                ws.frozen[i0], again = True, True
                ws.rims[slot, 0], ws.rims[slot, 1], ws.rims[slot, 2] = 1.0, ga, gg
                _refresh(ws, i0)
                _refresh(ws, i0 + 1)
    return again


@njit(cache=True)
def _update_active_set(ws, data):
    """After a solve: freeze unknowns at a bound that the step pushes out, release frozen
    ones whose unconstrained step points inside, and the same for caps on their rim
    (:func:`_update_caps`).  True if anything changed."""
    lay = ws.lay
    C = lay.sides.shape[0]
    again = False
    for k in range(ws.x.shape[0]):
        if not lay.boxed[k]:
            continue
        at_lo, at_hi = ws.x[k] <= lay.lo[k], ws.x[k] >= lay.hi[k]
        if ws.frozen[k]:
            d = 0.0  # sign of the unconstrained step: -J^T y
            for r in range(6 * C):
                d -= ws.J[r, k] * ws.y[r]
            if (at_lo and d > 0.0) or (at_hi and d < 0.0):
                ws.frozen[k] = False  # in the solve again if there is one, else from the next step on
                _refresh(ws, k)
        elif (at_lo and ws.dx[k] < 0.0) or (at_hi and ws.dx[k] > 0.0):
            ws.frozen[k], again = True, True
            _refresh(ws, k)
    return _update_caps(ws, data) or again


@njit(cache=True)
def active_set_step(ws, data, damping_sq, active_set):
    """One damped step ``ws.dx`` with an active set warm-started from the previous step's
    (frozen unknowns stay frozen while at their bound, held caps while on their rim);
    solved once more if the active set changed, the product ``J~ J~^T`` updated for the
    changed columns only.  False if the system could not be solved."""
    lay = ws.lay
    for k in range(ws.x.shape[0]):
        at_bound = lay.boxed[k] and (ws.x[k] <= lay.lo[k] or ws.x[k] >= lay.hi[k])
        ws.frozen[k] = ws.frozen[k] and at_bound and active_set
    if active_set:
        _turn_rims(ws, data)
    else:
        fill(ws.rims, 0.0)
    args = (ws.J, ws.f, 6 * lay.sides.shape[0], (ws.col_scale, ws.frozen), damping_sq, (ws.A, ws.L, ws.y, ws.dx, ws.Js))
    ok = dls_dense(*args)
    if ok and active_set and _update_active_set(ws, data):  # the product updated column by column
        ok = dls_again(ws.f, args[2], args[3], args[5])
    for slot in range(ws.rims.shape[0]):  # back to (alpha, gamma); the radial part is 0
        if ws.rims[slot, 0] != 0.0:
            i0 = lay.sides[slot // 2, slot % 2, S_X]
            dt = ws.dx[i0 + 1]
            ws.dx[i0], ws.dx[i0 + 1] = -ws.rims[slot, 2] * dt, ws.rims[slot, 1] * dt
            ws.frozen[i0] = False
    return ok


@njit(cache=True)
def limit_step(dx, col_scale, alpha, max_step):
    """``dx *= alpha``, then scaled so that no unknown moves more than ``max_step`` [mm]."""
    big = 0.0
    for j in range(dx.shape[0]):
        if col_scale[j] > 0.0:
            big = max(big, abs(dx[j]) / col_scale[j])
    fac = alpha if big * alpha <= max_step else max_step / big
    for j in range(dx.shape[0]):
        dx[j] *= fac


@njit(cache=True)
def contact_motion(f, f_prev, C):
    """How far the contacts moved in one step (eq. 10): sum of the two rows' changes [mm]."""
    total = 0.0
    for r0 in range(0, 6 * C, 3):
        total += math.sqrt((f[r0] - f_prev[r0]) ** 2 + (f[r0 + 1] - f_prev[r0 + 1]) ** 2 + (f[r0 + 2] - f_prev[r0 + 2]) ** 2)
    return total


@njit(cache=True)
def stacked_step(ws, n_rows, mu2):
    """One damped (``mu2`` [mm^2]) Gauss-Newton step on the stacked rows ``ws.M``, ``ws.g``
    (joint limits kept by freezing angles at a bound that the step pushes out)."""
    lay = ws.lay
    fill(ws.frozen, False)
    args = (ws.M, ws.g, n_rows, (ws.col_scale, ws.frozen), mu2, (ws.A, ws.L, ws.y, ws.dx, ws.Ms))
    ok = dls_dense(*args)
    if ok:
        again = False
        for j in range(ws.x.shape[0]):
            if lay.boxed[j] and ((ws.x[j] <= lay.lo[j] and ws.dx[j] < 0.0) or (ws.x[j] >= lay.hi[j] and ws.dx[j] > 0.0)):
                ws.frozen[j], again = True, True
        if again:
            ok = dls_dense(*args)
    if ok:
        limit_step(ws.dx, ws.col_scale, 1.0, ws.opt.max_step)
    return ok
