"""Convex pieces of an object for the physics engine (MuJoCo collides convex hulls only).

The object's solid (:func:`prehension.quality.object_solid`) already comes in convex
pieces for primitives and regions; a mesh that is not convex is decomposed by CoACD
(approximate convex decomposition, the ``coacd`` package of the ``sim`` extra).

* **Coarse, cached.**  The whole solid is decomposed once, with :data:`DECOMPOSITION`
  (concavities up to 8% of the mesh's size are filled; half CoACD's default effort, as
  the pieces next to the hand are refined anyway).  A mesh of more than
  :data:`SIMPLIFY_ABOVE` triangles is first simplified by manifold3d within
  :data:`SIMPLIFY_FRACTION` of its diagonal (a 100k-triangle mesh: 0.3 s, then CoACD on a
  few thousand triangles: seconds, not minutes).  The pieces are stored in the geometry
  cache (:mod:`prehension.objects.geometry_cache`), named by a hash of the mesh, the
  settings and CoACD's version: a later process reads them back instead of decomposing.
* **Fine near the hand** (:func:`refine`).  A coarse piece may fill a concavity the
  solver's mesh leaves open (the guitar's waist: 25 mm), which the hand would start
  inside.  Where the physics test finds a piece's surface more than a tolerance away
  from the solver's mesh next to the hand (:mod:`.start`), that piece is replaced by the
  hulls of the eight octants of the *exact* part of the solid inside it (a manifold3d
  intersection of the solver's mesh with the piece), and so on down to the tolerance.

An open mesh (edges not shared by exactly two faces) has no inside to decompose: it is
refused with the reason (:func:`check_closed`), never handed to CoACD (which can run for
many minutes on one).
"""

from __future__ import annotations

import weakref
from importlib import metadata

import numpy as np

from ..errors import InvalidObject, PrehensionError
from ..disk_cache import content_key, load_arrays, store_arrays
from ..objects.mesh_io import _boundary_edges
from ..objects.meshes import Mesh
from ..objects.model import GraspObject
from ..quality.solid import hull_mesh, object_solid

__all__ = ["convex_pieces", "solid_pieces", "decompose", "refine", "check_closed", "DECOMPOSITION", "SIMPLIFY_ABOVE",
           "SIMPLIFY_FRACTION"]  # fmt: skip

#: CoACD settings: concavity threshold (a fraction of the mesh size), most pieces, effort.
DECOMPOSITION = {"threshold": 0.08, "max_convex_hull": 16, "preprocess_mode": "off", "resolution": 500,
                 "mcts_iterations": 20, "mcts_max_depth": 2, "mcts_nodes": 10, "seed": 0}  # fmt: skip
SIMPLIFY_ABOVE = 5000  # triangles: larger meshes are simplified before CoACD
SIMPLIFY_FRACTION = 0.002  # of the mesh's bounding-box diagonal: the simplification's tolerance
_VERSION = 3  # of how the pieces are made (part of every cache entry's name)

_PIECES: "weakref.WeakKeyDictionary[GraspObject, tuple]" = weakref.WeakKeyDictionary()
_MANIFOLDS: "weakref.WeakKeyDictionary[Mesh, object]" = weakref.WeakKeyDictionary()


def convex_pieces(obj: GraspObject) -> tuple[Mesh, ...]:
    """The coarse convex pieces of ``obj`` (object frame, mm), each a closed hull mesh."""
    return tuple(piece for piece, _ in solid_pieces(obj))


def solid_pieces(obj: GraspObject) -> tuple[tuple[Mesh, Mesh | None], ...]:
    """``(piece, source)`` per coarse convex piece of ``obj``: ``source`` is the non-convex
    solid piece it approximates (what :func:`refine` cuts), ``None`` for an exact piece."""
    cached = _PIECES.get(obj)
    if cached is None:
        solid = object_solid(obj)
        pieces: list = []
        for piece, convex in zip(solid.pieces, solid.convex):
            if convex:
                pieces.append((hull_mesh(piece.vertices), None))
            else:
                check_closed(piece, f"object {obj.name!r}")
                pieces += [(part, piece) for part in decompose(piece)]
        cached = _PIECES[obj] = tuple(pieces)
    return cached


def check_closed(mesh: Mesh, what: str) -> None:
    """Refuse an open mesh: it has no inside to fill with convex pieces."""
    open_edges = _boundary_edges(mesh.faces)
    if open_edges:
        raise PrehensionError(
            f"{what}: the physics test needs a closed solid, and its mesh is open ({open_edges} edges not shared by "
            "exactly two faces); repair the mesh (fill its holes) or give the object a closed solid"
        )


_PIECE_ARRAYS = ("vertices", "faces", "vertex_end", "face_end")  # a cached decomposition


def decompose(mesh: Mesh, settings: dict = DECOMPOSITION) -> list[Mesh]:
    """Convex hulls of CoACD's decomposition of the closed ``mesh`` (mm), read from the
    geometry cache when this mesh was decomposed before with these settings."""
    coacd = _coacd()
    key = content_key("coacd pieces", _VERSION, metadata.version("coacd"), settings, SIMPLIFY_ABOVE, SIMPLIFY_FRACTION,
                      mesh.vertices, mesh.faces)  # fmt: skip
    stored = load_arrays(key, _PIECE_ARRAYS)
    if stored is not None:
        return _split(dict(zip(_PIECE_ARRAYS, stored)))
    simple = _simplified(mesh)
    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(np.asarray(simple.vertices, float), np.asarray(simple.faces, np.int64)), **settings)
    pieces = [hull_mesh(np.asarray(vertices, float)) for vertices, _ in parts]
    store_arrays(key, dict(vertices=np.concatenate([p.vertices for p in pieces]), faces=np.concatenate([p.faces for p in pieces]),
                           vertex_end=np.cumsum([len(p.vertices) for p in pieces]),
                           face_end=np.cumsum([len(p.faces) for p in pieces])))  # fmt: skip
    return pieces


def refine(source: Mesh, piece: Mesh) -> list[Mesh] | None:
    """Finer pieces in place of the convex ``piece``: the exact part of ``source`` (a
    closed solid, mm) inside it, cut into the eight octants of its bounding box, each
    connected part of each octant its own convex hull (an empty list: the piece holds none
    of the solid; ``None`` when manifold3d cannot take this mesh: the piece stays).

    A hull of a part of size ``s`` stands off the surface by at most about ``s^2 / 8 R``
    on a smooth stretch (``R`` the radius of curvature) and ``s`` times the angle of a
    crease, so halving the pieces next to the hand in every direction brings them onto
    the solver's mesh there in a few rounds, whatever way a crease runs; far from the
    hand nothing changes.
    """
    solid = _manifold(source)
    if solid is None:
        return None
    parts = [solid ^ _to_manifold(piece)]
    if parts[0].is_empty():
        return []
    centre = np.reshape(parts[0].bounding_box(), (2, 3)).mean(axis=0)
    for axis in range(3):
        parts = [half for part in parts for half in part.split_by_plane(np.eye(3)[axis], float(centre[axis]))]
    out = []
    for component in (c for part in parts for c in part.decompose()):
        try:
            out.append(hull_mesh(np.asarray(component.to_mesh().vert_properties[:, :3], float)))
        except InvalidObject:  # a sliver with no volume
            continue
    return out


def _coacd():
    try:
        import coacd
    except ImportError:
        raise PrehensionError(
            'the object is not convex, and decomposing it for the physics test needs CoACD; install it with: '
            'pip install "prehension[sim]"'
        ) from None
    return coacd


def _split(stored: dict) -> list[Mesh]:
    v_end, f_end = stored["vertex_end"], stored["face_end"]
    v_start, f_start = np.r_[0, v_end[:-1]], np.r_[0, f_end[:-1]]
    return [Mesh(stored["vertices"][a:b], stored["faces"][c:d]) for a, b, c, d in zip(v_start, v_end, f_start, f_end)]


def _to_manifold(mesh: Mesh):
    import manifold3d

    return manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.asarray(mesh.vertices, np.float32),
                                               tri_verts=np.asarray(mesh.faces, np.uint32)))  # fmt: skip


def _manifold(mesh: Mesh):
    """``mesh`` as a manifold3d solid (kept per mesh), ``None`` if it is not a valid one."""
    import manifold3d

    if mesh not in _MANIFOLDS:
        solid = _to_manifold(mesh)
        _MANIFOLDS[mesh] = solid if solid.status() == manifold3d.Error.NoError else None
    return _MANIFOLDS[mesh]


def _simplified(mesh: Mesh) -> Mesh:
    """``mesh`` with fewer triangles (within :data:`SIMPLIFY_FRACTION` of its diagonal)
    when it has more than :data:`SIMPLIFY_ABOVE`; the mesh itself otherwise."""
    if len(mesh.faces) <= SIMPLIFY_ABOVE:
        return mesh
    solid = _manifold(mesh)
    if solid is None:
        return mesh
    diagonal = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    out = solid.simplify(SIMPLIFY_FRACTION * diagonal).to_mesh()
    if len(out.tri_verts) < 4:
        return mesh
    return Mesh(np.asarray(out.vert_properties[:, :3], float), np.asarray(out.tri_verts, np.int64))
