"""The push a grasp can resist with the forces its squeeze applies (a measure, for the benchmark).

Epsilon measures the wrenches a grasp resists *per unit total normal force*; the physics
test pushes with a fixed force (``push_accel`` x ``mass_kg``, 1 N) against whatever normal
forces the position actuators produce.  :func:`push_margin` predicts the outcome from both:

1. **The squeeze's forces.**  The squeeze moves the actuators' targets from the solved
   angles ``q`` to ``q_s`` (:func:`squeeze_for`, the test's own kind and depth).
   While the object blocks the fingers the hand stays near ``q``, so the actuators apply the
   torques ``tau = kp (q_s - q)``; the contact forces ``f`` (palm frame, on the object)
   balance them through the contacts' point Jacobians ``J`` (``J^T f = tau`` over the
   dofs that move, least squares).  Each contact's normal force is ``N_i = max(f_i . n_i, 0)``
   (``n_i`` the inward normal).
2. **The largest push.**  For each of the six push directions ``d``, the linear program

   .. math::

       \\max t \\quad \\text{s.t.} \\quad \\sum_{i,g} \\lambda_{ig} w_{ig} + t\\,(d, 0) = 0,
       \\qquad \\sum_g \\lambda_{ig} \\le N_i,\\qquad \\lambda \\ge 0,

   with ``w_ig`` the primitive wrenches of contact ``i`` (friction cone edges and, soft
   fingers, the torsion generators, each of unit normal force; torques about the object's
   centre of mass, where the test pushes): the largest push ``t`` [N] along ``d`` that
   contact forces with at most the squeeze's normal forces resist.

The margin is the smallest of the six ``t`` over the push force: at least 1, the squeeze
presses hard enough to resist every push, to first order; 0, some push is resisted by no
such forces (a contact the squeeze does not load, or no force closure).  It is a model
(rigid fingers, the forces of the squeeze's first instant), not the test.  With the
``"forces"`` squeeze every candidate of margin at least 1 held in the test (49 of 65
measured, ``benchmarks/hold.py --per-candidate``), though not every one since (two of
002-3c-3's, margins 1.14 and 1.26, held 3 and 5 of 6: their contacts slide during the
squeeze); with the ``"balanced"`` one, whose quasi-static forces are far from the simulated
ones, it orders candidates no better than epsilon (docs/quality.md, "Physics in the
loop").  The ``"push"`` squeeze (the default, :mod:`.aim`) is the one of largest margin
among the balanced force sets; ``--hold`` records each tried candidate's margin.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import linprog

from ..tasks.model import Task
from .options import PUSH_DIRECTIONS, SimOptions
from .aim import push_squeeze, push_wrenches
from .squeeze import _targets, contact_jacobian, free_dofs, inward_normals, squeeze_step

__all__ = ["PushMargin", "push_margin", "squeeze_normal_forces", "squeeze_forces", "squeeze_for", "as_good_a_push_squeeze"]

MM = 1e-3


class PushMargin(NamedTuple):
    """What :func:`push_margin` finds: ``margin`` (smallest resisted push over the push
    force, unitless), ``pushes`` ``(6,)`` the largest push [N] per direction (in
    :data:`~.options.PUSH_DIRECTIONS`' order), ``normal`` ``(C,)`` the squeeze's normal
    forces [N]."""

    margin: float
    pushes: np.ndarray
    normal: np.ndarray


def squeeze_for(task: Task, q, T_palm_object, contacts, options: SimOptions = SimOptions()) -> tuple[np.ndarray, np.ndarray]:
    """The squeeze of ``options.squeeze``: ``(targets (n_dof,) [rad], how far each contact is
    aimed into the object (C,) [mm])``.  ``"push"``: the squeeze of :func:`~.aim.push_squeeze`
    when its margin is at least the ``"forces"`` squeeze's, else the ``"forces"`` one (a
    grasp that is not force closure has no balanced set loading every contact: then the
    forces squeeze's least-unbalanced forces, which may still resist some pushes)."""
    q = np.asarray(q, dtype=float)
    forces = squeeze_step(task, q, contacts, options.squeeze_mm, "forces" if options.squeeze == "push" else options.squeeze,
                          options.friction)  # fmt: skip
    if options.squeeze != "push":
        return forces
    aimed = push_squeeze(task, q, T_palm_object, contacts, options)
    if aimed is None:
        return forces
    W = push_wrenches(task, T_palm_object, contacts, options)
    old = _pushes(W, _normal_forces(task, q, contacts, forces[0], options), options).min()
    return (aimed.targets, aimed.depths) if aimed.margin * options.push_accel * options.mass_kg >= old else forces


def as_good_a_push_squeeze(task: Task, q, T_palm_object, contacts, options: SimOptions, given, depths_mm,
                           tol: float = 1e-6) -> bool:  # fmt: skip
    """Whether the angles ``given`` (n_dof,) [rad] with the stated depths ``depths_mm`` (C,)
    are a ``"push"`` squeeze as good as the one :func:`squeeze_for` finds now: within the
    joint limits, the dofs that do not move (or follow a coupling) as the step has them,
    the stated depths those of the step (``tol`` mm), none more than
    ``squeeze_mm`` in, and a push margin at least the found one's (- ``tol`` relative).  How
    ``prehension check`` re-derives a stored push squeeze: the program's optimum is unique,
    its forces need not be (another platform's solver may return others)."""
    q, given = np.asarray(q, dtype=float), np.asarray(given, dtype=float)
    hand = task.hand
    if given.shape != q.shape or np.any(given < hand.lower - 1e-12) or np.any(given > hand.upper + 1e-12):
        return False
    free = free_dofs(task)
    if not np.allclose(_targets(hand, q, free, (given - q)[free]), given, atol=1e-9, rtol=0):
        return False
    depths = np.einsum("cd,cd->c", (contact_jacobian(task, q, contacts) @ (given - q)).reshape(-1, 3), inward_normals(contacts))
    stated = np.asarray(depths_mm, dtype=float)
    if stated.shape != depths.shape or not np.allclose(stated, depths, atol=tol, rtol=0):
        return False
    if len(depths) and depths.max() > options.squeeze_mm + tol:
        return False
    W = push_wrenches(task, T_palm_object, contacts, options)
    found = _pushes(W, _normal_forces(task, q, contacts, squeeze_for(task, q, T_palm_object, contacts, options)[0], options), options)
    mine = _pushes(W, _normal_forces(task, q, contacts, given, options), options)
    return bool(mine.min() >= found.min() * (1.0 - tol) - 1e-12)


def squeeze_normal_forces(task: Task, solution, options: SimOptions = SimOptions()) -> np.ndarray:
    """The normal forces ``(C,)`` [N] the squeeze's actuators press each contact with (module docstring, 1)."""
    q_squeeze = squeeze_for(task, solution.q, solution.T_palm_object, solution.contacts, options)[0]
    return _normal_forces(task, np.asarray(solution.q, float), solution.contacts, q_squeeze, options)


def _normal_forces(task: Task, q: np.ndarray, contacts, q_squeeze: np.ndarray, options: SimOptions) -> np.ndarray:
    """The normal forces ``(C,)`` [N] of the contact forces balancing the torques towards ``q_squeeze``."""
    inward = inward_normals(contacts)
    return np.maximum(np.einsum("cd,cd->c", _forces(task, q, contacts, q_squeeze, options), inward), 0.0)


def squeeze_forces(task: Task, solution, options: SimOptions = SimOptions()) -> np.ndarray:
    """The contact forces ``(C, 3)`` [N] (palm frame, on the object) that balance the squeeze's actuator torques (module docstring, 1)."""
    q = np.asarray(solution.q, dtype=float)
    q_squeeze = squeeze_for(task, q, solution.T_palm_object, solution.contacts, options)[0]
    return _forces(task, q, solution.contacts, q_squeeze, options)


def _forces(task: Task, q: np.ndarray, contacts, q_squeeze: np.ndarray, options: SimOptions) -> np.ndarray:
    tau = options.kp * (q_squeeze - q)  # [N m]
    J = contact_jacobian(task, q, contacts) * MM  # (3C, n_dof) [m/rad]
    moving = np.asarray(task.active_mask, bool)
    if not moving.any():
        return np.zeros((len(contacts), 3))
    return np.linalg.lstsq(J[:, moving].T, tau[moving], rcond=None)[0].reshape(-1, 3)  # on the object [N]


def push_margin(task: Task, solution, options: SimOptions = SimOptions(), q_squeeze=None) -> PushMargin:
    """The largest push per direction a grasp resists with its squeeze's normal forces
    (module docstring); ``q_squeeze``: the squeeze's targets when already computed (the
    first of :func:`squeeze_for`'s answer with the same ``options``), else computed here."""
    if q_squeeze is None:
        q_squeeze = squeeze_for(task, solution.q, solution.T_palm_object, solution.contacts, options)[0]
    normal = _normal_forces(task, np.asarray(solution.q, dtype=float), solution.contacts, q_squeeze, options)
    pushes = _pushes(push_wrenches(task, solution.T_palm_object, solution.contacts, options), normal, options)
    push = options.push_accel * options.mass_kg
    return PushMargin(float(pushes.min() / push) if push > 0 else float("inf"), pushes, normal)


def _pushes(W: np.ndarray, normal: np.ndarray, options: SimOptions) -> np.ndarray:
    """The largest push [N] per direction ``(6,)`` resisted by the wrenches ``W`` ``(C, G, 6)`` within the normal forces."""
    C, G = W.shape[:2]
    A_ub = np.c_[np.kron(np.eye(C), np.ones((1, G))), np.zeros((C, 1))]
    pushes = np.zeros(len(PUSH_DIRECTIONS))
    for k, (_, d) in enumerate(PUSH_DIRECTIONS):
        A_eq = np.c_[W.reshape(C * G, 6).T, np.r_[np.asarray(d, float), np.zeros(3)]]
        res = linprog(np.r_[np.zeros(C * G), -1.0], A_ub=A_ub, b_ub=normal, A_eq=A_eq, b_eq=np.zeros(6),
                      bounds=(0, None), method="highs")  # fmt: skip
        pushes[k] = max(float(res.x[-1]), 0.0) + 0.0 if res.status == 0 else 0.0  # + 0.0: no -0.0
    return pushes
