"""A file hand's fitted collision capsules and their fit, kept on disk between processes.

Fitting enclosing capsules to a link's meshes (:func:`~prehension.hands.shapes.mesh_capsule`
tries 306 axes) and measuring what they miss and how far they stick out
(:func:`~prehension.hands.enclosure.link_fit`) costs 2-3 s for a whole hand, in every
process that reads the hand file.  Both depend only on the link's collision shapes, so
they are stored per link under a SHA-256 of: each shape's kind, sizes, pose in the link
and (for a mesh) its vertices' bytes; the source of the modules that compute them; the
versions of numpy and scipy; and :data:`VERSION`.  Editing a mesh, a shape or that code
misses the cache.  The key holds the vertices as read (not the file's bytes), so a reader
that reads a file differently misses the cache too; :data:`VERSION` is bumped whenever what
"a mesh's vertices" means changes (version 2: the distinct vertices of the triangles, read
through trimesh by :func:`~prehension.hands.shapes.read_mesh_vertices`; version 1 read
every ``v`` line of an OBJ and every corner of an STL).  A link whose shapes could not all
be read is never stored.  Folder and rules:
:mod:`prehension.disk_cache`.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Callable

import numpy as np

from ..disk_cache import code_fingerprint, content_key, load_arrays, store_arrays
from .model import Capsule
from .provenance import ShapeFit

__all__ = ["VERSION", "link_key", "cached_link_fit"]

VERSION = 2  # of the key: bump when the vertices read for the same file could differ

_SOURCES = ("shapes.py", "enclosure.py", "link_cache.py", "assemble.py")  # assemble: which surface samples, the label
_LIBRARIES = ("numpy", "scipy")


@functools.lru_cache(maxsize=1)
def _fingerprint() -> bytes:
    here = Path(__file__).parent
    return f"link-cache/{VERSION};".encode() + code_fingerprint([here / name for name in _SOURCES], _LIBRARIES)


def link_key(shapes, vertices) -> str:
    """The entry name of a link's collision ``shapes`` (:class:`RawShape`), ``vertices``
    the mesh vertices of each (``None`` for a primitive)."""
    parts = []
    for s, v in zip(shapes, vertices):
        parts += [(s.kind, tuple(float(x) for x in s.size)), np.asarray(s.T_link_shape, dtype=float),
                  None if v is None else np.asarray(v, dtype=float)]  # fmt: skip
    return content_key(_fingerprint(), *parts)


def cached_link_fit(
    key: str | None, compute: Callable[[], tuple[list[Capsule], ShapeFit | None, bool]]
) -> tuple[list[Capsule], ShapeFit | None]:
    """The stored capsules and fit for ``key``, else ``compute()``'s ``(capsules, fit,
    storable)``, stored when ``storable`` (``key`` ``None``: never stored)."""
    stored = load_arrays(key, ("capsules", "fit", "geometry"))
    if stored is not None:
        caps, fit, geometry = stored
        return [Capsule(c[:3], c[3:6], c[6]) for c in caps], ShapeFit(str(geometry), float(fit[0]), float(fit[1]))
    caps, fit, storable = compute()
    if key is not None and storable and fit is not None:
        rows = np.array([[*c.a, *c.b, c.radius] for c in caps], dtype=float).reshape(-1, 7)
        store_arrays(key, dict(capsules=rows, fit=np.array([fit.miss_mm, fit.stick_out_mm]), geometry=np.array(fit.geometry)))
    return caps, fit
