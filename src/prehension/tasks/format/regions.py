"""Contact regions in a file, read and written: the format's one module that knows the kinds.

A region is one of ``{bezier: control_points}``, ``{point: [x, y, z], normal: [nx, ny, nz]}``
or ``{sphere_cap: {center, radius, axis, half_angle_deg}}`` (object regions, and hand
regions with a ``link:`` besides, see :mod:`.hands`).  A new region kind is read and
written here and nowhere else in the format.
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import InvalidTask
from ...geometry.bezier import BezierPatch
from ...geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from .errors import located, validate
from .schema import RegionSpec
from .values import plain_floats, settled_unit, written_deg

__all__ = ["region_from_spec", "region_from_dict", "region_to_dict"]


def region_from_spec(spec: RegionSpec) -> Region:
    """The region of a checked region mapping (errors are the model's; callers locate them)."""
    if spec.bezier is not None:
        return BezierRegion(BezierPatch(np.array(spec.bezier, dtype=float)))
    if spec.sphere_cap is not None:
        cap = spec.sphere_cap
        return SphereCap(cap.center, cap.radius, cap.axis, math.radians(cap.half_angle_deg))
    return PointRegion(spec.point, spec.normal)


def region_from_dict(data: dict, where: str) -> Region:
    """A contact region from ``{bezier: ...}``, ``{point:, normal:}`` or ``{sphere_cap: ...}``.

    ``where`` starts every error message (e.g. ``"task.yaml: object.regions.knob"``).
    """
    spec = validate(RegionSpec, data, where)
    with located(where, ""):
        return region_from_spec(spec)


_ZERO3 = np.zeros(3)


def _cap_axis(v):
    return SphereCap(_ZERO3, 1.0, v, 0.0).axis


def _point_normal(v):
    return PointRegion(_ZERO3, v).normal


def region_to_dict(region: Region) -> dict:
    """The file mapping of a contact region (inverse of :func:`region_from_dict`)."""
    if isinstance(region, BezierRegion):
        return {"bezier": plain_floats(region.patch.control_points)}
    if isinstance(region, SphereCap):
        cap = {
            "center": plain_floats(region.center),
            "radius": float(region.radius),
            "axis": settled_unit(region.axis, _cap_axis),
            "half_angle_deg": written_deg(region.half_angle),
        }
        return {"sphere_cap": cap}
    if isinstance(region, PointRegion):
        return {"point": plain_floats(region.point), "normal": settled_unit(region.normal, _point_normal)}
    kind = type(region).__name__
    raise InvalidTask(f"cannot write a region of type {kind}; task files hold bezier, sphere_cap, point")
