"""Writing: tasks, hands and regions -> plain dicts (lists, floats, ints, bools, strings).

A hand that differs from a built-in one only in limits, regions or by having no couplings
is written as the built-in name plus just the differences; angles are written in degrees
rounded to ``_DEG_DECIMALS`` decimals, and unit vectors so that reading and writing again
gives the same numbers (see :func:`_settled`).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Callable

import numpy as np

from ...atomic import to_plain
from ...errors import InvalidTask
from ...geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from ...hands.model import Capsule, Coupling, Hand, HandRegion, Joint, Link, _unit3
from ...objects.model import GraspObject
from ..model import Contact, Task
from .schema import BUILTIN_HANDS, FORMAT_TAG

_DEG_DECIMALS = 12  # degrees are written rounded to this many decimals (1e-12 deg ~ 2e-14 rad)
_BUILTIN_TOL = 1e-9  # a hand "is" the built-in one when its numbers agree to this [mm, unitless]


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
    return _unit3(v, "axis")  # what Joint does to both of its axes


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
    if link.fit is not None:  # what the capsules miss of the link's own shapes, how far they stick out
        f = link.fit
        out["fit"] = {"geometry": f.geometry, "miss_mm": float(f.miss_mm), "stick_out_mm": float(f.stick_out_mm)}
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
    if hand.frames:
        out["frames"] = {name: _frame_to_dict(f) for name, f in hand.frames.items()}
    if hand.opposing_finger is not None and hand.opposing_finger != "thumb":
        out["opposing_finger"] = hand.opposing_finger
    if hand.source is not None:
        s = hand.source
        out["source"] = {"format": s.format, "path": s.path, "sha256": s.sha256, "options": to_plain(dict(s.options))}
    return out


def _frame_to_dict(frame) -> dict:
    out: dict = {"link": frame.link, "origin": _floats(frame.T_link_frame[:3, 3])}
    if not np.array_equal(frame.T_link_frame[:3, :3], np.eye(3)):
        out["rotation"] = _floats(frame.T_link_frame[:3, :3])
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


def _builtin_entries(name, full: dict, builtin: dict) -> dict | None:
    """``hand: <name>`` (or a file reference) plus the differences from the built-in (or
    the file's) hand, or None if not expressible."""
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


def _hand_entries(hand: Hand, base_dir=None, inline: bool = False) -> dict:
    """The ``hand:`` entries of a task: a built-in name or a file reference with the
    task's differences, else (or when ``inline``) the whole hand."""
    from .hand_files import reference_entries

    full = hand_to_dict(hand)
    if inline:
        return {"hand": full}
    if hand.source is not None:
        entries = reference_entries(hand, full, base_dir, _builtin_entries)
        if entries is not None:
            return entries
    elif hand.name in BUILTIN_HANDS:
        entries = _builtin_entries(hand.name, full, _builtin_hand_dict(hand.name))
        if entries is not None:
            return entries
    return {"hand": full}


@functools.lru_cache(maxsize=None)
def _builtin_hand_dict(name: str) -> dict:
    """:func:`hand_to_dict` of a built-in hand (computed once; do not modify)."""
    return hand_to_dict(BUILTIN_HANDS[name]())


def _object_to_dict(obj: GraspObject, base_dir) -> dict:
    from .objects import object_to_dict

    return object_to_dict(obj, base_dir)


def _contact_to_dict(c: Contact) -> dict:
    out = {"name": c.name} if c.name != f"{c.hand_region}->{c.object_region}" else {}
    return {**out, "hand": c.hand_region, "object": c.object_region}


def task_to_dict(task: Task, *, base_dir: Path | str | None = None, hand_inline: bool = False) -> dict:
    """The task-file mapping of ``task``: plain lists, floats, ints, bools and strings.

    ``base_dir``: write ``mesh_file`` and hand file references relative to this folder
    (default: as stored, absolute).  ``hand_inline``: write the whole hand even when it
    comes from a hand file (result files do, so that they can be re-checked alone).
    """
    out: dict = {"prehension": FORMAT_TAG, "name": task.name}
    if task.description:
        out["description"] = task.description
    out.update(_hand_entries(task.hand, base_dir, hand_inline))
    out["object"] = _object_to_dict(task.object, base_dir)
    out["contacts"] = [_contact_to_dict(c) for c in task.contacts]
    out["fingers"] = list(task.fingers)
    if task.idle_angles:
        out["idle_angles_deg"] = {dof: _deg(v) for dof, v in task.idle_angles.items()}
    return out
