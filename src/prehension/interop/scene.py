"""A posed grasp as one scene of meshes: GLB, OBJ or PLY, written through trimesh.

The scene is in the **object frame** (the object at the identity, as the grasp records of
:mod:`prehension.interop` have it): each link ``L`` of the hand is placed at
``T_object_palm @ T_palm_L`` (forward kinematics of the chosen stage's joint angles), the
object mesh (:meth:`GraspObject.display_mesh`) at the identity.

One node per link, named as the link, and one node named ``object``.  A link is drawn as its
**mesh files** where the hand has them (:attr:`Link.meshes`: a URDF's or MJCF's visual
meshes, else its collision meshes), else as its collision **capsules** (the geometry every
check of prehension judges: trimesh capsules, a capsule with ``a == b`` a sphere); a link
with neither is an empty node.  ``meshes={}`` (``export --draw capsules``) draws every
link as its capsules.  A
result file holds its hand inline, without meshes: :func:`hand_meshes` takes them from the
hand file the result names (:attr:`Hand.source`) while that file is unchanged.  The built-in
SA hand is drawn as its capsules: its published shapes are the CuikSuite bodies (GPL,
never shipped), and a scene should not depend on what a machine happens to hold.  A mesh
file that cannot be read leaves its link drawn as capsules, said in the scene's
``metadata["drawn"]`` (per link: ``"mesh"``, ``"capsules"`` or ``"none"``).  Lengths in
metres (``units="m"``, what glTF, Blender and three.js expect) or millimetres.  GLB keeps
the nodes with their transforms; OBJ keeps one named object per link, the vertices posed;
PLY holds one mesh, every part joined (the format has no names).
"""

from __future__ import annotations


import numpy as np
import trimesh

from ..errors import InvalidTask
from ..hands.kinematics import forward_kinematics
from ..hands.link_meshes import joined_link_triangles
from ..hands.model import Capsule
from ..tasks.format.hand_files import hand_meshes

__all__ = ["SCENE_FORMATS", "UNITS", "OBJECT_NODE", "grasp_scene", "hand_meshes", "scene_bytes", "capsule_mesh"]

SCENE_FORMATS = ("glb", "obj", "ply")
UNITS = {"m": 1e-3, "mm": 1.0}  # scene units per mm
OBJECT_NODE = "object"


def capsule_mesh(cap: Capsule, sections: int = 24):
    """The trimesh of ``cap`` in its link's frame [mm]: a capsule along ``b - a``, or a sphere."""
    axis = cap.b - cap.a
    length = float(np.linalg.norm(axis))
    if length < 1e-12:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=cap.radius)
        mesh.apply_translation(cap.a)
        return mesh
    mesh = trimesh.creation.capsule(height=length, radius=cap.radius, count=[sections, sections])
    T = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], axis / length)
    T[:3, 3] = (cap.a + cap.b) / 2.0
    mesh.apply_transform(T)
    return mesh


def _capsules(link):
    parts = [capsule_mesh(c) for c in link.collision]
    return trimesh.util.concatenate(parts) if parts else None


def _link_mesh(link, meshes) -> tuple:
    """``(trimesh of the link in its frame [mm] or None, what was drawn)``."""
    joined = joined_link_triangles(meshes) if meshes else None
    if joined is not None:
        return trimesh.Trimesh(*joined, process=False), "mesh"
    mesh = _capsules(link)  # none, or a file gone or unreadable: the capsules stand in
    return mesh, ("none" if mesh is None else "capsules")


def _scaled(T: np.ndarray, s: float) -> np.ndarray:
    out = T.copy()
    out[:3, 3] *= s
    return out


def grasp_scene(task, q, T_palm_object, units: str = "m", meshes=None):
    """The :class:`trimesh.Scene` of ``task``'s hand at angles ``q`` (n_dof,) [rad] with the
    object at ``T_palm_object`` (4, 4) [mm] (see the module docstring for frames and names).

    ``meshes``: per link name, the :class:`~prehension.hands.model.LinkMesh` files that draw
    it (default: each link's own :attr:`~prehension.hands.model.Link.meshes`; ``{}``: every
    link as its capsules)."""
    if units not in UNITS:
        raise InvalidTask(f"unknown units {units!r}; use one of {sorted(UNITS)}")
    if meshes is None:
        meshes = {link.name: link.meshes for link in task.hand.links}
    s = UNITS[units]
    hand = task.hand
    if OBJECT_NODE in hand.link_names:
        raise InvalidTask(f"hand {hand.name!r} has a link named {OBJECT_NODE!r}, the scene's name for the object")
    T_object_palm = np.linalg.inv(np.asarray(T_palm_object, dtype=float))
    T_palm_link = forward_kinematics(hand, np.asarray(q, dtype=float)).T_palm_link[0]
    scene = trimesh.Scene()
    drawn = scene.metadata.setdefault("drawn", {})
    for link, T in zip(hand.links, T_palm_link):
        pose = _scaled(T_object_palm @ T, s)
        mesh, drawn[link.name] = _link_mesh(link, meshes.get(link.name, ()))
        if mesh is None:
            scene.graph.update(frame_to=link.name, frame_from=scene.graph.base_frame, matrix=pose)
        else:
            mesh.apply_scale(s)
            scene.add_geometry(mesh, node_name=link.name, geom_name=link.name, transform=pose)
    obj = task.object.display_mesh()
    if len(obj.faces):
        scene.add_geometry(trimesh.Trimesh(obj.vertices * s, obj.faces, process=False), node_name=OBJECT_NODE, geom_name=OBJECT_NODE)
    return scene


def scene_bytes(scene, fmt: str) -> bytes:
    """The file's bytes of ``scene`` in ``fmt`` (``glb``, ``obj`` or ``ply``)."""
    if fmt not in SCENE_FORMATS:
        raise InvalidTask(f"unknown scene format {fmt!r}; use one of {list(SCENE_FORMATS)}")
    if fmt == "glb":
        return scene.export(file_type="glb")
    if fmt == "ply":
        return scene.to_mesh().export(file_type="ply")
    text = scene.export(file_type="obj", include_normals=False, include_texture=False)
    return text.encode("utf-8") if isinstance(text, str) else text
