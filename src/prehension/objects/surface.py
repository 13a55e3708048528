"""Regions and the solid agree: every contact region lies on the surface, normals outward.

:func:`check_regions_on_surface` is run whenever an object with a solid is made (so when a
task is loaded).  For each region it samples points (a 7 x 7 parameter grid of a patch, a
grid of normals over a sphere cap's cone, the point of a point region) and measures:

* the largest distance from a sample to the surface [mm]; it must be at most the
  object's ``surface_tolerance_mm`` (0.5 mm by default);
* the orientation: a step of twice the tolerance along the region's normal must leave the
  solid.  A region whose normal points into the object at more than half of its samples
  is refused (for a patch: its control points are listed in the wrong order along one
  direction, since the outward normal is ``p_u x p_v``); so is a region on an internal
  wall of a mesh, whose both sides are inside.

The orientation test needs a closed surface; with ``collisions: false`` (an open mesh) only
the distance is checked.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidObject
from ..geometry.regions import Region

__all__ = ["region_samples", "region_surface_report", "check_regions_on_surface"]

GRID = 7


def region_samples(region: Region) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample ``params (S, k)`` (:meth:`~prehension.geometry.regions.Region.sample_params`),
    points (S, 3) [mm] and outward normals (S, 3) of a region."""
    params = region.sample_params(GRID)
    points, normals = region.evaluate(params)
    return params, points, normals


def region_surface_report(distance, region: Region, closed: bool, tolerance_mm: float = 0.5) -> dict:
    """``{"distance_mm", "at_params", "inward_fraction"}`` of one region against a surface.

    ``distance``: a :class:`~prehension.objects.distance.MeshDistance` of the surface.
    ``inward_fraction``: the share of samples ``p`` whose outward side
    ``p + 2 tolerance_mm n`` lies inside the solid (a flipped normal, or a region on an
    internal wall); 0 when ``closed`` is false.
    """
    params, points, normals = region_samples(region)
    sd = distance.signed_distance(points)
    worst = int(np.argmax(np.abs(sd)))
    inward = 0.0
    if closed:
        ahead = distance.signed_distance(points + 2.0 * tolerance_mm * normals)
        inward = float(np.mean(ahead <= 0.0))
    return {"distance_mm": float(abs(sd[worst])), "at_params": params[worst], "inward_fraction": inward}


def check_regions_on_surface(name: str, regions, distance, tolerance_mm: float, closed: bool) -> None:
    """Raise :class:`InvalidObject` naming the first region off the surface or facing inwards."""
    for rname, region in regions.items():
        rep = region_surface_report(distance, region, closed, tolerance_mm)
        if rep["distance_mm"] > tolerance_mm:
            at = ", ".join(f"{x:.3g}" for x in rep["at_params"])
            where = f" at parameters ({at})" if at else ""
            raise InvalidObject(
                f"object {name!r}: region {rname!r} is {rep['distance_mm']:.3g} mm from the object's surface{where}; "
                f"every region must lie on the surface within {tolerance_mm:g} mm (surface_tolerance_mm)"
            )
        if rep["inward_fraction"] > 0.5:
            raise InvalidObject(
                f"object {name!r}: region {rname!r} has its normal pointing into the object "
                f"at {100 * rep['inward_fraction']:.0f}% of its points; region normals must point outwards{region.inward_hint}"
            )
