"""The stages of an executable grasp in one picture: pre-grasp, grasp, squeeze.

A result file stores with each solution its pre-grasp (every participating finger backed
off along its contact normal) and the physics test's squeeze targets
(:mod:`prehension.pregrasp`); :func:`~prehension.viewer.grasp.pose_from_result` reads them
as :class:`~prehension.viewer.grasp.Stage` s.  :func:`stage_layers` draws the hand at each
stage's joint angles (the object where the grasp holds it; the palm does not move), one
layer per stage, tagged with it (:attr:`~.model.Layer.stage`); the grasp's own hand,
hand-region and pad layers are tagged ``"grasp"``.  The page shows one stage at a time
(its stage selector), the picture the one :func:`with_stage` picks (``render --stage``).
The contacts, cones, object and regions belong to every stage: in the pre-grasp they mark
where the fingers will touch, in the squeeze where they touched.
"""

from __future__ import annotations

from dataclasses import replace

from ..errors import PrehensionError
from ..tasks.model import Task
from .grasp import GraspPose, link_poses
from .layers import HandDrawing, hand_layer
from .model import PREGRASP_COLOR, SQUEEZE_COLOR, Layer, LegendEntry, Scene

__all__ = ["STAGES", "GRASP_STAGE_LAYERS", "stage_layers", "stage_legend", "stage_choices", "tag_grasp_layers", "with_stage"]

STAGES = ("pregrasp", "grasp", "squeeze")  # the order a robot goes through them
GRASP_STAGE_LAYERS = ("hand", "hand_regions", "pads")  # the grasp's own layers: shown with the grasp stage only
_COLORS = {"pregrasp": PREGRASP_COLOR, "squeeze": SQUEEZE_COLOR}
_NAMES = {"pregrasp": "pre-grasp", "grasp": "grasp", "squeeze": "squeeze"}


def stage_layers(task: Task, pose: GraspPose, drawing: HandDrawing | None = None) -> tuple[Layer, ...]:
    """One hidden layer per stored stage: the hand at the stage's angles, drawn as the
    grasp's hand is (``drawing``; default: its capsules), in the stage's colour (key
    ``hand_pregrasp`` / ``hand_squeeze``)."""
    out = []
    for stage in pose.stages:
        drawn = hand_layer(task.hand, link_poses(task, stage.q), drawing=drawing)
        meshes = tuple(replace(m, color=_COLORS[stage.name]) for m in drawn.meshes)
        out.append(Layer(f"hand_{stage.name}", f"hand at the {_NAMES[stage.name]}", meshes, drawn.lines,
                         visible=False, stage=stage.name))  # fmt: skip
    return tuple(out)


def stage_legend(pose: GraspPose) -> tuple[LegendEntry, ...]:
    """The colour key of each stored stage's hand."""
    return tuple(LegendEntry(f"hand at the {_NAMES[s.name]}", _COLORS[s.name], s.name) for s in pose.stages)


def stage_choices(pose: GraspPose) -> tuple[tuple[str, str], ...]:
    """``(stage, label)`` of every stage the pose can show, in :data:`STAGES` order; empty
    without stored stages (the picture is the grasp alone)."""
    if not pose.stages:
        return ()
    notes = {s.name: s.note for s in pose.stages}
    notes["grasp"] = "grasp: the solution"
    return tuple((name, notes[name]) for name in STAGES if name in notes)


def tag_grasp_layers(layers: tuple[Layer, ...]) -> tuple[Layer, ...]:
    """The grasp's own layers (:data:`GRASP_STAGE_LAYERS`) tagged with the ``"grasp"`` stage."""
    return tuple(replace(l, stage="grasp") if l.key in GRASP_STAGE_LAYERS else l for l in layers)


def with_stage(scene: Scene, stage: str) -> Scene:
    """The scene showing ``stage``: its layers visible, the other stages' hidden (a
    :class:`PrehensionError` naming the stages it has otherwise)."""
    known = [name for name, _ in scene.stages]
    if stage not in known:
        have = f"it has: {', '.join(known)}" if known else "it stores no pre-grasp or squeeze (only a solution in a result file does)"
        raise PrehensionError(f"no stage {stage!r} to show; stages are {', '.join(STAGES)}; {have}")
    layers = tuple(replace(l, visible=l.stage == stage) if l.stage is not None else l for l in scene.layers)
    return replace(scene, layers=layers, stage=stage)
