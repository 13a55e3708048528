"""The field's formats, in and out: grasp records (DexGraspBench/BODex ``.npy``, DexGraspNet
``.npy``, JSON in metres), ``moveit_msgs/Grasp`` messages (out), MuJoCo ``qpos`` and posed
scenes (GLB, OBJ, PLY) drawn with the hand file's link meshes.

See docs/interop.md for the frames, units and which field maps to which.
"""

from __future__ import annotations

from ..hands.qpos import base_from_transform, qpos_configuration, qpos_joint_order, solution_qpos, transform_from_base

__all__ = ["solution_qpos", "qpos_configuration", "qpos_joint_order", "base_from_transform", "transform_from_base"]
