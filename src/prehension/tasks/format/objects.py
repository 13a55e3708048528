"""The ``object:`` part of a task file: regions, the solid (mesh file or primitives), display.

Reading turns a checked :class:`~.schema.ObjectSpec` into a
:class:`~prehension.objects.model.GraspObject` (mesh paths relative to the task file's
folder); writing turns an object back into its mapping (paths relative to the folder the
file is written to).  A model error (a mesh that is not closed, a region off the surface)
is re-raised at the field it came from.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from ...errors import InvalidTask, not_a_file
from ...objects.model import SURFACE_TOLERANCE_MM, GraspObject
from ...objects.mesh_io import UNITS
from ...objects.solid import MeshFileSolid, PrimitiveSolid
from .errors import fail, join_path, located
from .regions import region_from_spec, region_to_dict
from .schema import PRIMITIVES, DisplaySpec, ObjectSpec, PrimitiveSpec
from .values import plain_floats

__all__ = ["object_from_spec", "object_to_dict", "primitive_from_spec", "primitive_to_dict"]


# -- reading ----------------------------------------------------------------------------
def primitive_from_spec(spec: PrimitiveSpec, source: str, loc: str):
    """The primitive of one ``{kind: {...}}`` item, checked."""
    for key, (_, cls) in PRIMITIVES.items():
        sub = getattr(spec, key)
        if sub is not None:
            fields = {k: (tuple(v) if isinstance(v, list) else v) for k, v in sub.model_dump(exclude_none=True).items()}
            with located(source, join_path(loc, key)):
                prim = cls(**fields)
                prim.mesh()  # checks what the schema cannot (e.g. a cylinder of zero length)
            return prim
    raise AssertionError("unreachable: PrimitiveSpec holds exactly one primitive")


def _existing(name: str, base: Path, source: str, loc: str) -> str:
    path = (base / name).resolve()
    if not path.is_file():
        raise fail(source, loc, not_a_file("mesh file", path))
    return str(path)


def _solid(spec: ObjectSpec, base: Path, source: str):
    if spec.mesh is not None:
        path = _existing(spec.mesh, base, source, "object.mesh")
        scale = UNITS[spec.units] if spec.units is not None else float(spec.scale)
        return MeshFileSolid(path, scale, spec.units)
    if spec.shape is not None:
        return PrimitiveSolid(tuple(primitive_from_spec(p, source, join_path("object.shape", i)) for i, p in enumerate(spec.shape)))
    return None


def object_from_spec(spec: ObjectSpec, base: Path, source: str) -> GraspObject:
    """The object of a checked ``object:`` mapping; errors name ``source`` and the field."""
    regions = {}
    for name, r in spec.regions.items():
        with located(source, join_path("object.regions", name)):
            regions[name] = region_from_spec(r)
    display = spec.display or DisplaySpec()
    prims = [primitive_from_spec(p, source, join_path("object.display.primitives", i)) for i, p in enumerate(display.primitives)]
    mesh_file = _existing(display.mesh_file, base, source, "object.display.mesh_file") if display.mesh_file else None
    solid = _solid(spec, base, source)
    tol = spec.surface_tolerance_mm if spec.surface_tolerance_mm is not None else SURFACE_TOLERANCE_MM
    with located(source, "object"):
        return GraspObject(spec.name, regions, tuple(prims), mesh_file, solid, spec.collisions, tol)


# -- writing ----------------------------------------------------------------------------
def primitive_to_dict(prim) -> dict:
    for key, (_, cls) in PRIMITIVES.items():
        if type(prim) is cls:
            fields = {}
            for f in dataclasses.fields(cls):
                value = getattr(prim, f.name)
                if f.default is not dataclasses.MISSING and value == f.default:
                    continue
                fields[f.name] = int(value) if f.name == "resolution" else plain_floats(value)
            return {key: fields}
    raise InvalidTask(f"cannot write a display primitive of type {type(prim).__name__}; use {', '.join(PRIMITIVES)}")


def _mesh_path(mesh_file: str, base_dir) -> str:
    if base_dir is None:
        return str(mesh_file)
    try:
        return Path(os.path.relpath(Path(mesh_file).resolve(), Path(base_dir).resolve())).as_posix()
    except ValueError:  # another drive (Windows): keep it absolute
        return str(mesh_file)


def _solid_entries(obj: GraspObject, base_dir) -> dict:
    solid, out = obj.solid, {}
    if isinstance(solid, MeshFileSolid):
        out["mesh"] = _mesh_path(solid.path, base_dir)
        if solid.units is not None:
            out["units"] = solid.units
        else:
            out["scale"] = float(solid.scale)
    elif isinstance(solid, PrimitiveSolid):
        out["shape"] = [primitive_to_dict(p) for p in solid.primitives]
    if solid is not None and not obj.collisions:
        out["collisions"] = False
    if solid is not None and obj.surface_tolerance_mm != SURFACE_TOLERANCE_MM:
        out["surface_tolerance_mm"] = float(obj.surface_tolerance_mm)
    return out


def object_to_dict(obj: GraspObject, base_dir) -> dict:
    """The ``object:`` mapping of ``obj`` (inverse of :func:`object_from_spec`)."""
    out: dict = {"name": obj.name, "regions": {name: region_to_dict(r) for name, r in obj.regions.items()}}
    out.update(_solid_entries(obj, base_dir))
    display: dict = {}
    if obj.primitives:
        display["primitives"] = [primitive_to_dict(p) for p in obj.primitives]
    if obj.mesh_file:
        display["mesh_file"] = _mesh_path(obj.mesh_file, base_dir)
    if display:
        out["display"] = display
    return out
