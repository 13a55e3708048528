"""The layers of a grasp scene, one function each (palm frame, mm).

Each function takes the task and the poses (``T_palm_link`` by link name, ``T_palm_object``)
and returns a :class:`~prehension.viewer.model.Layer`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ..hands.link_meshes import joined_link_triangles
from ..hands.model import Capsule, Hand
from ..objects.meshes import Mesh
from ..tasks.model import Task
from . import model as S
from .grasp import GraspPose
from ..tessellation import capsule_mesh, region_center, region_mesh

__all__ = [
    "HandDrawing", "hand_drawing", "hand_layer", "capsule_layer", "object_layer", "hand_region_layer",
    "object_region_layer", "contact_layer", "frame_layer", "object_extent_mm", "penetrating_links", "pad_layer", "sunk_pads",
]  # fmt: skip


def _transform(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``points (N, 3)`` in a body frame -> palm frame, with ``T_palm_body (4, 4)``."""
    return np.asarray(points, float) @ T[:3, :3].T + T[:3, 3]


def _rotate(T: np.ndarray, directions: np.ndarray) -> np.ndarray:
    return np.asarray(directions, float) @ T[:3, :3].T


def _merged(meshes_in_palm: list[Mesh], color: str, opacity: float = 1.0, closed: bool = False):
    """One :class:`TriangleMesh` of several meshes already in the palm frame (or ``None``)."""
    mesh = Mesh.concatenate(meshes_in_palm)
    if len(mesh.faces) == 0:
        return None
    return S.TriangleMesh(mesh.vertices, mesh.faces, color, opacity, closed)


@dataclass(frozen=True, eq=False)
class HandDrawing:
    """How each link of a hand is drawn, in the link's own frame [mm].

    Attributes:
        shapes: per link name, its mesh files' triangles (:attr:`Link.meshes`: a URDF's or
            MJCF's visual meshes) where it has readable ones, else its collision capsules
            (an empty mesh for a link without either).
        drawn: per link name, ``"mesh"``, ``"capsules"`` or ``"none"``.
        note: why meshes that were asked for are not drawn (``""``: nothing to say).
    """

    shapes: Mapping[str, Mesh]
    drawn: Mapping[str, str]
    note: str = ""

    @property
    def meshed(self) -> bool:
        """Some link is drawn as its mesh files (not as the capsules every check judges)."""
        return any(d == "mesh" for d in self.drawn.values())


def hand_drawing(hand: Hand, meshes: Mapping[str, tuple] | None = None, note: str = "") -> HandDrawing:
    """The :class:`HandDrawing` of ``hand``: each link as its files in ``meshes`` (link name
    -> :class:`~prehension.hands.model.LinkMesh` files, e.g.
    :func:`~prehension.tasks.format.hand_files.hand_meshes`; ``None``: none), else as its
    capsules.  A file that cannot be read leaves its link drawn as capsules, said in
    ``note``."""
    meshes = meshes or {}
    shapes, drawn, unreadable = {}, {}, []
    for link in hand.links:
        files = meshes.get(link.name, ())
        joined = joined_link_triangles(files) if files else None
        if joined is not None:
            shapes[link.name], drawn[link.name] = Mesh(*joined), "mesh"
            continue
        if files:  # a file gone or unreadable: the capsules stand in
            unreadable.append(link.name)
        shapes[link.name] = Mesh.concatenate([capsule_mesh(c) for c in link.collision])
        drawn[link.name] = "capsules" if link.collision else "none"
    if unreadable:
        note = (f"{note}; " if note else "") + (f"the mesh files of {len(unreadable)} link(s) cannot be read "
                                                f"({', '.join(unreadable[:3])}{', ...' if len(unreadable) > 3 else ''}): "
                                                "drawn as their capsules")  # fmt: skip
    return HandDrawing(shapes, drawn, note)


def hand_layer(hand: Hand, T_palm_link: Mapping[str, np.ndarray], penetrating: Mapping[str, float] | None = None,
               drawing: HandDrawing | None = None) -> "S.Layer":  # fmt: skip
    """Every link as ``drawing`` draws it (default: its collision capsules), red for the
    links in ``penetrating`` (those deeper than the tolerance into the object); a thin
    segment between joint centres for links drawn as nothing."""
    drawing = drawing or hand_drawing(hand)
    penetrating = penetrating or {}
    groups: dict[tuple[str, bool], list[Mesh]] = {}
    lines = []
    for link in hand.links:
        T = T_palm_link[link.name]
        kind = drawing.drawn[link.name]
        if kind == "none":
            lines.extend(_skeleton(hand, link.name, T))
            continue
        color = S.PENETRATION_COLOR if link.name in penetrating else S.PALM_COLOR if link.name == hand.palm else S.HAND_COLOR
        groups.setdefault((color, kind == "capsules"), []).append(drawing.shapes[link.name].transformed(T))
    order = (S.PALM_COLOR, S.HAND_COLOR, S.PENETRATION_COLOR)
    groups = dict(sorted(groups.items(), key=lambda kv: order.index(kv[0][0])))
    meshes = [_merged(parts, color, closed=closed) for (color, closed), parts in groups.items()]
    return S.Layer("hand", "hand", tuple(m for m in meshes if m is not None), tuple(lines))


def capsule_layer(hand: Hand, T_palm_link: Mapping[str, np.ndarray], penetrating: Mapping[str, float] | None = None) -> "S.Layer":
    """The collision capsules of every link (what every check judges), hidden at first: the
    layer a picture adds when its hand is drawn as its mesh files."""
    drawn = hand_layer(hand, T_palm_link, penetrating)
    return S.Layer("capsules", "collision capsules (what the checks judge)", drawn.meshes, drawn.lines, visible=False)


def penetrating_links(task: Task, pose: GraspPose, tolerance_mm: float = 0.5) -> dict[str, float]:
    """Links deeper than ``tolerance_mm`` into the object in ``pose``, with their depth [mm]
    (as the residual function measures it: only what lies inside a contact's own pad is
    excused); empty when the object has no colliding solid or the pose makes no contact."""
    depths = _object_depths(task, pose)
    return {link: d for link, d in depths[0].items() if d > tolerance_mm} if depths else {}


def sunk_pads(task: Task, pose: GraspPose, tolerance_mm: float = 0.5) -> dict[str, float]:
    """Contacts whose pad (a fingertip cap's ball) is deeper than ``tolerance_mm`` into the
    object in ``pose``, with its depth [mm]; empty as :func:`penetrating_links`."""
    depths = _object_depths(task, pose)
    return {name: d for name, d in depths[1].items() if d > tolerance_mm} if depths else {}


def _object_depths(task: Task, pose: GraspPose):
    """``(link depths, pad depths)`` of the residual function [mm], or ``None`` without a
    colliding solid or a solution."""
    if not task.object.collides or not pose.has_solution:
        return None
    from ..hands.kinematics import HandPose
    from ..tasks.object_collision import link_penetrations, pad_penetrations

    T_links = np.stack([pose.T_palm_link[name] for name in task.hand.link_names])[None]  # (1, L, 4, 4)
    n = task.hand.n_dof
    hand_pose = HandPose(T_links[..., :3, :3], T_links[..., :3, 3], np.zeros((1, n, 3)), np.zeros((1, n, 3)))
    T = pose.T_palm_object
    by_name = {c.name: c.hand_point for c in pose.contacts}
    points = [(by_name.get(c.name, np.full(3, np.inf)) - T[:3, 3]) @ T[:3, :3] for c in task.contacts]
    return link_penetrations(task, hand_pose, T, points), pad_penetrations(task, hand_pose, T, points)


def pad_layer(task: Task, T_palm_link: Mapping[str, np.ndarray], sunk: Mapping[str, float] | None = None) -> "S.Layer":
    """Each contact's pad, a fingertip cap's whole ball (the solid that touches the object
    and is excused from its link's check), translucent in the pad colour, red when it is
    in ``sunk`` (deeper than the tolerance); a point or patch hand region has no volume
    and is drawn by :func:`hand_region_layer` only."""
    sunk = sunk or {}
    own, red = [], []
    for contact in task.contacts:
        hr = task.hand_region(contact)
        pad = hr.region.ball()
        if pad is not None:
            centre, radius = pad
            mesh = capsule_mesh(Capsule(centre, centre, radius))
            (red if contact.name in sunk else own).append(mesh.transformed(T_palm_link[hr.link]))
    meshes = (_merged(own, S.PAD_COLOR, 0.35, closed=True), _merged(red, S.PENETRATION_COLOR, 0.6, closed=True))
    return S.Layer("pads", "pads", tuple(m for m in meshes if m is not None))


def _skeleton(hand: Hand, link: str, T: np.ndarray) -> list["S.Polyline"]:
    """Segments from a shapeless link's joint centre to the centres of its child joints."""
    own = hand.joint_of_link(link)
    start = own.origin_in_child if own is not None else np.zeros(3)
    ends = [j.origin_in_parent for j in hand.joints if j.parent == link]
    return [S.Polyline(_transform(T, np.array([start, end])), S.PALM_COLOR, 3.0) for end in ends]


def object_extent_mm(task: Task) -> tuple[np.ndarray, np.ndarray]:
    """``(lower (3,), upper (3,))`` of the object's display mesh and regions, object frame [mm]."""
    parts = [task.object.display_mesh().vertices] + [region_mesh(r).vertices for r in task.object.regions.values()]
    parts += [region_center(r)[0][None] for r in task.object.regions.values()]
    pts = np.concatenate(parts)
    if len(pts) == 0:
        return np.zeros(3), np.zeros(3)
    return pts.min(axis=0), pts.max(axis=0)


def object_layer(task: Task, T_palm_object: np.ndarray) -> "S.Layer":
    """The object's display mesh, translucent (nothing when the object has none)."""
    mesh = _merged([task.object.display_mesh().transformed(T_palm_object)], S.OBJECT_COLOR, S.OBJECT_OPACITY)
    return S.Layer("object", task.object.name, () if mesh is None else (mesh,))


def hand_region_layer(task: Task, T_palm_link: Mapping[str, np.ndarray], colors: Mapping[str, str]) -> "S.Layer":
    """The hand regions the contacts name, each in its contact's colour."""
    meshes, seen = [], set()
    for contact in task.contacts:
        if contact.hand_region in seen:
            continue
        seen.add(contact.hand_region)
        hr = task.hand.region(contact.hand_region)
        mesh = _merged([region_mesh(hr.region).transformed(T_palm_link[hr.link])], colors[contact.name])
        meshes += [mesh] if mesh is not None else []
    return S.Layer("hand_regions", "hand regions", tuple(meshes))


def all_hand_regions_layer(hand: Hand, T_palm_link: Mapping[str, np.ndarray]) -> "S.Layer":
    """Every region of a hand (a hand shown alone), each in a colour of its own."""
    meshes = []
    for k, (name, hr) in enumerate(hand.regions.items()):
        mesh = _merged([region_mesh(hr.region).transformed(T_palm_link[hr.link])], S.CONTACT_COLORS[k % len(S.CONTACT_COLORS)])
        meshes += [mesh] if mesh is not None else []
    return S.Layer("hand_regions", "hand regions", tuple(meshes))


def object_region_layer(task: Task, T_palm_object: np.ndarray, colors: Mapping[str, str]) -> "S.Layer":
    """Every object region: in its contact's colour, or pale blue-grey when no contact names it."""
    color_of = {}
    for contact in task.contacts:
        color_of.setdefault(contact.object_region, colors[contact.name])
    meshes = []
    for name, region in task.object.regions.items():
        mesh = _merged([region_mesh(region).transformed(T_palm_object)], color_of.get(name, S.SPARE_REGION_COLOR))
        meshes += [mesh] if mesh is not None else []
    return S.Layer("object_regions", "object regions", tuple(meshes))


def contact_layer(task: Task, pose: GraspPose, colors: Mapping[str, str], length_mm: float) -> "S.Layer":
    """Contact points and normals; for a task alone, each region's centre, its normal, and a
    dashed line joining the two regions each contact pairs."""
    if pose.has_solution:
        markers = [(colors.get(c.name, S.CONTACT_COLORS[0]), c.hand_point, c.hand_normal, c.object_point, c.object_normal)
                   for c in pose.contacts]  # fmt: skip
        lines = ()
    else:
        markers = [(colors[c.name], *_region_centres(task, c, pose)) for c in task.contacts]
        lines = tuple(S.Polyline(np.array([m[1], m[3]]), m[0], 1.5, dashed=True) for m in markers)
    points, arrows = [], []
    for color, hand_p, hand_n, obj_p, obj_n in markers:
        points.append(S.PointSet(np.array([hand_p, obj_p]), color, 7.0))
        arrows.append(S.ArrowSet(np.array([hand_p]), length_mm * np.array([hand_n]), color))
        arrows.append(S.ArrowSet(np.array([obj_p]), length_mm * np.array([obj_n]), S.OBJECT_NORMAL_COLOR))
    label = "contact points, normals" if pose.has_solution else "regions to touch (pairs), normals"
    return S.Layer("contacts", label, (), lines, tuple(points), tuple(arrows), on_top=True)


def _region_centres(task: Task, contact, pose: GraspPose):
    """Hand and object region centres and normals of ``contact``, palm frame."""
    hr = task.hand.region(contact.hand_region)
    T_link = pose.T_palm_link[hr.link]
    hand_p, hand_n = region_center(hr.region)
    obj_p, obj_n = region_center(task.object.region(contact.object_region))
    T_obj = pose.T_palm_object
    return (_transform(T_link, hand_p[None])[0], _rotate(T_link, hand_n[None])[0],
            _transform(T_obj, obj_p[None])[0], _rotate(T_obj, obj_n[None])[0])  # fmt: skip


def frame_layer(task: Task, pose: GraspPose, length_mm: float) -> "S.Layer":
    """Axes x, y, z (red, green, blue) of the palm (long), the object and every link (short)."""
    frames = [(np.eye(4), 2.0 * length_mm), (pose.T_palm_object, 1.5 * length_mm)]
    frames += [(pose.T_palm_link[name], 0.6 * length_mm) for name in task.hand.link_names[1:]]
    lines = []
    for T, size in frames:
        for axis, color in enumerate(S.AXIS_COLORS):
            lines.append(S.Polyline(np.array([T[:3, 3], T[:3, 3] + size * T[:3, axis]]), color, 2.0))
    return S.Layer("frames", "frames (x y z = red green blue)", (), tuple(lines), visible=False, on_top=True)
