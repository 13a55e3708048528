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

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .._compiled import aot
from ..errors import InvalidConfiguration
from ..frozen import cached_per_value
from ..geometry.rotations import skew
from ._capsules import njit
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


class _ChainArrays(NamedTuple):
    """The joint tree as arrays for :func:`_fk_loop`, built once per hand (:func:`_chain_arrays`).

    Per joint ``k`` (J joints, in tree order): ``parent``, ``child`` link indices and
    ``offset`` (first dof) (J,) int64; ``universal`` (J,) int64 (1: a second dof);
    ``origin_in_parent``, ``origin_in_child``, ``axis_in_parent``, ``axis_in_child`` (J, 3)
    [mm, unit]; ``R_zero`` (J, 3, 3); ``k1``, ``kk1``, ``k2``, ``kk2`` (J, 3, 3): the
    Rodrigues terms ``[a]_x`` and ``[a]_x^2`` of the first and second axis (zeros when
    there is none).
    """

    parent: np.ndarray
    child: np.ndarray
    offset: np.ndarray
    universal: np.ndarray
    origin_in_parent: np.ndarray
    origin_in_child: np.ndarray
    axis_in_parent: np.ndarray
    axis_in_child: np.ndarray
    R_zero: np.ndarray
    k1: np.ndarray
    kk1: np.ndarray
    k2: np.ndarray
    kk2: np.ndarray


@cached_per_value
def _chain_arrays(hand: Hand) -> _ChainArrays:
    """The hand's :class:`_ChainArrays`, once per hand."""
    tables = tree_tables(hand)
    J = len(hand.joints)
    k1, kk1, k2, kk2 = (np.zeros((J, 3, 3)) for _ in range(4))
    for k, j in enumerate(hand.joints):
        k1[k], kk1[k] = _axis_terms(j.axis_in_parent)
        if j.kind == "universal":
            k2[k], kk2[k] = _axis_terms(j.axis_in_child)
    vec = lambda name: np.array([np.broadcast_to(getattr(j, name), 3) for j in hand.joints], dtype=float).reshape(J, 3)  # noqa: E731
    return _ChainArrays(
        np.asarray(tables["parent"], dtype=np.int64).reshape(J), np.asarray(tables["child"], dtype=np.int64).reshape(J),
        np.array(hand.dof_offsets, dtype=np.int64).reshape(J),
        np.array([j.kind == "universal" for j in hand.joints], dtype=np.int64).reshape(J),
        vec("origin_in_parent"), vec("origin_in_child"), vec("axis_in_parent"),
        np.array([j.axis_in_child if j.kind == "universal" else np.zeros(3) for j in hand.joints], dtype=float).reshape(J, 3),
        np.array([j.R_parent_child_zero for j in hand.joints], dtype=float).reshape(J, 3, 3),
        k1, kk1, k2, kk2,
    )  # fmt: skip


@njit(cache=True)
def _rodrigues(k, kk, j, angle, out):
    """``I + sin(angle) [a]_x + (1 - cos(angle)) [a]_x^2`` of joint ``j``'s axis terms -> out (3, 3)."""
    s, c1 = math.sin(angle), 1.0 - math.cos(angle)
    for i in range(3):
        for m in range(3):
            out[i, m] = ((1.0 if i == m else 0.0) + s * k[j, i, m]) + c1 * kk[j, i, m]


@njit(cache=True)
def mat_mat(A, B, out):
    """``out = A @ B`` for (3, 3) matrices (sums in index order; ``out`` distinct from ``A``
    and ``B``).  Also the local solver's kernel's 3x3 product (``solvers.local._linalg``)."""
    for i in range(3):
        for m in range(3):
            out[i, m] = A[i, 0] * B[0, m] + A[i, 1] * B[1, m] + A[i, 2] * B[2, m]


@njit(cache=True)
def mat_vec(A, v, out):
    """``out = A @ v`` for a (3, 3) matrix and a (3,) vector (also the kernel's)."""
    for i in range(3):
        out[i] = A[i, 0] * v[0] + A[i, 1] * v[1] + A[i, 2] * v[2]


@njit(cache=True)
def _fk_loop(q, ch, R, r, axis, origin):
    """Forward kinematics of ``q (B, n_dof)`` through the tree ``ch`` into ``R (B, L, 3, 3)``,
    ``r (B, L, 3)``, ``axis`` and ``origin (B, n_dof, 3)`` (palm row of ``R`` preset to I)."""
    rot, tmp, vec = np.empty((3, 3)), np.empty((3, 3)), np.empty(3)
    for b in range(q.shape[0]):
        for k in range(ch.parent.shape[0]):
            p, c, d = ch.parent[k], ch.child[k], ch.offset[k]
            mat_vec(R[b, p], ch.origin_in_parent[k], vec)
            for i in range(3):
                origin[b, d, i] = vec[i] + r[b, p, i]
            mat_vec(R[b, p], ch.axis_in_parent[k], axis[b, d])
            _rodrigues(ch.k1, ch.kk1, k, q[b, d], rot)
            mat_mat(R[b, p], rot, tmp)
            mat_mat(tmp, ch.R_zero[k], R[b, c])
            if ch.universal[k] == 1:
                mat_vec(R[b, c], ch.axis_in_child[k], axis[b, d + 1])
                for i in range(3):
                    origin[b, d + 1, i] = origin[b, d, i]
                _rodrigues(ch.k2, ch.kk2, k, q[b, d + 1], rot)
                tmp[:, :] = R[b, c]
                mat_mat(tmp, rot, R[b, c])
            mat_vec(R[b, c], ch.origin_in_child[k], vec)
            for i in range(3):
                r[b, c, i] = origin[b, d, i] - vec[i]


def forward_kinematics(hand: Hand, q) -> HandPose:
    """Poses of all links for joint angles ``q (B, n_dof)`` [rad] (the palm is the identity).

    Joint ``k`` with parent link ``p`` places its child ``c`` at
    ``R_c = R_p Rot(a_k, q_k) R_zero_k`` (times ``Rot(v_k, q_k')`` for a universal joint's
    second axis ``v_k``, fixed in the child), ``r_c = o_k - R_c origin_in_child_k`` with the
    joint centre ``o_k = R_p origin_in_parent_k + r_p``; ``Rot`` is Rodrigues' formula.  The
    loop over configurations and joints is compiled (numba): one configuration of a
    20-joint hand takes microseconds.
    """
    q = np.ascontiguousarray(as_batch(q, hand.n_dof))
    B, L = q.shape[0], len(hand.links)
    R = np.zeros((B, L, 3, 3))
    r = np.zeros((B, L, 3))
    R[:, 0] = np.eye(3)
    axis = np.zeros((B, hand.n_dof, 3))
    origin = np.zeros((B, hand.n_dof, 3))
    aot(_fk_loop)(q, _chain_arrays(hand), R, r, axis, origin)
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
