"""The shapes of a grasp scene: triangle meshes to draw, solids to simulate.

The tessellation/scene stage's one module that knows the region kinds, shared by the
viewer (:mod:`prehension.viewer`) and the physics scene (:mod:`prehension.sim.scene`):
a new region kind adds its drawing and its solid here.

* :func:`capsule_mesh`: a link's collision capsule; :func:`region_mesh`: the surface of a
  contact region (a Bézier patch, a sphere cap, a disc on a point); :func:`region_center`:
  a marker point and normal of a region.  Every mesh is a
  :class:`~prehension.objects.meshes.Mesh` in the frame of the body that carries the shape
  (a link or the object), in mm.  Closed shapes (capsules) are oriented outwards
  (counter-clockwise seen from outside), so a renderer may cull their back faces; region
  surfaces are open and must be drawn two-sided.
* :func:`region_solid`: the solid a hand region is the surface of, for a simulator.
"""

from __future__ import annotations

import numpy as np

from .geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from .geometry.rotations import orthonormal_frame
from .hands.model import Capsule
from .objects.meshes import Mesh
from .quality.solid import hull_mesh

__all__ = ["grid_faces", "capsule_mesh", "region_mesh", "region_center", "region_solid", "drop_degenerate"]

CAPSULE_SEGMENTS = 16  # around the axis
CAPSULE_RINGS = 5  # per hemisphere, pole excluded
PATCH_SAMPLES = 13  # per parameter of a Bézier patch
CAP_SAMPLES = (8, 24)  # (polar, around) for a sphere cap
REGION_LIFT_MM = 0.3  # regions are drawn this far out of their body, to sit on its surface


def grid_faces(nu: int, nv: int, wrap_v: bool = False) -> np.ndarray:
    """Triangles of a ``(nu, nv)`` grid of vertices (row-major), shape ``(F, 3)``.

    With ``p_u``, ``p_v`` the grid's steps along its two indices, every triangle's normal
    (right-hand rule over its vertex order) points along ``p_v x p_u``.
    """
    idx = np.arange(nu * nv).reshape(nu, nv)
    iv = np.arange(nv if wrap_v else nv - 1)
    a = idx[:-1][:, iv]
    b = idx[1:][:, iv]
    c = idx[1:][:, (iv + 1) % nv]
    d = idx[:-1][:, (iv + 1) % nv]
    return np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])


def drop_degenerate(mesh: Mesh, decimals: int = 9) -> Mesh:
    """``mesh`` with coincident vertices merged (grid poles and seams) and the triangles
    that collapse to a segment or a point dropped: a closed grid becomes watertight."""
    v, inverse = np.unique(np.round(mesh.vertices, decimals), axis=0, return_inverse=True)
    f = inverse.reshape(-1)[mesh.faces]
    distinct = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])
    return Mesh(v, f[distinct])


def capsule_mesh(capsule: Capsule, segments: int = CAPSULE_SEGMENTS, rings: int = CAPSULE_RINGS) -> Mesh:
    """A closed, outward-oriented capsule (link frame, mm): two hemispheres and a tube."""
    a, b, r = capsule.a, capsule.b, capsule.radius
    length = np.linalg.norm(b - a)
    axis = (b - a) / length if length > 1e-9 else np.array([0.0, 0.0, 1.0])
    e1, e2, _ = orthonormal_frame(axis).T
    lat = np.concatenate([np.linspace(-np.pi / 2, 0, rings + 1), np.linspace(0, np.pi / 2, rings + 1)])
    ends = np.concatenate([np.repeat(a[None], rings + 1, 0), np.repeat(b[None], rings + 1, 0)])  # (n_lat, 3)
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    around = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2  # (segments, 3)
    radial = np.cos(lat)[:, None, None] * around[None] + np.sin(lat)[:, None, None] * axis  # (n_lat, seg, 3)
    points = ends[:, None, :] + r * radial
    return drop_degenerate(Mesh(points.reshape(-1, 3), grid_faces(len(lat), segments, wrap_v=True)))


def _lifted(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    return points + REGION_LIFT_MM * normals


def _bezier_mesh(region: BezierRegion, n: int = PATCH_SAMPLES) -> Mesh:
    t = np.linspace(0.0, 1.0, n)
    uu, vv = np.meshgrid(t, t, indexing="ij")
    points, normals = region.evaluate(np.stack([uu.ravel(), vv.ravel()], axis=1))
    return Mesh(_lifted(points, normals), grid_faces(n, n))


def _cap_mesh(region: SphereCap, samples: tuple[int, int] = CAP_SAMPLES) -> Mesh:
    n_polar, n_around = samples
    e1, e2, m = region.frame.T
    theta = np.linspace(0.0, region.half_angle, n_polar + 1)
    phi = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    around = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2  # (n_around, 3)
    normals = np.cos(theta)[:, None, None] * m + np.sin(theta)[:, None, None] * around[None]  # (n_polar+1, n_around, 3)
    normals = normals.reshape(-1, 3)
    points = region.center + region.radius * normals
    return drop_degenerate(Mesh(_lifted(points, normals), grid_faces(n_polar + 1, n_around, wrap_v=True)))


def _point_mesh(region: PointRegion, radius_mm: float = 2.0) -> Mesh:
    """A small disc on the contact point, facing along its normal."""
    e1, e2, _ = orthonormal_frame(region.normal).T
    phi = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    rim = region.point + radius_mm * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    faces = np.stack([np.zeros(16, int), 1 + np.arange(16), 1 + (np.arange(16) + 1) % 16], -1)
    return Mesh(_lifted(np.vstack([region.point, rim]), region.normal), faces)


def region_mesh(region: Region) -> Mesh:
    """The surface of a contact region (its body's frame, mm), lifted slightly outwards.

    Regions of a kind this module does not know are drawn as nothing (an empty mesh);
    their centre still gets a marker (:func:`region_center`).
    """
    if isinstance(region, BezierRegion):
        return _bezier_mesh(region)
    if isinstance(region, SphereCap):
        return _cap_mesh(region)
    if isinstance(region, PointRegion):
        return _point_mesh(region)
    return Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=int))


def region_center(region: Region) -> tuple[np.ndarray, np.ndarray]:
    """A representative point (3,) [mm] and outward normal (3,) of a region.

    The middle of the parameter box for patches and points; the cap's axis for caps.
    """
    if isinstance(region, SphereCap):
        return region.center + region.radius * region.axis, region.axis.copy()
    lo, hi = region.param_bounds()
    point, normal = region.evaluate(((lo + hi) / 2)[None, :])
    return point[0], normal[0]


def region_solid(region: Region) -> tuple[np.ndarray, float] | Mesh:
    """The solid a hand region is the surface of, for a physics scene (link frame, mm).

    A ball ``(centre (3,), radius)``: a sphere cap's sphere, or for a point region a 1 mm
    ball whose surface passes through the point; else a closed convex :class:`Mesh`: for a
    Bézier patch the hull of its 7 x 7 samples and of the same samples 2 mm inside along
    its normals.  A kind without a solid is refused by name (``TypeError``).
    """
    if isinstance(region, SphereCap):
        return region.ball()
    if isinstance(region, PointRegion):
        return region.point - region.normal, 1.0
    if isinstance(region, BezierRegion):
        p, n = region.evaluate(region.sample_params(7))
        return hull_mesh(np.concatenate([p, p - 2.0 * n]))
    raise TypeError(f"no physics shape for a {type(region).__name__} hand region")
