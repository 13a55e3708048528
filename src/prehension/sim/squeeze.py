"""The squeeze: joint angles that would carry each contact a little further into the object.

Four kinds (``SimOptions.squeeze``; :func:`~.push.squeeze_for` computes any of them,
:func:`squeeze_step` every one but ``"push"``):

* ``"push"`` (the default, :mod:`.aim`): the ``"forces"`` step with, of all balanced
  force sets, the one whose squeeze resists the largest push (it needs the object's pose).
* ``"forces"`` (the default until 2026-11-28): the targets are chosen so that the actuators' own torques
  press the object with a set of contact forces that resist each other.  With
  ``f*`` the balanced contact forces of :func:`balanced_normal_forces` (zero net wrench
  when the grasp is force closure) and ``J`` the contacts' point Jacobians over the
  independent dofs, the step is ``dq = s J^T f* / w`` (``w``: 1 plus the squared ratios of
  the dofs coupled to a dof), ``s`` scaled so that the contact aimed deepest along its
  inward normal goes ``squeeze_mm`` in.  A position actuator of gain ``kp`` held at ``q``
  by the object applies ``tau = kp dq``, and the contact forces that balance it,
  ``J^T f = tau``, are then ``f = kp s f*`` (``J^T`` of full column rank, no couplings):
  the forces of the balanced set, whatever the fingers' leverage.

* ``"uniform"`` (DexGraspBench's): every contact is aimed ``squeeze_mm`` into the object,
  whatever the balance of forces.  Three fingertips on one face and a thumb on the other
  then push three times harder one way than the other, and the object turns during the
  squeeze itself.
* ``"balanced"`` (the default before ``"forces"``): each contact is aimed ``squeeze_mm * f_i / max_j f_j``
  into the object, ``f_i`` its normal force in a set of contact forces that resist each
  other -- a zero net force and torque -- found by :func:`balanced_normal_forces`.  The
  position actuators press roughly in proportion to how far their targets lie inside the
  object -- which holds only when every contact's finger is equally stiff: through the
  hand's Jacobians a fingertip with a short lever presses many times harder per mm than
  one with a long lever (docs/quality.md, "The squeeze"), so the forces need not
  cancel; ``"forces"`` corrects this.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import linprog, lsq_linear

from ..hands.kinematics import forward_kinematics, point_jacobian
from ..quality.wrenches import cone_edges
from ..tasks.model import Task

__all__ = ["squeeze_step", "squeeze_targets", "as_good_a_squeeze", "squeeze_depths", "balanced_normal_forces",
           "balance_wrenches", "coupling_weights", "free_dofs", "BalancedForces", "SQUEEZE_KINDS"]  # fmt: skip

SQUEEZE_KINDS = ("forces", "balanced", "uniform", "push")


class BalancedForces(NamedTuple):
    """Normal forces ``(C,)`` of contact forces that resist each other, scaled so the
    smallest is 1 (unitless), the forces themselves ``(C, 3)`` (same scale, in the
    normals' frame), and ``residual``: the norm of their net wrench relative to
    their total normal force (0: exactly balanced; > 0: the best the friction cones
    allow -- the grasp is not force closure and no balanced set with every contact
    pressing exists)."""

    normal: np.ndarray
    forces: np.ndarray
    residual: float


def balanced_normal_forces(points_mm, inward_normals, friction: float, n_edges: int = 8) -> BalancedForces:
    """Contact forces in the linearised friction cones whose net wrench is smallest.

    The linear program: edge weights ``lambda >= 0`` of every contact's cone edges (each
    with a unit normal component, :func:`~prehension.quality.wrenches.cone_edges`), every
    contact's normal force ``sum_j lambda_ij >= 1`` (every contact presses), and a slack
    ``s >= |sum lambda w|`` per wrench component (force; torque about the contacts' mean
    point divided by their largest distance from it, so both have force units), minimising
    ``sum s + 1e-3 * sum lambda`` (the net wrench first, then the smallest such forces, so
    at least one contact's normal force is 1).  A force-closure grasp reaches a zero net
    wrench (its positive span holds the origin in its interior); for any other the
    residual says how far from balanced the best squeeze is.

    Args:
        points_mm: (C, 3) contact points [mm] (any frame, the normals' frame).
        inward_normals: (C, 3) unit normals pointing into the object.
        friction: Coulomb coefficient of the cones.
        n_edges: edges of each linearised cone.
    """
    n = np.asarray(inward_normals, dtype=float).reshape(-1, 3)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    edges, W = balance_wrenches(points_mm, n, friction, n_edges)
    C, E = edges.shape[:2]
    nv = C * E
    # variables: lambda (C E), s (6);  -s <= W lambda <= s;  -sum_j lambda_ij <= -1
    A_ub = np.block([[W, -np.eye(6)], [-W, -np.eye(6)], [-np.kron(np.eye(C), np.ones((1, E))), np.zeros((C, 6))]])
    b_ub = np.r_[np.zeros(12), -np.ones(C)]
    cost = np.r_[1e-3 * np.ones(nv), np.ones(6)]
    res = linprog(cost, A_ub=A_ub, b_ub=b_ub, bounds=(0, None), method="highs")
    if res.status != 0:  # cannot happen (lambda = 1 per contact, s = |W lambda| is feasible); fall back to equal forces
        return BalancedForces(np.ones(C), n.copy(), float("nan"))
    lam = res.x[:nv].reshape(C, E)
    normal = lam.sum(axis=1)
    residual = float(np.linalg.norm(W @ res.x[:nv]) / normal.sum())
    forces = np.einsum("ce,ced->cd", lam, edges) / normal.min()
    return BalancedForces(normal / normal.min(), forces, residual if residual > 1e-7 else 0.0)


def balance_wrenches(points_mm, inward_normals, friction: float, n_edges: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """The cone edges ``(C, E, 3)`` (unit normal component,
    :func:`~prehension.quality.wrenches.cone_edges`) and their wrenches ``(6, C E)`` as the
    balance of :func:`balanced_normal_forces` counts them: force, and torque about the
    contacts' mean point divided by their largest distance from it (force units)."""
    p = np.asarray(points_mm, dtype=float).reshape(-1, 3)
    arm = p - p.mean(axis=0)
    scale = max(float(np.max(np.linalg.norm(arm, axis=1))), 1e-9)
    edges = cone_edges(np.asarray(inward_normals, dtype=float).reshape(-1, 3), friction, n_edges)
    C, E = edges.shape[:2]
    return edges, np.concatenate([edges, np.cross(arm[:, None, :], edges) / scale], axis=2).reshape(C * E, 6).T


def coupling_weights(hand) -> np.ndarray:
    """``w`` ``(n_dof,)`` of the forces squeeze's step ``J^T f / w``: 1 plus the squared
    ratios of the dofs coupled to each dof (a source moves its followers too)."""
    weight = np.ones(hand.n_dof)
    for c in hand.couplings:
        weight[hand.dof_index(c.source)] += c.ratio**2
    return weight


def squeeze_step(task: Task, q, contacts, squeeze_mm: float, kind: str = "forces", friction: float = 0.6) -> tuple[np.ndarray, np.ndarray]:
    """The squeeze of ``kind`` (module docstring): ``(targets (n_dof,) [rad], how far each
    contact is aimed into the object (C,) [mm])``.  ``"forces"``: when no contact would be
    aimed inward (more than 1e-9 mm per unit of balanced force), the ``"balanced"`` one."""
    q = np.asarray(q, dtype=float)
    if kind == "push":
        raise ValueError("squeeze_step: the 'push' squeeze needs the object's pose and the push: sim.push.squeeze_for")
    if kind == "forces":
        J, _, free, _ = _problem(task, q, contacts, squeeze_mm, None)  # (3C, n_dof) [mm/rad], couplings folded
        inward = inward_normals(contacts)
        forces = _balanced(contacts, friction).forces  # (C, 3)
        dq = np.zeros(task.hand.n_dof)
        dq[free] = J[:, free].T @ forces.reshape(-1) / coupling_weights(task.hand)[free]
        depths = np.einsum("cd,cd->c", (J @ dq).reshape(-1, 3), inward)
        if len(contacts) and depths.max() > 1e-9:
            scale = squeeze_mm / depths.max()
            return _targets(task.hand, q, free, scale * dq[free]), scale * depths
        kind = "balanced"
    depths = squeeze_depths(contacts, squeeze_mm, kind, friction)
    return squeeze_targets(task, q, contacts, squeeze_mm, depths), depths


def squeeze_depths(contacts, squeeze_mm: float, kind: str = "balanced", friction: float = 0.6) -> np.ndarray:
    """How far each contact is aimed into the object [mm] ``(C,)`` by the ``"balanced"`` or
    ``"uniform"`` squeeze (module docstring; ``"forces"``' depths: :func:`squeeze_step`)."""
    if kind not in ("balanced", "uniform"):
        raise ValueError(f"squeeze_depths: the {kind!r} squeeze's depths need the hand: squeeze_step")
    C = len(contacts)
    if kind == "uniform" or C == 0:
        return np.full(C, float(squeeze_mm))
    normal = _balanced(contacts, friction).normal
    return squeeze_mm * normal / normal.max()


def inward_normals(contacts) -> np.ndarray:
    """The contacts' inward normals ``(C, 3)`` (into the object)."""
    return -np.array([np.asarray(c.object_normal, float) for c in contacts])


def _balanced(contacts, friction: float) -> BalancedForces:
    """:func:`balanced_normal_forces` at the contacts' points and inward normals."""
    return balanced_normal_forces(np.array([np.asarray(c.hand_point, float) for c in contacts]), inward_normals(contacts), friction)


def contact_jacobian(task: Task, q: np.ndarray, contacts) -> np.ndarray:
    """The contacts' hand-point Jacobians stacked, ``(3C, n_dof)`` [mm/rad] (no coupling folded)."""
    hand = task.hand
    pose = forward_kinematics(hand, q)
    rows = []
    for contact, state in zip(task.contacts, contacts):
        link = hand.link_index(hand.region(contact.hand_region).link)
        rows.append(point_jacobian(hand, pose, link, np.asarray(state.hand_point, float)[None])[0])  # (3, n_dof)
    return np.concatenate(rows)


def _problem(task: Task, q: np.ndarray, contacts, squeeze_mm: float, depths_mm):
    """``(J (3C, n_dof) [mm/rad], target (3C,) [mm], free (n_dof,) bool, (lo, hi) of dq[free])``
    of :func:`squeeze_targets`: coupled dofs folded into their sources."""
    hand = task.hand
    depths = np.full(len(task.contacts), float(squeeze_mm)) if depths_mm is None else np.asarray(depths_mm, float)
    J = contact_jacobian(task, q, contacts)  # (3C, n_dof)
    target = [-depth * np.asarray(state.object_normal, float) for state, depth in zip(contacts, depths)]
    free = free_dofs(task)
    for c in hand.couplings:  # a coupled dof moves with its source
        J[:, hand.dof_index(c.source)] += c.ratio * J[:, hand.dof_index(c.dof)]
    bounds = np.minimum((hand.lower - q)[free], 0), np.maximum((hand.upper - q)[free], 0)
    return J, np.concatenate(target), free, bounds


def free_dofs(task: Task) -> np.ndarray:
    """The dofs a squeeze step moves on its own ``(n_dof,)`` bool: the task's active ones but
    those that follow a coupling (they move with their source)."""
    free = np.asarray(task.active_mask, bool).copy()
    for c in task.hand.couplings:
        free[task.hand.dof_index(c.dof)] = False
    return free


def _targets(hand, q: np.ndarray, free: np.ndarray, dq_free: np.ndarray) -> np.ndarray:
    """The angles of a step given on the free dofs: coupled dofs follow, clipped into the limits."""
    dq = np.zeros(hand.n_dof)
    dq[free] = dq_free
    for c in hand.couplings:
        dq[hand.dof_index(c.dof)] = c.ratio * dq[hand.dof_index(c.source)]
    return np.clip(q + dq, hand.lower, hand.upper)


def squeeze_targets(task: Task, q: np.ndarray, contacts, squeeze_mm: float, depths_mm=None) -> np.ndarray:
    """Joint angles ``(n_dof,)`` [rad] that move every contact's hand point ``squeeze_mm``
    (or, per contact, ``depths_mm``) along the object's inward normal, to first order.

    With ``J`` the stacked Jacobians of the contacts' hand points with respect to the
    independent moving dofs (a coupled dof follows its source), the step is the
    least-squares one, ``min |J dq - d * n_in|`` within the joint limits
    (``scipy.optimize.lsq_linear``); coupled dofs follow.  ``contacts`` carry palm-frame ``hand_point`` and
    outward ``object_normal`` (as a :class:`~prehension.results.Solution`'s do).  ``J``
    has more columns than rows, so the least-squares step need not be unique: with a
    bound active, ``lsq_linear`` may stop at different equally good steps for contacts
    1e-11 mm apart; :func:`as_good_a_squeeze` is how a stored step is re-derived.

    Args:
        task: the task.
        q: (n_dof,) the solved angles [rad].
        contacts: the solution's contacts.
        squeeze_mm: how far into the object [mm] (every contact, unless ``depths_mm``).
        depths_mm: (C,) per contact depths [mm] (:func:`squeeze_depths`), or ``None``.
    """
    q = np.asarray(q, dtype=float)
    J, target, free, bounds = _problem(task, q, contacts, squeeze_mm, depths_mm)
    dq_free = lsq_linear(J[:, free], target, bounds=bounds).x if free.any() else np.zeros(0)
    return _targets(task.hand, q, free, dq_free)


def as_good_a_squeeze(task: Task, q: np.ndarray, contacts, squeeze_mm: float, depths_mm, given, tol_mm: float = 1e-6) -> bool:
    """Whether the angles ``given`` (n_dof,) [rad] are a squeeze step of :func:`squeeze_targets`'s
    problem as good as the one it finds now: a step within its bounds on the free dofs (the
    others following or fixed, as there) whose residual ``|J dq - d * n_in|`` is at most
    ``tol_mm`` larger.  How ``prehension check`` re-derives stored squeeze targets when
    the least-squares step is not unique."""
    q, given = np.asarray(q, dtype=float), np.asarray(given, dtype=float)
    J, target, free, (lo, hi) = _problem(task, q, contacts, squeeze_mm, depths_mm)
    dq_free = np.clip((given - q)[free], lo, hi)
    if not np.allclose(_targets(task.hand, q, free, dq_free), given, atol=1e-9, rtol=0):
        return False
    best = squeeze_targets(task, q, contacts, squeeze_mm, depths_mm)
    cost = float(np.linalg.norm(J[:, free] @ dq_free - target))
    return cost <= float(np.linalg.norm(J[:, free] @ (best - q)[free] - target)) + tol_mm
