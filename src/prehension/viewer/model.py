"""The viewer's data types: one model of a grasp picture, drawn by the HTML page and the PNG.

A :class:`Scene` is a tuple of named :class:`Layer` s (hand, object, hand regions, object
regions, contacts, frames), each a few triangle meshes (:class:`TriangleMesh`), polylines,
points and arrows with their colours, all in the **palm frame, mm**; plus a title, caption
lines and a legend.  This module holds those records, the colours and the shading both
drawings share (:func:`camera_basis`, :func:`shade_faces`); it imports nothing of the
viewer.  :mod:`.scene` composes a scene from a task (with :mod:`.layers` and
:mod:`.cones`); :mod:`.html` and :mod:`.render` draw one.

Colours: the hand is steel grey, the object sand and translucent; each contact has its own
colour, shared by its hand region, its object region, its point and the normal out of the
hand; normals out of the object are dark slate; links that reach more than 0.5 mm into the
object (the residual function's ``object_collision`` check) are red.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "TriangleMesh", "Polyline", "PointSet", "ArrowSet", "Layer", "LegendEntry", "Scene", "camera_basis", "shade_faces",
]  # fmt: skip

HAND_COLOR = "#a9b4bf"
PALM_COLOR = "#8f9baa"
OBJECT_COLOR = "#d9c49a"
PENETRATION_COLOR = "#d62728"  # links (and pads) that reach into the object
PREGRASP_COLOR = "#8fc1e3"  # the hand at the pre-grasp (light blue)
SQUEEZE_COLOR = "#6d7f94"  # the hand at the squeeze targets (dark slate grey)
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
        stage: the stage of the grasp the layer belongs to (``"grasp"``, ``"pregrasp"``,
            ``"squeeze"``: shown only with its stage, chosen with the page's stage
            selector or ``render --stage``), or ``None``: every stage.
    """

    key: str
    label: str
    meshes: tuple[TriangleMesh, ...] = ()
    lines: tuple[Polyline, ...] = ()
    points: tuple[PointSet, ...] = ()
    arrows: tuple[ArrowSet, ...] = ()
    visible: bool = True
    on_top: bool = False
    stage: str | None = None

    def all_points_mm(self) -> np.ndarray:
        """(N, 3) every vertex, line point, dot and arrow end of the layer [mm]."""
        parts = [m.vertices_mm for m in self.meshes] + [p.points_mm for p in self.lines + self.points]
        parts += [a.origins_mm for a in self.arrows] + [a.origins_mm + a.vectors_mm for a in self.arrows]
        return np.concatenate(parts) if parts else np.zeros((0, 3))


@dataclass(frozen=True)
class LegendEntry:
    """A colour key; ``stage``: shown with that stage of the grasp only (``None``: always)."""

    label: str
    color: str
    stage: str | None = None


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
        stages: ``(stage, label)`` of each stage of the grasp the scene can show
            (:mod:`.stages`; empty: one picture, no stages).
        stage: the stage shown (its layers visible, the other stages' hidden).
    """

    task_name: str
    status: str
    title: str
    caption: tuple[str, ...]
    layers: tuple[Layer, ...]
    legend: tuple[LegendEntry, ...]
    view_elev_deg: float = 18.0
    view_azim_deg: float = 35.0
    stages: tuple[tuple[str, str], ...] = ()
    stage: str = "grasp"

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
