"""Regions and the solid agree: every contact region lies on the surface, normals outward.

:func:`check_regions_on_surface` is run whenever an object with a solid is made (so when a
task is loaded).  For each region it samples points (a 7 x 7 parameter grid of a patch, a
grid of normals over a sphere cap's cone, the point of a point region) and measures:

* the largest distance from a sample to the surface [mm]; it must be at most the
  object's ``surface_tolerance_mm`` (0.5 mm by default);
* the orientation: the region's normal against the outward normal of the surface at the
  closest point.  A region whose normal points into the object at more than half of its
  samples is refused (for a patch: its control points are listed in the wrong order along
  one direction, since the outward normal is ``p_u x p_v``).

The orientation test needs a closed surface; with ``collisions: false`` (an open mesh) only
the distance is checked.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidObject
from ..geometry.regions import BezierRegion, PointRegion, Region, SphereCap

__all__ = ["region_samples", "region_surface_report", "check_regions_on_surface"]

GRID = 7


def region_samples(region: Region) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample ``params (S, k)``, points (S, 3) [mm] and outward normals (S, 3) of a region."""
    if isinstance(region, PointRegion):
        params = np.zeros((1, 0))
    elif isinstance(region, BezierRegion):
        t = np.linspace(0.0, 1.0, GRID)
        params = np.stack(np.meshgrid(t, t, indexing="ij"), -1).reshape(-1, 2)
    elif isinstance(region, SphereCap):
        params = region.seed_params(GRID)
        params = params[region.domain_violation(params) <= 0]
    else:
        params = region.seed_params(GRID)
    points, normals = region.evaluate(params)
    return params, points, normals


def region_surface_report(distance, region: Region, closed: bool) -> dict:
    """``{"distance_mm", "at_params", "inward_fraction"}`` of one region against a surface.

    ``distance``: a :class:`~prehension.objects.distance.MeshDistance` of the surface.
    """
    params, points, normals = region_samples(region)
    sd, closest = distance.signed_distance(points, closest=True)
    worst = int(np.argmax(np.abs(sd)))
    inward = 0.0
    if closed:
        outward = _outward_at(distance, points, sd, closest)
        inward = float(np.mean(np.sum(normals * outward, axis=1) < 0.0))
    return {"distance_mm": float(abs(sd[worst])), "at_params": params[worst], "inward_fraction": inward}


def _outward_at(distance, points, sd, closest) -> np.ndarray:
    """Outward surface normal at the closest point of each sample (N, 3)."""
    away = points - closest
    norm = np.linalg.norm(away, axis=1)
    faces = distance.closest_faces(points)
    face_n = distance.face_normals[faces]
    # off the surface the direction to the point (signed) is the outward normal; on it, the face's
    use = norm > 1e-6
    out = face_n.copy()
    out[use] = np.sign(sd[use])[:, None] * away[use] / norm[use, None]
    return out


def check_regions_on_surface(name: str, regions, distance, tolerance_mm: float, closed: bool) -> None:
    """Raise :class:`InvalidObject` naming the first region off the surface or facing inwards."""
    for rname, region in regions.items():
        rep = region_surface_report(distance, region, closed)
        if rep["distance_mm"] > tolerance_mm:
            at = ", ".join(f"{x:.3g}" for x in rep["at_params"])
            where = f" at parameters ({at})" if at else ""
            raise InvalidObject(
                f"object {name!r}: region {rname!r} is {rep['distance_mm']:.3g} mm from the object's surface{where}; "
                f"every region must lie on the surface within {tolerance_mm:g} mm (surface_tolerance_mm)"
            )
        if rep["inward_fraction"] > 0.5:
            hint = (
                " (a patch's outward normal is p_u x p_v: list its control points in the other order along one direction)"
                if isinstance(region, BezierRegion) else ""
            )  # fmt: skip
            raise InvalidObject(
                f"object {name!r}: region {rname!r} has its normal pointing into the object "
                f"at {100 * rep['inward_fraction']:.0f}% of its points; region normals must point outwards{hint}"
            )
