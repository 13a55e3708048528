"""The kinematic tree of a hand file: root, order, fixed joints merged, the palm, joints.

Steps 1-4 of :mod:`prehension.hands.assemble` (see its docstring): from a
:class:`~prehension.hands.description.RawHand` to the palm, the joints below it in order,
where every file link ends up (``home``), and the model's :class:`Joint` s and
:class:`Coupling` s.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from ..errors import InvalidHand
from .description import RawHand, RawJoint
from .model import Coupling, Joint

__all__ = ["rooted", "make_joint", "couplings"]


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
def make_joint(j: RawJoint, home) -> Joint:
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


def couplings(raw: RawHand, order: list[RawJoint]) -> list[Coupling]:
    movable = {j.name for j in order if j.type == "revolute"}
    joints = {j.name: j for j in raw.joints}
    stated = {c.dof: c for c in raw.couplings}
    out = []
    for j in order:
        if j.name in movable and j.name in stated:
            source, ratio, offset = _resolve(j.name, stated, joints, movable)
            out.append(Coupling(dof=j.name, source=source, ratio=ratio, offset=offset))
    return out


def rooted(raw: RawHand, root: str | None):
    """(palm, joints below it in order, home, palm note or None): steps 1-3 of
    :mod:`prehension.hands.assemble`; ``home[link] = (surviving link, T_survivor_link)``."""
    parent_of = _parent_joints(raw.joints)
    given = root
    root = _find_root(raw, parent_of, given)
    order = _ordered(raw, root, given is None)
    palm = _branch_link(root, order) if given is None else None
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
