"""The physics test of a grasp (optional extra ``sim``: MuJoCo, CoACD).

:func:`simulate_grasp` builds the MuJoCo scene of a solution (:mod:`.scene`), holds the
hand with position actuators, squeezes, pushes the object along six directions and
reports, per direction, whether the grasp held (the DexGraspBench protocol,
:class:`SimOptions`).  The scene builder needs nothing beyond prehension's own
dependencies; running it needs ``pip install "prehension[sim]"``.
"""

from .options import PUSH_DIRECTIONS, SimOptions
from .pieces import convex_pieces
from .run import PhysicsReport, PushOutcome, require_mujoco, scene_for, simulate_grasp
from .scene import SimScene, build_scene_xml
from .squeeze import squeeze_targets

__all__ = [
    "SimOptions", "PUSH_DIRECTIONS", "PhysicsReport", "PushOutcome", "simulate_grasp", "scene_for",
    "require_mujoco", "SimScene", "build_scene_xml", "convex_pieces", "squeeze_targets",
]  # fmt: skip
