"""Where the physics test starts: the object's pieces made fine next to the hand, and the
initial penetration split into the hand's own and the object's approximation error.

MuJoCo collides convex pieces (:mod:`.pieces`), the solver the object's closed mesh.  A
coarse piece can fill a concavity the mesh leaves open, and the hand, clear of the mesh,
would start inside the piece.  So before the test:

1. **Probe.** The scene is built with a contact margin of :data:`PROBE_MARGIN_MM`, so that
   MuJoCo reports every hand geom within that gap of a piece.  For each such contact,
   the piece's surface point (``pos + n dist / 2``, ``n`` from the hand geom to the piece)
   is measured against the solver's mesh (its signed distance, exact): a piece that stands
   more than :data:`APPROXIMATION_MM` out of the mesh there *strays*.  (A piece surface
   *inside* the mesh -- a seam between pieces, or the few tenths of a millimetre a large
   mesh loses to simplification -- cannot push the hand out of place and is left alone:
   the hand's own penetration below is measured against the mesh itself.)
2. **Refine.** Each stray piece is replaced by finer pieces made from the exact part of
   the solid inside it (:func:`~prehension.sim.pieces.refine`); back to 1, at most
   :data:`REFINE_LEVELS` times and while the object has at most :data:`MAX_PIECES` pieces.

The report then states, beside the penetration MuJoCo sees at the start
(``initial_penetration_mm``): ``hand_penetration_mm``, how deep the MuJoCo hand's own
geoms (the solver's collision capsules and the contact regions' solids) reach into the
solver's mesh, exactly (:meth:`~prehension.objects.distance.MeshDistance.capsule_depth`;
a patch region's hull by its corners); and ``approximation_mm``, how far the pieces still
stand out of the solver's mesh where the hand touches them (what the object's
approximation, not the hand, adds to the start).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PrehensionError
from ..objects.distance import MeshDistance
from ..objects.meshes import Mesh
from ..quality.solid import object_solid
from ..tasks.model import Task
from .options import SimOptions
from .pieces import refine, solid_pieces
from .scene import MM, build_scene_xml

__all__ = ["StartState", "start_state", "posed", "APPROXIMATION_MM", "PROBE_MARGIN_MM", "REFINE_LEVELS", "MAX_PIECES"]

APPROXIMATION_MM = 0.25  # a piece further than this from the solver's mesh next to the hand is refined [mm]
PROBE_MARGIN_MM = 3.0  # "next to the hand": contacts within this gap [mm]
REFINE_LEVELS = 8  # at most this many rounds of refinement
MAX_PIECES = 400  # no further round once the object has this many pieces

_CAPSULE, _SPHERE, _MESH = 3, 2, 7  # mujoco.mjtGeom values


@dataclass(frozen=True, eq=False)
class StartState:
    """The object's pieces for one grasp (object frame, mm), and how far they stand out of
    the solver's mesh next to the hand at the start [mm] (0 without a mesh to compare)."""

    pieces: tuple[Mesh, ...]
    approximation_mm: float


def posed(mujoco, xml: str, dof_names, q):
    """``(model, data)`` of a scene's MJCF with the hand at ``q (n_dof,)`` [rad], forward-computed;
    a scene MuJoCo refuses is a :class:`~prehension.errors.PrehensionError` naming its reason."""
    try:
        model = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:  # MuJoCo's compiler refuses the scene (its message says why)
        raise PrehensionError(f"MuJoCo cannot build the physics test's scene: {str(exc).splitlines()[0]}") from None
    data = mujoco.MjData(model)
    adr = np.array([model.joint(f"dof:{d}").qposadr[0] for d in dof_names])
    data.qpos[adr] = q
    data.ctrl[[model.actuator(f"act:{d}").id for d in dof_names]] = q
    mujoco.mj_forward(model, data)
    return model, data


def solver_distance(task: Task) -> MeshDistance | None:
    """The distances to the mesh the solver checks (or, without one, to the object's mesh
    file when it is the object's only solid); ``None`` when there is no mesh."""
    if task.object.solid is not None:
        return task.object.distance
    solid = object_solid(task.object)
    if solid.source == "mesh file":
        return MeshDistance(solid.pieces[0].vertices, solid.pieces[0].faces)
    return None


def start_state(mujoco, task: Task, T_palm_object: np.ndarray, q: np.ndarray, options: SimOptions) -> StartState:
    """The pieces refined next to the hand (see the module docstring)."""
    pairs = list(solid_pieces(task.object))
    distance = solver_distance(task)
    if distance is None:
        return StartState(tuple(p for p, _ in pairs), 0.0)
    for level in range(REFINE_LEVELS + 1):
        strays = _strays(mujoco, task, T_palm_object, q, [p for p, _ in pairs], options, distance)
        worse = {k for k, e in strays.items() if e > APPROXIMATION_MM and pairs[k][1] is not None}
        if not worse or level == REFINE_LEVELS or len(pairs) > MAX_PIECES:
            break
        pairs = [new for k, pair in enumerate(pairs) for new in _refined(pair, k in worse)]
    return StartState(tuple(p for p, _ in pairs), max([0.0, *strays.values()]))


def _refined(pair, stray: bool):
    piece, source = pair
    finer = refine(source, piece) if stray else None
    return [pair] if finer is None else [(p, source) for p in finer]


def _strays(mujoco, task, T, q, pieces, options, distance) -> dict[int, float]:
    """Per piece the hand comes within the probe margin of: the largest signed distance of
    its surface from the solver's mesh at those contacts [mm] (positive: outside the mesh)."""
    scene = build_scene_xml(task, T, pieces, options, margin_mm=PROBE_MARGIN_MM)
    model, data = posed(mujoco, scene.xml, scene.dof_names, q)
    T_object_palm = np.linalg.inv(T)
    out: dict[int, float] = {}
    for c in data.contact[: data.ncon]:
        names = model.geom(c.geom1).name, model.geom(c.geom2).name
        side = 1.0 if names[1].startswith("object_") else -1.0  # the normal points from geom1 to geom2
        k = int(names[1 if side > 0 else 0].split("_")[1])
        p = (c.pos + side * c.frame[:3] * c.dist / 2) / MM  # the piece's surface point, palm frame [mm]
        e = float(distance.signed_distance(T_object_palm[:3, :3] @ p + T_object_palm[:3, 3])[0])
        out[k] = max(e, out.get(k, -np.inf))
    return out


def hand_depth(model, data, distance: MeshDistance | None, T_palm_object: np.ndarray) -> float | None:
    """How deep the scene's hand geoms reach into the solver's mesh [mm] (``None`` without one)."""
    if distance is None:
        return None
    T_object_palm = np.linalg.inv(T_palm_object)
    R, t = T_object_palm[:3, :3], T_object_palm[:3, 3]
    deepest = 0.0
    for g in range(model.ngeom):
        if model.geom_contype[g] != 1:  # the hand's geoms (the object's are contype 2)
            continue
        centre, axes = data.geom_xpos[g] / MM, data.geom_xmat[g].reshape(3, 3)
        kind, size = model.geom_type[g], model.geom_size[g] / MM
        if kind in (_CAPSULE, _SPHERE):
            half = size[1] * axes[:, 2] if kind == _CAPSULE else np.zeros(3)
            ends = R @ np.array([centre - half, centre + half]).T + t[:, None]
            deepest = max(deepest, float(distance.capsule_depth(ends[:, 0], ends[:, 1], [size[0]])[0]))
        elif kind == _MESH:
            mesh = model.geom_dataid[g]
            v = model.mesh_vert[model.mesh_vertadr[mesh]: model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]] / MM
            points = (v @ axes.T + centre) @ R.T + t
            deepest = max(deepest, float(-distance.signed_distance(points).min()))
    return deepest
