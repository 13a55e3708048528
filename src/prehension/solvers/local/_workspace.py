"""The kernel's state and what travels with it: :class:`Workspace`, :class:`Options`, :class:`Outputs`.

A :class:`Workspace` (one numba StructRef) holds one state of :mod:`._kernel`'s
iterations, its scratch arrays and what it is solved with; :class:`Options` are the
kernel's options as named fields; :class:`Outputs` what :func:`._kernel.run_states` writes
per state.  :func:`residual_at` and :func:`penetration_at` pose a workspace at given
unknowns and read its rows back (for the tests and the baseline).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...kernels.jit import HAVE_NUMBA, njit
from . import _regions as RG
from ._linalg import copy
from ._model import contact_rows, inequality_rows, place_capsules, pose_hand, seeing_rows
from ._penetration import object_rows, surely_in_object

__all__ = ["Options", "Workspace", "Outputs", "new_workspace", "residual_at", "penetration_at", "surely_in_object_at",
           "stacked_rows_at", "MAX_INEQUALITY_ROWS"]

MAX_INEQUALITY_ROWS = 32  # self-collision pairs first, then the object's capsules


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
    on their rim, kept from step to step: :func:`._kernel._turn_rims`), stacked rows
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
    _WorkspaceType = None

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


@njit(cache=True)
def surely_in_object_at(x, R, t, data, model):
    """:func:`._penetration.surely_in_object` at a state, as :func:`residual_at`.  For tests."""
    ws = _state_at(x, R, t, data, model)
    place_capsules(ws)
    return surely_in_object(ws)


@njit(cache=True)
def stacked_rows_at(x, R, t, data, model, margin, reach, g):
    """The inequality rows at a state, as :func:`residual_at`: the seeing steps'
    (:func:`._model.seeing_rows`, the object searched up to ``reach``) or, with ``reach <=
    margin``, :func:`._model.inequality_rows` with the idle fingers (``every``); values in
    ``g`` (at most ``len(g)``), ``(rows written, smallest value seen)``.  For tests."""
    ws = _state_at(x, R, t, data, model)
    m = min(g.shape[0], ws.g.shape[0])
    if reach <= margin:
        n, vmin = inequality_rows(ws, data, margin, np.int64(0), m, np.bool_(True))
    else:
        n, vmin = seeing_rows(ws, data, margin, reach, np.int64(0), m)
    copy(ws.g[:n], g[:n])
    return n, vmin
