"""The friction cones of a grasp: one translucent cone per contact (palm frame, mm).

Each cone has its apex at the contact's object point and opens into the object along
the inward normal with half-angle ``atan(mu)``: the forces the finger can apply there
without slipping (Coulomb, :mod:`prehension.quality.wrenches`).  It is drawn as long as
the normals' arrows, in the contact's colour.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from ..geometry.rotations import orthonormal_frame
from ..objects.meshes import Mesh
from ..quality.options import DEFAULT_FRICTION
from . import model as S
from .grasp import GraspPose

__all__ = ["friction_cone_layer", "cone_mesh", "CONE_OPACITY"]

CONE_OPACITY = 0.45
_SEGMENTS = 24


def cone_mesh(apex_mm, axis, half_angle_rad: float, length_mm: float, segments: int = _SEGMENTS) -> Mesh:
    """A closed cone: apex ``apex_mm (3,)``, unit ``axis (3,)``, ``length_mm`` along it [mm]."""
    apex, axis = np.asarray(apex_mm, float), np.asarray(axis, float) / np.linalg.norm(axis)
    e1, e2, _ = orthonormal_frame(axis).T
    phi = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    radius = length_mm * np.tan(half_angle_rad)
    rim = apex + length_mm * axis + radius * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)  # (S, 3)
    centre = apex + length_mm * axis
    k = np.arange(segments)
    side = np.stack([np.zeros(segments, int), 2 + (k + 1) % segments, 2 + k], -1)  # apex, rim: outward
    cap = np.stack([np.ones(segments, int), 2 + k, 2 + (k + 1) % segments], -1)  # centre, rim
    return Mesh(np.vstack([apex, centre, rim]), np.concatenate([side, cap]))


def friction_cone_layer(pose: GraspPose, colors: Mapping[str, str], length_mm: float,
                        friction: float = DEFAULT_FRICTION) -> "S.Layer":  # fmt: skip
    """The friction cones of every contact of ``pose`` (empty without contacts)."""
    meshes = []
    for c in pose.contacts:
        mesh = cone_mesh(c.object_point, -np.asarray(c.object_normal), float(np.arctan(friction)), length_mm)
        meshes.append(S.TriangleMesh(mesh.vertices, mesh.faces, colors.get(c.name, S.CONTACT_COLORS[0]), CONE_OPACITY, True))
    return S.Layer("friction_cones", f"friction cones (mu {friction:g})", tuple(meshes))
