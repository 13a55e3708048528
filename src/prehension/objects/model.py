"""Objects: rigid bodies with named contact regions and an optional display mesh."""

from __future__ import annotations

from dataclasses import dataclass, field
from ..frozen import FrozenMap
from typing import Mapping

from ..errors import InvalidObject
from ..geometry.regions import Region
from .meshes import Mesh, to_mesh

__all__ = ["GraspObject"]


@dataclass(frozen=True, eq=False)
class GraspObject:
    """A rigid object (its own frame, mm) with contact regions whose normals point outwards.

    Attributes:
        name: object name.
        regions: named contact regions in the object frame.
        primitives: display primitives (see :mod:`prehension.objects.meshes`).
        mesh_file: optional path of a display mesh (OFF) used instead of the primitives.
    """

    name: str
    regions: Mapping[str, Region] = field(default_factory=dict)
    primitives: tuple = ()
    mesh_file: str | None = None

    def __post_init__(self):
        object.__setattr__(self, "regions", FrozenMap(dict(self.regions)))
        object.__setattr__(self, "primitives", tuple(self.primitives))
        for name, region in self.regions.items():
            if not isinstance(region, Region):
                raise InvalidObject(f"object {self.name!r}: region {name!r} is not a contact region")

    def region(self, name: str) -> Region:
        try:
            return self.regions[name]
        except KeyError:
            names = ", ".join(self.regions) or "(none defined)"
            raise InvalidObject(f"object region {name!r} not found on {self.name!r}; regions are: {names}") from None

    def display_mesh(self) -> Mesh:
        """The display mesh in the object frame (empty when none is given)."""
        if self.mesh_file is not None:
            from .meshes import read_off

            return read_off(self.mesh_file)
        return to_mesh(self.primitives)
