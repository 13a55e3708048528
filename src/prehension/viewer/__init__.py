"""Pictures of grasps: a self-contained HTML viewer and a static PNG, from one scene model.

:func:`build_scene` turns a task (and optionally a grasp) into a :class:`Scene` of layers
in the palm frame [mm]; :func:`write_html` writes the interactive page (plain JS, no
network), :func:`render_png` the picture (matplotlib, the ``plot`` extra).
"""

from .grasp import GraspPose, LoadedGrasp, load_grasp
from .html import scene_to_html, write_html
from .render import render_png
from .model import Layer, Scene
from .scene import build_hand_scene, build_scene

__all__ = ["build_scene", "build_hand_scene", "Scene", "Layer", "GraspPose", "LoadedGrasp", "load_grasp", "scene_to_html", "write_html", "render_png"]
