"""A hand's joint tree as flat arrays, and the one compiled forward-kinematics loop over them.

:class:`JointTables` holds the joints in tree order (built once per hand by
:func:`prehension.hands.kinematics.joint_tables`); :func:`pose_chain` places every link of
one configuration, :func:`pose_chains` of a batch (the foundation's
:func:`~prehension.hands.kinematics.forward_kinematics`); the local solver's kernel calls
:func:`pose_chain` on its own state.  Joint ``k`` with parent link ``p`` places its child
``c`` at

.. math::

    R_c = R_p \\, \\mathrm{Rot}(a_k, q_k) \\, R^0_k, \\qquad
    r_c = o_k - R_c \\, o^{child}_k, \\qquad o_k = R_p \\, o^{parent}_k + r_p,

times ``Rot(v_k, q_k')`` for a universal joint's second axis ``v_k`` (fixed in the child).

``Rot`` has two written forms, which round differently, and each caller keeps its own so
that its answers stay what they were to the bit: the foundation's
``I + sin q [a]_x + (1 - cos q) [a]_x^2`` from the tables' precomputed terms (as
:func:`prehension.geometry.rotations.axis_angle_to_matrix` computes it) and the kernel's
closed form :func:`rot` (``closed_form=True``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .jit import njit

__all__ = ["JointTables", "mat_mat", "mat_vec", "rot", "pose_chain", "pose_chains"]


class JointTables(NamedTuple):
    """The joint tree as arrays (J joints in tree order; palm frame conventions, mm).

    ``parent``, ``child`` link indices and ``dof`` (first angle) (J,) int64; ``universal``
    (J,) int64 (1: a second angle, about ``axis_in_child``); ``origin_in_parent``,
    ``origin_in_child`` [mm], ``axis_in_parent``, ``axis_in_child`` (unit; zeros without a
    second axis) (J, 3); ``R_zero`` (J, 3, 3); ``k1``, ``kk1``, ``k2``, ``kk2`` (J, 3, 3):
    the Rodrigues terms ``[a]_x`` and ``[a]_x^2`` of the first and second axis (zeros
    when there is none).
    """

    parent: np.ndarray
    child: np.ndarray
    dof: np.ndarray
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


@njit(cache=True)
def mat_mat(A, B, out):
    """``out = A @ B`` for (3, 3) matrices (sums in index order; ``out`` distinct from ``A`` and ``B``)."""
    for i in range(3):
        for m in range(3):
            out[i, m] = A[i, 0] * B[0, m] + A[i, 1] * B[1, m] + A[i, 2] * B[2, m]


@njit(cache=True)
def mat_vec(A, v, out):
    """``out = A @ v`` for a (3, 3) matrix and a (3,) vector."""
    for i in range(3):
        out[i] = A[i, 0] * v[0] + A[i, 1] * v[1] + A[i, 2] * v[2]


@njit(cache=True)
def rot(u0, u1, u2, th, out):
    """Rodrigues' closed form: ``out = Rot(u, th)`` (3, 3) for a unit axis ``u``."""
    c, s = math.cos(th), math.sin(th)
    v = 1.0 - c
    out[0, 0] = c + u0 * u0 * v
    out[0, 1] = u0 * u1 * v - u2 * s
    out[0, 2] = u0 * u2 * v + u1 * s
    out[1, 0] = u1 * u0 * v + u2 * s
    out[1, 1] = c + u1 * u1 * v
    out[1, 2] = u1 * u2 * v - u0 * s
    out[2, 0] = u2 * u0 * v - u1 * s
    out[2, 1] = u2 * u1 * v + u0 * s
    out[2, 2] = c + u2 * u2 * v


@njit(cache=True)
def _rodrigues(k, kk, j, angle, out):
    """``I + sin(angle) [a]_x + (1 - cos(angle)) [a]_x^2`` of joint ``j``'s axis terms -> out (3, 3)."""
    s, c1 = math.sin(angle), 1.0 - math.cos(angle)
    for i in range(3):
        for m in range(3):
            out[i, m] = ((1.0 if i == m else 0.0) + s * k[j, i, m]) + c1 * kk[j, i, m]


@njit(cache=True)
def _joint_rotation(axis, k_terms, kk_terms, j, angle, closed_form, out):
    """``Rot`` of joint ``j``'s axis ``axis[j]`` (its terms ``k_terms[j]``, ``kk_terms[j]``)
    by ``angle`` -> out (3, 3), in the closed form or from the terms."""
    if closed_form:
        rot(axis[j, 0], axis[j, 1], axis[j, 2], angle, out)
    else:
        _rodrigues(k_terms, kk_terms, j, angle, out)


@njit(cache=True, inline="always")
def pose_chain(q, jt, closed_form, R, r, axis, origin, rot3, tmp, vec):
    """Forward kinematics of one configuration ``q (n_dof,)`` [rad] through the tree ``jt``:
    link poses ``R (L, 3, 3)``, ``r (L, 3)`` [mm] (the palm, link 0, at the identity), each
    angle's axis ``axis`` and centre ``origin (n_dof, 3)`` (palm frame); ``rot3``, ``tmp``
    (3, 3) and ``vec (3,)`` scratch; ``closed_form``: which form of ``Rot`` (module
    docstring).  Inlined into its callers (a call per configuration costs more than the
    loop of a small hand)."""
    for i in range(3):
        r[0, i] = 0.0
        for j in range(3):
            R[0, i, j] = 1.0 if i == j else 0.0
    for k in range(jt.parent.shape[0]):
        p, c, d = jt.parent[k], jt.child[k], jt.dof[k]
        mat_vec(R[p], jt.origin_in_parent[k], vec)
        for i in range(3):
            origin[d, i] = vec[i] + r[p, i]
        mat_vec(R[p], jt.axis_in_parent[k], axis[d])
        _joint_rotation(jt.axis_in_parent, jt.k1, jt.kk1, k, q[d], closed_form, rot3)
        mat_mat(R[p], rot3, tmp)
        mat_mat(tmp, jt.R_zero[k], R[c])
        if jt.universal[k] == 1:  # the second axis, fixed in the child
            mat_vec(R[c], jt.axis_in_child[k], axis[d + 1])
            for i in range(3):
                origin[d + 1, i] = origin[d, i]
            _joint_rotation(jt.axis_in_child, jt.k2, jt.kk2, k, q[d + 1], closed_form, rot3)
            for i in range(3):
                for j in range(3):
                    tmp[i, j] = R[c, i, j]
            mat_mat(tmp, rot3, R[c])
        mat_vec(R[c], jt.origin_in_child[k], vec)
        for i in range(3):
            r[c, i] = origin[d, i] - vec[i]


@njit(cache=True)
def pose_chains(q, jt, R, r, axis, origin):
    """:func:`pose_chain` of every configuration ``q (B, n_dof)`` into ``R (B, L, 3, 3)``,
    ``r (B, L, 3)``, ``axis`` and ``origin (B, n_dof, 3)``, the foundation's form of ``Rot``."""
    rot3, tmp, vec = np.empty((3, 3)), np.empty((3, 3)), np.empty(3)
    for b in range(q.shape[0]):
        pose_chain(q[b], jt, np.bool_(False), R[b], r[b], axis[b], origin[b], rot3, tmp, vec)
