"""A :class:`~prehension.hands.description.RawHand` (any file format) -> a :class:`Hand`.

1. **Tree.**  The root is ``root=`` if given, else the unique link that is no joint's
   child.  Joints are ordered depth-first from it (parent before child, a finger's together).
2. **Fixed joints merged.**  A link joined to its parent by a fixed joint (or by a joint
   type prehension does not model: prismatic, ball, free...) is merged into its nearest
   ancestor that is joined by a revolute joint (or the root): its shapes and outgoing
   joints are re-expressed in that ancestor's frame, whose name is kept, and it stays on
   the hand as a named frame (:attr:`Hand.frames`).  Every surviving link keeps its file
   frame, so link poses agree with any tool that reads the file.
3. **Palm.**  Without ``root=`` the palm is the first link, going down from the root, where
   the tree branches (into subtrees that hold a revolute joint: tip frames and sites do
   not count).  The links rigidly attached to it (by fixed joints, up to the nearest
   revolute joint above it) are merged into it; a forearm and a wrist above that joint
   are cut off, with a note saying how to keep them (``root=``).  A tree that never
   branches keeps its root.
4. **Joints** become revolute :class:`Joint` s: ``T_parent_child(q) = T_pj Rot(a, q) T_jc``
   gives ``P = t_pj``, ``Q = -R_jc^T t_jc``, ``R0 = R_pj R_jc`` and ``u = R_pj a``.  A joint
   of an unsupported type below the palm is held at its reference position, with a
   warning.  **Couplings** chained through coupled sources are resolved to the
   independent source: ``q_K = m m' q_J + (m o' + o)``.
5. **Collision capsules** enclosing the collision shapes (:mod:`prehension.hands.shapes`),
   each link with what they miss and how far they stick out (:attr:`Link.fit`,
   :mod:`prehension.hands.enclosure`); a shape that cannot be read is skipped with a warning, and a link that has visual
   shapes but no collision capsule is named in a warning (it is not checked for
   self-collision).  Link pairs whose capsules overlap at the rest pose (zero angles
   clamped into the limits) are excluded from self-collision checks, with a note.
6. **Fingers** (:mod:`prehension.hands.fingers`) and **fingertips**
   (:mod:`prehension.hands.fingertips`): a ``<finger>_tip`` sphere cap per finger whose
   distal link has geometry (or whose fingertip the user gave in full).

Every note and warning is recorded on the hand (:attr:`Hand.notes`, warnings start with
``"warning: "``).
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field, replace
from typing import Mapping

import numpy as np

from ..errors import InvalidHand
from .collision import capsule_clearances
from .enclosure import link_fit
from .link_cache import cached_link_fit, link_key
from .description import RawHand, RawShape
from .fingers import CLOSURES, closure, finger_chains, finger_names, make_fingers
from .fingertips import PadFrame, TipOverride, apply_override, cap_axis, fit_fingertip, pad_frame
from .kinematics import forward_kinematics
from .model import Capsule, Hand, HandRegion, Link, LinkMesh, NamedFrame
from .provenance import ShapeFit
from .shapes import shape_capsules, surface_points
from .tree import couplings, make_joint, rooted

__all__ = ["ImportOptions", "assemble", "rest_pose", "with_rest_exclusions"]

_FIXED_TYPES = ("fixed",)


@dataclass(frozen=True)
class ImportOptions:
    """How to read a hand file.

    Attributes:
        name: hand name (default: the file's model name).
        root: the link that becomes the palm (default: where the fingers branch).
        fingertips: per finger name, values that replace the fitted fingertip's
            (:class:`~prehension.hands.fingertips.TipOverride`).
        fit_fingertips: fit a ``<finger>_tip`` cap per finger (default True).
    """

    name: str | None = None
    root: str | None = None
    fingertips: Mapping[str, TipOverride] = field(default_factory=dict)
    fit_fingertips: bool = True


# -- 5. shapes -----------------------------------------------------------------------------------
def _moved(shape: RawShape, T: np.ndarray) -> RawShape:
    return replace(shape, T_link_shape=T @ shape.T_link_shape)


def _survivor_shapes(raw: RawHand, home) -> dict[str, list[RawShape]]:
    out: dict[str, list[RawShape]] = defaultdict(list)
    for link, (survivor, T) in home.items():
        out[survivor] += [_moved(s, T) for s in raw.shapes.get(link, [])]
    return out


def _readable(shapes: list[RawShape], warnings: list[str]) -> tuple[list[RawShape], list, bool]:
    """The collision shapes whose files can be read (a mesh's vertices read once and kept
    on the shape), their vertices (``None`` for a primitive), and whether all could."""
    used, verts, complete = [], [], True
    for s in shapes:
        if s.role != "collision":
            continue
        try:
            v = None if s.kind != "mesh" else np.asarray(s.vertices(), dtype=float)
        except (ValueError, OSError) as exc:
            warnings.append(f"warning: {s.what}: {exc}; skipped")
            complete = False
            continue
        used.append(s if v is None else replace(s, vertices=lambda v=v: v))
        verts.append(v)
    return used, verts, complete


def _capsules(shapes: list[RawShape], warnings: list[str]) -> tuple[list[Capsule], ShapeFit | None, bool]:
    """The capsules of ``shapes`` and their :func:`~prehension.hands.enclosure.link_fit`,
    and whether every shape gave its capsules (nothing was skipped with a warning)."""
    out, used, surface = [], [], []
    for s in shapes:
        try:
            out += shape_capsules(s)
            surface.append(surface_points(s, 2000))
            used.append(s)
        except (ValueError, OSError) as exc:
            warnings.append(f"warning: {s.what}: {exc}; skipped")
    fit = link_fit(out, used, surface, _fit_label(used)) if out else None
    return out, fit, len(used) == len(shapes)


def _fit_label(used: list[RawShape]) -> str:
    kinds = {s.kind == "mesh" for s in used}
    return "collision mesh" if kinds == {True} else ("collision shapes" if kinds == {False} else "collision meshes and shapes")


def _drawn(shapes: list[RawShape]) -> tuple[LinkMesh, ...]:
    """The mesh files that draw a link: its visual shapes when each is a mesh file, else its
    collision shapes when each is, else none (the link is drawn as its capsules)."""
    for role in ("visual", "collision"):
        group = [s for s in shapes if s.role == role]
        if group and all(s.file is not None for s in group):
            return tuple(replace(s.file, T_link_mesh=s.T_link_shape @ s.file.T_link_mesh) for s in group)
    return ()


def _links(names: list[str], shapes: dict[str, list[RawShape]], warnings: list[str]) -> list[Link]:
    """One link per name, its capsules enclosing its collision shapes, with their fit, and
    the mesh files that draw it."""
    links = []
    for n in names:
        used, verts, complete = _readable(shapes.get(n, []), warnings)
        key = link_key(used, verts) if (used and complete) else None  # fitted once, kept on disk
        caps, fit = cached_link_fit(key, lambda: _capsules(used, warnings))
        if not caps and shapes.get(n):
            warnings.append(f"warning: link {n!r} has no collision shape: it is not checked for self-collision")
        links.append(Link(n, tuple(caps), fit, _drawn(shapes.get(n, []))))
    return links


def rest_pose(hand: Hand) -> np.ndarray:
    """(n_dof,) zero angles clamped into the limits, couplings applied (then clamped) [rad]."""
    q = np.clip(0.0, hand.lower, hand.upper)
    for c in hand.couplings:
        q[hand.dof_index(c.dof)] = c.ratio * q[hand.dof_index(c.source)] + c.offset
    return np.clip(q, hand.lower, hand.upper)


def _file_exclusions(raw: RawHand, home) -> tuple[tuple[str, str], ...]:
    """The file's exclusions between links that survive as two different links."""
    out = []
    for a, b in raw.exclusions:
        if a in home and b in home and home[a][0] != home[b][0]:
            out.append((home[a][0], home[b][0]))
    return tuple(out)


def with_rest_exclusions(hand: Hand) -> Hand:
    """The hand with the link pairs whose capsules overlap at :func:`rest_pose` excluded
    from self-collision checks (noted): capsules only approximate the shapes, and a pair
    that touches at rest would make every configuration a collision."""
    clearance, names = capsule_clearances(hand, forward_kinematics(hand, rest_pose(hand)))
    pairs = sorted({tuple(names[i]) for i in np.flatnonzero(clearance[0] < 0)})
    if not pairs:
        return hand
    listed = ", ".join(f"{a}/{b}" for a, b in pairs)
    note = f"self-collision not checked between {listed}: their capsules overlap at the rest pose"
    return replace(hand, collision_exclusions=hand.collision_exclusions + tuple(pairs), notes=hand.notes + (note,))


# -- 6. fingertips -------------------------------------------------------------------------------
def _points(shapes: list[RawShape], role: str, warnings: list[str]) -> tuple[np.ndarray | None, str]:
    pts, kinds = [], set()
    for s in shapes:
        if s.role != role:
            continue
        try:
            pts.append(surface_points(s))
            kinds.add("mesh" if s.kind == "mesh" else "shapes")
        except (ValueError, OSError) as exc:
            if role == "visual":  # a collision shape that fails is reported with the capsules
                warnings.append(f"warning: {s.what}: {exc}; not used for the fingertip")
    if not pts:
        return None, ""
    return np.concatenate(pts), f"{role} {'mesh' if kinds == {'mesh'} else 'shapes'}"


def _tip_points(shapes: list[RawShape], warnings: list[str]) -> tuple[np.ndarray | None, str]:
    points, label = _points(shapes, "collision", warnings)
    return (points, label) if points is not None else _points(shapes, "visual", warnings)


def _tip_hints(raw: RawHand, home, order) -> dict[str, np.ndarray]:
    """Per survivor, the origin of its one merged leaf link (a URDF tip frame), if exactly one."""
    parents = {j.parent for j in raw.joints}
    leaves: dict[str, list[np.ndarray]] = defaultdict(list)
    for link, (survivor, T) in home.items():
        if survivor != link and link not in parents:
            leaves[survivor].append(T[:3, 3])
    return {s: v[0] for s, v in leaves.items() if len(v) == 1}


def _pad_frames(hand: Hand, chains, points, hints) -> list[PadFrame | None]:
    return [pad_frame(hand, c[-1], points[c[-1]][0], hints.get(c[-1])) for c in chains]


def _pads_in_palm(hand: Hand, frames: list[PadFrame | None]) -> np.ndarray | None:
    """(S, F, 3) each finger's cap axis direction in the palm frame at each closure, or
    None when a finger has no pad frame."""
    if any(f is None for f in frames) or not frames:
        return None
    pose = forward_kinematics(hand, np.array([closure(hand, s) for s in CLOSURES]))
    cols = [pose.directions(hand.link_index(f.link), cap_axis(f)) for f in frames]  # each (S, 3)
    return np.stack(cols, axis=1)


def _fit(finger, frame, pts, label, fit: bool, capsules=()):
    """(cap, report, why there is none) of one finger's fitted fingertip."""
    if not fit:
        return None, None, "fingertips not fitted (fit_fingertips=False)"
    if pts is None:
        return None, None, f"no geometry on link {finger.tip_link!r}"
    if frame is None:
        return None, None, f"the joint of link {finger.tip_link!r} gives no finger axis"
    try:
        return (*fit_fingertip(finger.name, frame, pts, label, capsules), "")
    except InvalidHand as exc:
        return None, None, str(exc)


def _fingertips(hand: Hand, fingers, frames, points, overrides: Mapping[str, TipOverride], fit: bool):
    """(regions, fit reports, notes for the fingers left without a fingertip)."""
    regions, fits, notes = {}, {}, []
    for finger, frame in zip(fingers, frames):
        link = finger.tip_link
        capsules = hand.links[hand.link_index(link)].collision
        cap, report, why = _fit(finger, frame, *points[link], fit, capsules)
        override = overrides.get(finger.name)
        if override is not None:
            link = override.link or link
            cap, report = apply_override(cap, report, finger.name, link, override)
        if cap is not None:
            regions[f"{finger.name}_tip"] = HandRegion(link, cap)
            fits[f"{finger.name}_tip"] = report
        else:
            notes.append(f"finger {finger.name!r}: no fingertip found ({why})")
    return regions, fits, notes


# -- assembling -----------------------------------------------------------------------------------
def _check_overrides(overrides, fingers) -> None:
    names = [f.name for f in fingers]
    unknown = [k for k in overrides if k not in names]
    if unknown:
        raise InvalidHand(f"fingertip given for unknown finger(s) {unknown}; fingers are: {', '.join(names) or '(none)'}")


def _frames(home) -> dict[str, NamedFrame]:
    return {link: NamedFrame(s, T) for link, (s, T) in home.items() if s != link}


def _tree_notes(raw: RawHand, order, frames) -> list[str]:
    notes = []
    for j in order:
        if j.type not in ("revolute",) + _FIXED_TYPES:
            notes.append(
                f"warning: joint {j.name!r} is {j.type}; prehension models revolute joints only: "
                f"it is held at its reference position and {j.child!r} merged into its parent"
            )
    if frames:
        merged = ", ".join(f"{n} (on {f.link})" for n, f in frames.items())
        notes.append(f"links merged by fixed joints, kept as named frames: {merged}")
    return notes


def assemble(raw: RawHand, options: ImportOptions = ImportOptions()) -> Hand:
    """The :class:`Hand` of a file read into ``raw`` (see the module docstring)."""
    palm, order, home, palm_note = rooted(raw, options.root)
    notes = list(raw.warnings) + ([palm_note] if palm_note else [])
    joints = [make_joint(j, home) for j in order if j.type == "revolute"]
    shapes = _survivor_shapes(raw, home)
    warnings: list[str] = []
    links = _links([palm] + [j.child for j in joints], shapes, warnings)
    frames = _frames(home)
    name = options.name or raw.name
    kin = Hand(name, tuple(links), tuple(joints), tuple(couplings(raw, order)), frames=frames,
               collision_exclusions=_file_exclusions(raw, home))  # fmt: skip
    kin = with_rest_exclusions(kin)
    chains = finger_chains(palm, [(j.parent, j.child) for j in joints])
    points = {c[-1]: _tip_points(shapes.get(c[-1], []), warnings) for c in chains}
    pads = _pad_frames(kin, chains, points, _tip_hints(raw, home, order))
    names, thumb, naming = finger_names(kin, chains, _pads_in_palm(kin, pads))
    fingers = make_fingers(chains, names)
    _check_overrides(options.fingertips, fingers)
    regions, fits, missing = _fingertips(kin, fingers, pads, points, options.fingertips, options.fit_fingertips)
    notes += _tree_notes(raw, order, frames) + [naming] + warnings + missing
    return replace(
        kin, fingers=tuple(fingers), regions=regions, opposing_finger=None if thumb is None else names[thumb],
        notes=tuple(notes) + kin.notes, tip_fits=fits,
    )  # fmt: skip
