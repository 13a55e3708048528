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

One damped step (the active set, the caps held on their rim, the stacked rows of the
repair) is :mod:`._step`'s.  The caller (:mod:`.solver`) re-checks every answer with the
foundation's functions.
The state, its scratch arrays and its options travel as NamedTuples
(:class:`Workspace`, :class:`Options`, :class:`~._layout.HandArrays`,
:class:`~._layout.Layout`, :class:`~._penetration.ObjectArrays`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...kernels.jit import HAVE_NUMBA, njit
from . import _regions as RG
from ._linalg import copy, fill
from ._model import contact_rows, inequality_rows, initial_pose, move, place_capsules, pose_hand, project_all
from ._penetration import object_rows
from ._step import active_set_step, contact_motion, limit_step, stacked_step

__all__ = ["Options", "Workspace", "Outputs", "MESSAGES", "run_states", "residual_at", "penetration_at", "LOCAL_SOLUTIONS"]

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
MAX_INEQUALITY_ROWS = 32  # self-collision pairs first, then the object's capsules
BEST, REPAIRED = 0, 1  # slots of the workspace's saved states
REPAIR_PATIENCE, REPAIR_GAIN = 6, 0.05  # a repair in collision ends after 6 steps without a clearance 0.05 mm better than its best


class Options(NamedTuple):
    """The kernel's options, named (built by :meth:`.options.LocalOptions.kernel_options`).

    ``alpha`` step size; ``damping_sq`` mu^2 [mm^2]; ``d_min``, ``s_min`` [mm], ``n_stall``,
    ``k_max``: the paper's ending conditions; ``w_n`` weight of the normal rows [mm];
    ``max_step`` largest scaled change of one unknown per step [mm]; ``n_polish``,
    ``polish_tol`` [mm]; ``active_set``; ``procrustes`` (else the paper's psi rule);
    ``cap_margin`` [rad]; ``n_repair``, ``collision_margin`` [mm]; ``check_collisions``.
    """

    alpha: float
    damping_sq: float
    d_min: float
    w_n: float
    s_min: float
    n_stall: int
    k_max: int
    max_step: float
    n_polish: int
    polish_tol: float
    active_set: bool
    procrustes: bool
    cap_margin: float
    n_repair: int
    collision_margin: float
    check_collisions: bool


WORKSPACE_FIELDS = (
    "hand", "lay", "opt", "obj",
    "x", "col_scale", "dx", "frozen", "R", "t", "q", "Rl", "rl", "ax", "org", "f", "f_prev", "J", "Js", "ph", "nh", "po", "no",
    "A", "L", "y", "rims", "M", "Ms", "g", "err", "keep_x", "keep_R", "keep_t", "keep_err",
    "pt", "nr", "dpt", "dnr", "work", "tmp", "vec", "cp", "pa", "pb", "ends", "half", "cut", "oseg",
)  # fmt: skip
_WORKSPACE_DOC = """One state, its scratch arrays, and what it is solved with.

    ``hand`` (:class:`~._layout.HandArrays`), ``lay`` (:class:`~._layout.Layout`), ``opt``
    (:class:`Options`), ``obj`` (:class:`~._penetration.ObjectArrays`).  The state: ``x`` (nx) unknowns, ``R`` (3, 3) and ``t`` (3) object
    pose [mm]; ``col_scale`` (nx) the problem's column scales ``D^-1``; derived: ``q`` angles, ``Rl``/``rl`` link poses, ``ax``/``org`` joint axes and
    centres, ``f`` (6C) contact rows, ``J`` (6C, nx), ``ph``/``nh``/``po``/``no`` (C, 3)
    contact points and normals, ``err`` (2) largest contact distance and weighted normal
    error [mm].  Saved states: ``keep_*`` (slots ``BEST``, ``REPAIRED``).  The rest is
    scratch: the step (``dx``, ``frozen``, ``A``, ``L``, ``y``, ``Js``; ``rims`` (2C, 3) the caps held
    on their rim, kept from step to step: :func:`._step._turn_rims`), stacked rows
    (``M``, ``Ms``, ``g``), regions (``pt``, ``nr``, ``dpt``, ``dnr``, ``work``), capsules
    (``ends``, ``half``, ``pa``, ``pb``), the object's rows (``cut`` pieces of a segment,
    ``oseg`` points in the object frame) and 3-vectors.

    A numba StructRef: every phase takes it as one reference, which keeps the compiled
    functions' signatures -- and so the compilation time -- small."""

if HAVE_NUMBA:
    from numba import types
    from numba.experimental import structref

    @structref.register
    class _WorkspaceType(types.StructRef):
        def preprocess_fields(self, fields):
            return tuple((name, types.unliteral(typ)) for name, typ in fields)

    class Workspace(structref.StructRefProxy):
        __doc__ = _WORKSPACE_DOC

    structref.define_proxy(Workspace, _WorkspaceType, list(WORKSPACE_FIELDS))
else:  # pragma: no cover - plain Python without numba

    class Workspace:
        __doc__ = _WORKSPACE_DOC

        def __init__(self, *values):
            for name, value in zip(WORKSPACE_FIELDS, values):
                setattr(self, name, value)


@njit(cache=True)
def new_workspace(hand, lay, opt, obj, C, nx):
    """A workspace for states of ``C`` contacts and ``nx`` unknowns."""
    n, m = 6 * C, 6 * C + MAX_INEQUALITY_ROWS
    n_dof, n_links, n_caps = lay.dof_free.shape[0], hand.n_links, max(hand.cap_link.shape[0], 1)
    z = np.zeros
    return Workspace(
        hand, lay, opt, obj,
        z(nx), z(nx), z(nx), z(nx, dtype=np.bool_), z((3, 3)), z(3), z(n_dof), z((n_links, 3, 3)), z((n_links, 3)),
        z((n_dof, 3)), z((n_dof, 3)), z(n), z(n), z((n, nx)), z((m, nx)), z((C, 3)), z((C, 3)), z((C, 3)),
        z((C, 3)), z((m, m)), z((m, m)), z(m), z((2 * C, 3)), z((m, nx)), z((m, nx)), z(m), z(2),
        z((2, nx)), z((2, 3, 3)), z((2, 3)), z((2, 2)), z(3), z(3), z((3, 2)), z((3, 2)),
        z((7, RG.WORK_COLS)), z((2, 3, 3)), z(3), z(3), z(3), z(3), z((n_caps, 2, 3)), z(n_caps),
        z((2, C + 2, 2)), z((7, 3)),
    )  # fmt: skip


class Outputs(NamedTuple):
    """Per state: ``status`` (a ``MESSAGES`` code), ``iterations``, ``polish_iterations``,
    ``repair_iterations``, final ``x`` (S, nx), ``R`` (S, 3, 3), ``t`` (S, 3) and ``err``
    (S, 2): largest contact distance and largest ``w_n |n_h + n_o|`` [mm]."""

    status: np.ndarray
    iterations: np.ndarray
    polish_iterations: np.ndarray
    repair_iterations: np.ndarray
    x: np.ndarray
    R: np.ndarray
    t: np.ndarray
    err: np.ndarray

    @classmethod
    def allocate(cls, S: int, nx: int) -> "Outputs":
        i = lambda: np.zeros(S, dtype=np.int64)  # noqa: E731
        return cls(i(), i(), i(), i(), np.zeros((S, nx)), np.zeros((S, 3, 3)), np.zeros((S, 3)), np.zeros((S, 2)))


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

    With ``seeing``, the inequality rows (:func:`._model.inequality_rows`: capsule pairs,
    and capsules against the object, the idle fingers' too, closer than the margin) are stacked
    under the contact rows at every step: the hand approaches the contacts around the
    object instead of through it; ``WITHIN_DMIN`` then says nothing of the clearance (the
    caller checks it).

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
            stall = stall + 1 if contact_motion(ws.f, ws.f_prev, C) < opt.s_min else 0
            if stall >= opt.n_stall:
                return STALLED, k
        if k == opt.k_max:
            break
        copy(ws.f, ws.f_prev)
        if seeing:
            copy(ws.J, ws.M[:n])
            copy(ws.f, ws.g[:n])
            rows = inequality_rows(ws, data, opt.collision_margin, n, np.int64(MAX_INEQUALITY_ROWS), np.bool_(True))[0]
            ok = stacked_step(ws, n + rows, opt.damping_sq)
        else:
            ok = active_set_step(ws, data, opt.damping_sq, opt.active_set)
            if ok:
                limit_step(ws.dx, ws.col_scale, opt.alpha, opt.max_step)
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
        if not active_set_step(ws, data, 1e-18, np.bool_(True)):
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
        if not stacked_step(ws, n + rows, 1e-6):
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
    rows, cmin = first_inequality_rows(ws, data)
    if cmin >= 0.0:
        return code, k, n_pol, 0
    if opt.n_repair == 0:
        return COLLIDING, k, n_pol, 0
    if ws.obj.active:  # through the object: from the start again, seeing it
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


@njit(cache=True)
def _state_at(x, R, t, data, model):
    """A workspace posed at unknowns ``x`` and object pose ``(R, t)`` of one problem, its
    contact rows computed; ``model = (hand, lay, opt, obj)``."""
    hand, lay, opt, obj = model
    ws = new_workspace(hand, lay, opt, obj, lay.sides.shape[0], x.shape[0])
    copy(lay.col_scale, ws.col_scale)
    copy(x, ws.x)
    copy(R, ws.R)
    copy(t, ws.t)
    pose_hand(ws)
    contact_rows(ws, data, np.bool_(True))
    return ws


@njit(cache=True)
def residual_at(x, R, t, data, model, f, J):
    """Contact rows ``f`` (6C) and their Jacobian ``J`` (6C, nx) at unknowns ``x`` and object
    pose ``(R, t)`` of one problem (its ``data`` row), ``model = (hand, lay, opt, obj)``:
    for tests and the baseline."""
    ws = _state_at(x, R, t, data, model)
    copy(ws.f, f)
    copy(ws.J, J)


@njit(cache=True)
def penetration_at(x, R, t, data, model, margin, g, M):
    """The object's penetration rows (:func:`._penetration.object_rows`) at a state, as
    :func:`residual_at`: values ``g`` and Jacobian ``M`` of at most ``len(g)`` rows; returns
    ``(rows written, smallest value seen)``.  For tests."""
    ws = _state_at(x, R, t, data, model)
    place_capsules(ws)
    n, vmin = object_rows(ws, data, margin, np.int64(0), min(g.shape[0], ws.g.shape[0]), np.bool_(False))
    copy(ws.g[:n], g[:n])
    copy(ws.M[:n], M[:n])
    return n, vmin
