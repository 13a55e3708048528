"""The ``"push"`` squeeze: the balanced contact forces whose squeeze resists the largest push.

The ``"forces"`` squeeze (:mod:`.squeeze`) aims the hand along ``dq = s J^T f* / w`` with
``f*`` *one* set of balanced contact forces -- the linear program of
:func:`~.squeeze.balanced_normal_forces` picks it without regard to the pushes.  Any
balanced set would do; this module picks the one whose squeeze resists the largest push
(:mod:`.push`'s margin), in one linear program.  Every quantity the margin is made of is
linear in ``g = s f*`` (the forces with their scale):

* ``g = sum_ie mu_ie e_ie`` with ``mu >= 0`` and ``e_ie`` the friction cone edges of
  contact ``i`` (friction ``SimOptions.friction``): ``f*`` in the cones; ``sum mu_ie w_ie = 0``
  (``w_ie`` the edges' wrenches): a zero net wrench;
* the step ``dq = A g`` (``A = J^T / w`` on the free dofs; a coupled dof follows its source);
  every contact's depth along its inward normal, ``n_i . (J dq)_i <= squeeze_mm`` (the rule
  of the forces squeeze, "the deepest contact aimed ``squeeze_mm`` in", as rows), and the
  targets within the joint limits (so no clipping makes the step non-linear);
* the squeeze's normal forces ``N(g) = n_i . (P g)_i`` with ``P = kp (J_m^T)^+ A_m`` over the
  moving dofs ``m`` (what :func:`~.push.squeeze_forces` computes, by least squares);
* per push direction ``d`` (:data:`~.options.PUSH_DIRECTIONS`), contact forces
  ``lambda^d >= 0`` of :func:`~.push.push_margin`'s primitive wrenches with
  ``sum_g lambda^d_ig <= N_i(g)`` and ``sum lambda^d w + t (d, 0) = 0``.

Maximise ``t``: for the ``g`` found, ``min_d max t_d = t`` (the common ``t`` is feasible per
direction, and per direction the optimum at ``g`` is feasible here), so the squeeze's
:func:`~.push.push_margin` equals the program's ``t`` over the push force.  The squeeze
also needs the object's centre of mass (where the pushes act), so it takes the object
pose; :func:`~.push.squeeze_for` is how the test, the margin and the result files ask for it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import linprog

from ..quality.options import QualityOptions
from ..quality.solid import object_reference
from ..quality.wrenches import primitive_wrenches
from ..tasks.model import Task
from .options import PUSH_DIRECTIONS, SimOptions
from .squeeze import _problem, _targets, balance_wrenches, contact_jacobian, coupling_weights, inward_normals

__all__ = ["AimedSqueeze", "push_squeeze", "push_wrenches"]

MM = 1e-3
T_CAP = 1e3  # the program's push is bounded by T_CAP push forces (never binds in practice: a bounded LP)


class AimedSqueeze(NamedTuple):
    """What :func:`push_squeeze` finds: the targets ``(n_dof,)`` [rad], how far each contact
    is aimed in ``(C,)`` [mm], the program's margin (push resisted over the push force,
    unitless; ``nan`` when the program failed) and the balanced forces ``g`` ``(C, 3)`` [N / kp
    scale: the squeeze's forces over ``kp`` when the fingers are equally stiff]."""

    targets: np.ndarray
    depths: np.ndarray
    margin: float
    forces: np.ndarray


def push_wrenches(task: Task, T_palm_object, contacts, options: SimOptions) -> np.ndarray:
    """The contacts' primitive wrenches ``(C, G, 6)`` of the push test's contact model
    (friction and torsion of ``options``; torques about the object's centroid, palm frame,
    scaled by the object's radius)."""
    T = np.asarray(T_palm_object, float)
    centre, rho = object_reference(task.object)  # the centroid: the centre of mass the test pushes
    com = T[:3, :3] @ centre + T[:3, 3]
    points = np.array([np.asarray(c.object_point, float) for c in contacts])
    model = QualityOptions(friction=options.friction, torsion_mm=options.torsion_mm)
    return primitive_wrenches(points, inward_normals(contacts), com, rho, model)


def _step_matrix(task: Task, J: np.ndarray, free: np.ndarray) -> np.ndarray:
    """``A`` ``(n_dof, 3C)``: the step ``dq = A g`` of the forces squeeze (``J`` folded)."""
    hand = task.hand
    A = np.zeros((hand.n_dof, J.shape[0]))
    A[free] = J[:, free].T / coupling_weights(hand)[free, None]
    for c in hand.couplings:
        A[hand.dof_index(c.dof)] = c.ratio * A[hand.dof_index(c.source)]
    return A


def _linear_model(task: Task, q: np.ndarray, contacts, options: SimOptions):
    """``(A, D, Nm, (lo, hi), free)``: the step ``dq = A g``, the depths ``D g`` [mm], the
    normal forces ``Nm g`` [N], the bounds ``(lo, hi)`` of ``dq`` and the free dofs' mask
    (module docstring)."""
    J, _, free, _ = _problem(task, q, contacts, options.squeeze_mm, None)
    inward = inward_normals(contacts)
    C = len(contacts)
    rows = np.zeros((C, 3 * C))  # n_i . (x)_i as a matrix
    for i in range(C):
        rows[i, 3 * i:3 * i + 3] = inward[i]
    A = _step_matrix(task, J, free)
    moving = np.asarray(task.active_mask, bool)
    Ju = contact_jacobian(task, q, contacts) * MM  # (3C, n_dof) [m/rad]
    P = options.kp * np.linalg.pinv(Ju[:, moving].T) @ A[moving]  # (3C, 3C) [N per unit g]
    lo, hi = np.minimum(task.hand.lower - q, 0.0), np.maximum(task.hand.upper - q, 0.0)
    return A, rows @ J[:, free] @ A[free], rows @ P, (lo, hi), free  # J folded: the coupled dofs' motion is in their sources' columns


def _balance_rows(contacts, friction: float, n_edges: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """``(E (3C, C e) the cone edges as columns, W (6, C e) their wrenches)``: ``g = E mu``, balanced when ``W mu = 0``."""
    p = np.array([np.asarray(c.hand_point, float) for c in contacts])
    edges, W = balance_wrenches(p, inward_normals(contacts), friction, n_edges)  # (C, e, 3), (6, C e)
    C, e = edges.shape[:2]
    E = np.zeros((3 * C, C * e))
    for i in range(C):
        E[3 * i:3 * i + 3, i * e:(i + 1) * e] = edges[i].T
    return E, W


def push_squeeze(task: Task, q, T_palm_object, contacts, options: SimOptions = SimOptions()) -> AimedSqueeze | None:
    """The balanced forces whose squeeze resists the largest push, and that squeeze (module
    docstring); ``None`` when the program finds no squeeze resisting a positive push (no
    balanced set loads the contacts so that every push direction is resisted)."""
    q = np.asarray(q, dtype=float)
    C = len(contacts)
    if C == 0:
        return None
    A, D, Nm, (lo, hi), free = _linear_model(task, q, contacts, options)
    E, Wb = _balance_rows(contacts, options.friction)
    Wp = push_wrenches(task, T_palm_object, contacts, options)  # (C, G, 6)
    G, n_mu, K = Wp.shape[1], E.shape[1], len(PUSH_DIRECTIONS)
    n_lam = C * G
    nv = n_mu + K * n_lam + 1  # mu, lambda^d per direction, t
    push = options.push_accel * options.mass_kg
    moved = np.any(A != 0, axis=1)
    AE = (A @ E)[moved]
    ub_rows = [np.c_[D @ E, np.zeros((C, nv - n_mu))], np.c_[AE, np.zeros((len(AE), nv - n_mu))],
               np.c_[-AE, np.zeros((len(AE), nv - n_mu))]]  # fmt: skip
    ub_rhs = [np.full(C, options.squeeze_mm), hi[moved], -lo[moved]]
    eq_rows, eq_rhs = [np.c_[Wb, np.zeros((6, nv - n_mu))]], [np.zeros(6)]
    cap = np.kron(np.eye(C), np.ones((1, G)))  # sum_g lambda_ig
    for k, (_, d) in enumerate(PUSH_DIRECTIONS):
        block = np.zeros((C, nv))
        block[:, n_mu + k * n_lam:n_mu + (k + 1) * n_lam] = cap
        block[:, :n_mu] = -Nm @ E
        ub_rows.append(block)
        ub_rhs.append(np.zeros(C))
        row = np.zeros((6, nv))
        row[:, n_mu + k * n_lam:n_mu + (k + 1) * n_lam] = Wp.reshape(n_lam, 6).T
        row[:, -1] = np.r_[np.asarray(d, float), np.zeros(3)]
        eq_rows.append(row)
        eq_rhs.append(np.zeros(6))
    cost = np.zeros(nv)
    cost[-1] = -1.0
    bounds = [(0, None)] * (nv - 1) + [(0, T_CAP * push if push > 0 else None)]
    res = linprog(cost, A_ub=np.vstack(ub_rows), b_ub=np.concatenate(ub_rhs), A_eq=np.vstack(eq_rows),
                  b_eq=np.concatenate(eq_rhs), bounds=bounds, method="highs")  # fmt: skip
    if res.status != 0 or not res.x[-1] > 0:
        return None
    g = E @ res.x[:n_mu]
    dq = A @ g
    return AimedSqueeze(_targets(task.hand, q, free, dq[free]), D @ g, float(res.x[-1] / push) if push > 0 else float("inf"),
                        g.reshape(-1, 3))  # fmt: skip
