"""The contact wrench set: linearised Coulomb cones, optionally with torsional friction.

A contact at ``p`` (object frame, mm) with *inward* unit normal ``n`` (the direction a
finger pushes the object) can apply any force in its friction cone
``{f : |f - (f.n) n| <= mu (f.n)}``.  The cone is linearised by the pyramid of ``m`` edges

.. math::

    f_j = n + \\mu (\\cos\\theta_j\\, t_1 + \\sin\\theta_j\\, t_2), \\qquad \\theta_j = 2\\pi j / m,

(unit normal component; ``t_1, t_2`` an orthonormal basis of the tangent plane), inscribed
in the cone.  Each edge gives the *primitive wrench* (force, torque about the centre ``c``
divided by the object radius ``rho``, so that both halves have force units):

.. math::

    w_j = \\big(f_j,\\; (p - c) \\times f_j / \\rho\\big) \\in \\mathbb{R}^6 .

A soft finger (``torsion_mm = gamma > 0``) can also resist a moment about its normal of up
to ``gamma`` times its normal force.  Its wrench set is taken inside the elliptic model
``|f_t|^2 / mu^2 + tau_n^2 / gamma^2 <= f_n^2``: the ``m`` edges above and the two pure
torsion generators ``(n, ((p - c) x n +- gamma n) / rho)``, all of which lie on that cone,
so that their hull is inscribed in it.  Every generator has a unit normal force, so the
convex hull of all contacts' generators is the set of wrenches a grasp can apply with a
total normal force of at most one (Ferrari & Canny's L1 bound, their "Q1").
"""

from __future__ import annotations

import numpy as np

from ..geometry.rotations import orthonormal_frame
from .options import QualityOptions

__all__ = ["cone_edges", "primitive_wrenches"]


def cone_edges(inward_normals: np.ndarray, friction: float, n_edges: int) -> np.ndarray:
    """Edges of the linearised friction cones: ``(C, 3) unit normals -> (C, E, 3)`` forces.

    Each edge has a normal component of 1.  A frictionless contact (``friction == 0``)
    has one edge, its normal (``E = 1``); otherwise ``E = n_edges``.
    """
    n = np.asarray(inward_normals, dtype=float).reshape(-1, 3)
    if friction == 0.0:
        return n[:, None, :].copy()
    frame = orthonormal_frame(n)  # (C, 3, 3) columns t1, t2, n
    theta = 2.0 * np.pi * np.arange(n_edges) / n_edges  # (E,)
    tangent = np.cos(theta)[None, :, None] * frame[:, None, :, 0] + np.sin(theta)[None, :, None] * frame[:, None, :, 1]
    return n[:, None, :] + friction * tangent  # (C, E, 3)


def primitive_wrenches(points_mm, inward_normals, center_mm, radius_mm: float, options: QualityOptions) -> np.ndarray:
    """The primitive wrenches of every contact (see the module docstring).

    Args:
        points_mm: (C, 3) contact points, object frame [mm].
        inward_normals: (C, 3) unit normals pointing into the object (object frame).
        center_mm: (3,) point torques are taken about [mm].
        radius_mm: torque scale ``rho`` [mm].
        options: friction model.

    Returns:
        (C, G, 6) wrenches ``(force [unitless], torque / rho [unitless])``, ``G`` the
        generators per contact: the cone edges, then (soft fingers) the two torsion ones.
    """
    p = np.asarray(points_mm, dtype=float).reshape(-1, 3)
    n = np.asarray(inward_normals, dtype=float).reshape(-1, 3)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    arm = p - np.asarray(center_mm, dtype=float)  # (C, 3)
    forces = cone_edges(n, options.friction, options.cone_edges)  # (C, E, 3)
    torques = np.cross(arm[:, None, :], forces)  # (C, E, 3)
    if options.torsion_mm > 0:
        spin = options.torsion_mm * n  # (C, 3)
        normal_torque = np.cross(arm, n)  # (C, 3)
        forces = np.concatenate([forces, n[:, None, :], n[:, None, :]], axis=1)
        torques = np.concatenate([torques, (normal_torque + spin)[:, None], (normal_torque - spin)[:, None]], axis=1)
    return np.concatenate([forces, torques / float(radius_mm)], axis=2)  # (C, G, 6)
