"""Reading: checked schema models -> hands, regions, objects and tasks.

Every error names the source and the field path (see :mod:`.errors`); a model error
(InvalidHand, InvalidGeometry, ...) is re-raised at the field it came from.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache
from pathlib import Path

import numpy as np

from ...geometry.bezier import BezierPatch
from ...geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from ...hands.model import Capsule, Coupling, Finger, Hand, HandRegion, Joint, Link, NamedFrame
from ...hands.provenance import HandSource, ShapeFit, file_sha256
from ...objects.model import GraspObject
from ..model import Contact, Task
from .errors import fail, join_path, kind_of, located, validate
from .schema import (
    BUILTIN_HANDS,
    FORMAT_TAG,
    HandRegionSpec,
    HandSpec,
    JointSpec,
    LinkSpec,
    ObjectSpec,
    RegionSpec,
    TaskSpec,
)
from .yaml_text import parse_yaml, read_text


def _region(spec: RegionSpec) -> Region:
    if spec.bezier is not None:
        return BezierRegion(BezierPatch(np.array(spec.bezier, dtype=float)))
    if spec.sphere_cap is not None:
        cap = spec.sphere_cap
        return SphereCap(cap.center, cap.radius, cap.axis, math.radians(cap.half_angle_deg))
    return PointRegion(spec.point, spec.normal)


def _hand_regions(specs: dict[str, HandRegionSpec], links, source: str, loc: str, hint=None) -> dict[str, HandRegion]:
    """Regions on links; ``hint(name)`` says why a name is not a link (default: the links)."""
    out = {}
    for name, spec in specs.items():
        if spec.link not in links:
            message = hint(spec.link) if hint else f"link {spec.link!r} not found; links are: {', '.join(links)}"
            raise fail(source, join_path(loc, name, "link"), message)
        with located(source, join_path(loc, name)):
            out[name] = HandRegion(spec.link, _region(spec))
    return out


def _link(spec: LinkSpec) -> Link:
    shapes = []
    for c in spec.collision:
        a, b = (c.center, c.center) if c.center is not None else (c.a, c.b)
        shapes.append(Capsule(a, b, c.radius))
    fit = None if spec.fit is None else ShapeFit(**spec.fit.model_dump())
    return Link(spec.name, tuple(shapes), fit)


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
        with located(source, join_path(loc, "links", i)):
            links.append(_link(s))
    for i, s in enumerate(spec.joints):
        with located(source, join_path(loc, "joints", i)):
            joints.append(_joint(s))
    for i, s in enumerate(spec.couplings):
        with located(source, join_path(loc, "couplings", i)):
            couplings.append(Coupling(s.angle, s.source, s.ratio, math.radians(s.offset_deg)))
    fingers = [Finger(f.name, tuple(f.links)) for f in spec.fingers]
    regions = _hand_regions(spec.regions, [link.name for link in links], source, join_path(loc, "regions"))
    exclusions = tuple(tuple(p) for p in spec.collision_exclusions)
    frames = {}
    for name, f in spec.frames.items():
        with located(source, join_path(loc, "frames", name)):
            frames[name] = NamedFrame(f.link, _transform(f.rotation, f.origin))
    origin = None if spec.source is None else HandSource(**spec.source.model_dump())
    with located(source, loc):
        return Hand(
            spec.name, tuple(links), tuple(joints), tuple(couplings), tuple(fingers), regions, exclusions,
            frames=frames, opposing_finger=spec.opposing_finger, source=origin,
        )  # fmt: skip


def _transform(rotation, origin) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    T[:3, 3] = origin
    return T


def _hand_from_data(data, source: str, loc: str) -> Hand:
    prefix = (loc,) if loc else ()
    return _build_hand(validate(HandSpec, data, source, prefix), source, loc)


def hand_from_dict(data: dict, source: str = "<dict>") -> Hand:
    """A :class:`Hand` from an inline hand mapping (schema in the docstring of :mod:`prehension.tasks.yaml_io`)."""
    _check_mapping(data, source, "a hand is a mapping with keys name, links, joints, ...")
    return _hand_from_data(data, source, "")


def region_from_dict(data: dict, where: str) -> Region:
    """A contact region from ``{bezier: ...}``, ``{point:, normal:}`` or ``{sphere_cap: ...}``.

    ``where`` starts every error message (e.g. ``"task.yaml: object.regions.knob"``).
    """
    spec = validate(RegionSpec, data, where)
    with located(where, ""):
        return _region(spec)


def _builtin_names() -> str:
    return ", ".join(BUILTIN_HANDS) or "(none)"


def hand_file(path: Path, where: str) -> Hand:
    """The hand of a YAML hand file (one inline hand mapping), its source recorded."""
    text = read_text(path, where)
    data = parse_yaml(text, where)
    _check_mapping(data, where, "a hand file holds one inline hand mapping (name, links, joints, ...)")
    hand = _hand_from_data(data, where, "")
    if hand.source is not None:  # an inline hand that says where it came from
        return hand
    resolved = path.resolve()
    return replace(hand, source=HandSource("yaml", str(resolved), file_sha256(resolved)))


def _hand_file(value: dict, base: Path, source: str) -> Hand:
    if set(value) != {"file"} or not isinstance(value["file"], str) or not value["file"]:
        raise fail(source, "hand", "a hand file reference is {file: path/to/hand.yaml} with no other key")
    path = base / value["file"]
    return hand_file(path, f"{source}: hand.file: {path}")


_HAND_FORMS = "a built-in hand name ({}), an inline hand mapping, {{file: hand.yaml}}, {{urdf: hand.urdf}} or {{mjcf: hand.xml}}"


@lru_cache(maxsize=None)
def _builtin_hand(name: str) -> Hand:
    """A built-in hand, built once per process (a hand is immutable: tasks share it, and so
    do the tables solvers build for it)."""
    return BUILTIN_HANDS[name]()


def _base_hand(value, base: Path, source: str) -> Hand:
    from .hand_files import HAND_ALIASES, hand_from_reference, is_hand_reference

    if isinstance(value, str):
        if HAND_ALIASES.get(value, value) not in BUILTIN_HANDS:
            raise fail(
                source, "hand", f"unknown built-in hand {value!r}; built-in hands are: {_builtin_names()} "
                "(or give an inline hand mapping, {file: hand.yaml}, {urdf: hand.urdf} or {mjcf: hand.xml})",
            )  # fmt: skip
        return _builtin_hand(HAND_ALIASES.get(value, value))
    if isinstance(value, dict) and "file" in value:
        return _hand_file(value, base, source)
    if is_hand_reference(value):
        return hand_from_reference(value, base, source)
    if isinstance(value, dict):
        return _hand_from_data(value, source, "hand")
    raise fail(source, "hand", f"give {_HAND_FORMS.format(_builtin_names())}; got {kind_of(value)}")


def _with_limits(hand: Hand, limits: dict[str, list[float]], source: str) -> Hand:
    for name in limits:
        if name not in hand.dof_names:
            raise fail(
                source, join_path("hand_limits_deg", name),
                f"unknown joint angle {name!r}; angles of {hand.name!r} are: {', '.join(hand.dof_names)}",
            )  # fmt: skip
        if limits[name][0] > limits[name][1]:
            lo, hi = limits[name]
            raise fail(source, join_path("hand_limits_deg", name), f"lower limit {lo} exceeds upper limit {hi}")
    with located(source, "hand_limits_deg"):
        return hand.with_limits({k: (math.radians(lo), math.radians(hi)) for k, (lo, hi) in limits.items()})


def _task_hand(spec: TaskSpec, base: Path, source: str) -> Hand:
    hand = _base_hand(spec.hand, base, source)
    if spec.hand_limits_deg:
        hand = _with_limits(hand, spec.hand_limits_deg, source)
    if not spec.hand_couplings:
        hand = hand.without_couplings()
    if spec.hand_regions:
        extra = _hand_regions(spec.hand_regions, hand.link_names, source, "hand_regions", hand.missing_link_message)
        with located(source, "hand_regions"):
            hand = hand.with_regions(extra)
    return hand


def _task_object(spec: ObjectSpec, base: Path, source: str) -> GraspObject:
    from .objects import object_from_spec

    return object_from_spec(spec, base, source)


def _check_names(spec: TaskSpec, hand: Hand, obj: GraspObject, source: str) -> None:
    """Name the field of an unknown finger, region or angle before Task checks the rest."""
    for i, f in enumerate(spec.fingers):
        with located(source, join_path("fingers", i)):
            hand.finger(f)
    for i, c in enumerate(spec.contacts):
        with located(source, join_path("contacts", i, "hand")):
            hand.region(c.hand)
        with located(source, join_path("contacts", i, "object")):
            obj.region(c.object)
    for dof, value in spec.idle_angles_deg.items():
        with located(source, join_path("idle_angles_deg", dof)):
            k = hand.dof_index(dof)
        lo, hi = math.degrees(hand.lower[k]), math.degrees(hand.upper[k])
        if not lo - 1e-9 <= value <= hi + 1e-9:
            limits = f"[{lo:.6g}, {hi:.6g}] deg"
            raise fail(source, join_path("idle_angles_deg", dof), f"{value} deg is outside the limits {limits}")


def _check_mapping(data, source: str, what: str) -> None:
    if data is None:
        raise fail(source, "", f"the file is empty; {what}")
    if not isinstance(data, dict):
        raise fail(source, "", f"the top level must be a mapping (key: value pairs), got {kind_of(data)}; {what}")


def _check_tag(data: dict, source: str) -> None:
    if "prehension" not in data:
        raise fail(source, "prehension", f"missing format tag; a task file starts with 'prehension: {FORMAT_TAG}'")
    if data["prehension"] != FORMAT_TAG:
        raise fail(
            source, "prehension", f"unsupported format tag {data['prehension']!r}; the supported tag is {FORMAT_TAG!r}"
        )


def task_from_dict(data: dict, *, base_dir: Path | None = None, source: str = "<dict>") -> Task:
    """A :class:`Task` from the mapping of a task file.

    Args:
        data: the parsed task file (schema in the docstring of :mod:`prehension.tasks.yaml_io`).
        base_dir: folder that relative ``hand: {file: ...}`` and ``mesh_file`` paths are
            taken from (default: the current directory).
        source: name that starts every error message (normally the file path).

    Raises:
        InvalidTask: naming ``source``, the field path and what would be valid.
    """
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    _check_mapping(data, source, f"a task file is a mapping that starts with 'prehension: {FORMAT_TAG}'")
    _check_tag(data, source)
    spec = validate(TaskSpec, data, source)
    hand = _task_hand(spec, base, source)
    obj = _task_object(spec.object, base, source)
    _check_names(spec, hand, obj, source)
    contacts = [Contact(c.hand, c.object, c.name) for c in spec.contacts]
    idle = {k: math.radians(v) for k, v in spec.idle_angles_deg.items()}
    with located(source, ""):
        return Task(spec.name, hand, obj, tuple(contacts), tuple(spec.fingers), spec.description, idle)
