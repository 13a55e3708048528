"""Mesh files read through trimesh: object surfaces, and the link meshes of hand files.

The one reader of mesh files in the package (:func:`read_triangles`): OBJ, STL, PLY, OFF,
GLB and GLTF with the trimesh prehension installs, and DAE (COLLADA) when the optional
``pycollada`` is installed (without it, a DAE file is refused with a message saying so).
Hand files read their link meshes here too (:func:`prehension.hands.shapes.read_mesh_vertices`).

Mesh files carry no units: :func:`load_mesh` takes ``scale`` (mm per file unit, e.g.
1000 for a file in metres; :data:`UNITS` names the common ones).  What is checked, each
with an :class:`~prehension.errors.InvalidObject` that names the file and the problem:

* the file exists, is a format trimesh reads, and holds triangles (not a point cloud or
  an empty scene);
* every vertex is finite and within 1e9 mm of the origin; faces of zero area (repeated corners, collinear corners) are
  dropped, and a mesh left with none, or flat (zero extent along an axis), is refused;
* ``closed=True`` (what collisions need): the surface is watertight (every edge shared by
  exactly two faces) and its faces are consistently wound (else refused, counting the
  edges that disagree; nothing is re-wound silently, and no optional module is needed).  A closed mesh whose faces all
  face inwards is turned outwards (its inside is unambiguous); a mesh that does not enclose
  a positive volume is refused.

A GLB/GLTF (or DAE) scene is flattened into one mesh (every node at its scene pose: the
node transforms applied).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from ..errors import InvalidObject, not_a_file
from .meshes import Mesh

__all__ = [
    "UNITS", "MESH_SUFFIXES", "load_mesh", "load_display_mesh", "checked_mesh", "scale_of", "read_triangles",
    "check_mesh_suffix",
]  # fmt: skip

# mm per unit
UNITS = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}
MAX_COORDINATE_MM = 1e9  # as the numbers of a task file (tasks.format.schema.MAX_MAGNITUDE)
MESH_SUFFIXES = (".obj", ".stl", ".ply", ".off", ".glb", ".gltf", ".dae")
_OPTIONAL = {".dae": ("collada", "pycollada")}  # suffix -> (module trimesh needs, what to pip install)


def scale_of(scale: float | None, units: str | None) -> float:
    """mm per file unit from exactly one of ``scale`` and ``units``."""
    if (scale is None) == (units is None):
        raise InvalidObject(
            "a mesh file carries no units: give exactly one of scale (mm per file unit, e.g. 1000 for metres) "
            f"or units ({', '.join(UNITS)})"
        )
    if units is not None:
        if units not in UNITS:
            raise InvalidObject(f"unknown units {units!r}; units are: {', '.join(UNITS)} (or give scale in mm per unit)")
        return UNITS[units]
    scale = float(scale)
    if not (np.isfinite(scale) and scale > 0):
        raise InvalidObject(f"mesh scale must be a positive number of mm per file unit, got {scale}")
    return scale


def _trimesh():
    try:
        import trimesh
    except ImportError:  # pragma: no cover - trimesh is a dependency
        raise InvalidObject("reading mesh files needs trimesh: pip install trimesh") from None
    return trimesh


def check_mesh_suffix(path) -> None:
    """Refuse (:class:`InvalidObject`, naming the file and the formats read) a file whose
    suffix names no mesh format read here, or one that needs an optional module not installed."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise InvalidObject(f"{path}: unsupported mesh format {path.suffix or '(no suffix)'}; {_formats_read()}")
    if suffix in _OPTIONAL:
        module, package = _OPTIONAL[suffix]
        if importlib.util.find_spec(module) is None:
            raise InvalidObject(
                f"{path}: reading {suffix[1:].upper()} files needs the optional module {module} (pip install {package}); "
                f"{_formats_read()}"
            )


def _formats_read() -> str:
    plain = [s for s in MESH_SUFFIXES if s not in _OPTIONAL]
    optional = [f"{s} (with {package})" for s, (_, package) in _OPTIONAL.items()]
    return f"mesh files are read from {', '.join(plain + optional)}"


def read_triangles(path) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of the mesh file ``path`` as stored, in the file's units: vertices
    ``(V, 3)`` (finite) and faces ``(F, 3)`` (F > 0, indexing the vertices), a scene
    flattened with its node transforms applied.  Nothing is merged, dropped or re-wound.

    Raises:
        InvalidObject: the file is missing, empty, of a format not read (see
            :func:`check_mesh_suffix`), unreadable, holds no triangles, or non-finite
            vertices, or faces index vertices it does not have; the message names the file.
    """
    path = Path(path)
    vertices, faces = _read(path)
    if not np.all(np.isfinite(vertices)):
        raise InvalidObject(f"{path}: mesh has non-finite vertex coordinates (NaN or infinity)")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise InvalidObject(f"{path}: faces index vertices 0..{len(vertices) - 1}, got {faces.min()}..{faces.max()}")
    return vertices, faces


def _read(path: Path):
    trimesh = _trimesh()
    if not path.is_file():
        raise InvalidObject(not_a_file("mesh file", path))
    check_mesh_suffix(path)
    if path.stat().st_size == 0:
        raise InvalidObject(f"{path}: the file is empty (0 bytes); a mesh file is needed")
    try:
        loaded = trimesh.load(str(path), force="mesh", process=False)
    except ImportError as exc:
        raise InvalidObject(_missing_module(path, exc)) from None
    except IndexError as exc:
        raise InvalidObject(f"{path}: not a readable mesh: a face refers to a vertex the file does not have ({exc})") from None
    except Exception as exc:  # trimesh raises many kinds on a bad file
        raise InvalidObject(f"{path}: not a readable mesh ({type(exc).__name__}: {exc}); {_formats_read()}") from None
    faces = getattr(loaded, "faces", None)
    if faces is None or len(faces) == 0:
        raise InvalidObject(f"{path}: holds no triangles (a point cloud, lines or an empty scene); a mesh file is needed")
    return np.asarray(loaded.vertices, dtype=float), np.asarray(faces, dtype=np.int64)


def _missing_module(path: Path, exc: ImportError) -> str:
    """Why trimesh wanted a module it does not have: mostly to guess the encoding of text it
    cannot decode, i.e. the file is not a mesh of its kind at all."""
    kind = path.suffix.lower().lstrip(".").upper()
    try:
        path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        binary = f" and not a binary {kind} (its header does not match its size)" if kind == "STL" else ""
        return f"{path}: not a readable {kind} file: it is not text (not UTF-8 or ASCII){binary}"
    name = getattr(exc, "name", None) or str(exc)
    return f"{path}: reading this {kind} file needs the optional module {name} (pip install {name})"


def load_mesh(path, scale: float, *, closed: bool = True) -> Mesh:
    """The triangle mesh of ``path`` in mm (``scale`` mm per file unit), checked (see the module docstring)."""
    path = Path(path)
    vertices, faces = _read(path)
    return checked_mesh(vertices * float(scale), faces, str(path), closed=closed)


def load_display_mesh(path) -> Mesh:
    """A mesh file that is only drawn (``display.mesh_file``, mm): any triangles of any
    readable format, finite and indexing their vertices; open or flat is fine."""
    path = Path(path)
    vertices, faces = read_triangles(path)
    _check_vertices(vertices, str(path))
    return Mesh(vertices, faces)


def _check_vertices(v: np.ndarray, source: str) -> None:
    if not np.all(np.isfinite(v)):
        raise InvalidObject(f"{source}: mesh has non-finite vertex coordinates (NaN or infinity)")
    if len(v) and np.abs(v).max() > MAX_COORDINATE_MM:
        raise InvalidObject(
            f"{source}: mesh coordinates reach {np.abs(v).max():.3g} mm, more than {MAX_COORDINATE_MM:g} mm (1000 km; "
            "beyond it the 1e-6 mm tolerances are below double precision); check the file's units or scale"
        )


def checked_mesh(vertices, faces, source: str, *, closed: bool = True) -> Mesh:
    """``vertices (V, 3)`` [mm] and ``faces (F, 3)`` checked and cleaned into a :class:`Mesh`.

    Args:
        source: what the mesh is called in error messages (file name, "primitives").
        closed: require a watertight, consistently wound surface (turned outwards).
    """
    trimesh = _trimesh()
    v = np.asarray(vertices, dtype=float).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    _check_vertices(v, source)
    if len(f) and (f.min() < 0 or f.max() >= len(v)):
        raise InvalidObject(f"{source}: faces index vertices 0..{len(v) - 1}, got {f.min()}..{f.max()}")
    # What trimesh's process(validate=True) does, without its fix_normals: that needs the optional
    # networkx and would re-wind a mesh silently, which the winding check below refuses instead.
    mesh = trimesh.Trimesh(v, f, process=False)
    mesh.update_faces(mesh.unique_faces() & mesh.nondegenerate_faces())  # drops duplicate and zero-area faces
    mesh.merge_vertices()
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) == 0:
        raise InvalidObject(f"{source}: degenerate mesh: every face has zero area")
    if np.min(mesh.extents) <= 1e-9 * max(1.0, float(np.max(mesh.extents))):
        raise InvalidObject(f"{source}: degenerate mesh: flat (extents {np.round(mesh.extents, 6).tolist()} mm)")
    if closed:
        _check_closed(mesh, source, trimesh)
    return Mesh(np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces, dtype=np.int64))


def _check_closed(mesh, source: str, trimesh) -> None:
    open_edges = _boundary_edges(mesh.faces)
    if open_edges:
        raise InvalidObject(
            f"{source}: mesh is not watertight ({open_edges} edges not shared by exactly two faces); "
            "collisions need a closed surface: repair the mesh (fill its holes), or set collisions: false "
            "to use it for display and contact regions only"
        )
    disagree = _disagreeing_edges(mesh.faces)
    if disagree:
        raise InvalidObject(
            f"{source}: the faces of the mesh are not wound consistently ({disagree} of {len(mesh.edges_unique)} edges "
            "are listed in the same direction by both faces that share them; a consistently wound surface lists "
            "each edge once in each direction); re-orient the faces (e.g. MeshLab: Filters > Normals > Re-Orient "
            "all faces coherently) and save the mesh again, or set collisions: false to use it for display and "
            "contact regions only"
        )
    if mesh.volume < 0:
        mesh.invert()
    if not mesh.volume > 0:
        raise InvalidObject(f"{source}: degenerate mesh: it encloses no volume")


def _boundary_edges(faces: np.ndarray) -> int:
    """Number of distinct edges not shared by exactly two faces."""
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return int(np.sum(counts != 2))


def _disagreeing_edges(faces: np.ndarray) -> int:
    """Number of edges of a watertight mesh that both their faces list in the same direction.

    Each face lists its edges ``(a, b), (b, c), (c, a)``; on a consistently wound closed
    surface the two faces sharing an edge list it in opposite directions, so no directed
    edge occurs twice.  (Plain numpy: trimesh's winding repair needs the optional networkx.)
    """
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    _, counts = np.unique(directed, axis=0, return_counts=True)
    return int(np.sum(counts > 1))
