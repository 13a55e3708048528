"""The schema of a task file (pydantic v2): one model a mapping, ``extra="forbid"``.

Besides the models, the names a file may use: the format tag, the built-in hands (and
their aliases) that ``hand:`` may name, and the display primitives of ``object.display.primitives``.
"""

from __future__ import annotations

import difflib
from typing import Annotated, Any, Callable, Literal

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, field_validator, model_validator

from ...hands.model import Hand
from ...hands.sa_hand import schunk_sa_hand
from ...objects.meshes import Box, Cylinder, Ellipsoid, Sphere, Torus

FORMAT_TAG = "task/1"


def _sa_enclosing() -> Hand:
    """The SA hand with enclosing capsules (read on first use: it imports the file-hand assembler)."""
    from ...hands.sa_enclosing import schunk_sa_hand_enclosing

    return schunk_sa_hand_enclosing()


BUILTIN_HANDS: dict[str, Callable[[], Hand]] = {"schunk-sa": schunk_sa_hand, "schunk-sa-enclosing": _sa_enclosing}
HAND_ALIASES = {"sa": "schunk-sa"}  # other names ``hand:`` (and the command line) accept for a built-in hand


def _list_of(n: int, what: str):
    def check(value):
        if not isinstance(value, (list, tuple)) or len(value) != n:
            raise ValueError(f"expected a list of {n} {what}, got {value!r}")
        return value

    return BeforeValidator(check)


MAX_MAGNITUDE = 1e9  # mm (1000 km), degrees...: beyond it a 1e-6 mm tolerance is below a double's resolution


def _bounded(value: float) -> float:
    if abs(value) > MAX_MAGNITUDE:
        raise ValueError(
            f"must be at most {MAX_MAGNITUDE:g} in size (in mm: 1000 km; beyond it the 1e-6 mm tolerances are "
            f"below double precision), got {value:g}"
        )
    return value


Num = Annotated[float, Field(strict=True, allow_inf_nan=False), AfterValidator(_bounded)]
PosNum = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0), AfterValidator(_bounded)]
Vec3 = Annotated[list[Num], _list_of(3, "numbers [x, y, z]")]
PosVec3 = Annotated[list[PosNum], _list_of(3, "positive numbers")]
Mat3 = Annotated[list[Vec3], _list_of(3, "rows of 3 numbers")]
Pair = Annotated[list[Num], _list_of(2, "numbers [lower, upper]")]
Name = Annotated[str, Field(strict=True, min_length=1)]
Text = Annotated[str, Field(strict=True)]
Resolution = Annotated[int, Field(strict=True, ge=3, le=1024)]
ControlNet = Annotated[list[Annotated[list[Vec3], Field(min_length=1)]], Field(min_length=1)]


class _Spec(BaseModel):
    """Base of every schema mapping: unknown keys are errors that list the allowed ones."""

    model_config = ConfigDict(extra="forbid", defer_build=True)

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data):
        if isinstance(data, dict):
            allowed = list(cls.model_fields)
            extra = [k for k in data if k not in allowed]
            if extra:
                hint = difflib.get_close_matches(str(extra[0]), allowed, n=1)
                raise ValueError(
                    f"extra key {extra[0]!r} not allowed here; allowed keys: {', '.join(allowed)}"
                    + (f" (did you mean {hint[0]!r}?)" if hint else "")
                )
        return data


def _exactly_one(spec: BaseModel, keys: tuple[str, ...]) -> str:
    given = [k for k in keys if getattr(spec, k) is not None]
    if len(given) != 1:
        got = f" (got {', '.join(given)})" if given else ""
        raise ValueError(f"give exactly one of {', '.join(keys)}{got}")
    return given[0]


class SphereCapSpec(_Spec):
    center: Vec3
    radius: PosNum
    axis: Vec3
    half_angle_deg: Annotated[float, Field(strict=True, ge=0, le=180)]


class RegionSpec(_Spec):
    bezier: ControlNet | None = None
    sphere_cap: SphereCapSpec | None = None
    point: Vec3 | None = None
    normal: Vec3 | None = None

    @field_validator("bezier")
    @classmethod
    def _rectangular(cls, net):
        if net is not None:
            for i, row in enumerate(net):
                if len(row) != len(net[0]):
                    raise ValueError(
                        f"control net is ragged: row 0 has {len(net[0])} points but row {i} has {len(row)}; "
                        "give an (M+1) x (N+1) grid of [x, y, z] points"
                    )
        return net

    @model_validator(mode="after")
    def _one_kind(self):
        kind = _exactly_one(self, ("bezier", "sphere_cap", "point"))
        if kind == "point" and self.normal is None:
            raise ValueError("a point region needs 'normal' (the outward normal) besides 'point'")
        if kind != "point" and self.normal is not None:
            raise ValueError("'normal' belongs to a point region (give 'point' and 'normal')")
        return self


class HandRegionSpec(RegionSpec):
    link: Name


class CollisionSpec(_Spec):
    a: Vec3 | None = None
    b: Vec3 | None = None
    center: Vec3 | None = None
    radius: PosNum

    @model_validator(mode="after")
    def _capsule_or_sphere(self):
        capsule = self.a is not None and self.b is not None
        if capsule == (self.center is not None) or (self.a is None) != (self.b is None):
            raise ValueError("give either a, b and radius (a capsule) or center and radius (a sphere)")
        return self


class FitSpec(_Spec):
    geometry: Name
    miss_mm: Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0)]
    stick_out_mm: Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0)]


class LinkSpec(_Spec):
    name: Name
    collision: list[CollisionSpec] = []
    fit: FitSpec | None = None


class AngleSpec(_Spec):
    name: Name
    lower_deg: Num
    upper_deg: Num

    @model_validator(mode="after")
    def _ordered(self):
        if self.lower_deg > self.upper_deg:
            raise ValueError(f"lower_deg ({self.lower_deg}) must not exceed upper_deg ({self.upper_deg})")
        return self


class JointSpec(_Spec):
    name: Name
    type: Literal["revolute", "universal"]
    parent: Name
    child: Name
    origin_in_parent: Vec3
    origin_in_child: Vec3 = [0.0, 0.0, 0.0]
    axis_in_parent: Vec3
    axis_in_child: Vec3 | None = None
    rotation_zero: Mat3 | None = None
    angles: list[AngleSpec]

    @model_validator(mode="after")
    def _angles_fit_type(self):
        n = 1 if self.type == "revolute" else 2
        if len(self.angles) != n:
            raise ValueError(f"a {self.type} joint has {n} angle(s); got {len(self.angles)} in 'angles'")
        if self.type == "universal" and self.axis_in_child is None:
            raise ValueError("a universal joint needs axis_in_child (its second axis, child frame)")
        if self.type == "revolute" and self.axis_in_child is not None:
            raise ValueError("a revolute joint has no axis_in_child")
        return self


class CouplingSpec(_Spec):
    angle: Name
    source: Name
    ratio: Num = 1.0
    offset_deg: Num = 0.0


class FingerSpec(_Spec):
    name: Name
    links: Annotated[list[Name], Field(min_length=1)]


class FrameSpec(_Spec):
    link: Name
    origin: Vec3
    rotation: Mat3 | None = None


class SourceSpec(_Spec):
    format: Literal["urdf", "mjcf", "yaml"]
    path: Name
    sha256: Name
    options: dict[str, Any] = {}


class HandSpec(_Spec):
    name: Name
    links: Annotated[list[LinkSpec], Field(min_length=1)]
    joints: list[JointSpec] = []
    couplings: list[CouplingSpec] = []
    fingers: list[FingerSpec] = []
    regions: dict[Name, HandRegionSpec] = {}
    collision_exclusions: list[Annotated[list[Name], _list_of(2, "link names")]] = []
    frames: dict[Name, FrameSpec] = {}
    opposing_finger: Name | None = None
    source: SourceSpec | None = None


class BoxSpec(_Spec):
    center: Vec3
    size: PosVec3


class SphereSpec(_Spec):
    center: Vec3
    radius: PosNum


class EllipsoidSpec(_Spec):
    center: Vec3
    radii: PosVec3
    resolution: Resolution | None = None


class CylinderSpec(_Spec):
    start: Vec3
    end: Vec3
    radius: PosNum
    end_radius: PosNum | None = None
    resolution: Resolution | None = None


class TorusSpec(_Spec):
    center: Vec3
    axis: Vec3
    major: PosNum
    minor: PosNum
    resolution: Resolution | None = None


# File key -> (schema, display primitive class of objects/meshes.py).
PRIMITIVES = {
    "box": (BoxSpec, Box),
    "sphere": (SphereSpec, Sphere),
    "ellipsoid": (EllipsoidSpec, Ellipsoid),
    "cylinder": (CylinderSpec, Cylinder),
    "torus": (TorusSpec, Torus),
}


class PrimitiveSpec(_Spec):
    box: BoxSpec | None = None
    sphere: SphereSpec | None = None
    ellipsoid: EllipsoidSpec | None = None
    cylinder: CylinderSpec | None = None
    torus: TorusSpec | None = None

    @model_validator(mode="after")
    def _one_kind(self):
        _exactly_one(self, tuple(PRIMITIVES))
        return self


class DisplaySpec(_Spec):
    primitives: list[PrimitiveSpec] = []
    mesh_file: Name | None = None


class ObjectSpec(_Spec):
    name: Name
    regions: Annotated[dict[Name, RegionSpec], Field(min_length=1)]
    mesh: Name | None = None  # the solid from a mesh file (relative to the task file)
    scale: PosNum | None = None  # mm per mesh-file unit ...
    units: Literal["mm", "cm", "m", "in"] | None = None  # ... or the file's units
    shape: Annotated[list[PrimitiveSpec], Field(min_length=1)] | None = None  # or a union of primitives
    collisions: Annotated[bool, Field(strict=True)] = True
    surface_tolerance_mm: PosNum | None = None
    display: DisplaySpec | None = None

    @model_validator(mode="after")
    def _one_solid(self):
        if self.mesh is not None and self.shape is not None:
            raise ValueError("give at most one of mesh (a mesh file) and shape (primitives) for the object's solid")
        if self.mesh is not None and (self.scale is None) == (self.units is None):
            raise ValueError(
                "a mesh file carries no units: give exactly one of scale (mm per file unit, e.g. 1000 for metres) "
                "or units (mm, cm, m, in)"
            )
        if self.mesh is None and (self.scale is not None or self.units is not None):
            raise ValueError("scale and units belong to a mesh file: give mesh as well")
        if self.mesh is None and self.shape is None and self.surface_tolerance_mm is not None:
            raise ValueError("surface_tolerance_mm needs a solid: give mesh or shape")
        return self


ANY_HAND = "any"  # ``hand: any``: an open contact, any hand region (docs/assignment.md)


def _hand_side(value):
    """A contact's ``hand:``: a hand region, ``any``, or a list of candidate hand regions."""
    if isinstance(value, str) and value:
        return value
    if isinstance(value, list) and value and all(isinstance(v, str) and v and v != ANY_HAND for v in value):
        if len(set(value)) != len(value):
            raise ValueError(f"candidate hand regions repeat: {value}")
        return value
    raise ValueError(
        f"expected a hand region name, '{ANY_HAND}' (any hand region), or a non-empty list of candidate hand "
        f"region names, got {value!r}"
    )


class ContactSpec(_Spec):
    name: Text = ""
    hand: Annotated[Any, AfterValidator(_hand_side)]
    object: Name

    @property
    def is_open(self) -> bool:
        return self.hand == ANY_HAND or isinstance(self.hand, list)


class TaskSpec(_Spec):
    prehension: Literal["task/1"]
    name: Name
    description: Text = ""
    hand: Any  # built-in name | inline hand | {file: path} | {urdf: path} | {mjcf: path}: read._base_hand
    hand_limits_deg: dict[Name, Pair] = {}
    hand_couplings: Annotated[bool, Field(strict=True)] = True
    hand_regions: dict[Name, HandRegionSpec] = {}
    object: ObjectSpec
    contacts: Annotated[list[ContactSpec], Field(min_length=1)]
    fingers: list[Name] | None = None  # omitted: the fingers of the links the contacts use
    idle_angles_deg: dict[Name, Num] = {}
