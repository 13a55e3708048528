"""The composition of a grasp picture: a :class:`~.model.Scene` from a task and a grasp.

:func:`build_scene` makes the scene of a task and, optionally, a grasp (a solution, a
configuration or a :class:`~prehension.viewer.grasp.GraspPose`) from the layers of
:mod:`.layers` and :mod:`.cones`; :func:`build_hand_scene` the scene of a hand alone.  The
records a scene is made of, its colours and its shading live in :mod:`.model`, which
imports nothing of the viewer (so the layers do not import back from here).
"""

from __future__ import annotations

import numpy as np

from ..errors import PrehensionError
from ..hands.kinematics import forward_kinematics
from ..tasks.format.hand_files import hand_meshes
from ..tasks.model import Configuration, Task
from .cones import friction_cone_layer
from .grasp import REFERENCE, GraspPose, beside_the_hand, link_poses, pose_from_configuration, pose_from_solution, reference_angles
from .layers import (
    HandDrawing, all_hand_regions_layer, capsule_layer, contact_layer, frame_layer, hand_drawing, hand_layer,
    hand_region_layer, object_extent_mm, object_layer, object_region_layer, pad_layer, penetrating_links, sunk_pads,
)  # fmt: skip
from .stages import stage_choices, stage_layers, stage_legend, tag_grasp_layers
from .model import (
    AXIS_COLORS, CONTACT_COLORS, HAND_COLOR, OBJECT_COLOR, OBJECT_NORMAL_COLOR, PAD_COLOR, PENETRATION_COLOR, Layer,
    LegendEntry, Polyline, Scene,
)  # fmt: skip

__all__ = ["build_scene", "build_hand_scene", "DRAW_CHOICES"]

DRAW_CHOICES = ("meshes", "capsules")  # how a hand's links are drawn (``draw=``)

def build_scene(task: Task, grasp=None, *, status: str | None = None, draw: str = "meshes") -> Scene:
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
        draw: ``"meshes"``: each link as its hand file's mesh files where it has them
            (:func:`~prehension.tasks.format.hand_files.hand_meshes`: a URDF's or MJCF's
            visual meshes; a result's hand takes them from the file it names, while that
            file is unchanged), else as its capsules, with the capsules in a layer of their
            own, hidden at first; ``"capsules"``: every link as the capsules every check
            judges.
    """
    drawing = _drawing(task.hand, draw)
    pose = _as_pose(task, grasp)
    colors = {c.name: CONTACT_COLORS[i % len(CONTACT_COLORS)] for i, c in enumerate(task.contacts)}
    if pose is None:
        links = link_poses(task, reference_angles(task))
        hand = hand_layer(task.hand, links, drawing=drawing).all_points_mm()
        pose = GraspPose(links, beside_the_hand(hand.min(0), hand.max(0), *object_extent_mm(task)))
    scale_mm = _arrow_length_mm(task, pose)
    red, sunk = penetrating_links(task, pose), sunk_pads(task, pose)
    layers = (
        hand_layer(task.hand, pose.T_palm_link, red, drawing),
        object_layer(task, pose.T_palm_object),
        hand_region_layer(task, pose.T_palm_link, colors),
        pad_layer(task, pose.T_palm_link, sunk),
        object_region_layer(task, pose.T_palm_object, colors),
        contact_layer(task, pose, colors, scale_mm),
        frame_layer(task, pose, scale_mm),
    )
    if pose.has_solution:
        layers += (friction_cone_layer(pose, colors, scale_mm),)
    if drawing.meshed:
        layers += (capsule_layer(task.hand, pose.T_palm_link, red),)
    if pose.stages:  # pre-grasp and squeeze stored with the solution: one stage shown at a time
        layers = tag_grasp_layers(layers) + stage_layers(task, pose, drawing)
    status = status or pose.status
    legend = _legend(task, colors, drawing if layers[0].meshes else None, has_object=bool(layers[1].meshes))
    if layers[3].meshes:
        legend += (LegendEntry("pad (a fingertip's ball, excused from its link)", PAD_COLOR),)
    if red or sunk:
        legend += (LegendEntry("link or pad into the object (> 0.5 mm)", PENETRATION_COLOR),)
    sunk_names = {f"{name} pad": depth for name, depth in sunk.items()}
    caption = _caption(pose) + ((_penetration_line({**red, **sunk_names}),) if red or sunk else ()) + _drawing_line(drawing)
    legend += stage_legend(pose)
    return Scene(task.name, status, _title(task, pose, status), caption, layers, legend, stages=stage_choices(pose))


def build_hand_scene(hand, draw: str = "meshes") -> Scene:
    """The picture of a hand alone (``prehension view HAND``): its links at zero angles
    clamped into the limits (couplings applied), drawn as ``draw`` says
    (:func:`build_scene`), every hand region (found fingertips included), and the palm and
    link frames."""
    drawing = _drawing(hand, draw)
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
        hand_layer(hand, links, drawing=drawing),
        all_hand_regions_layer(hand, links),
        Layer("frames", "frames (x y z = red green blue)", (), lines, visible=False, on_top=True),
    ) + ((capsule_layer(hand, links),) if drawing.meshed else ())
    fingers = ", ".join(f.name for f in hand.fingers) or "none"
    caption = (f"fingers: {fingers}; regions: {', '.join(hand.regions) or 'none'}",
               "links at zero angles clamped into their limits; palm frame, mm") + _drawing_line(drawing)  # fmt: skip
    legend = (_hand_entry(drawing),)
    return Scene(hand.name, "hand", f"hand {hand.name!r}: {len(hand.links)} links, {hand.n_dof} joint angles", caption, layers, legend)


def _drawing(hand, draw: str) -> HandDrawing:
    """The hand's :class:`~.layers.HandDrawing` for ``draw`` (:data:`DRAW_CHOICES`)."""
    if draw not in DRAW_CHOICES:
        raise PrehensionError(f"draw must be one of {', '.join(DRAW_CHOICES)}, got {draw!r}")
    if draw == "capsules":
        return hand_drawing(hand)
    return hand_drawing(hand, *hand_meshes(hand))


def _hand_entry(drawing: HandDrawing) -> LegendEntry:
    what = "link meshes of its hand file" if drawing.meshed else "collision capsules"
    return LegendEntry(f"hand ({what})", HAND_COLOR)


def _drawing_line(drawing: HandDrawing) -> tuple[str, ...]:
    """A caption line when the links are not drawn as the capsules the checks judge, or
    when meshes were wanted and are not drawn (why)."""
    lines = []
    if drawing.meshed:
        lines.append("links drawn as their hand file's meshes; the checks judge the collision capsules (layer 'capsules')")
    if drawing.note:
        lines.append(f"links drawn as capsules: {drawing.note}")
    return tuple(lines)


def _penetration_line(red: dict[str, float]) -> str:
    worst = sorted(red.items(), key=lambda kv: -kv[1])
    return "into the object (red): " + ", ".join(f"{link} {depth:.1f} mm" for link, depth in worst)


def _as_pose(task: Task, grasp) -> GraspPose | None:
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


def _legend(task: Task, colors: dict[str, str], drawing: HandDrawing | None, has_object: bool) -> tuple[LegendEntry, ...]:
    entries = [_hand_entry(drawing)] if drawing is not None else []
    entries += [LegendEntry(task.object.name, OBJECT_COLOR)] if has_object else []
    entries += [LegendEntry(f"contact {name}", color) for name, color in colors.items()]
    entries.append(LegendEntry("normal out of the object", OBJECT_NORMAL_COLOR))
    return tuple(entries)
