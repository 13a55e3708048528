"""Convex pieces of an object for the physics engine (MuJoCo collides convex hulls only).

The object's solid (:func:`prehension.quality.object_solid`) already comes in convex
pieces for primitives and regions; a mesh file that is not convex is decomposed by
CoACD (approximate convex decomposition, the ``coacd`` package of the ``sim`` extra),
with settings that take a few seconds for a mesh of a thousand triangles.  The result is
kept for the life of the process.
"""

from __future__ import annotations

import weakref

import numpy as np

from ..errors import PrehensionError
from ..objects.meshes import Mesh
from ..objects.model import GraspObject
from ..quality.solid import hull_mesh, object_solid

__all__ = ["convex_pieces", "decompose", "DECOMPOSITION"]

#: CoACD settings: concavity threshold (a fraction of the mesh size), most pieces, effort.
DECOMPOSITION = {"threshold": 0.08, "max_convex_hull": 16, "preprocess_mode": "off", "resolution": 1000,
                 "mcts_iterations": 40, "mcts_max_depth": 2, "mcts_nodes": 10, "seed": 0}  # fmt: skip

_PIECES: "weakref.WeakKeyDictionary[GraspObject, tuple[Mesh, ...]]" = weakref.WeakKeyDictionary()


def convex_pieces(obj: GraspObject) -> tuple[Mesh, ...]:
    """The convex pieces of ``obj`` (object frame, mm), each a closed hull mesh."""
    cached = _PIECES.get(obj)
    if cached is None:
        solid = object_solid(obj)
        pieces: list[Mesh] = []
        for piece, convex in zip(solid.pieces, solid.convex):
            pieces += [hull_mesh(piece.vertices)] if convex else decompose(piece)
        cached = tuple(pieces)
        _PIECES[obj] = cached
    return cached


def decompose(mesh: Mesh) -> list[Mesh]:
    """Convex hulls of CoACD's decomposition of ``mesh`` (mm)."""
    try:
        import coacd
    except ImportError:
        raise PrehensionError(
            'the object is not convex, and decomposing it for the physics test needs CoACD; install it with: '
            'pip install "prehension[sim]"'
        ) from None
    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)), **DECOMPOSITION)
    return [hull_mesh(np.asarray(vertices, float)) for vertices, _ in parts]
