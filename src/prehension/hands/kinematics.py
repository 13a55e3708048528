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
from ..frozen import cached_per_value
from ..geometry.rotations import skew
from ..kernels.aot import aot
from ..kernels.chain import JointTables, pose_chains
from .model import Hand, tree_tables

__all__ = ["HandPose", "as_batch", "forward_kinematics", "joint_tables", "point_jacobian", "direction_jacobian"]


def as_batch(q, n_dof: int) -> np.ndarray:
    """Check and promote joint angles to shape ``(B, n_dof)`` [rad]."""
    arr = np.asarray(q, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != n_dof:
        raise InvalidConfiguration(
            f"joint angles must have shape (n_dof,) or (B, n_dof) with n_dof = {n_dof}, got {np.shape(q)}"
        )
    if not np.isfinite(arr).all():
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
    """``([a]_x, [a]_x^2)`` (3, 3) of a joint axis, computed as :func:`axis_angle_to_matrix` does."""
    k = skew(np.atleast_2d(axis / np.linalg.norm(axis, axis=-1, keepdims=True)))[0]
    return k, k @ k


@cached_per_value
def joint_tables(hand: Hand) -> JointTables:
    """The hand's joint tree as the compiled loop reads it (:class:`~prehension.kernels.chain.JointTables`),
    built once per hand (weak cache, never on the frozen hand); the local solver's kernel
    reads the same tables."""
    tables = tree_tables(hand)
    J = len(hand.joints)
    k1, kk1, k2, kk2 = (np.zeros((J, 3, 3)) for _ in range(4))
    for k, j in enumerate(hand.joints):
        k1[k], kk1[k] = _axis_terms(j.axis_in_parent)
        if j.kind == "universal":
            k2[k], kk2[k] = _axis_terms(j.axis_in_child)
    vec = lambda name: np.array([np.broadcast_to(getattr(j, name), 3) for j in hand.joints], dtype=float).reshape(J, 3)  # noqa: E731
    return JointTables(
        np.asarray(tables["parent"], dtype=np.int64).reshape(J), np.asarray(tables["child"], dtype=np.int64).reshape(J),
        np.array(hand.dof_offsets, dtype=np.int64).reshape(J),
        np.array([j.kind == "universal" for j in hand.joints], dtype=np.int64).reshape(J),
        vec("origin_in_parent"), vec("origin_in_child"), vec("axis_in_parent"),
        np.array([j.axis_in_child if j.kind == "universal" else np.zeros(3) for j in hand.joints], dtype=float).reshape(J, 3),
        np.array([j.R_parent_child_zero for j in hand.joints], dtype=float).reshape(J, 3, 3),
        k1, kk1, k2, kk2,
    )  # fmt: skip


def forward_kinematics(hand: Hand, q) -> HandPose:
    """Poses of all links for joint angles ``q (B, n_dof)`` [rad] (the palm is the identity).

    Joint ``k`` with parent link ``p`` places its child ``c`` at
    ``R_c = R_p Rot(a_k, q_k) R_zero_k`` (times ``Rot(v_k, q_k')`` for a universal joint's
    second axis ``v_k``, fixed in the child), ``r_c = o_k - R_c origin_in_child_k`` with the
    joint centre ``o_k = R_p origin_in_parent_k + r_p``; ``Rot`` is Rodrigues' formula.  The
    loop over configurations and joints is compiled (numba,
    :func:`prehension.kernels.chain.pose_chains`): one configuration of a 20-joint hand
    takes microseconds.
    """
    q = np.ascontiguousarray(as_batch(q, hand.n_dof))
    B, L = q.shape[0], len(hand.links)
    R = np.zeros((B, L, 3, 3))
    r = np.zeros((B, L, 3))
    R[:, 0] = np.eye(3)
    axis = np.zeros((B, hand.n_dof, 3))
    origin = np.zeros((B, hand.n_dof, 3))
    aot(pose_chains)(q, joint_tables(hand), R, r, axis, origin)
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
