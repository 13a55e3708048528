"""Task files: the YAML format of a grasp task, read into and written from the model classes.

A task file is one YAML mapping.  Lengths are millimetres; angles are **degrees** in the
file (every key that holds an angle ends in ``_deg``) and radians in the model classes.
Every mapping is checked with a strict schema (pydantic v2, ``extra="forbid"``): a
misspelt key is an error that lists the keys allowed there, and every error is an
:class:`~prehension.errors.InvalidTask` whose message starts with the file name and the
path of the offending field, e.g. ``bad.yaml: contacts.0.hand: field required``.

Schema (format ``task/1``)::

    prehension: task/1              # required format tag
    name: teapot-lid-lifting        # required, non-empty
    description: "..."              # optional free text
    hand: schunk-sa                 # a built-in hand name (BUILTIN_HANDS), or an inline hand
                                    # mapping (below), or {file: hand.yaml}: a YAML file that
                                    # holds an inline hand mapping (path relative to this file)
    hand_limits_deg:                # optional: replace limits, {angle: [lower, upper]}
      index_mcp_abd: [-22.5, 22.5]
    hand_couplings: true            # optional (default true); false drops every coupling
    hand_regions:                   # optional: new or replacing contact regions on hand links
      index_tip: {link: index_distal, sphere_cap: {center: [20, 0, 0], radius: 13,
                                                   axis: [0.14, 0, 0.99], half_angle_deg: 60}}
    object:
      name: teapot
      regions:                      # at least one; each region gives exactly one of:
        knob: {bezier: [[[x, y, z], [x, y, z]], [[x, y, z], [x, y, z]]]}
                                    #   control_points[i][j], i along u, j along v; any
                                    #   (M+1) x (N+1) grid; outward normal = p_u x p_v
        rim: {point: [x, y, z], normal: [nx, ny, nz]}
        bump: {sphere_cap: {center: [x, y, z], radius: r, axis: [ax, ay, az], half_angle_deg: a}}
      display:                      # optional, only for looking at grasps
        primitives:                 # each item has exactly one key:
          - {box: {center: [0, 0, 0], size: [10, 20, 30]}}
          - {sphere: {center: [0, 0, 0], radius: 5}}
          - {ellipsoid: {center: [0, 0, 0], radii: [5, 6, 7], resolution: 24}}
          - {cylinder: {start: [0, 0, 0], end: [0, 0, 50], radius: 5, end_radius: 3, resolution: 32}}
          - {torus: {center: [0, 0, 0], axis: [0, 0, 1], major: 30, minor: 4, resolution: 32}}
        mesh_file: teapot.off       # optional OFF mesh, relative to this file's folder
    contacts:                       # at least one
      - {hand: index_tip, object: knob}   # optional name: (default "index_tip->knob")
    fingers: [index, thumb]         # required: the fingers that take part
    idle_angles_deg: {ring_mcp_flex: 10}  # optional: angles of idle dofs

Inline hand mapping (also the content of a ``{file: ...}`` hand file)::

    name: my-hand
    links:                          # the first link is the palm
      - name: palm
        collision: [{a: [x, y, z], b: [x, y, z], radius: 10}, {center: [x, y, z], radius: 5}]
    joints:                         # from the palm outwards
      - name: index_mcp
        type: universal             # or revolute
        parent: palm
        child: index_proximal
        origin_in_parent: [x, y, z]
        origin_in_child: [0, 0, 0]  # optional, default zeros
        axis_in_parent: [1, 0, 0]
        axis_in_child: [0, -1, 0]   # universal joints only
        rotation_zero: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]  # rows; optional, default identity
        angles:                     # 1 (revolute) or 2 (universal)
          - {name: index_mcp_abd, lower_deg: -15, upper_deg: 15}
          - {name: index_mcp_flex, lower_deg: -4, upper_deg: 75}
    couplings: [{angle: index_dip, source: index_pip, ratio: 1.0, offset_deg: 0.0}]
    fingers: [{name: index, links: [index_proximal, index_middle, index_distal]}]
    regions: {index_tip: {link: index_distal, sphere_cap: {...}}}
    collision_exclusions: [[link_a, link_b]]

Writing (:func:`task_to_dict`): a hand whose name is a built-in one and that differs from
that built-in only in limits, regions, or by having no couplings is written as the
name plus ``hand_limits_deg`` / ``hand_couplings: false`` / ``hand_regions`` for just the
differences; any other hand is written inline.  Angles are written in degrees rounded to
12 decimals, and unit vectors as the nearest value that the model's own normalisation
leaves unchanged, so that reading a written task and writing it again gives the same
dict.

Reading refuses duplicate keys in a mapping (plain ``yaml.safe_load`` silently keeps the
last one).  See ``docs/task-format.md`` for a complete example.
"""

from __future__ import annotations

import contextlib
import dataclasses
import difflib
import math
import os
from pathlib import Path
from typing import Annotated, Any, Callable, Iterator, Literal

import numpy as np
import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..atomic import write_text_atomic
from ..errors import InvalidTask, PrehensionError
from ..geometry.bezier import BezierPatch
from ..geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from ..hands.model import Capsule, Coupling, Finger, Hand, HandRegion, Joint, Link
from ..hands.sa_hand import schunk_sa_hand
from ..objects.meshes import Box, Cylinder, Ellipsoid, Sphere, Torus
from ..objects.model import GraspObject
from .model import Contact, Task

__all__ = [
    "FORMAT_TAG",
    "BUILTIN_HANDS",
    "task_from_dict",
    "task_to_dict",
    "load_task",
    "loads_task",
    "dump_task",
    "dumps_task",
    "hand_from_dict",
    "hand_to_dict",
    "region_from_dict",
    "region_to_dict",
]

FORMAT_TAG = "task/1"
BUILTIN_HANDS: dict[str, Callable[[], Hand]] = {"schunk-sa": schunk_sa_hand}

_DEG_DECIMALS = 12  # degrees are written rounded to this many decimals (1e-12 deg ~ 2e-14 rad)
_BUILTIN_TOL = 1e-9  # a hand "is" the built-in one when its numbers agree to this [mm, unitless]


# ======================================================================================
# Error reporting
# ======================================================================================
def _join(*parts) -> str:
    return ".".join(str(p) for p in parts if p != "" and p is not None)


def _fail(source: str, loc: str, message: str) -> InvalidTask:
    """An :class:`InvalidTask` reading ``"<source>: <loc>: <message>"`` (marked as located)."""
    exc = InvalidTask(": ".join(p for p in (source, loc, message) if p))
    exc._prehension_located = True  # type: ignore[attr-defined]
    return exc


@contextlib.contextmanager
def _located(source: str, loc: str) -> Iterator[None]:
    """Re-raise a model error (InvalidHand, InvalidGeometry, ...) as a located InvalidTask."""
    try:
        yield
    except PrehensionError as exc:
        if getattr(exc, "_prehension_located", False):
            raise
        raise _fail(source, loc, str(exc)) from None


def _kind(value) -> str:
    names = {dict: "a mapping", list: "a list", str: "a string", type(None): "nothing (null)"}
    return names.get(type(value), type(value).__name__)


def _pydantic_message(err: dict) -> str:
    """One pydantic error as plain words (no pydantic jargon, no URLs)."""
    kind, ctx, value = err["type"], err.get("ctx") or {}, err.get("input")
    if kind == "missing":
        return "field required"
    if kind in ("value_error", "assertion_error"):
        return err["msg"].split(", ", 1)[-1] if err["msg"].startswith(("Value error", "Assertion")) else err["msg"]
    if kind in ("model_type", "dict_type", "model_attributes_type"):
        return f"expected a mapping (key: value pairs), got {_kind(value)}"
    if kind in ("list_type", "tuple_type"):
        return f"expected a list, got {_kind(value)}"
    if kind == "too_short":
        return f"needs at least {ctx.get('min_length')} item(s), got {ctx.get('actual_length')}"
    if kind == "too_long":
        return f"takes at most {ctx.get('max_length')} item(s), got {ctx.get('actual_length')}"
    if kind == "extra_forbidden":
        return "extra key not allowed here"
    msg = err["msg"].replace("Input should be", "must be", 1)
    if isinstance(value, (int, float, str, bool)) or value is None:
        msg += f" (got {value!r})"
    return msg


def _validation_error(exc: ValidationError, source: str, prefix: tuple = ()) -> InvalidTask:
    lines = []
    for err in exc.errors(include_url=False):
        loc = _join(*prefix, *err["loc"])
        lines.append(": ".join(p for p in (source, loc, _pydantic_message(err)) if p))
    more = f"\n(and {len(lines) - 10} more)" if len(lines) > 10 else ""
    result = InvalidTask("\n".join(lines[:10]) + more)
    result._prehension_located = True  # type: ignore[attr-defined]
    return result


def _validate(spec_cls, data, source: str, prefix: tuple = ()):
    try:
        return spec_cls.model_validate(data)
    except ValidationError as exc:
        raise _validation_error(exc, source, prefix) from None


# ======================================================================================
# Schema (pydantic v2)
# ======================================================================================
def _list_of(n: int, what: str):
    def check(value):
        if not isinstance(value, (list, tuple)) or len(value) != n:
            raise ValueError(f"expected a list of {n} {what}, got {value!r}")
        return value

    return BeforeValidator(check)


Num = Annotated[float, Field(strict=True, allow_inf_nan=False)]
PosNum = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0)]
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

    model_config = ConfigDict(extra="forbid")

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


class LinkSpec(_Spec):
    name: Name
    collision: list[CollisionSpec] = []


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


class HandSpec(_Spec):
    name: Name
    links: Annotated[list[LinkSpec], Field(min_length=1)]
    joints: list[JointSpec] = []
    couplings: list[CouplingSpec] = []
    fingers: list[FingerSpec] = []
    regions: dict[Name, HandRegionSpec] = {}
    collision_exclusions: list[Annotated[list[Name], _list_of(2, "link names")]] = []


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
_PRIMITIVES = {
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
        _exactly_one(self, tuple(_PRIMITIVES))
        return self


class DisplaySpec(_Spec):
    primitives: list[PrimitiveSpec] = []
    mesh_file: Name | None = None


class ObjectSpec(_Spec):
    name: Name
    regions: Annotated[dict[Name, RegionSpec], Field(min_length=1)]
    display: DisplaySpec | None = None


class ContactSpec(_Spec):
    name: Text = ""
    hand: Name
    object: Name


class TaskSpec(_Spec):
    prehension: Literal["task/1"]
    name: Name
    description: Text = ""
    hand: Any  # built-in name | inline hand | {file: path}: dispatched by _base_hand
    hand_limits_deg: dict[Name, Pair] = {}
    hand_couplings: Annotated[bool, Field(strict=True)] = True
    hand_regions: dict[Name, HandRegionSpec] = {}
    object: ObjectSpec
    contacts: Annotated[list[ContactSpec], Field(min_length=1)]
    fingers: list[Name]
    idle_angles_deg: dict[Name, Num] = {}


# ======================================================================================
# Reading: schema -> model classes
# ======================================================================================
def _region(spec: RegionSpec) -> Region:
    if spec.bezier is not None:
        return BezierRegion(BezierPatch(np.array(spec.bezier, dtype=float)))
    if spec.sphere_cap is not None:
        cap = spec.sphere_cap
        return SphereCap(cap.center, cap.radius, cap.axis, math.radians(cap.half_angle_deg))
    return PointRegion(spec.point, spec.normal)


def _hand_regions(specs: dict[str, HandRegionSpec], links, source: str, loc: str) -> dict[str, HandRegion]:
    out = {}
    for name, spec in specs.items():
        if spec.link not in links:
            known = ", ".join(links)
            raise _fail(source, _join(loc, name, "link"), f"link {spec.link!r} not found; links are: {known}")
        with _located(source, _join(loc, name)):
            out[name] = HandRegion(spec.link, _region(spec))
    return out


def _link(spec: LinkSpec) -> Link:
    shapes = []
    for c in spec.collision:
        a, b = (c.center, c.center) if c.center is not None else (c.a, c.b)
        shapes.append(Capsule(a, b, c.radius))
    return Link(spec.name, tuple(shapes))


def _joint(spec: JointSpec) -> Joint:
    return Joint(
        spec.name, spec.type, spec.parent, spec.child, spec.origin_in_parent, spec.origin_in_child,
        spec.axis_in_parent, np.eye(3) if spec.rotation_zero is None else spec.rotation_zero,
        tuple(a.name for a in spec.angles), tuple(math.radians(a.lower_deg) for a in spec.angles),
        tuple(math.radians(a.upper_deg) for a in spec.angles), axis_in_child=spec.axis_in_child,
    )  # fmt: skip


def _build_hand(spec: HandSpec, source: str, loc: str) -> Hand:
    links, joints, couplings = [], [], []
    for i, s in enumerate(spec.links):
        with _located(source, _join(loc, "links", i)):
            links.append(_link(s))
    for i, s in enumerate(spec.joints):
        with _located(source, _join(loc, "joints", i)):
            joints.append(_joint(s))
    for i, s in enumerate(spec.couplings):
        with _located(source, _join(loc, "couplings", i)):
            couplings.append(Coupling(s.angle, s.source, s.ratio, math.radians(s.offset_deg)))
    fingers = [Finger(f.name, tuple(f.links)) for f in spec.fingers]
    regions = _hand_regions(spec.regions, [link.name for link in links], source, _join(loc, "regions"))
    exclusions = tuple(tuple(p) for p in spec.collision_exclusions)
    with _located(source, loc):
        return Hand(spec.name, tuple(links), tuple(joints), tuple(couplings), tuple(fingers), regions, exclusions)


def _hand_from_data(data, source: str, loc: str) -> Hand:
    prefix = (loc,) if loc else ()
    return _build_hand(_validate(HandSpec, data, source, prefix), source, loc)


def hand_from_dict(data: dict, source: str = "<dict>") -> Hand:
    """A :class:`Hand` from an inline hand mapping (see the module docstring)."""
    _check_mapping(data, source, "a hand is a mapping with keys name, links, joints, ...")
    return _hand_from_data(data, source, "")


def region_from_dict(data: dict, where: str) -> Region:
    """A contact region from ``{bezier: ...}``, ``{point:, normal:}`` or ``{sphere_cap: ...}``.

    ``where`` starts every error message (e.g. ``"task.yaml: object.regions.knob"``).
    """
    spec = _validate(RegionSpec, data, where)
    with _located(where, ""):
        return _region(spec)


def _builtin_names() -> str:
    return ", ".join(BUILTIN_HANDS) or "(none)"


def _hand_file(value: dict, base: Path, source: str) -> Hand:
    if set(value) != {"file"} or not isinstance(value["file"], str) or not value["file"]:
        raise _fail(source, "hand", "a hand file reference is {file: path/to/hand.yaml} with no other key")
    path = base / value["file"]
    where = f"{source}: hand.file: {path}"
    text = _read_text(path, where)
    data = _parse_yaml(text, where)
    _check_mapping(data, where, "a hand file holds one inline hand mapping (name, links, joints, ...)")
    return _hand_from_data(data, where, "")


def _base_hand(value, base: Path, source: str) -> Hand:
    if isinstance(value, str):
        if value not in BUILTIN_HANDS:
            raise _fail(
                source, "hand",
                f"unknown built-in hand {value!r}; built-in hands are: {_builtin_names()} "
                "(or give an inline hand mapping, or {file: path})",
            )  # fmt: skip
        return BUILTIN_HANDS[value]()
    if isinstance(value, dict) and "file" in value:
        return _hand_file(value, base, source)
    if isinstance(value, dict):
        return _hand_from_data(value, source, "hand")
    raise _fail(
        source, "hand",
        f"give a built-in hand name ({_builtin_names()}), an inline hand mapping or {{file: path}}; got {_kind(value)}",
    )  # fmt: skip


def _with_limits(hand: Hand, limits: dict[str, list[float]], source: str) -> Hand:
    for name in limits:
        if name not in hand.dof_names:
            raise _fail(
                source, _join("hand_limits_deg", name),
                f"unknown joint angle {name!r}; angles of {hand.name!r} are: {', '.join(hand.dof_names)}",
            )  # fmt: skip
        if limits[name][0] > limits[name][1]:
            lo, hi = limits[name]
            raise _fail(source, _join("hand_limits_deg", name), f"lower limit {lo} exceeds upper limit {hi}")
    with _located(source, "hand_limits_deg"):
        return hand.with_limits({k: (math.radians(lo), math.radians(hi)) for k, (lo, hi) in limits.items()})


def _task_hand(spec: TaskSpec, base: Path, source: str) -> Hand:
    hand = _base_hand(spec.hand, base, source)
    if spec.hand_limits_deg:
        hand = _with_limits(hand, spec.hand_limits_deg, source)
    if not spec.hand_couplings:
        hand = hand.without_couplings()
    if spec.hand_regions:
        extra = _hand_regions(spec.hand_regions, hand.link_names, source, "hand_regions")
        with _located(source, "hand_regions"):
            hand = hand.with_regions(extra)
    return hand


def _primitive(spec: PrimitiveSpec, source: str, loc: str):
    for key, (_, cls) in _PRIMITIVES.items():
        sub = getattr(spec, key)
        if sub is not None:
            fields = {k: (tuple(v) if isinstance(v, list) else v) for k, v in sub.model_dump(exclude_none=True).items()}
            with _located(source, _join(loc, key)):
                prim = cls(**fields)
                prim.mesh()  # checks what the schema cannot (e.g. a cylinder of zero length)
            return prim
    raise AssertionError("unreachable: PrimitiveSpec holds exactly one primitive")


def _mesh_file(name: str | None, base: Path, source: str) -> str | None:
    if name is None:
        return None
    path = (base / name).resolve()
    if not path.is_file():
        raise _fail(source, "object.display.mesh_file", f"mesh file not found: {path}")
    return str(path)


def _task_object(spec: ObjectSpec, base: Path, source: str) -> GraspObject:
    regions = {}
    for name, r in spec.regions.items():
        with _located(source, _join("object.regions", name)):
            regions[name] = _region(r)
    display = spec.display or DisplaySpec()
    prims = [_primitive(p, source, _join("object.display.primitives", i)) for i, p in enumerate(display.primitives)]
    mesh = _mesh_file(display.mesh_file, base, source)
    with _located(source, "object"):
        return GraspObject(spec.name, regions, tuple(prims), mesh)


def _check_names(spec: TaskSpec, hand: Hand, obj: GraspObject, source: str) -> None:
    """Name the field of an unknown finger, region or angle before Task checks the rest."""
    for i, f in enumerate(spec.fingers):
        with _located(source, _join("fingers", i)):
            hand.finger(f)
    for i, c in enumerate(spec.contacts):
        with _located(source, _join("contacts", i, "hand")):
            hand.region(c.hand)
        with _located(source, _join("contacts", i, "object")):
            obj.region(c.object)
    for dof, value in spec.idle_angles_deg.items():
        with _located(source, _join("idle_angles_deg", dof)):
            k = hand.dof_index(dof)
        lo, hi = math.degrees(hand.lower[k]), math.degrees(hand.upper[k])
        if not lo - 1e-9 <= value <= hi + 1e-9:
            limits = f"[{lo:.6g}, {hi:.6g}] deg"
            raise _fail(source, _join("idle_angles_deg", dof), f"{value} deg is outside the limits {limits}")


def _check_mapping(data, source: str, what: str) -> None:
    if data is None:
        raise _fail(source, "", f"the file is empty; {what}")
    if not isinstance(data, dict):
        raise _fail(source, "", f"the top level must be a mapping (key: value pairs), got {_kind(data)}; {what}")


def _check_tag(data: dict, source: str) -> None:
    if "prehension" not in data:
        raise _fail(source, "prehension", f"missing format tag; a task file starts with 'prehension: {FORMAT_TAG}'")
    if data["prehension"] != FORMAT_TAG:
        raise _fail(
            source, "prehension", f"unsupported format tag {data['prehension']!r}; the supported tag is {FORMAT_TAG!r}"
        )


def task_from_dict(data: dict, *, base_dir: Path | None = None, source: str = "<dict>") -> Task:
    """A :class:`Task` from the mapping of a task file.

    Args:
        data: the parsed task file (see the module docstring for the schema).
        base_dir: folder that relative ``hand: {file: ...}`` and ``mesh_file`` paths are
            taken from (default: the current directory).
        source: name that starts every error message (normally the file path).

    Raises:
        InvalidTask: naming ``source``, the field path and what would be valid.
    """
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    _check_mapping(data, source, f"a task file is a mapping that starts with 'prehension: {FORMAT_TAG}'")
    _check_tag(data, source)
    spec = _validate(TaskSpec, data, source)
    hand = _task_hand(spec, base, source)
    obj = _task_object(spec.object, base, source)
    _check_names(spec, hand, obj, source)
    contacts = [Contact(c.hand, c.object, c.name) for c in spec.contacts]
    idle = {k: math.radians(v) for k, v in spec.idle_angles_deg.items()}
    with _located(source, ""):
        return Task(spec.name, hand, obj, tuple(contacts), tuple(spec.fingers), spec.description, idle)


# ======================================================================================
# Writing: model classes -> plain dicts
# ======================================================================================
def _deg(rad: float) -> float:
    return round(math.degrees(float(rad)), _DEG_DECIMALS) + 0.0  # "+ 0.0" turns -0.0 into 0.0


def _floats(values) -> list:
    """A (nested) list of plain floats, without negative zeros."""
    arr = np.asarray(values, dtype=float) + 0.0
    return arr.tolist()


def _settled(vector, canon: Callable[[np.ndarray], np.ndarray]) -> list[float]:
    """A unit vector within a few ulps of ``vector`` that ``canon`` (the model's own
    normalisation) maps exactly onto itself, so that writing, reading and writing again
    gives the same numbers.  Deterministic; falls back to ``canon(vector)``."""
    y = canon(np.asarray(vector, dtype=float))
    for _ in range(8):
        z = canon(y)
        if np.array_equal(z, y):
            return _floats(y)
        y = z
    rng = np.random.default_rng(0)
    for _ in range(500):
        cand = canon(y + rng.integers(-2, 3, size=y.shape) * (y != 0) * np.spacing(y))
        if np.array_equal(canon(cand), cand):
            return _floats(cand)
    return _floats(y)


_ZERO3 = np.zeros(3)


def _joint_axis(v):
    return Joint("axis", "revolute", "p", "c", _ZERO3, _ZERO3, v, np.eye(3), ("q",), (0.0,), (0.0,)).axis_in_parent


def _cap_axis(v):
    return SphereCap(_ZERO3, 1.0, v, 0.0).axis


def _point_normal(v):
    return PointRegion(_ZERO3, v).normal


def region_to_dict(region: Region) -> dict:
    """The file mapping of a contact region (inverse of :func:`region_from_dict`)."""
    if isinstance(region, BezierRegion):
        return {"bezier": _floats(region.patch.control_points)}
    if isinstance(region, SphereCap):
        cap = {
            "center": _floats(region.center),
            "radius": float(region.radius),
            "axis": _settled(region.axis, _cap_axis),
            "half_angle_deg": _deg(region.half_angle),
        }
        return {"sphere_cap": cap}
    if isinstance(region, PointRegion):
        return {"point": _floats(region.point), "normal": _settled(region.normal, _point_normal)}
    kind = type(region).__name__
    raise InvalidTask(f"cannot write a region of type {kind}; task files hold bezier, sphere_cap, point")


def _hand_region_to_dict(hr: HandRegion) -> dict:
    return {"link": hr.link, **region_to_dict(hr.region)}


def _capsule_to_dict(c: Capsule) -> dict:
    if np.array_equal(c.a, c.b):
        return {"center": _floats(c.a), "radius": float(c.radius)}
    return {"a": _floats(c.a), "b": _floats(c.b), "radius": float(c.radius)}


def _link_to_dict(link: Link) -> dict:
    out: dict = {"name": link.name}
    if link.collision:
        out["collision"] = [_capsule_to_dict(c) for c in link.collision]
    return out


def _joint_to_dict(j: Joint) -> dict:
    out: dict = {"name": j.name, "type": j.kind, "parent": j.parent, "child": j.child}
    out["origin_in_parent"] = _floats(j.origin_in_parent)
    if np.any(j.origin_in_child != 0):
        out["origin_in_child"] = _floats(j.origin_in_child)
    out["axis_in_parent"] = _settled(j.axis_in_parent, _joint_axis)
    if j.kind == "universal":
        out["axis_in_child"] = _settled(j.axis_in_child, _joint_axis)
    if not np.array_equal(j.R_parent_child_zero, np.eye(3)):
        out["rotation_zero"] = _floats(j.R_parent_child_zero)
    out["angles"] = [
        {"name": d, "lower_deg": _deg(lo), "upper_deg": _deg(hi)} for d, lo, hi in zip(j.dof_names, j.lower, j.upper)
    ]
    return out


def _coupling_to_dict(c: Coupling) -> dict:
    return {"angle": c.dof, "source": c.source, "ratio": float(c.ratio), "offset_deg": _deg(c.offset)}


def hand_to_dict(hand: Hand) -> dict:
    """The inline hand mapping of ``hand`` (plain Python types; inverse of :func:`hand_from_dict`)."""
    out: dict = {
        "name": hand.name,
        "links": [_link_to_dict(link) for link in hand.links],
        "joints": [_joint_to_dict(j) for j in hand.joints],
    }
    if hand.couplings:
        out["couplings"] = [_coupling_to_dict(c) for c in hand.couplings]
    if hand.fingers:
        out["fingers"] = [{"name": f.name, "links": list(f.links)} for f in hand.fingers]
    if hand.regions:
        out["regions"] = {name: _hand_region_to_dict(r) for name, r in hand.regions.items()}
    if hand.collision_exclusions:
        out["collision_exclusions"] = [list(p) for p in hand.collision_exclusions]
    return out


def _close(a, b, tol: float = _BUILTIN_TOL) -> bool:
    """Structural equality of plain dicts/lists, floats compared to ``tol``."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k], tol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y, tol) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) <= tol
    return type(a) is type(b) and a == b


def _core(hand_dict: dict) -> dict:
    """A hand mapping without what a task may change: regions, couplings, limits."""
    core = {k: v for k, v in hand_dict.items() if k not in ("regions", "couplings")}
    core["joints"] = [
        {**j, "angles": [a["name"] for a in j["angles"]]} for j in hand_dict["joints"]
    ]
    return core


def _limits(hand_dict: dict) -> dict[str, list[float]]:
    return {a["name"]: [a["lower_deg"], a["upper_deg"]] for j in hand_dict["joints"] for a in j["angles"]}


def _builtin_entries(name: str, full: dict, builtin: dict) -> dict | None:
    """``hand: <name>`` plus the differences from the built-in hand, or None if not expressible."""
    if not _close(_core(full), _core(builtin)):
        return None
    out: dict = {"hand": name}
    base_limits = _limits(builtin)
    limits = {d: lim for d, lim in _limits(full).items() if lim != base_limits[d]}
    if limits:
        out["hand_limits_deg"] = limits
    couplings, base_couplings = full.get("couplings", []), builtin.get("couplings", [])
    if not _close(couplings, base_couplings):
        if couplings:
            return None
        out["hand_couplings"] = False
    regions, base_regions = full.get("regions", {}), builtin.get("regions", {})
    if not set(base_regions) <= set(regions):
        return None  # a task can add or replace built-in regions, not remove them
    changed = {k: r for k, r in regions.items() if k not in base_regions or not _close(r, base_regions[k])}
    if changed:
        out["hand_regions"] = changed
    return out


def _hand_entries(hand: Hand) -> dict:
    full = hand_to_dict(hand)
    make = BUILTIN_HANDS.get(hand.name)
    if make is not None:
        entries = _builtin_entries(hand.name, full, hand_to_dict(make()))
        if entries is not None:
            return entries
    return {"hand": full}


def _primitive_to_dict(prim) -> dict:
    for key, (_, cls) in _PRIMITIVES.items():
        if type(prim) is cls:
            fields = {}
            for f in dataclasses.fields(cls):
                value = getattr(prim, f.name)
                if f.default is not dataclasses.MISSING and value == f.default:
                    continue
                fields[f.name] = int(value) if f.name == "resolution" else _floats(value)
            return {key: fields}
    raise InvalidTask(f"cannot write a display primitive of type {type(prim).__name__}; use {', '.join(_PRIMITIVES)}")


def _mesh_path(mesh_file: str, base_dir) -> str:
    if base_dir is None:
        return str(mesh_file)
    try:
        return Path(os.path.relpath(Path(mesh_file).resolve(), Path(base_dir).resolve())).as_posix()
    except ValueError:  # another drive (Windows): keep it absolute
        return str(mesh_file)


def _object_to_dict(obj: GraspObject, base_dir) -> dict:
    out: dict = {"name": obj.name, "regions": {name: region_to_dict(r) for name, r in obj.regions.items()}}
    display: dict = {}
    if obj.primitives:
        display["primitives"] = [_primitive_to_dict(p) for p in obj.primitives]
    if obj.mesh_file:
        display["mesh_file"] = _mesh_path(obj.mesh_file, base_dir)
    if display:
        out["display"] = display
    return out


def _contact_to_dict(c: Contact) -> dict:
    out = {"name": c.name} if c.name != f"{c.hand_region}->{c.object_region}" else {}
    return {**out, "hand": c.hand_region, "object": c.object_region}


def task_to_dict(task: Task, *, base_dir: Path | str | None = None) -> dict:
    """The task-file mapping of ``task``: plain lists, floats, ints, bools and strings.

    ``base_dir``: write ``mesh_file`` relative to this folder (default: as stored, absolute).
    """
    out: dict = {"prehension": FORMAT_TAG, "name": task.name}
    if task.description:
        out["description"] = task.description
    out.update(_hand_entries(task.hand))
    out["object"] = _object_to_dict(task.object, base_dir)
    out["contacts"] = [_contact_to_dict(c) for c in task.contacts]
    out["fingers"] = list(task.fingers)
    if task.idle_angles:
        out["idle_angles_deg"] = {dof: _deg(v) for dof, v in task.idle_angles.items()}
    return out


# ======================================================================================
# YAML text and files
# ======================================================================================
class _Loader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses duplicate keys (PyYAML silently keeps the last)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=deep)
                with contextlib.suppress(TypeError):  # unhashable keys: the base class reports them
                    if key in seen:
                        raise yaml.constructor.ConstructorError(
                            "while reading a mapping", node.start_mark, f"duplicate key {key!r}", key_node.start_mark
                        )
                    seen.add(key)
        return super().construct_mapping(node, deep=deep)


def _parse_yaml(text: str, source: str):
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = f" (line {mark.line + 1})" if mark is not None else ""
        context = ""
        if exc.context and exc.context_mark is not None:
            context = f" ({exc.context} on line {exc.context_mark.line + 1})"
        raise _fail(source, "", f"not valid YAML{line}: {exc.problem or exc.context}{context}") from None
    except yaml.YAMLError as exc:
        raise _fail(source, "", f"not valid YAML: {exc}") from None


def _read_text(path: Path, source: str) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise _fail(source, "", "not a UTF-8 text file") from None
    except OSError as exc:
        raise _fail(source, "", f"cannot read the file: {exc.strerror or exc}") from None


def loads_task(text: str, source: str = "<string>", *, base_dir: Path | None = None) -> Task:
    """A :class:`Task` from the YAML text of a task file."""
    return task_from_dict(_parse_yaml(text, source), base_dir=base_dir, source=source)


def load_task(path) -> Task:
    """Read a task file; relative paths inside it are taken from its folder."""
    path = Path(path)
    source = str(path)
    return loads_task(_read_text(path, source), source, base_dir=path.parent)


class _FlowList(list):
    pass


class _FlowDict(dict):
    pass


class _Dumper(yaml.SafeDumper):
    def ignore_aliases(self, data):
        return True


_Dumper.add_representer(
    _FlowList, lambda d, x: d.represent_sequence("tag:yaml.org,2002:seq", x, flow_style=True)
)
_Dumper.add_representer(
    _FlowDict, lambda d, x: d.represent_mapping("tag:yaml.org,2002:map", x, flow_style=True)
)


def _is_flat(value) -> bool:
    if isinstance(value, list):
        return all(_is_flat(v) for v in value)
    return not isinstance(value, dict)


def _depth(value) -> int:
    return 1 + max((_depth(v) for v in value), default=0) if isinstance(value, list) else 0


def _styled(value):
    """Mark short lists (and short flat mappings) for YAML flow style, e.g. [1.0, 2.0, 3.0]."""
    if isinstance(value, dict):
        out = {k: _styled(v) for k, v in value.items()}
        short = all(_is_flat(v) for v in value.values()) and len(repr(value)) <= 90
        return _FlowDict(out) if short and value else out
    if isinstance(value, list):
        items = [_styled(v) for v in value]
        flow = _is_flat(value) and (_depth(value) <= 1 or (_depth(value) == 2 and len(repr(value)) <= 80))
        return _FlowList(items) if flow else items
    return value


def dumps_task(task: Task, *, base_dir: Path | str | None = None) -> str:
    """The YAML text of a task file (keys in schema order, short lists in flow style)."""
    data = _styled(task_to_dict(task, base_dir=base_dir))
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)


def dump_task(task: Task, path) -> None:
    """Write ``task`` to ``path`` atomically (a reader sees the old file or the new one)."""
    path = Path(path)
    text = dumps_task(task, base_dir=path.resolve().parent)
    write_text_atomic(path, text)
