"""Batch forward kinematics and Jacobians of a :class:`~prehension.hands.model.Hand`.

Every function takes a batch of joint-angle vectors ``q (B, n_dof)`` [rad] (a single
vector ``(n_dof,)`` is promoted to ``B = 1``) and returns arrays whose first axis is the
batch.  Poses are homogeneous transforms ``T_palm_link`` with ``x_palm = T x_link``
(translations in mm).

Jacobians are geometric: a dof ``d`` turns every link it moves about its axis
``w_d`` (palm frame) through the point ``o_d``, so a point ``p`` and a direction ``n``
fixed to such a link move with

.. math::

    \\frac{\\partial p}{\\partial q_d} = w_d \\times (p - o_d), \\qquad
    \\frac{\\partial n}{\\partial q_d} = w_d \\times n .
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidConfiguration
from ..geometry.rotations import skew
from .model import Hand, tree_tables

__all__ = ["HandPose", "as_batch", "forward_kinematics", "point_jacobian", "direction_jacobian"]


def as_batch(q, n_dof: int) -> np.ndarray:
    """Check and promote joint angles to shape ``(B, n_dof)`` [rad]."""
    arr = np.asarray(q, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != n_dof:
        raise InvalidConfiguration(
            f"joint angles must have shape (n_dof,) or (B, n_dof) with n_dof = {n_dof}, got {np.shape(q)}"
        )
    if not np.all(np.isfinite(arr)):
        raise InvalidConfiguration("joint angles must be finite numbers (rad)")
    return arr


@dataclass(frozen=True, eq=False)
class HandPose:
    """Every link's pose and every dof's axis for a batch of configurations.

    Attributes:
        R_palm_link: (B, n_links, 3, 3) link orientations in the palm frame.
        r_palm_link: (B, n_links, 3) link origins in the palm frame [mm].
        axis_palm: (B, n_dof, 3) unit rotation axis of each dof in the palm frame.
        origin_palm: (B, n_dof, 3) a point on each dof's axis (the joint centre) [mm].
    """

    R_palm_link: np.ndarray
    r_palm_link: np.ndarray
    axis_palm: np.ndarray
    origin_palm: np.ndarray

    @property
    def T_palm_link(self) -> np.ndarray:
        """(B, n_links, 4, 4) homogeneous transforms."""
        B, L = self.r_palm_link.shape[:2]
        T = np.zeros((B, L, 4, 4))
        T[..., :3, :3] = self.R_palm_link
        T[..., :3, 3] = self.r_palm_link
        T[..., 3, 3] = 1.0
        return T

    def points(self, link_index: int, p_link) -> np.ndarray:
        """Points fixed to a link, ``p_link (3,) or (B, 3)`` [mm] -> palm frame (B, 3)."""
        R = self.R_palm_link[:, link_index]
        return np.einsum("bij,bj->bi", R, np.broadcast_to(p_link, (R.shape[0], 3))) + self.r_palm_link[:, link_index]

    def directions(self, link_index: int, n_link) -> np.ndarray:
        """Directions fixed to a link, ``(3,) or (B, 3)`` -> palm frame (B, 3)."""
        R = self.R_palm_link[:, link_index]
        return np.einsum("bij,bj->bi", R, np.broadcast_to(n_link, (R.shape[0], 3)))


def _axis_terms(axis) -> tuple[np.ndarray, np.ndarray]:
    """``([a]_x, [a]_x^2)`` (1, 3, 3) of a joint axis, computed as :func:`axis_angle_to_matrix` does."""
    k = skew(np.atleast_2d(axis / np.linalg.norm(axis, axis=-1, keepdims=True)))
    return k, k @ k


def _rodrigues_terms(hand: Hand) -> list:
    """Per joint, the Rodrigues terms of its axis (and of its second axis), once per hand."""
    tables = tree_tables(hand)
    terms = tables.get("rodrigues")
    if terms is None:
        terms = [(_axis_terms(j.axis_in_parent), _axis_terms(j.axis_in_child) if j.kind == "universal" else None)
                 for j in hand.joints]  # fmt: skip
        tables["rodrigues"] = terms
    return terms


def _rotation(terms, angle) -> np.ndarray:
    """Rodrigues' rotation (B, 3, 3) for ``angle (B,)`` [rad] about a precomputed axis:
    the same bits as ``axis_angle_to_matrix(axis, angle)``, without re-checking the axis."""
    k, kk = terms
    angle = angle[:, None, None]
    return _EYE + np.sin(angle) * k + (1.0 - np.cos(angle)) * kk


_EYE = np.eye(3)


def forward_kinematics(hand: Hand, q) -> HandPose:
    """Poses of all links for joint angles ``q (B, n_dof)`` [rad] (the palm is the identity)."""
    q = as_batch(q, hand.n_dof)
    B, L = q.shape[0], len(hand.links)
    R = np.zeros((B, L, 3, 3))
    r = np.zeros((B, L, 3))
    R[:, 0] = np.eye(3)
    axis = np.zeros((B, hand.n_dof, 3))
    origin = np.zeros((B, hand.n_dof, 3))
    tables = tree_tables(hand)
    rodrigues = _rodrigues_terms(hand)
    for k, (joint, off) in enumerate(zip(hand.joints, hand.dof_offsets)):
        p, c = tables["parent"][k], tables["child"][k]
        R_p, r_p = R[:, p], r[:, p]
        centre = np.einsum("bij,j->bi", R_p, joint.origin_in_parent) + r_p  # (B, 3)
        R_a = np.einsum("bij,bjk->bik", R_p, _rotation(rodrigues[k][0], q[:, off]))
        R_c = R_a @ joint.R_parent_child_zero  # (B, 3, 3)
        axis[:, off] = R_p @ joint.axis_in_parent
        origin[:, off] = centre
        if joint.kind == "universal":
            axis[:, off + 1] = R_c @ joint.axis_in_child
            origin[:, off + 1] = centre
            R_c = np.einsum("bij,bjk->bik", R_c, _rotation(rodrigues[k][1], q[:, off + 1]))
        R[:, c] = R_c
        r[:, c] = centre - np.einsum("bij,j->bi", R_c, joint.origin_in_child)
    return HandPose(R, r, axis, origin)


def point_jacobian(hand: Hand, pose: HandPose, link_index: int, p_palm) -> np.ndarray:
    """d p / d q for points ``p_palm (B, 3)`` [mm] fixed to a link -> (B, 3, n_dof) [mm/rad]."""
    moves = tree_tables(hand)["moves"][link_index]  # (n_dof,)
    J = np.cross(pose.axis_palm, np.asarray(p_palm)[:, None, :] - pose.origin_palm)  # (B, n_dof, 3)
    return np.swapaxes(J * moves[None, :, None], 1, 2)


def direction_jacobian(hand: Hand, pose: HandPose, link_index: int, n_palm) -> np.ndarray:
    """d n / d q for directions ``n_palm (B, 3)`` fixed to a link -> (B, 3, n_dof) [1/rad]."""
    moves = tree_tables(hand)["moves"][link_index]
    J = np.cross(pose.axis_palm, np.asarray(n_palm)[:, None, :])  # (B, n_dof, 3)
    return np.swapaxes(J * moves[None, :, None], 1, 2)
