"""Inline hand mappings, read and written (links, joints, couplings, fingers, regions, frames).

The schema is in the docstring of :mod:`prehension.tasks.yaml_io`; a hand YAML file holds
one such mapping (:mod:`.hand_files`), and a task may hold one under ``hand:``
(:mod:`.task_hands`).  Every error names the source and the field path (see
:mod:`.errors`); a model error (InvalidHand, ...) is re-raised at the field it came from.
"""

from __future__ import annotations

import math

import numpy as np

from ...atomic import to_plain
from ...hands.model import Capsule, Coupling, Finger, Hand, HandRegion, Joint, Link, NamedFrame, _unit3
from ...hands.provenance import HandSource, ShapeFit
from .errors import check_mapping, fail, join_path, located, validate
from .regions import region_from_spec, region_to_dict
from .schema import HandRegionSpec, HandSpec, JointSpec, LinkSpec
from .values import plain_floats, settled_unit, written_deg

__all__ = ["hand_from_dict", "hand_from_data", "hand_regions", "hand_to_dict"]


# -- reading ----------------------------------------------------------------------------
def hand_regions(specs: dict[str, HandRegionSpec], links, source: str, loc: str, hint=None) -> dict[str, HandRegion]:
    """Regions on links; ``hint(name)`` says why a name is not a link (default: the links)."""
    out = {}
    for name, spec in specs.items():
        if spec.link not in links:
            message = hint(spec.link) if hint else f"link {spec.link!r} not found; links are: {', '.join(links)}"
            raise fail(source, join_path(loc, name, "link"), message)
        with located(source, join_path(loc, name)):
            out[name] = HandRegion(spec.link, region_from_spec(spec))
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
    regions = hand_regions(spec.regions, [link.name for link in links], source, join_path(loc, "regions"))
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


def hand_from_data(data, source: str, loc: str) -> Hand:
    """The hand of an inline hand mapping found at field ``loc`` ("" at the top) of ``source``."""
    prefix = (loc,) if loc else ()
    return _build_hand(validate(HandSpec, data, source, prefix), source, loc)


def hand_from_dict(data: dict, source: str = "<dict>") -> Hand:
    """A :class:`Hand` from an inline hand mapping (schema in the docstring of :mod:`prehension.tasks.yaml_io`)."""
    check_mapping(data, source, "a hand is a mapping with keys name, links, joints, ...")
    return hand_from_data(data, source, "")


# -- writing ----------------------------------------------------------------------------
def _joint_axis(v):
    return _unit3(v, "axis")  # what Joint does to both of its axes


def _hand_region_to_dict(hr: HandRegion) -> dict:
    """The ``{link: ..., <region>}`` mapping of a hand region."""
    return {"link": hr.link, **region_to_dict(hr.region)}


def _capsule_to_dict(c: Capsule) -> dict:
    if np.array_equal(c.a, c.b):
        return {"center": plain_floats(c.a), "radius": float(c.radius)}
    return {"a": plain_floats(c.a), "b": plain_floats(c.b), "radius": float(c.radius)}


def _link_to_dict(link: Link) -> dict:
    out: dict = {"name": link.name}
    if link.collision:
        out["collision"] = [_capsule_to_dict(c) for c in link.collision]
    if link.fit is not None:  # what the capsules miss of the link's own shapes, how far they stick out
        f = link.fit
        out["fit"] = {"geometry": f.geometry, "miss_mm": float(f.miss_mm), "stick_out_mm": float(f.stick_out_mm)}
    return out


def _joint_to_dict(j: Joint) -> dict:
    out: dict = {"name": j.name, "type": j.kind, "parent": j.parent, "child": j.child}
    out["origin_in_parent"] = plain_floats(j.origin_in_parent)
    if np.any(j.origin_in_child != 0):
        out["origin_in_child"] = plain_floats(j.origin_in_child)
    out["axis_in_parent"] = settled_unit(j.axis_in_parent, _joint_axis)
    if j.kind == "universal":
        out["axis_in_child"] = settled_unit(j.axis_in_child, _joint_axis)
    if not np.array_equal(j.R_parent_child_zero, np.eye(3)):
        out["rotation_zero"] = plain_floats(j.R_parent_child_zero)
    out["angles"] = [
        {"name": d, "lower_deg": written_deg(lo), "upper_deg": written_deg(hi)}
        for d, lo, hi in zip(j.dof_names, j.lower, j.upper)
    ]
    return out


def _coupling_to_dict(c: Coupling) -> dict:
    return {"angle": c.dof, "source": c.source, "ratio": float(c.ratio), "offset_deg": written_deg(c.offset)}


def _frame_to_dict(frame) -> dict:
    out: dict = {"link": frame.link, "origin": plain_floats(frame.T_link_frame[:3, 3])}
    if not np.array_equal(frame.T_link_frame[:3, :3], np.eye(3)):
        out["rotation"] = plain_floats(frame.T_link_frame[:3, :3])
    return out


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
    if hand.frames:
        out["frames"] = {name: _frame_to_dict(f) for name, f in hand.frames.items()}
    if hand.opposing_finger is not None and hand.opposing_finger != "thumb":
        out["opposing_finger"] = hand.opposing_finger
    if hand.source is not None:
        s = hand.source
        out["source"] = {"format": s.format, "path": s.path, "sha256": s.sha256, "options": to_plain(dict(s.options))}
    return out
