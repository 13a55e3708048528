"""Variants of a task with one object region moved or turned: infeasible benchmarks and tests.

``move_object_region(task, "knob_back", (0, 0, 200))`` shifts one Bézier region of the
object (the object's display primitives stay where they are); ``turn_object_region``
rotates one about its centre, e.g. by 180 degrees so that it faces away from the hand.
A variant's object has no solid (the moved region no longer lies on its surface): it is
drawn with its display primitives only and has no collision checks.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import InvalidTask
from ..geometry.regions import BezierRegion
from ..geometry.rotations import axis_angle_to_matrix
from .model import Task

__all__ = ["move_object_region", "turn_object_region"]


def _bezier_region(task: Task, name: str) -> BezierRegion:
    region = task.object.regions.get(name)
    if not isinstance(region, BezierRegion):
        names = ", ".join(n for n, r in task.object.regions.items() if isinstance(r, BezierRegion))
        raise InvalidTask(f"object region {name!r} is not a Bézier region of {task.object.name!r}; those are: {names}")
    return region


def _with_region(task: Task, name: str, region: BezierRegion, label: str) -> Task:
    regions = dict(task.object.regions)
    regions[name] = region
    obj = replace(task.object, regions=regions, solid=None)
    return replace(task, name=f"{task.name} ({name} {label})", object=obj)


def move_object_region(task: Task, name: str, offset_mm) -> Task:
    """``task`` with the object region ``name`` translated by ``offset_mm`` (object frame)."""
    offset = np.asarray(offset_mm, dtype=float)
    region = _bezier_region(task, name)
    moved = BezierRegion(region.patch.transformed(np.eye(3), offset))
    return _with_region(task, name, moved, f"+{np.linalg.norm(offset):g} mm")


def turn_object_region(task: Task, name: str, axis, angle_deg: float) -> Task:
    """``task`` with the object region ``name`` rotated by ``angle_deg`` about ``axis``
    through the centre of its control points (its normals turn with it)."""
    region = _bezier_region(task, name)
    R = axis_angle_to_matrix(np.asarray(axis, dtype=float), np.radians(angle_deg))[0]
    centre = region.patch.control_points.reshape(-1, 3).mean(axis=0)
    turned = BezierRegion(region.patch.transformed(R, centre - R @ centre))
    return _with_region(task, name, turned, f"turned {angle_deg:g} deg")
