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
5. **Collision capsules** from the collision shapes (:mod:`prehension.hands.shapes`);
   a shape that cannot be read is skipped with a warning, and a link that has visual
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

import math
from collections import defaultdict
from dataclasses import dataclass, field, replace
from typing import Mapping

import numpy as np

from ..errors import InvalidHand
from .description import RawHand, RawJoint, RawShape
from .fingers import CLOSURES, closure, finger_chains, finger_names, make_fingers
from .fingertips import PadFrame, TipOverride, apply_override, cap_axis, fit_fingertip, pad_frame
from .collision import capsule_clearances
from .kinematics import forward_kinematics
from .model import Capsule, Coupling, Hand, HandRegion, Joint, Link, NamedFrame
from .shapes import shape_capsules, surface_points

__all__ = ["ImportOptions", "assemble"]

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


# -- 1. the tree ----------------------------------------------------------------------------
def _parent_joints(joints) -> dict[str, RawJoint]:
    parent_of: dict[str, RawJoint] = {}
    for j in joints:
        if j.child in parent_of:
            raise InvalidHand(
                f"link {j.child!r} is the child of several joints ({parent_of[j.child].name!r}, {j.name!r}); "
                "the links must form a tree"
            )
        parent_of[j.child] = j
    return parent_of


def _find_root(raw: RawHand, parent_of, root: str | None) -> str:
    if root is not None:
        if root not in raw.links:
            raise InvalidHand(f"root link {root!r} not found; links are: {', '.join(raw.links)}")
        return root
    roots = [name for name in raw.links if name not in parent_of]
    if not roots:
        raise InvalidHand("no root link: every link is some joint's child, so the joints form a cycle")
    if len(roots) > 1:
        raise InvalidHand(
            f"several root links (links that are no joint's child): {', '.join(roots)}; "
            "connect them by joints or choose the palm with root="
        )
    return roots[0]


def _ordered(raw: RawHand, root: str, check_all: bool) -> list[RawJoint]:
    """Joints below ``root``, depth-first in file order (parent before child, so that each
    finger's joints, and so its angles, come together)."""
    by_parent: dict[str, list[RawJoint]] = defaultdict(list)
    for j in raw.joints:
        by_parent[j.parent].append(j)
    seen, order, stack = {root}, [], list(reversed(by_parent[root]))
    while stack:
        j = stack.pop()
        if j.child in seen:
            raise InvalidHand(f"joint {j.name!r} closes a cycle: link {j.child!r} is already below {root!r}")
        seen.add(j.child)
        order.append(j)
        stack.extend(reversed(by_parent[j.child]))
    if check_all and len(seen) < len(raw.links):
        raise InvalidHand(f"some links are not below the root {root!r}: the joints form a cycle")
    return order


# -- 2. merging ------------------------------------------------------------------------------
def _merge(root: str, order: list[RawJoint]) -> dict[str, tuple[str, np.ndarray]]:
    """For every link below root: (the surviving link it belongs to, T_survivor_link)."""
    home = {root: (root, np.eye(4))}
    for j in order:
        survivor, T = home[j.parent]
        home[j.child] = (j.child, np.eye(4)) if j.type == "revolute" else (survivor, T @ j.T_fixed)
    return home


# -- 3. the palm -----------------------------------------------------------------------------
def _branch_link(root: str, order: list[RawJoint]) -> str | None:
    """The first link, going down from ``root``, with two children whose subtrees hold a
    revolute joint (tip frames and sites do not count); None for a single chain."""
    children: dict[str, list[RawJoint]] = defaultdict(list)
    for j in order:
        children[j.parent].append(j)
    moving: dict[str, bool] = {}
    for j in reversed(order):  # children after parents in ``order``: fill bottom-up
        moving[j.child] = j.type == "revolute" or any(moving[c.child] for c in children[j.child])
    link = root
    while True:
        branches = [j for j in children[link] if moving[j.child]]
        if len(branches) != 1:
            return link if branches else None
        link = branches[0].child


def _palm_group(palm: str, top: str, order: list[RawJoint], home_top) -> dict:
    """``home`` re-rooted at ``palm``: the links rigid with ``top`` (``palm`` among them)
    belong to ``palm``, placed by ``T_palm_x = T_top_palm^-1 T_top_x``."""
    T_palm_top = np.linalg.inv(home_top[palm][1])
    return {x: (palm, T_palm_top @ T) if s == top else (s, T) for x, (s, T) in home_top.items()}


def _rigid_top(palm: str, parent_of: dict[str, RawJoint], root: str) -> str:
    """The highest link joined to ``palm`` by non-revolute joints only."""
    link = palm
    while link != root and parent_of[link].type != "revolute":
        link = parent_of[link].parent
    return link


# -- 4. joints and couplings -------------------------------------------------------------------
def _joint(j: RawJoint, home) -> Joint:
    survivor, T_sp = home[j.parent]
    T_pj = T_sp @ j.T_parent_joint
    R_jc, t_jc = j.T_joint_child[:3, :3], j.T_joint_child[:3, 3]
    axis = np.asarray(j.axis, dtype=float)
    if np.linalg.norm(axis) < 1e-12:
        raise InvalidHand(f"joint {j.name!r}: the axis is the zero vector")
    return Joint(
        name=j.name, kind="revolute", parent=survivor, child=j.child, origin_in_parent=T_pj[:3, 3],
        origin_in_child=-R_jc.T @ t_jc, axis_in_parent=T_pj[:3, :3] @ (axis / np.linalg.norm(axis)),
        R_parent_child_zero=T_pj[:3, :3] @ R_jc, dof_names=(j.name,), lower=(j.limits[0],), upper=(j.limits[1],),
    )  # fmt: skip


def _resolve(name: str, stated: dict, joints: dict[str, RawJoint], movable: set[str]) -> tuple[str, float, float]:
    """(independent source, ratio, offset) of coupled joint ``name``, following chains."""
    ratio, offset, current, seen = 1.0, 0.0, name, [name]
    while current in stated:
        c = stated[current]
        ratio, offset = ratio * c.ratio, ratio * c.offset + offset
        source = c.source
        if source not in joints:
            raise InvalidHand(f"joint {current!r} follows joint {source!r} (a coupling), which is not defined")
        if joints[source].type != "revolute":
            raise InvalidHand(
                f"joint {current!r} follows joint {source!r} (a coupling), which is {joints[source].type}, not revolute"
            )
        if source not in movable:
            raise InvalidHand(
                f"joint {current!r} follows joint {source!r} (a coupling), which is not below the palm; "
                "choose a palm above both with root="
            )
        if source in seen:
            raise InvalidHand(f"couplings form a cycle: {' -> '.join(seen + [source])}")
        seen.append(source)
        current = source
    return current, ratio, offset


def _couplings(raw: RawHand, order: list[RawJoint]) -> list[Coupling]:
    movable = {j.name for j in order if j.type == "revolute"}
    joints = {j.name: j for j in raw.joints}
    stated = {c.dof: c for c in raw.couplings}
    out = []
    for j in order:
        if j.name in movable and j.name in stated:
            source, ratio, offset = _resolve(j.name, stated, joints, movable)
            out.append(Coupling(dof=j.name, source=source, ratio=ratio, offset=offset))
    return out


# -- 5. shapes -----------------------------------------------------------------------------------
def _moved(shape: RawShape, T: np.ndarray) -> RawShape:
    return replace(shape, T_link_shape=T @ shape.T_link_shape)


def _survivor_shapes(raw: RawHand, home) -> dict[str, list[RawShape]]:
    out: dict[str, list[RawShape]] = defaultdict(list)
    for link, (survivor, T) in home.items():
        out[survivor] += [_moved(s, T) for s in raw.shapes.get(link, [])]
    return out


def _capsules(shapes: list[RawShape], warnings: list[str]) -> list[Capsule]:
    out = []
    for s in shapes:
        if s.role != "collision":
            continue
        try:
            out += shape_capsules(s)
        except (ValueError, OSError) as exc:
            warnings.append(f"warning: {s.what}: {exc}; skipped")
    return out


def _links(names: list[str], shapes: dict[str, list[RawShape]], warnings: list[str]) -> list[Link]:
    links = []
    for n in names:
        caps = _capsules(shapes.get(n, []), warnings)
        if not caps and shapes.get(n):
            warnings.append(f"warning: link {n!r} has no collision shape: it is not checked for self-collision")
        links.append(Link(n, tuple(caps)))
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


def _with_rest_exclusions(hand: Hand) -> Hand:
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


def _fingertips(fingers, frames, points, overrides: Mapping[str, TipOverride], fit: bool):
    regions, fits = {}, {}
    for finger, frame in zip(fingers, frames):
        link = finger.tip_link
        pts, label = points[link]
        cap = report = None
        if fit and frame is not None and pts is not None:
            cap, report = fit_fingertip(finger.name, frame, pts, label)
        override = overrides.get(finger.name)
        if override is not None:
            link = override.link or link
            cap, report = apply_override(cap, report, finger.name, link, override)
        if cap is not None:
            regions[f"{finger.name}_tip"] = HandRegion(link, cap)
            fits[f"{finger.name}_tip"] = report
    return regions, fits


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


def _rooted(raw: RawHand, options: ImportOptions):
    """(palm, joints below it in order, home, palm note or None); see steps 1-3."""
    parent_of = _parent_joints(raw.joints)
    root = _find_root(raw, parent_of, options.root)
    order = _ordered(raw, root, options.root is None)
    palm = _branch_link(root, order) if options.root is None else None
    if palm is None or palm == root:
        return root, order, _merge(root, order), None
    top = _rigid_top(palm, parent_of, root)
    below = _ordered(raw, top, False)
    home = _palm_group(palm, top, below, _merge(top, below))
    kept = {j.name for j in below}
    above = [j for j in order if j.name not in kept]
    note = f"palm: {palm!r}, the link where the fingers branch"
    if above:
        cut = sorted(({root} | {j.child for j in above}) - set(home))
        note += (
            f"; cut off above it: link(s) {', '.join(cut)} and joint(s) {', '.join(j.name for j in above)}; "
            f"read the file with root={root!r} to keep them"
        )
    return palm, below, home, note


def assemble(raw: RawHand, options: ImportOptions = ImportOptions()) -> Hand:
    """The :class:`Hand` of a file read into ``raw`` (see the module docstring)."""
    palm, order, home, palm_note = _rooted(raw, options)
    notes = list(raw.warnings) + ([palm_note] if palm_note else [])
    joints = [_joint(j, home) for j in order if j.type == "revolute"]
    shapes = _survivor_shapes(raw, home)
    warnings: list[str] = []
    links = _links([palm] + [j.child for j in joints], shapes, warnings)
    frames = _frames(home)
    name = options.name or raw.name
    kin = Hand(name, tuple(links), tuple(joints), tuple(_couplings(raw, order)), frames=frames,
               collision_exclusions=_file_exclusions(raw, home))  # fmt: skip
    kin = _with_rest_exclusions(kin)
    chains = finger_chains(palm, [(j.parent, j.child) for j in joints])
    points = {c[-1]: _tip_points(shapes.get(c[-1], []), warnings) for c in chains}
    pads = _pad_frames(kin, chains, points, _tip_hints(raw, home, order))
    names, thumb, naming = finger_names(kin, chains, _pads_in_palm(kin, pads))
    fingers = make_fingers(chains, names)
    _check_overrides(options.fingertips, fingers)
    regions, fits = _fingertips(fingers, pads, points, options.fingertips, options.fit_fingertips)
    notes += _tree_notes(raw, order, frames) + [naming] + warnings
    notes += [f"finger {f.name!r}: no fingertip found (no geometry on link {f.tip_link!r})"
              for f in fingers if f"{f.name}_tip" not in regions]  # fmt: skip
    return replace(
        kin, fingers=tuple(fingers), regions=regions, opposing_finger=None if thumb is None else names[thumb],
        notes=tuple(notes) + kin.notes, tip_fits=fits,
    )  # fmt: skip
