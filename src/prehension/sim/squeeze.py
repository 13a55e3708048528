"""The squeeze: joint angles that would carry each contact a little further into the object."""

from __future__ import annotations

import numpy as np
from scipy.optimize import lsq_linear

from ..hands.kinematics import forward_kinematics, point_jacobian
from ..tasks.model import Task

__all__ = ["squeeze_targets"]


def squeeze_targets(task: Task, q: np.ndarray, contacts, squeeze_mm: float) -> np.ndarray:
    """Joint angles ``(n_dof,)`` [rad] that move every contact's hand point ``squeeze_mm``
    along the object's inward normal, to first order.

    With ``J`` the stacked Jacobians of the contacts' hand points with respect to the
    independent moving dofs (a coupled dof follows its source), the step is the
    least-squares one, ``min |J dq - squeeze_mm * n_in|`` within the joint limits
    (``scipy.optimize.lsq_linear``); coupled dofs follow.  ``contacts`` carry palm-frame ``hand_point`` and
    outward ``object_normal`` (as a :class:`~prehension.results.Solution`'s do).

    Args:
        task: the task.
        q: (n_dof,) the solved angles [rad].
        contacts: the solution's contacts.
        squeeze_mm: how far into the object [mm].
    """
    hand = task.hand
    q = np.asarray(q, dtype=float)
    pose = forward_kinematics(hand, q)
    rows, target = [], []
    for contact, state in zip(task.contacts, contacts):
        link = hand.link_index(hand.region(contact.hand_region).link)
        rows.append(point_jacobian(hand, pose, link, np.asarray(state.hand_point)[None])[0])  # (3, n_dof) [mm/rad]
        target.append(-squeeze_mm * np.asarray(state.object_normal, float))
    J = np.concatenate(rows)  # (3C, n_dof)
    free = task.active_mask.copy()
    for c in hand.couplings:  # a coupled dof moves with its source
        i, s = hand.dof_index(c.dof), hand.dof_index(c.source)
        J[:, s] += c.ratio * J[:, i]
        free[i] = False
    dq = np.zeros(hand.n_dof)
    if free.any():
        room = (hand.lower - q)[free], (hand.upper - q)[free]
        dq[free] = lsq_linear(J[:, free], np.concatenate(target), bounds=(np.minimum(room[0], 0), np.maximum(room[1], 0))).x
    for c in hand.couplings:
        dq[hand.dof_index(c.dof)] = c.ratio * dq[hand.dof_index(c.source)]
    return np.clip(q + dq, hand.lower, hand.upper)
