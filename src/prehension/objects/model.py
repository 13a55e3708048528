"""Objects: rigid bodies with named contact regions, an optional solid and display shapes."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Mapping

import numpy as np

from ..errors import InvalidObject
from ..frozen import FrozenMap
from ..geometry.regions import Region
from .meshes import Mesh, to_mesh
from .solid import MeshFileSolid, PrimitiveSolid, solid_geometry

__all__ = ["GraspObject", "SURFACE_TOLERANCE_MM"]

SURFACE_TOLERANCE_MM = 0.5  # default: how far a contact region may lie from the solid's surface


@dataclass(frozen=True, eq=False)
class GraspObject:
    """A rigid object (its own frame, mm) with contact regions whose normals point outwards.

    Attributes:
        name: object name.
        regions: named contact regions in the object frame.
        primitives: display primitives (see :mod:`prehension.objects.meshes`).
        mesh_file: optional path of a display mesh (OFF, OBJ, STL, PLY, GLB; mm) drawn
            instead of the primitives; read (and refused if it is not a mesh) when the
            object is made.
        solid: the object's closed surface (a mesh file or a union of primitives, see
            :mod:`prehension.objects.solid`), or ``None``: then the object has no
            collision geometry and only its regions constrain a grasp.
        collisions: whether the hand must stay clear of the solid (the residual function's
            ``object_collision`` checks); ``False`` also accepts an open (not watertight)
            mesh, used for display and the region checks only.
        surface_tolerance_mm: how far a region may lie from the solid's surface [mm].

    With a solid, every region is checked against it when the object is made (see
    :func:`~prehension.objects.surface.check_regions_on_surface`).
    """

    name: str
    regions: Mapping[str, Region] = field(default_factory=dict)
    primitives: tuple = ()
    mesh_file: str | None = None
    solid: MeshFileSolid | PrimitiveSolid | None = None
    collisions: bool = True
    surface_tolerance_mm: float = SURFACE_TOLERANCE_MM

    def __post_init__(self):
        object.__setattr__(self, "regions", FrozenMap(dict(self.regions)))
        object.__setattr__(self, "primitives", tuple(self.primitives))
        for name, region in self.regions.items():
            if not isinstance(region, Region):
                raise InvalidObject(f"object {self.name!r}: region {name!r} is not a contact region")
        if self.solid is not None and not isinstance(self.solid, (MeshFileSolid, PrimitiveSolid)):
            raise InvalidObject(f"object {self.name!r}: solid must be a MeshFileSolid or a PrimitiveSolid")
        tol = float(self.surface_tolerance_mm)
        if not (np.isfinite(tol) and tol > 0):
            raise InvalidObject(f"object {self.name!r}: surface_tolerance_mm must be a positive number of mm, got {tol}")
        if self.mesh_file is not None:
            self._display_file_mesh  # read now: a bad display file is refused here, not when drawing
        if self.solid is not None:
            from .surface import check_regions_on_surface

            check_regions_on_surface(self.name, self.regions, self.distance, tol, self.collisions)

    def region(self, name: str) -> Region:
        try:
            return self.regions[name]
        except KeyError:
            names = ", ".join(self.regions) or "(none defined)"
            raise InvalidObject(f"object region {name!r} not found on {self.name!r}; regions are: {names}") from None

    @cached_property
    def surface(self) -> Mesh | None:
        """The solid's closed surface in the object frame [mm] (``None`` without a solid)."""
        if self.solid is None:
            return None
        return solid_geometry(self.solid, self.collisions)[0]

    @cached_property
    def distance(self):
        """A :class:`~prehension.objects.distance.MeshDistance` of :attr:`surface` (``None`` without a solid)."""
        if self.solid is None:
            return None
        return solid_geometry(self.solid, self.collisions)[1]

    @property
    def collides(self) -> bool:
        """Whether the hand is checked against this object's solid."""
        return self.solid is not None and self.collisions

    @cached_property
    def _display_file_mesh(self) -> Mesh:
        """The display mesh file [mm], read through trimesh (any closed or open mesh)."""
        from .mesh_io import load_display_mesh

        return load_display_mesh(self.mesh_file)

    def display_mesh(self) -> Mesh:
        """What the viewer draws, object frame [mm]: the solid's surface together with the
        display mesh file, or else the display primitives (empty when there is none)."""
        parts = [self.surface] if self.solid is not None else []
        if self.mesh_file is not None:
            parts.append(self._display_file_mesh)
        else:
            parts.append(to_mesh(self.primitives))
        return Mesh.concatenate(parts)
