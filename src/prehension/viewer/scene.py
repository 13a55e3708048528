"""One model of a grasp picture, drawn by both the HTML viewer and the PNG renderer.

A :class:`Scene` is a tuple of named :class:`Layer` s (hand, object, hand regions, object
regions, contacts, frames), each a few triangle meshes, polylines, points and arrows with
their colours, all in the **palm frame, mm**; plus a title, caption lines and a legend.
:func:`build_scene` makes one from a task and, optionally, a grasp (a solution, a
configuration or a :class:`~prehension.viewer.grasp.GraspPose`).

Colours: the hand is steel grey, the object sand and translucent; each contact has its own
colour, shared by its hand region, its object region, its point and the normal out of the
hand; normals out of the object are dark slate; links that reach more than 0.5 mm into the
object (the residual function's ``object_collision`` check) are red.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..tasks.model import Task
from .grasp import REFERENCE, GraspPose, beside_the_hand, link_poses, pose_from_configuration, pose_from_solution, reference_angles

__all__ = [
    "TriangleMesh", "Polyline", "PointSet", "ArrowSet", "Layer", "LegendEntry", "Scene", "build_scene",
    "build_hand_scene", "camera_basis", "shade_faces",
]  # fmt: skip

HAND_COLOR = "#a9b4bf"
PALM_COLOR = "#8f9baa"
OBJECT_COLOR = "#d9c49a"
PENETRATION_COLOR = "#d62728"  # links (and pads) that reach into the object
PAD_COLOR = "#b39ddb"  # the contacts' pads: a fingertip cap's ball (lavender: none of the contact colours)
OBJECT_OPACITY = 0.38
SPARE_REGION_COLOR = "#a9b7c6"  # object regions no contact names
OBJECT_NORMAL_COLOR = "#2f3b4a"
CONTACT_COLORS = ("#e69f00", "#0072b2", "#cc79a7", "#009e73", "#d55e00", "#56b4e9", "#f0e442")  # Okabe-Ito
AXIS_COLORS = ("#d62728", "#2ca02c", "#1f77b4")  # x, y, z
BACKGROUND = "#f4f6f8"
# Flat shading, the same in the page and the picture: a light fixed to the camera, coming
# from the upper left, in camera coordinates (right, up, towards the viewer); Lambert
# diffuse on top of an ambient share.  Open surfaces are lit on both sides.
LIGHT_IN_CAMERA = (-0.35, 0.55, 0.76)
AMBIENT = 0.42


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """Triangles ``faces (F, 3)`` over ``vertices_mm (V, 3)``; ``closed``: outward-oriented, cull back faces."""

    vertices_mm: np.ndarray
    faces: np.ndarray
    color: str
    opacity: float = 1.0
    closed: bool = False


@dataclass(frozen=True, eq=False)
class Polyline:
    """A connected line through ``points_mm (N, 3)``."""

    points_mm: np.ndarray
    color: str
    width_px: float = 1.5
    dashed: bool = False


@dataclass(frozen=True, eq=False)
class PointSet:
    """Dots at ``points_mm (N, 3)``."""

    points_mm: np.ndarray
    color: str
    size_px: float = 6.0


@dataclass(frozen=True, eq=False)
class ArrowSet:
    """Arrows from ``origins_mm (N, 3)`` to ``origins_mm + vectors_mm``."""

    origins_mm: np.ndarray
    vectors_mm: np.ndarray
    color: str


@dataclass(frozen=True, eq=False)
class Layer:
    """A group the user can show or hide.

    Attributes:
        key: short identifier (``"hand"``, ``"object"``, ``"hand_regions"``...).
        label: what the toggle says.
        visible: shown at first.
        on_top: drawn over every surface (markers that must not hide inside bodies).
    """

    key: str
    label: str
    meshes: tuple[TriangleMesh, ...] = ()
    lines: tuple[Polyline, ...] = ()
    points: tuple[PointSet, ...] = ()
    arrows: tuple[ArrowSet, ...] = ()
    visible: bool = True
    on_top: bool = False

    def all_points_mm(self) -> np.ndarray:
        """(N, 3) every vertex, line point, dot and arrow end of the layer [mm]."""
        parts = [m.vertices_mm for m in self.meshes] + [p.points_mm for p in self.lines + self.points]
        parts += [a.origins_mm for a in self.arrows] + [a.origins_mm + a.vectors_mm for a in self.arrows]
        return np.concatenate(parts) if parts else np.zeros((0, 3))


@dataclass(frozen=True)
class LegendEntry:
    label: str
    color: str


@dataclass(frozen=True, eq=False)
class Scene:
    """A grasp picture in the palm frame [mm].

    Attributes:
        task_name: the task's name.
        status: ``"solved"``, ``"infeasible"``, ``"gave_up"`` or ``"reference"`` (a task alone).
        title: one line: task and what is shown.
        caption: further lines (solution, residual, how the object was placed).
        layers: the layers, drawn in this order.
        legend: colour keys.
        view_elev_deg, view_azim_deg: initial view direction (as matplotlib's elev/azim).
    """

    task_name: str
    status: str
    title: str
    caption: tuple[str, ...]
    layers: tuple[Layer, ...]
    legend: tuple[LegendEntry, ...]
    view_elev_deg: float = 18.0
    view_azim_deg: float = 35.0

    def layer(self, key: str) -> Layer:
        for layer in self.layers:
            if layer.key == key:
                return layer
        raise KeyError(f"no layer {key!r}; layers are: {', '.join(l.key for l in self.layers)}")

    def bounds_mm(self, visible_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """``(lower (3,), upper (3,))`` corners of everything drawn [mm]."""
        pts = [l.all_points_mm() for l in self.layers if l.visible or not visible_only]
        pts = np.concatenate(pts) if pts else np.zeros((0, 3))
        if len(pts) == 0:
            return -np.ones(3), np.ones(3)
        return pts.min(axis=0), pts.max(axis=0)


def camera_basis(elev_deg: float, azim_deg: float) -> np.ndarray:
    """(3, 3) rows: screen right, screen up, towards the viewer, in the palm frame.

    The camera looks at the scene from ``(cos e cos a, cos e sin a, sin e)`` with z up,
    as matplotlib's ``view_init(elev, azim)``.
    """
    e, a = np.radians(elev_deg), np.radians(azim_deg)
    return np.array([
        [-np.sin(a), np.cos(a), 0.0],
        [-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)],
        [np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)],
    ])  # fmt: skip


def shade_faces(triangles_mm: np.ndarray, basis: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Brightness in [AMBIENT, 1] of ``triangles_mm (F, 3, 3)`` seen with ``basis`` (see
    :func:`camera_basis`), and which of them to draw (F,) bool: back faces of a closed
    mesh are not drawn; open surfaces are lit on the side the viewer sees.
    """
    n = np.cross(triangles_mm[:, 1] - triangles_mm[:, 0], triangles_mm[:, 2] - triangles_mm[:, 0])  # (F, 3)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    towards_viewer = n @ basis[2]  # (F,)
    light = np.asarray(LIGHT_IN_CAMERA) @ basis
    light /= np.linalg.norm(light)
    lambert = np.maximum(0.0, np.where(towards_viewer < 0, -1.0, 1.0) * (n @ light))
    keep = towards_viewer >= 0 if closed else np.ones(len(n), dtype=bool)
    return AMBIENT + (1 - AMBIENT) * lambert, keep


def build_scene(task: Task, grasp=None, *, status: str | None = None) -> Scene:
    """The picture of ``task`` with ``grasp`` made (or the task alone, ``grasp=None``).

    Args:
        task: the task (hand, object, contacts).
        grasp: a :class:`~prehension.viewer.grasp.GraspPose`, a
            :class:`~prehension.results.Solution`, a
            :class:`~prehension.tasks.model.Configuration`, or ``None`` for the reference
            pose: the hand at :func:`~prehension.viewer.grasp.reference_angles`, the object
            unrotated beside it (:func:`~prehension.viewer.grasp.beside_the_hand`).
        status: the status of the result the grasp comes from, shown in the title
            (e.g. ``"infeasible"`` for a result without a solution, shown as its task).
    """
    from .layers import (
        contact_layer, frame_layer, hand_layer, hand_region_layer, object_extent_mm, object_layer, object_region_layer,
        pad_layer, penetrating_links, sunk_pads,
    )  # fmt: skip

    pose = _as_pose(task, grasp)
    colors = {c.name: CONTACT_COLORS[i % len(CONTACT_COLORS)] for i, c in enumerate(task.contacts)}
    if pose is None:
        links = link_poses(task, reference_angles(task))
        hand = hand_layer(task.hand, links).all_points_mm()
        pose = GraspPose(links, beside_the_hand(hand.min(0), hand.max(0), *object_extent_mm(task)))
    scale_mm = _arrow_length_mm(task, pose)
    red, sunk = penetrating_links(task, pose), sunk_pads(task, pose)
    layers = (
        hand_layer(task.hand, pose.T_palm_link, red),
        object_layer(task, pose.T_palm_object),
        hand_region_layer(task, pose.T_palm_link, colors),
        pad_layer(task, pose.T_palm_link, sunk),
        object_region_layer(task, pose.T_palm_object, colors),
        contact_layer(task, pose, colors, scale_mm),
        frame_layer(task, pose, scale_mm),
    )
    if pose.has_solution:
        from .cones import friction_cone_layer

        layers += (friction_cone_layer(pose, colors, scale_mm),)
    status = status or pose.status
    legend = _legend(task, colors, has_hand=bool(layers[0].meshes), has_object=bool(layers[1].meshes))
    if layers[3].meshes:
        legend += (LegendEntry("pad (a fingertip's ball, excused from its link)", PAD_COLOR),)
    if red or sunk:
        legend += (LegendEntry("link or pad into the object (> 0.5 mm)", PENETRATION_COLOR),)
    sunk_names = {f"{name} pad": depth for name, depth in sunk.items()}
    caption = _caption(pose) + ((_penetration_line({**red, **sunk_names}),) if red or sunk else ())
    return Scene(task.name, status, _title(task, pose, status), caption, layers, legend)


def build_hand_scene(hand) -> Scene:
    """The picture of a hand alone (``prehension view HAND``): its links at zero angles
    clamped into the limits (couplings applied), every hand region (found fingertips
    included), and the palm and link frames."""
    from ..hands.kinematics import forward_kinematics
    from .layers import all_hand_regions_layer, hand_layer

    q = np.clip(np.zeros(hand.n_dof), hand.lower, hand.upper)
    for c in hand.couplings:
        q[hand.dof_index(c.dof)] = c.ratio * q[hand.dof_index(c.source)] + c.offset
    T = forward_kinematics(hand, np.clip(q, hand.lower, hand.upper)).T_palm_link[0]
    links = {name: T[i] for i, name in enumerate(hand.link_names)}
    frames = [(np.eye(4), 60.0)] + [(links[name], 15.0) for name in hand.link_names[1:]]
    lines = tuple(
        Polyline(np.array([F[:3, 3], F[:3, 3] + size * F[:3, axis]]), color, 2.0)
        for F, size in frames for axis, color in enumerate(AXIS_COLORS)
    )  # fmt: skip
    layers = (
        hand_layer(hand, links),
        all_hand_regions_layer(hand, links),
        Layer("frames", "frames (x y z = red green blue)", (), lines, visible=False, on_top=True),
    )
    fingers = ", ".join(f.name for f in hand.fingers) or "none"
    caption = (f"fingers: {fingers}; regions: {', '.join(hand.regions) or 'none'}",
               "links at zero angles clamped into their limits; palm frame, mm")  # fmt: skip
    legend = (LegendEntry("hand (collision capsules)", HAND_COLOR),)
    return Scene(hand.name, "hand", f"hand {hand.name!r}: {len(hand.links)} links, {hand.n_dof} joint angles", caption, layers, legend)


def _penetration_line(red: dict[str, float]) -> str:
    worst = sorted(red.items(), key=lambda kv: -kv[1])
    return "into the object (red): " + ", ".join(f"{link} {depth:.1f} mm" for link, depth in worst)


def _as_pose(task: Task, grasp) -> GraspPose | None:
    from ..tasks.model import Configuration

    if grasp is None or isinstance(grasp, GraspPose):
        return grasp
    if isinstance(grasp, Configuration):
        return pose_from_configuration(task, grasp)
    return pose_from_solution(grasp)


def _arrow_length_mm(task: Task, pose: GraspPose) -> float:
    """Normals are drawn this long: 12% of the hand's reach, at least 15 mm."""
    origins = np.array([T[:3, 3] for T in pose.T_palm_link.values()])
    reach = float(np.ptp(origins, axis=0).max()) if len(origins) > 1 else 100.0
    return max(15.0, 0.12 * reach)


_STATUS_WORDS = {
    "solved": "solved",
    "infeasible": "proven infeasible: no solution, showing the task",
    "gave_up": "gave up: no solution found, showing the task",
    "unverified": "configuration (does NOT satisfy the task)",
    REFERENCE: "task (reference pose, no solution)",
}


def _title(task: Task, pose: GraspPose, status: str) -> str:
    words = _STATUS_WORDS.get(status, status)
    if pose.has_solution and status != "unverified":
        return f"{task.name}: {words} ({pose.note})"
    return f"{task.name}: {words}"


def _caption(pose: GraspPose) -> tuple[str, ...]:
    if pose.has_solution:
        return (
            f"max contact residual: {pose.max_distance_mm:.2g} mm, {pose.max_angle_deg:.2g} deg",
            "object placed by the grasp; palm frame, mm",
        )
    return (
        "max contact residual: none (no contact made)",
        "hand at its idle angles (task idle values, 0 for the fingers taking part, clamped to the limits);"
        " object unrotated, placed beside the palm along +x",
    )


def _legend(task: Task, colors: dict[str, str], has_hand: bool, has_object: bool) -> tuple[LegendEntry, ...]:
    entries = [LegendEntry("hand (collision capsules)", HAND_COLOR)] if has_hand else []
    entries += [LegendEntry(task.object.name, OBJECT_COLOR)] if has_object else []
    entries += [LegendEntry(f"contact {name}", color) for name, color in colors.items()]
    entries.append(LegendEntry("normal out of the object", OBJECT_NORMAL_COLOR))
    return tuple(entries)
