"""The closed meshes of the built-in objects (teapot, scalpel, guitar), made from primitives.

Each object is a boolean union (manifold3d) of closed parts: primitives of
:mod:`prehension.objects.solid`, convex prisms, and a *pad* under each contact region
that does not lie on the parts already (:func:`region_pad`): the region's own surface,
swept inwards along its mean normal.  A pad makes the mesh contain the region exactly
(up to tessellation), so the region-on-surface check holds by construction where a
bilinear patch (a ruled surface) sits on a curved body; pads stand at most a few mm
proud of the parts around them.

The shipped files ``prehension/tasks/builtin/meshes/*.ply`` are written by
``scripts/make_builtin_meshes.py`` from these functions; a test regenerates them and
compares.  Frames and mm are those of the built-in task files.
"""

from __future__ import annotations

import numpy as np

from ..geometry.regions import BezierRegion
from .meshes import Box, Cylinder, Mesh, Sphere, Torus
from .mesh_io import checked_mesh
from .solid import primitive_solid_mesh

__all__ = ["region_pad", "prism", "teapot_mesh", "scalpel_mesh", "guitar_mesh", "BUILTIN_OBJECTS"]


def _trimesh(vertices, faces):
    import trimesh

    return trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces, np.int64), process=True)


def _grid_faces(idx: np.ndarray, flip: bool) -> np.ndarray:
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    f = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return f[:, ::-1] if flip else f


def region_pad(region: BezierRegion, thickness: float, n: int = 12):
    """A closed solid whose outer face is the patch (outward), ``thickness`` mm deep along
    minus the patch's mean normal (a trimesh)."""
    t = np.linspace(0.0, 1.0, n)
    uv = np.stack(np.meshgrid(t, t, indexing="ij"), -1).reshape(-1, 2)
    top, normals = region.evaluate(uv)
    depth = -thickness * normals.mean(axis=0) / np.linalg.norm(normals.mean(axis=0))
    verts = np.concatenate([top, top + depth])
    idx_top = np.arange(n * n).reshape(n, n)
    idx_bot = idx_top + n * n
    faces = [_grid_faces(idx_top, flip=False), _grid_faces(idx_bot, flip=True)]
    rims = (idx_top[:, 0], idx_top[-1, :], idx_top[::-1, -1], idx_top[0, ::-1])  # boundary, u-then-v order
    for rim in rims:
        ring = np.stack([rim, rim + n * n], axis=1)  # (k, 2): top, bottom
        faces.append(_grid_faces(ring, flip=True))
    return _trimesh(verts, np.concatenate(faces))


def prism(polygon_yz, x0: float, x1: float):
    """A convex polygon ``(K, 2)``, counter-clockwise in the (y, z) plane, swept from x0 to x1 (a closed trimesh)."""
    p = np.asarray(polygon_yz, float)
    k = len(p)
    near = np.column_stack([np.full(k, x0), p])
    far = np.column_stack([np.full(k, x1), p])
    verts = np.concatenate([near, far])
    i = np.arange(k)
    j = (i + 1) % k
    sides = np.concatenate([np.stack([i, j + k, i + k], 1), np.stack([i, j, j + k], 1)])  # outward for CCW
    fan = np.stack([np.zeros(k - 2, int), np.arange(1, k - 1), np.arange(2, k)], 1)
    faces = np.concatenate([sides, fan[:, ::-1], fan + k])
    return _trimesh(verts, faces)


def _revolve_y(profile_ry, sections: int = 128):
    """A closed solid of revolution about the y axis from a profile ``(r, y)`` from axis to axis."""
    import trimesh

    T = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]])  # z -> y
    return trimesh.creation.revolve(np.asarray(profile_ry, float), sections=sections, transform=T)


def _union(parts, name: str) -> Mesh:
    import trimesh

    merged = trimesh.boolean.union(parts, engine="manifold")
    return checked_mesh(merged.vertices, merged.faces, f"built-in {name}", closed=True)


def _pads(regions, thickness: dict[str, float]):
    return [region_pad(regions[name], depth) for name, depth in thickness.items() if name in regions]


# -- teapot -----------------------------------------------------------------------------
TEAPOT_BODY_PROFILE = (  # (r, y) [mm]: a flat bottom of radius 72 at y = 0, the lid's rim at y = 112
    (0, 0), (72, 0), (81, 6), (86.5, 17), (88.5, 30), (88.5, 40), (87, 50), (84, 60), (80.5, 68),
    (74, 80), (64, 94), (53, 106), (45, 112), (0, 112),
)  # fmt: skip
TEAPOT_PADS = {  # region -> pad depth [mm]
    "knob_front": 3.0, "knob_back": 3.0, "handle_outer_low": 5.0, "handle_outer_mid": 8.0, "handle_top": 8.0,
    "body_spout_side": 6.0, "body_front": 6.0, "body_handle_side": 6.0, "bottom": 4.0,
}  # fmt: skip


ROD_MM = 2.0  # radius of the rods that join the handle's pads


def _pad_core(region: BezierRegion, thickness: float) -> np.ndarray:
    """A point under the patch's centre, a rod's radius above the pad's inner face [mm]."""
    p, n = region.evaluate(np.array([[0.5, 0.5]]))
    return p[0] - (thickness - ROD_MM) * n[0]


def _handle(regions) -> list:
    """The handle: the pads of its three regions joined by rods, and to the body."""
    names = ("handle_outer_low", "handle_outer_mid", "handle_top")
    if not all(n in regions for n in names):
        return [primitive_solid_mesh(Torus((-96, 63, 0), (0, 0, 1), 24, 5))]
    low, mid, top = (_pad_core(regions[n], TEAPOT_PADS[n]) for n in names)
    cores = [np.array([-80.0, 36.0, 0.0]), low, mid, np.array([-130.0, 80.0, 0.0]), top, np.array([-60.0, 92.0, 0.0])]
    return [primitive_solid_mesh(Cylinder(tuple(a), tuple(b), ROD_MM)) for a, b in zip(cores[:-1], cores[1:])]


def teapot_mesh(regions) -> Mesh:
    """The teapot: body of revolution about y, lid, knob, handle (-x), spout (+x)."""
    parts = [
        _revolve_y(TEAPOT_BODY_PROFILE),
        primitive_solid_mesh(Cylinder((0, 111, 0), (0, 120, 0), 45, 30)),  # lid
        primitive_solid_mesh(Cylinder((0, 119, 0), (0, 126, 0), 6)),  # knob stem
        primitive_solid_mesh(Sphere((0, 131.8, 0), 15.5)),  # knob
        primitive_solid_mesh(Cylinder((60, 40, 0), (150, 112, 0), 16, 6)),  # spout
    ]
    return _union(parts + _handle(regions) + _pads(regions, TEAPOT_PADS), "teapot")


# -- scalpel ----------------------------------------------------------------------------
SCALPEL_PADS = {"grip_side": 1.0, "grip_bottom": 1.0, "grip_top": 1.0, "handle_back": 1.0}


def scalpel_mesh(regions) -> Mesh:
    """The scalpel: a round handle along y (radius 8.9 mm, under every grip region), a taper, the blade."""
    parts = [
        primitive_solid_mesh(Cylinder((0, -58, 0), (0, 200, 0), 8.9)),
        primitive_solid_mesh(Cylinder((0, -58, 0), (0, -72, 0), 8.9, 3)),
        primitive_solid_mesh(Box((0, -96, 0), (1, 50, 14))),
    ]
    return _union(parts + _pads(regions, SCALPEL_PADS), "scalpel")


# -- guitar -----------------------------------------------------------------------------
def _neck_section(half_width: float, ends_at: float, n: int = 48) -> np.ndarray:
    """Counter-clockwise (y, z) section: flat fretboard top at z = 0, flat sides to z = -10
    at |y| = 25, a parabolic back z = -20 + 10 (y / ends_at)^2 (the neck-back regions)."""
    y = np.linspace(-ends_at, ends_at, n)
    back = np.column_stack([y, -20 + 10 * (y / ends_at) ** 2])
    rim = [[half_width, -10.0], [half_width, 0.0], [-half_width, 0.0], [-half_width, -10.0]]
    if ends_at >= half_width:  # the back meets the sides at their corners
        rim = rim[1:3]
    return np.concatenate([back, rim])


def _key(center_x: float, side: float):
    """One tuning key: a shaft from the headstock and a 14 x 10 x 9 mm button (y = side * 62)."""
    y0, y1, yc = side * 40, side * 57, side * 62
    return [
        primitive_solid_mesh(Cylinder((center_x, y0 - side, -8), (center_x, y1 + side, -8), 3)),
        primitive_solid_mesh(Box((center_x, yc, -8), (14, 10, 9))),
    ]


GUITAR_PADS = {"b_string_fret1": 4.5, "d_string_fret2": 4.5, "key_upper_face": 1.0, "key_lower_face": 1.0}


def guitar_mesh(regions) -> Mesh:
    """The guitar: fretboard and neck along +x from the nut (x = 0), headstock, six keys,
    two bouts (the neck joins the body at x = 330).  Strings are display only; under each
    fretting region a pad stands for the pressed string (the region is 4 mm above the board)."""
    parts = [
        prism(_neck_section(25.0, 24.0), 0.0, 170.0),
        prism(_neck_section(25.0, 25.0), 165.0, 335.0),
        primitive_solid_mesh(Box((-95, 0, -8), (190, 80, 16))),  # headstock
        primitive_solid_mesh(Cylinder((470, 0, -100), (470, 0, -6), 140)),
        primitive_solid_mesh(Cylinder((660, 0, -100), (660, 0, -6), 185)),
    ]
    for x in (-40.0, -80.0, -120.0):
        for side in (1.0, -1.0):
            parts += _key(x, side)
    return _union(parts + _pads(regions, GUITAR_PADS), "guitar")


BUILTIN_OBJECTS = {"teapot": teapot_mesh, "scalpel": scalpel_mesh, "guitar": guitar_mesh}


# -- files ------------------------------------------------------------------------------
def write_ply(mesh: Mesh, path) -> None:
    """Write ``mesh`` as a binary PLY file, atomically."""
    from ..atomic import write_bytes_atomic

    write_bytes_atomic(path, _trimesh(mesh.vertices, mesh.faces).export(file_type="ply", encoding="binary"))


def mesh_difference_mm(mesh: Mesh, path) -> float:
    """Largest distance from a vertex of either mesh to the other's surface [mm] (a
    symmetric check that the file at ``path`` holds ``mesh``, up to re-triangulation)."""
    from .distance import MeshDistance
    from .mesh_io import load_mesh

    shipped = load_mesh(path, 1.0)
    a = np.abs(MeshDistance(shipped.vertices, shipped.faces).signed_distance(mesh.vertices)).max()
    b = np.abs(MeshDistance(mesh.vertices, mesh.faces).signed_distance(shipped.vertices)).max()
    return float(max(a, b))
