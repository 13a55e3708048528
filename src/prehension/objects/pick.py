"""Contact regions picked on a mesh: a Bézier patch fitted to a piece of surface, or a point.

:func:`region_from_mesh` takes a piece of the surface, either the faces within ``radius``
of a point (the faces connected to the closest one, facing the same side) or a given set
of faces, and fits a Bézier patch of a chosen degree to it by least squares over a local
parametrisation:

* the frame: the surface point ``p0`` closest to ``at`` (or the faces' area-weighted
  centroid) and the area-weighted outward normal ``n`` of the piece; ``e1``, ``e2``
  complete a right-handed frame (``e1 x e2 = n``);
* the domain: the square ``[-h, h]^2`` of the tangent plane around ``p0`` (``h`` = the
  radius divided by sqrt(2), so that the square fits inside the picked disc; for a face set,
  the half-width of the faces' footprint);
* the patch: control points ``p0 + s_i e1 + t_j e2 + z_ij n`` over an even grid
  ``(s_i, t_j)`` of the square (so ``(u, v)`` maps linearly onto the square), with the
  heights ``z_ij`` the least-squares fit to points sampled on the faces over the square.
  The normal ``p_u x p_v`` is then ``n`` to first order: outward.

The piece must be a height field over the tangent plane (faces more than 84 degrees from
``n`` are dropped); how far from the point the surface starts to turn that far is reported
(``turns_away_mm``), so that a radius too large for one patch gets the advice of a smaller
one.  A point farther from the surface than the radius is refused with the nearest surface
point and the mesh's bounding box.  The fit's quality is
the largest distance from the patch to the surface, over a 25 x 25 grid of the patch [mm].

Only the *outer* surface is picked from: a mesh made of closed parts that overlap has
internal walls (faces with the solid on both sides), and a thin wall has its other side
within the radius.  A face is outer when a point :data:`OUTSIDE_STEP_MM` off it along its
normal (from its centre, or halfway from there to a corner) is outside the solid; the piece keeps the outer faces facing the same
side as the one closest to ``at`` (within 84 degrees of it) and connected to it.  The
fitted patch is then checked: on a 9 x 9 grid, a step of :data:`OUTSIDE_STEP_MM` along
its normal from the closest surface point must leave the solid (the normal points out,
not into the object), else the request is refused with the reason; the largest angle
between the patch's normal and the closest face's is reported (``max_angle_deg``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..errors import InvalidGeometry, InvalidObject
from ..geometry.bezier import BezierPatch
from ..geometry.regions import BezierRegion, PointRegion, Region
from .meshes import Mesh

if TYPE_CHECKING:  # numba is imported only when a distance is needed
    from .distance import MeshDistance

__all__ = ["PickedRegion", "OuterSurface", "outer_surface", "region_from_mesh", "MAX_DEGREE"]

MAX_DEGREE = 6
_SAMPLES_PER_EDGE = 5  # barycentric samples per triangle edge
_CHECK_GRID = 25
_MIN_COS = 0.1  # faces further than ~84 deg from the mean normal: not a height field
OUTSIDE_STEP_MM = 0.05  # a face (a patch point) is on the outer surface if this step along its normal leaves the solid
_NORMAL_GRID = 9


@dataclass(frozen=True, eq=False)
class PickedRegion:
    """A region fitted to a mesh.

    Attributes:
        region: the Bézier patch (or point with normal), object frame [mm].
        max_deviation_mm: largest distance from the region to the surface [mm].
        point: (3,) the surface point the region is centred on [mm].
        normal: (3,) the outward normal there.
        n_faces: how many faces were fitted.
        max_angle_deg: largest angle between the region's normal and the normal of the
            closest face, over a 9 x 9 grid of the region [deg] (next to an edge, the
            closest face may be the one across it: what is checked is the step outwards).
        turns_away_mm: how far from the point (over the outer surface connected to it) a
            face turns more than 84 degrees from the closest face's normal [mm]; a radius
            beyond it asks one patch to follow a surface that bends away (inf: never, or a
            set of faces was given).
    """

    region: Region
    max_deviation_mm: float
    point: np.ndarray
    normal: np.ndarray
    n_faces: int
    max_angle_deg: float = 0.0
    turns_away_mm: float = float("inf")


def _face_data(mesh: Mesh):
    tri = mesh.vertices[mesh.faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(cross, axis=1)
    return tri, cross / np.maximum(area2, 1e-300)[:, None], 0.5 * area2


def _connected(mesh: Mesh, candidates: np.ndarray, seed: int) -> np.ndarray:
    """The candidate faces connected to ``seed`` through shared edges (bool mask)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    f = mesh.faces
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    owner = np.tile(np.arange(len(f)), 3)
    keep = candidates[owner]
    edges, owner = edges[keep], owner[keep]
    _, inv = np.unique(edges, axis=0, return_inverse=True)
    order = np.argsort(inv, kind="stable")
    a, b = owner[order][:-1], owner[order][1:]
    same = inv.ravel()[order][:-1] == inv.ravel()[order][1:]
    graph = sp.coo_matrix((np.ones(same.sum()), (a[same], b[same])), shape=(len(f), len(f)))
    _, label = connected_components(graph, directed=False)
    return candidates & (label == label[seed])


def _samples(tri: np.ndarray) -> np.ndarray:
    """Points on each triangle (F, 3, 3) on a barycentric grid -> (F * k, 3)."""
    n = _SAMPLES_PER_EDGE
    w = np.array([(i, j, n - i - j) for i in range(n + 1) for j in range(n + 1 - i)], float) / n
    return np.einsum("kc,fcd->fkd", w, tri).reshape(-1, 3)


def _lifted_grid(distance: MeshDistance, p0, e1, e2, half: float, k: int = 15) -> np.ndarray:
    """The closest surface points of a k x k grid over the square (samples however large the faces)."""
    g = np.linspace(-half, half, k)
    S, T = np.meshgrid(g, g, indexing="ij")
    grid = p0 + S.reshape(-1, 1) * e1 + T.reshape(-1, 1) * e2
    return distance.signed_distance(grid, closest=True)[1]


def _bernstein(n: int, t: np.ndarray) -> np.ndarray:
    from math import comb

    t = np.asarray(t, float)[:, None]
    k = np.arange(n + 1)[None]
    return np.array([comb(n, i) for i in range(n + 1)])[None] * t**k * (1 - t) ** (n - k)


def _frame(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.eye(3)[np.argmin(np.abs(normal))]
    e1 = np.cross(helper, normal)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(normal, e1)


def _fit(points, p0, e1, e2, n, half: float, degree: int) -> BezierRegion:
    rel = points - p0
    s, t, z = rel @ e1, rel @ e2, rel @ n
    inside = (np.abs(s) <= half) & (np.abs(t) <= half)
    u, v = (s[inside] + half) / (2 * half), (t[inside] + half) / (2 * half)
    if inside.sum() < (degree + 1) ** 2:
        raise InvalidObject(
            f"too few surface samples ({inside.sum()}) over the patch's square (half-width {half:.4g} mm) for a "
            f"degree-{degree} patch: the surface there turns away from the tangent plane; pick a smaller radius or degree"
        )
    A = np.einsum("ki,kj->kij", _bernstein(degree, u), _bernstein(degree, v)).reshape(len(u), -1)
    heights, *_ = np.linalg.lstsq(A, z[inside], rcond=None)
    grid = np.linspace(-half, half, degree + 1)
    S, T = np.meshgrid(grid, grid, indexing="ij")
    ctrl = p0 + S[..., None] * e1 + T[..., None] * e2 + heights.reshape(degree + 1, degree + 1)[..., None] * n
    return BezierRegion(BezierPatch(ctrl))


def _grid(region: Region, k: int):
    """Points and normals of ``region`` on a k x k grid of its parameters (its point, for a point region)."""
    t = np.linspace(0, 1, k)
    uv = np.stack(np.meshgrid(t, t, indexing="ij"), -1).reshape(-1, 2) if region.n_params else np.zeros((1, 0))
    return region.evaluate(uv)


def _deviation(region: Region, distance: MeshDistance) -> float:
    points, _ = _grid(region, _CHECK_GRID)
    return float(np.abs(distance.signed_distance(points)).max())


def _outer_faces(distance, tri, normals) -> np.ndarray:
    """(F,) bool: the faces a step along their normal leaves the solid through, from their
    centre or from one of the three points halfway from it to a corner (a face that another
    part of the solid covers in part is outer where it is not covered)."""
    centre = tri.mean(axis=1, keepdims=True)
    points = np.concatenate([centre, 0.5 * (centre + tri)], axis=1) + OUTSIDE_STEP_MM * normals[:, None]  # (F, 4, 3)
    return (distance.signed_distance(points.reshape(-1, 3)).reshape(-1, 4) > 0).any(axis=1)


class OuterSurface(NamedTuple):
    """The outer faces of a mesh (``mask (F,)``) and the distance to them alone
    (``distance``): what every pick by radius on the mesh starts from (:func:`outer_surface`)."""

    mask: np.ndarray
    distance: MeshDistance


def outer_surface(mesh: Mesh, distance: MeshDistance) -> OuterSurface:
    """The :class:`OuterSurface` of ``mesh`` (built once for many picks: ``region_from_mesh(outer=...)``)."""
    tri, normals, _ = _face_data(mesh)
    outer = _outer_faces(distance, tri, normals)
    if not outer.any():
        raise InvalidObject("the mesh has no outer surface to pick from (every face has the solid on both sides)")
    from .distance import MeshDistance

    return OuterSurface(outer, MeshDistance(mesh.vertices, mesh.faces[outer]))  # closest points on the outer surface only


def _piece_by_radius(mesh, distance, at, radius, prepared: OuterSurface | None = None):
    at = np.asarray(at, dtype=float).reshape(3)
    tri, normals, areas = _face_data(mesh)
    outer, outside = prepared if prepared is not None else outer_surface(mesh, distance)
    _, closest = outside.signed_distance(at[None], closest=True)
    p0 = closest[0]
    gap = float(np.linalg.norm(at - p0))
    if gap > radius:
        lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
        box = " x ".join(f"[{a:.4g}, {b:.4g}]" for a, b in zip(lo, hi))
        raise InvalidObject(
            f"the point {_listed(at)} is {gap:.4g} mm from the object's outer surface, farther than the radius "
            f"({radius:g} mm); the nearest outer surface point is {_listed(p0)} mm, and the mesh spans {box} mm "
            "(x, y, z); give a point on (or near) the outer surface, in mm of the object frame"
        )
    seed = int(np.flatnonzero(outer)[outside.closest_faces(p0[None])[0]])
    if distance.signed_distance((p0 + OUTSIDE_STEP_MM * normals[seed])[None])[0] <= 0:
        raise InvalidObject(
            f"the outer surface point closest to {np.round(at, 3).tolist()} lies where another part of the solid covers "
            "the face (an internal wall of overlapping parts); pick a point elsewhere on the outside"
        )
    reach = np.linalg.norm(tri - p0, axis=2).min(axis=1)
    near = (reach <= radius) & outer & (normals @ normals[seed] > _MIN_COS)
    near[seed] = True
    piece = _connected(mesh, near, seed)
    away = _connected(mesh, outer, seed) & (normals @ normals[seed] <= _MIN_COS)
    turns_mm = float(reach[away].min()) if away.any() else float("inf")
    return p0, piece, tri, normals, areas, turns_mm


def _listed(point) -> str:
    return "[" + ", ".join(f"{x:.4g}" for x in np.asarray(point, float)) + "]"


class _Piece(NamedTuple):
    """The faces a region is fitted to: ``tri (F, 3, 3)``, ``normals (F, 3)``, ``areas (F,)``
    of every face, ``chosen (F,)`` the piece's; its surface point ``p0`` and mean normal
    ``n``, the patch's half-size ``half`` [mm] and how far away the surface turns
    (``turns_mm``, inf for given faces)."""

    tri: np.ndarray
    normals: np.ndarray
    areas: np.ndarray
    chosen: np.ndarray
    p0: np.ndarray
    n: np.ndarray
    half: float
    turns_mm: float


def _mean_normal(normals, areas, chosen) -> np.ndarray:
    n = (normals[chosen] * areas[chosen, None]).sum(axis=0)
    n /= np.linalg.norm(n)
    return n


def _piece_at(mesh: Mesh, distance: MeshDistance, at, radius, outer: OuterSurface | None = None) -> _Piece:
    """The piece within ``radius`` of the surface point nearest ``at``."""
    if at is None or radius is None or not (np.isfinite(radius) and radius > 0):
        raise InvalidObject("give a surface point 'at' and a positive 'radius' [mm], or a set of faces")
    p0, chosen, tri, normals, areas, turns_mm = _piece_by_radius(mesh, distance, at, float(radius), outer)
    n = _mean_normal(normals, areas, chosen)
    chosen &= normals @ n > _MIN_COS  # other side of a thin part: dropped
    return _Piece(tri, normals, areas, chosen, p0, n, float(radius) / np.sqrt(2.0), turns_mm)


def _piece_of(mesh: Mesh, distance: MeshDistance, faces) -> _Piece:
    """The piece of the given faces (a height field over their mean tangent plane)."""
    tri, normals, areas = _face_data(mesh)
    chosen = np.zeros(len(mesh.faces), bool)
    idx = np.asarray(faces, dtype=int).ravel()
    if idx.size == 0 or idx.min() < 0 or idx.max() >= len(mesh.faces):
        raise InvalidObject(f"faces must be indices 0..{len(mesh.faces) - 1}, got {idx.size} indices")
    chosen[idx] = True
    n = _mean_normal(normals, areas, chosen)
    if (normals[chosen] @ n).min() <= _MIN_COS:
        raise InvalidObject("the faces do not form a height field over their mean tangent plane; give fewer faces")
    p0 = (tri[chosen].mean(axis=1) * areas[chosen, None]).sum(axis=0) / areas[chosen].sum()
    p0 = distance.signed_distance(p0[None], closest=True)[1][0]
    e1, e2 = _frame(n)
    rel = tri[chosen].reshape(-1, 3) - p0
    half = float(np.max(np.abs(np.stack([rel @ e1, rel @ e2]))))
    return _Piece(tri, normals, areas, chosen, p0, n, half, float("inf"))


def _patch(piece: _Piece, distance: MeshDistance, degree: int, radius: float | None) -> BezierRegion:
    """The Bézier patch fitted to the piece's samples and the surface lifted over its plane."""
    e1, e2 = _frame(piece.n)
    lifted = _lifted_grid(distance, piece.p0, e1, e2, piece.half)
    lifted = lifted[distance.signed_distance(lifted + OUTSIDE_STEP_MM * piece.n) > 0]  # not on a thin wall's other side
    points = np.concatenate([_samples(piece.tri[piece.chosen]), lifted])
    try:
        return _fit(points, piece.p0, e1, e2, piece.n, piece.half, degree)
    except (InvalidGeometry, InvalidObject) as exc:
        if radius is not None and float(radius) > piece.turns_mm:
            raise InvalidObject(
                f"a radius of {float(radius):g} mm is too large for one patch here: the surface turns more than 84 degrees "
                f"from the point's normal {piece.turns_mm:.4g} mm away; pick a radius under that ({exc})"
            ) from None
        raise


def region_from_mesh(
    mesh: Mesh, *, at=None, radius: float | None = None, faces=None, degree: int = 2, point: bool = False,
    distance: MeshDistance | None = None, outer: OuterSurface | None = None,
) -> PickedRegion:  # fmt: skip
    """Fit a contact region to a piece of ``mesh`` (see the module docstring).

    Args:
        mesh: a closed, outward-oriented surface, object frame [mm].
        at: (3,) a point on or near the surface [mm]; with ``radius`` [mm].
        faces: instead of ``at``/``radius``: indices of the faces to fit.
        degree: the patch's degree in u and v (1..6).
        point: a point-with-normal region at the surface point instead of a patch.
        distance: the mesh's :class:`MeshDistance` when already built.
        outer: the mesh's :func:`outer_surface` when already built (many picks on one mesh).

    Raises:
        InvalidObject: a bad request (no faces, a point far from the surface, a piece
            that is not a height field), naming what would be valid.
    """
    if not (isinstance(degree, (int, np.integer)) and 1 <= degree <= MAX_DEGREE):
        raise InvalidObject(f"degree must be an integer from 1 to {MAX_DEGREE}, got {degree!r}")
    if distance is None:
        from .distance import MeshDistance

        distance = MeshDistance(mesh.vertices, mesh.faces)
    piece = _piece_at(mesh, distance, at, radius, outer) if faces is None else _piece_of(mesh, distance, faces)
    size = int(piece.chosen.sum())
    if point:
        region = PointRegion(piece.p0, piece.n)
        return PickedRegion(region, 0.0, piece.p0, piece.n, size, _outward_angle(region, distance, piece.normals), piece.turns_mm)
    region = _patch(piece, distance, degree, radius if faces is None else None)
    angle = _outward_angle(region, distance, piece.normals)
    return PickedRegion(region, _deviation(region, distance), piece.p0, piece.n, size, angle, piece.turns_mm)


def _outward_angle(region: Region, distance: MeshDistance, normals: np.ndarray) -> float:
    """The largest angle between ``region``'s normal and the closest face's [deg], over a
    grid of the region; refuses a region whose normal points into the object."""
    points, n = _grid(region, _NORMAL_GRID)
    _, closest = distance.signed_distance(points, closest=True)
    inward = distance.signed_distance(closest + OUTSIDE_STEP_MM * n) <= 0
    face_n = normals[distance.closest_faces(closest)]
    angle = float(np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, face_n), -1.0, 1.0))).max())
    if inward.any():
        k = int(np.argmax(inward))
        raise InvalidObject(
            f"the fitted region's normal points into the object at {int(inward.sum())} of {len(points)} points (e.g. at "
            f"{np.round(points[k], 2).tolist()}: a step along it stays inside the solid; up to {angle:.0f} deg from the "
            "closest face's normal): the piece of surface is not one outer side of the object there (a thin wall, an "
            "edge, or a face another part of the solid covers); pick a point farther from the edge or a smaller radius"
        )
    return angle
