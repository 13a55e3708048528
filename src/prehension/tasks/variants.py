"""Variants of a task with one object region moved or turned: infeasible benchmarks and tests.

``move_object_region(task, "knob_back", (0, 0, 200))`` shifts one region of the object
(the object's display primitives stay where they are); ``turn_object_region`` rotates one
about its centre, e.g. by 180 degrees so that it faces away from the hand.  Any region kind
moves (:meth:`~prehension.geometry.regions.Region.transformed`); its centre is the mean of
the points that define it (a patch's control points, a cap's sphere centre, the point).
A variant's object has no solid (the moved region no longer lies on its surface): it is
drawn with its display primitives only and has no collision checks.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import InvalidTask
from ..geometry.regions import Region
from ..geometry.rotations import axis_angle_to_matrix
from .model import Task

__all__ = ["move_object_region", "turn_object_region"]


def _object_region(task: Task, name: str) -> Region:
    region = task.object.regions.get(name)
    if region is None:
        names = ", ".join(task.object.regions)
        raise InvalidTask(f"{task.object.name!r} has no object region {name!r}; its regions are: {names}")
    return region


def _with_region(task: Task, name: str, region: Region, label: str) -> Task:
    regions = dict(task.object.regions)
    regions[name] = region
    obj = replace(task.object, regions=regions, solid=None)
    return replace(task, name=f"{task.name} ({name} {label})", object=obj)


def move_object_region(task: Task, name: str, offset_mm) -> Task:
    """``task`` with the object region ``name`` translated by ``offset_mm`` (object frame)."""
    offset = np.asarray(offset_mm, dtype=float)
    moved = _object_region(task, name).transformed(np.eye(3), offset)
    return _with_region(task, name, moved, f"+{np.linalg.norm(offset):g} mm")


def turn_object_region(task: Task, name: str, axis, angle_deg: float) -> Task:
    """``task`` with the object region ``name`` rotated by ``angle_deg`` about ``axis``
    through its centre (:meth:`~prehension.geometry.regions.Region.centroid`; its normals
    turn with it)."""
    region = _object_region(task, name)
    R = axis_angle_to_matrix(np.asarray(axis, dtype=float), np.radians(angle_deg))[0]
    centre = region.centroid()
    turned = region.transformed(R, centre - R @ centre)
    return _with_region(task, name, turned, f"turned {angle_deg:g} deg")
