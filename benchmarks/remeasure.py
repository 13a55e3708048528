"""An independent re-measure of how deep a solved grasp reaches into its object (issue 26).

Independent of the project's distance code (:mod:`prehension.objects.distance`, the
residual function, the kernel's rows): each collision capsule's axis is sampled at
``n`` points and each sample's ball ``B(s, r)`` is measured against the object's closed
mesh by brute force, ``depth = r - sd(s)``: the distance to the closest of all the
triangles (trimesh's ``closest_point_naive``, no spatial tree), negative inside by the
generalised winding number (the solid angles of all the triangles, summed: 1 inside,
0 outside); each contact's pad (a fingertip cap's ball ``B(c, rho)``) likewise,
``rho - sd(c)``.  Only a capsule ball inside its own link's pad ball
(``|s - c| + r <= rho``) is excused.  It reads the solution's stored link poses and
whatever capsules the hand has, so it measures any hand's collision geometry.

Sampling reads a segment's depth low by at most ``r - sqrt(r^2 - h^2/4)`` for samples
``h`` apart against a flat surface (64 samples of the SA hand's 90 mm palm capsules:
0.04 mm).  On meshes of several glued pieces the distance inside may be measured to an internal
wall (low); the outside, where a clear hand is, is exact.
"""

from __future__ import annotations

import numpy as np
import trimesh

from prehension.geometry.regions import SphereCap

SAMPLES = 64  # points per capsule axis
CHUNK = 32  # points measured against every triangle at once


def signed_distance(vertices, faces, points) -> np.ndarray:
    """Signed distance of ``points (P, 3)`` to the closed mesh, negative inside, (P,) [mm],
    by brute force over every triangle (see the module docstring)."""
    tri = np.asarray(vertices, dtype=float)[np.asarray(faces)]  # (F, 3, 3)
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    out = np.empty(len(points))
    for k in range(0, len(points), CHUNK):
        p = np.asarray(points[k : k + CHUNK], dtype=float)
        _, dist, _ = trimesh.proximity.closest_point_naive(mesh, p)
        out[k : k + CHUNK] = np.where(_winding(tri, p) > 0.5, -dist, dist)
    return out


def _winding(tri, p) -> np.ndarray:
    """Generalised winding number of points ``p (P, 3)``: sum of the triangles' solid
    angles / 4 pi (Van Oosterom and Strackee), (P,)."""
    a, b, c = (tri[None, :, i] - p[:, None] for i in range(3))  # (P, F, 3) each
    la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (a, b, c))
    det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
    den = la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc + np.einsum("pfi,pfi->pf", b, c) * la + np.einsum("pfi,pfi->pf", c, a) * lb
    return np.sum(2.0 * np.arctan2(det, den), axis=1) / (4.0 * np.pi)


def _object_frame(T_palm_object, points_palm):
    T = np.asarray(T_palm_object, dtype=float)
    return (np.asarray(points_palm, dtype=float) - T[:3, 3]) @ T[:3, :3]


def _pads(task, solution) -> dict[str, list[tuple[np.ndarray, float, str]]]:
    """Per link: the pad balls on it, ``(centre (3,) object frame [mm], rho, contact name)``."""
    out = {}
    for c in task.contacts:
        hr = task.hand_region(c)
        if isinstance(hr.region, SphereCap):
            T = solution.link_poses[hr.link]
            centre = _object_frame(solution.T_palm_object, T[:3, :3] @ hr.region.center + T[:3, 3])
            out.setdefault(hr.link, []).append((centre, float(hr.region.radius), c.name))
    return out


def deepest(task, solution, n: int = SAMPLES) -> tuple[float, str]:
    """``(depth [mm], what)``: the deepest capsule ball (not inside its link's pad) or pad
    ball of ``solution`` in the object's closed mesh; ``(0.0, "")`` when nothing reaches in."""
    pads = _pads(task, solution)
    centres, radii, names = [], [], []
    u = np.linspace(0.0, 1.0, n)[:, None]
    for link in task.hand.links:
        T = solution.link_poses[link.name]
        for capsule in link.collision:
            a, b = (T[:3, :3] @ p + T[:3, 3] for p in (capsule.a, capsule.b))
            s = _object_frame(solution.T_palm_object, a + u * (b - a))
            keep = np.ones(n, dtype=bool)
            for c, rho, _ in pads.get(link.name, ()):
                keep &= np.linalg.norm(s - c, axis=1) + capsule.radius > rho
            centres.append(s[keep])
            radii += [capsule.radius] * int(keep.sum())
            names += [link.name] * int(keep.sum())
    for link_pads in pads.values():
        for c, rho, name in link_pads:
            centres.append(c[None]), radii.append(rho), names.append(f"{name} pad")
    surface = task.object.surface
    depth = np.asarray(radii) - signed_distance(surface.vertices, surface.faces, np.vstack(centres))
    k = int(np.argmax(depth))
    return (float(depth[k]), names[k]) if depth[k] > 0 else (0.0, "")
