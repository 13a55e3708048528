"""The numeric core of the local solver (Claret & Suárez, sec. 3.1), compiled with numba.

One call of :func:`run_states` runs Algorithm 1's inner loop for ``S`` *states*, each a
(problem, initial pose) pair, one after the other.  A state goes through phases, each a
function that returns a status code (``MESSAGES`` says what each means, as
``scipy.optimize`` does):

1. :func:`start` -- Obtain_Initial_Conf: the hand at the initial pose, the object placed
   so that the anchor contact holds (:func:`._model.initial_pose`);
2. :func:`iterate` -- damped least-squares steps until every contact is within ``d_min``
   (``WITHIN_DMIN``), or the paper's ending conditions stop it (``STALLED``, ``K_MAX``,
   ``SINGULAR``);
3. :func:`polish` -- Gauss-Newton steps from a ``d_min`` answer until the contacts are
   within ``polish_tol`` (``STRICT``);
4. :func:`repair` -- Check_Collisions, and beyond the paper: a local solution in
   self-collision, or with a link in the object's solid, is moved out of it by
   Gauss-Newton on the contact rows plus one inequality row per capsule pair or capsule
   closer than the margin (:mod:`._model`, :mod:`._penetration`), then polished again;
   ``COLLIDING`` when that fails; a clear state within ``d_min`` met on the way is
   polished at once (:func:`_polished_clear`), which ends the repair when it succeeds.

The caller (:mod:`.solver`) re-checks every answer with the foundation's functions.
The state, its scratch arrays and its options travel as NamedTuples and one StructRef
(:mod:`._workspace`: :class:`~._workspace.Workspace`, :class:`~._workspace.Options`;
:class:`~._layout.HandArrays`, :class:`~._layout.Layout`,
:class:`~._penetration.ObjectArrays`).  The steps stay in this module: a compiled function
calls another module's functions measurably slower than its own module's (measured:
the damped step in a module of its own cost 8% of a batch of point problems).
"""

from __future__ import annotations

import math
import numpy as np

from ...kernels.jit import njit
from . import _regions as RG
from ._layout import S_KIND, S_OFF, S_X
from ._linalg import copy, dls_again, dls_dense, fill, refresh_column
from ._model import contact_rows, inequality_rows, initial_pose, move, place_capsules, pose_hand, project_all, seeing_rows
from ._penetration import surely_in_object
from ._workspace import MAX_INEQUALITY_ROWS, Options, Outputs, Workspace, _state_at, new_workspace, penetration_at, residual_at
from ._workspace import stacked_rows_at
from ._workspace import _WorkspaceType  # noqa: F401 -- named here by numba caches written before the workspace moved

__all__ = ["Options", "Workspace", "Outputs", "MESSAGES", "run_states", "residual_at", "penetration_at", "stacked_rows_at",
           "seeing_step_at", "LOCAL_SOLUTIONS"]

# status codes of a state, and what they mean
NOT_RUN, STRICT, WITHIN_DMIN, STALLED, K_MAX, SINGULAR, COLLIDING = 0, 1, 2, 3, 4, 5, 6
MESSAGES = {
    NOT_RUN: "not run",
    STRICT: "contacts within the polishing tolerance, clear of self-collision and of the object",
    WITHIN_DMIN: "contacts within d_min only (polishing did not reach its tolerance)",
    STALLED: "no progress: the contacts moved less than s_min for n_stall iterations",
    K_MAX: "k_max iterations without reaching d_min",
    SINGULAR: "the damped least-squares step could not be computed",
    COLLIDING: "a local solution in self-collision or in the object that the repair could not clear",
}
LOCAL_SOLUTIONS = (STRICT, WITHIN_DMIN)
BEST, REPAIRED = 0, 1  # slots of the workspace's saved states
REPAIR_PATIENCE, REPAIR_GAIN = 6, 0.05  # a repair in collision ends after 6 steps without a clearance 0.05 mm better than its best
# the seeing steps (:func:`_seeing_step`): capsules within SEEING_REACH_MM of the object are rows when the step would bring
# them within the margin (at most SEEING_PASSES more solves); while something is deeper than DEEP_MM, the contact rows
# weigh DEEP_WEIGHT (the hand first leaves the object).  Measured on the built-ins and objects.py's 30 mesh tasks, 32
# initial poses each (docs/local-solver.md): clear strict answers 501 -> 567 of 1248 states; a prototype's sweep gave
# 553-573 for any reach of 10-30 mm and weight of 0.2-0.5 (not tuned on the built-ins)
SEEING_REACH_MM, SEEING_PASSES, DEEP_MM, DEEP_WEIGHT = 20.0, 3, 1.0, 0.5


# -- saving and restoring a state ---------------------------------------------------------------
@njit(cache=True)
def _keep(ws, slot):
    copy(ws.x, ws.keep_x[slot])
    copy(ws.R, ws.keep_R[slot])
    copy(ws.t, ws.keep_t[slot])
    copy(ws.err, ws.keep_err[slot])


@njit(cache=True)
def _restore(ws, data, slot):
    """Back to a saved state, with its hand pose and contact rows recomputed."""
    copy(ws.keep_x[slot], ws.x)
    copy(ws.keep_R[slot], ws.R)
    copy(ws.keep_t[slot], ws.t)
    pose_hand(ws)
    contact_rows(ws, data, np.bool_(True))


# -- one step ---------------------------------------------------------------------------------------
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
def _step(ws, data, damping_sq, active_set):
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
def _limit_step(dx, col_scale, alpha, max_step):
    """``dx *= alpha``, then scaled so that no unknown moves more than ``max_step`` [mm]."""
    big = 0.0
    for j in range(dx.shape[0]):
        if col_scale[j] > 0.0:
            big = max(big, abs(dx[j]) / col_scale[j])
    fac = alpha if big * alpha <= max_step else max_step / big
    for j in range(dx.shape[0]):
        dx[j] *= fac


@njit(cache=True)
def _motion(f, f_prev, C):
    """How far the contacts moved in one step (eq. 10): sum of the two rows' changes [mm]."""
    total = 0.0
    for r0 in range(0, 6 * C, 3):
        total += math.sqrt((f[r0] - f_prev[r0]) ** 2 + (f[r0 + 1] - f_prev[r0 + 1]) ** 2 + (f[r0 + 2] - f_prev[r0 + 2]) ** 2)
    return total


# -- the phases -------------------------------------------------------------------------------------
@njit(cache=True)
def start(x0, ws, data):
    """Obtain_Initial_Conf from unknowns ``x0`` (hand angles and hand parameters used)."""
    copy(x0, ws.x)
    copy(ws.lay.col_scale, ws.col_scale)
    extent = max(data[ws.lay.pivot_offset + 3], 10.0)  # rotations scaled by the object's size
    for j in range(ws.lay.nf, ws.lay.nf + 3):
        ws.col_scale[j] = 1.0 / extent
    project_all(ws, data)
    pose_hand(ws)
    initial_pose(ws, data)
    fill(ws.frozen, False)
    fill(ws.rims, 0.0)


@njit(cache=True)
def iterate(ws, data, seeing):
    """Damped steps until the contacts are within ``d_min``: ``(code, iterations)``.

    With ``seeing``, the inequality rows (:func:`._model.seeing_rows`: capsule pairs closer
    than the margin, and capsules against the object, the idle fingers' too, within
    :data:`SEEING_REACH_MM`) are stacked under the contact rows at every step
    (:func:`_seeing_step`): the hand approaches the contacts around the object instead of
    through it; ``WITHIN_DMIN`` then says nothing of the clearance (the caller checks it).

    Seeing is run from the start again when the plain iterations' local solution went
    through the object (:func:`_seeing_again`): repairing that one is a search for another
    basin (a link through a guitar's neck stays through it under small steps), which costs
    tens of repair steps and mostly fails; approaching with the object in view ends clear
    far more often.  Each seeing step pays the rows' mesh queries, so the plain iterations
    stay the first try."""
    lay, opt = ws.lay, ws.opt
    C = lay.sides.shape[0]
    n = 6 * C
    stall = 0
    for k in range(opt.k_max + 1):
        contact_rows(ws, data, np.bool_(True))
        if ws.err[0] < opt.d_min and ws.err[1] < opt.d_min:
            return WITHIN_DMIN, k
        if k > 0:
            stall = stall + 1 if _motion(ws.f, ws.f_prev, C) < opt.s_min else 0
            if stall >= opt.n_stall:
                return STALLED, k
        if k == opt.k_max:
            break
        copy(ws.f, ws.f_prev)
        if seeing:
            ok = _seeing_step(ws, data)
        else:
            ok = _step(ws, data, opt.damping_sq, opt.active_set)
            if ok:
                _limit_step(ws.dx, ws.col_scale, opt.alpha, opt.max_step)
        if not ok:
            return SINGULAR, k + 1
        move(ws, data)
        pose_hand(ws)
    return K_MAX, opt.k_max


@njit(cache=True)
def polish(ws, data):
    """Gauss-Newton from the current state (its rows computed), keeping the best state met:
    ``(STRICT or WITHIN_DMIN, iterations)``."""
    opt = ws.opt
    tol = opt.polish_tol
    best = max(ws.err[0], ws.err[1]) / tol
    _keep(ws, np.int64(BEST))
    it = 0
    while it < opt.n_polish and best > 1.0:
        it += 1
        if not _step(ws, data, 1e-18, np.bool_(True)):
            break
        move(ws, data)
        pose_hand(ws)
        contact_rows(ws, data, np.bool_(True))
        cur = max(ws.err[0], ws.err[1]) / tol
        if cur < best:
            best = cur
            _keep(ws, np.int64(BEST))
        elif cur > 100.0 * best:  # diverging
            break
    _restore(ws, data, np.int64(BEST))
    return (STRICT if best <= 1.0 else WITHIN_DMIN), it


@njit(cache=True)
def clearance(ws, data):
    """Smallest inequality value of the state (negative: in collision) [mm]."""
    return inequality_rows(ws, data, ws.opt.collision_margin, np.int64(0), np.int64(0), np.bool_(False))[1]


@njit(cache=True)
def _repair_step(ws, n_rows, mu2):
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
        _limit_step(ws.dx, ws.col_scale, 1.0, ws.opt.max_step)
    return ok


@njit(cache=True)
def _swap_rows(ws, a, b):
    for j in range(ws.M.shape[1]):
        ws.M[a, j], ws.M[b, j] = ws.M[b, j], ws.M[a, j]
    ws.g[a], ws.g[b] = ws.g[b], ws.g[a]


@njit(cache=True)
def _take_predicted(ws, na, total):
    """Move the rows ``na .. total - 1`` that the step ``ws.dx`` would take below zero
    (linearly: ``g + M dx < 0``) up to ``na``; the new ``na``."""
    for r in range(na, total):
        pred = ws.g[r]
        for j in range(ws.dx.shape[0]):
            pred += ws.M[r, j] * ws.dx[j]
        if pred < 0.0:
            _swap_rows(ws, r, na)
            na += 1
    return na


@njit(cache=True)
def _seeing_step(ws, data):
    """One step of :func:`iterate` with ``seeing`` (:func:`_seeing_solve`): True if solved."""
    return _seeing_solve(ws, data)[0]


@njit(cache=True)
def _seeing_solve(ws, data):
    """One step of :func:`iterate` with ``seeing``: the contact rows and the inequality rows
    (:func:`._model.seeing_rows`) stacked.  A row already within the margin is always in
    the solve; a capsule farther (up to :data:`SEEING_REACH_MM`) joins only when the step
    would bring it within the margin, and the step is solved again (an active set, at
    most :data:`SEEING_PASSES` more solves): with rows made only once a capsule is within
    the margin, a step of tens of millimetres carried links through the object before any
    row saw it.  While a row is deeper than :data:`DEEP_MM`, the contact rows weigh
    :data:`DEEP_WEIGHT`: the hand leaves the object before it closes the contacts.
    ``(solved, rows in the solve, rows made, solves)``, the rows counted from 0, the
    contact rows first."""
    n = 6 * ws.lay.sides.shape[0]
    copy(ws.J, ws.M[:n])
    copy(ws.f, ws.g[:n])
    total, vmin = seeing_rows(ws, data, ws.opt.collision_margin, SEEING_REACH_MM, n, np.int64(MAX_INEQUALITY_ROWS))
    total += n
    na = n
    for r in range(n, total):  # the rows within the margin first
        if ws.g[r] < 0.0:
            _swap_rows(ws, r, na)
            na += 1
    if vmin < -DEEP_MM:
        for r in range(n):
            ws.g[r] *= DEEP_WEIGHT
            for j in range(ws.M.shape[1]):
                ws.M[r, j] *= DEEP_WEIGHT
    ok = _repair_step(ws, na, ws.opt.damping_sq)
    solves = 1
    for _ in range(SEEING_PASSES):
        if not ok or na == total:
            break
        more = _take_predicted(ws, na, total)
        if more == na:
            break
        na = more
        ok = _repair_step(ws, na, ws.opt.damping_sq)
        solves += 1
    return ok, na, total, solves


@njit(cache=True)
def seeing_step_at(x, R, t, data, model, dx, g, M):
    """One seeing step at a state, as :func:`residual_at`: the step in ``dx``, the stacked
    rows in ``g`` and ``M`` (the contact rows first, those in the solve next);
    ``(solved, rows in the solve, rows made, solves)``.  For tests."""
    ws = _state_at(x, R, t, data, model)
    ok, na, total, solves = _seeing_solve(ws, data)
    copy(ws.dx, dx)
    copy(ws.g[:total], g[:total])
    copy(ws.M[:total], M[:total])
    return ok, na, total, solves


@njit(cache=True)
def _polished_clear(ws, data):
    """Polish a clear repair state: ``(True, iterations)``, polished, if that reaches
    ``STRICT`` and stays clear; else ``(False, iterations)`` with the state back as it was
    (the repair goes on from it).

    Without it the repair's Gauss-Newton steps keep the inequality rows of the capsules
    that come within the margin, which appear and vanish from one step to the next and
    slow the contacts' convergence to the polishing tolerance (often all ``n_repair``
    iterations), each step paying the capsule-vs-mesh queries; the polish steps need none."""
    _keep(ws, np.int64(REPAIRED))
    code, it = polish(ws, data)
    if code == STRICT and clearance(ws, data) >= 0.0:
        return True, it
    _restore(ws, data, np.int64(REPAIRED))
    return False, it


@njit(cache=True)
def first_inequality_rows(ws, data):
    """The inequality rows of the state, written after its contact rows (where the repair's
    first step reads them): ``(rows, smallest value)``, as :func:`clearance` judges it."""
    return inequality_rows(ws, data, ws.opt.collision_margin, np.int64(6 * ws.lay.sides.shape[0]), np.int64(MAX_INEQUALITY_ROWS),
                           np.bool_(False))


@njit(cache=True)
def repair(ws, data, rows0, cmin0):
    """Out of collision: Gauss-Newton on the contact rows and the inequality rows of
    capsule pairs and capsules (against the object) closer than the margin; from each
    clear state within ``d_min``, a polish (:func:`_polished_clear`), which ends the repair
    when it reaches ``STRICT`` and stays clear.  ``rows0``, ``cmin0``: the state's
    inequality rows, already written (:func:`first_inequality_rows`: not searched twice).
    ``(STRICT, WITHIN_DMIN or COLLIDING, iterations, polish iterations)``."""
    opt = ws.opt
    n = 6 * ws.lay.sides.shape[0]
    prev, slow, cmin, rk, n_pol = 1e300, 0, -1.0, 0, 0
    best_c, stuck = -1e300, 0
    strict = within = False
    for rk in range(opt.n_repair + 1):
        contact_rows(ws, data, np.bool_(True))
        copy(ws.J, ws.M[:n])
        copy(ws.f, ws.g[:n])
        if rk == 0:
            rows, cmin = rows0, cmin0
        else:
            rows, cmin = inequality_rows(ws, data, opt.collision_margin, n, np.int64(MAX_INEQUALITY_ROWS), np.bool_(False))
        strict = max(ws.err[0], ws.err[1]) <= opt.polish_tol
        within = ws.err[0] < opt.d_min and ws.err[1] < opt.d_min
        if (cmin >= 0.0 and strict) or rk == opt.n_repair:
            break
        best_c, stuck = (cmin, 0) if cmin > best_c + REPAIR_GAIN else (best_c, stuck + 1)
        if cmin < 0.0 and stuck >= REPAIR_PATIENCE:
            break  # hopeless: no clearer for REPAIR_PATIENCE steps (a link held through the object)
        err = max(ws.err[0], ws.err[1]) / opt.polish_tol
        if cmin < 0.0:  # judge convergence only once clear
            prev, slow = 1e300, 0
        elif err < 0.5 * prev:
            prev, slow = err, 0
        else:
            slow += 1
        if cmin >= 0.0 and within and slow >= 5:
            break  # clear, within d_min, no longer converging
        if cmin >= 0.0 and within and opt.n_polish > 0:
            done, it = _polished_clear(ws, data)
            n_pol += it
            if done:
                return STRICT, rk, n_pol  # polished from a clear state: done
        if not _repair_step(ws, n + rows, 1e-6):
            break
        move(ws, data)
        pose_hand(ws)
    if cmin < 0.0:
        return COLLIDING, rk, n_pol
    return (STRICT if strict else (WITHIN_DMIN if within else COLLIDING)), rk, n_pol


@njit(cache=True)
def _seeing_again(x0, ws, data, k, n_pol):
    """From the start ``x0`` again with :func:`iterate` with ``seeing``, then polished; ``(code,
    iterations, polish iterations, inequality rows, smallest value)``, the counts added to
    ``k`` and ``n_pol``; the rows are written after the contact rows (:func:`first_inequality_rows`)."""
    start(x0, ws, data)
    code, k2 = iterate(ws, data, np.bool_(True))
    if code != WITHIN_DMIN:
        return code, k + k2, n_pol, 0, -1.0
    if ws.opt.n_polish > 0:
        code, more = polish(ws, data)
        n_pol += more
    rows, cmin = first_inequality_rows(ws, data)
    return code, k + k2, n_pol, rows, cmin


@njit(cache=True)
def solve_state(x0, ws, data):
    """Every phase for one state: ``(code, iterations, polish iterations, repair iterations)``."""
    opt = ws.opt
    start(x0, ws, data)
    code, k = iterate(ws, data, np.bool_(False))
    if code != WITHIN_DMIN:
        return code, k, 0, 0
    n_pol = n_rep = 0
    if opt.n_polish > 0:
        code, n_pol = polish(ws, data)
    if not opt.check_collisions:
        return code, k, n_pol, 0
    seeing, rows, cmin = opt.n_repair > 0 and ws.obj.active, 0, -1.0
    if seeing:  # the grid proves some answers through the object: seen at once, no exact query
        place_capsules(ws)
    if not (seeing and surely_in_object(ws)):
        rows, cmin = first_inequality_rows(ws, data)
        if cmin >= 0.0:
            return code, k, n_pol, 0
        if opt.n_repair == 0:
            return COLLIDING, k, n_pol, 0
    if seeing:  # through the object: from the start again, seeing it
        code, k, n_pol, rows, cmin = _seeing_again(x0, ws, data, k, n_pol)
        if code != WITHIN_DMIN and code != STRICT:
            return COLLIDING, k, n_pol, 0
        if cmin >= 0.0 and code == STRICT:
            return code, k, n_pol, 0
    code, n_rep, more = repair(ws, data, rows, cmin)
    n_pol += more
    if code == WITHIN_DMIN and opt.n_polish > 0:  # polish the repaired answer, keep it clear
        done, more = _polished_clear(ws, data)
        n_pol += more
        if done:
            code = STRICT
    return code, k, n_pol, n_rep


@njit(cache=True)
def run_states(problem, x0, pdata, hand, lay, opt, obj, out):
    """Solve state ``s`` from unknowns ``x0[s]`` on problem ``problem[s]`` (its row of
    ``pdata``), for every ``s``; results in ``out`` (:class:`Outputs`).  ``obj``: the
    object's solid (:class:`~._penetration.ObjectArrays`, inactive without one)."""
    ws = new_workspace(hand, lay, opt, obj, lay.sides.shape[0], x0.shape[1])
    for s in range(problem.shape[0]):
        data = pdata[problem[s]]
        code, k, n_pol, n_rep = solve_state(x0[s], ws, data)
        out.status[s], out.iterations[s], out.polish_iterations[s], out.repair_iterations[s] = code, k, n_pol, n_rep
        copy(ws.x, out.x[s])
        copy(ws.R, out.R[s])
        copy(ws.t, out.t[s])
        copy(ws.err, out.err[s])
