"""What of a parsed CuikSuite world prehension can model, made ready for the importer.

:func:`prepare_world` takes a :class:`~prehension.tasks.cuik_records.WorldFile` as parsed
and returns the world :mod:`prehension.tasks.cuik_import` turns into a hand or a task:

* **refused**, each with the construct, its line and why (:func:`refuse_unmodelled`): a
  ``prismatic`` joint (prehension's hands turn, they do not slide), the bars, legs,
  springs and cables (``sph_sph``, ``sph_prs_sph``, ``spring``, ``xyspring``, ``c_cable``,
  ``c_spring``, ``c_leg``: each closes a loop between two bodies), ``[EQUATIONS]`` (extra
  equations no task can carry) and, for a task, ``[OBSTACLES]`` that a ``check``
  statement of ``[COLLISIONS]`` asks to avoid (a task has one object);
* ``fix`` joints are **folded**: the second link becomes part of the first, every point,
  axis, reference vector and patch written in its frame re-expressed in the first link's
  (:func:`fold_fixed`); a chain of them folds into its first link;
* joints written from the outer link to the inner one are **turned round** (a revolute
  or crevolute joint: its two sides swapped, its range ``[lo, hi]`` becoming
  ``[-hi, -lo]``), so that every joint leads away from the ground link
  (:func:`orient_from_ground`); a universal joint written backwards is refused;
* ``crevolute`` joints are revolute joints whose angle CuikSuite ties to the previous
  non-coupled revolute joint's (it equates their cosines; prehension reads equal angles,
  negated when exactly one of the two was turned round): :func:`crevolute_couplings`.

Everything else is display or solver detail prehension does not need: link bodies and
colours, masses, inertias and joint dynamics, ``avoid limits`` and the ``[COLLISIONS]``
statements (prehension judges collisions with its own hand and object geometry, as the
task's description says).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import WorldFileError
from .cuik_records import WorldFile, WorldJoint

__all__ = ["prepare_world", "refuse_unmodelled", "fold_fixed", "orient_from_ground", "crevolute_couplings"]

_BARS = ("sph_sph", "sph_prs_sph", "spring", "xyspring", "c_cable", "c_spring", "c_leg")
_TREE = ("revolute", "crevolute", "universal")


def _fail(world: WorldFile, message: str, line: int | None) -> WorldFileError:
    return WorldFileError(message, path=world.path, line=line)


def refuse_unmodelled(world: WorldFile, *, task: bool) -> None:
    """Raise :class:`WorldFileError` at the first construct prehension cannot model."""
    for joint in world.joints:
        if joint.kind == "prismatic":
            raise _fail(world, f"prismatic joint between {joint.link1!r} and {joint.link2!r}: prehension's hands "
                        "have revolute and universal joints only (a sliding joint cannot be modelled)", joint.line)
        if joint.kind in _BARS:
            named = f" {joint.name!r}" if joint.name else ""
            raise _fail(world, f"{joint.kind} joint{named} between {joint.link1!r} and {joint.link2!r}: a "
                        "bar/leg/spring/cable between two bodies closes a kinematic loop; prehension's hands are "
                        "trees of revolute and universal joints", joint.line)
    if world.equations:
        file, line = world.equations[0]
        raise _fail(world, f"[EQUATIONS] adds the equations of {file!r}: prehension cannot add equations to a hand "
                    "or a task", line)
    checked = {name for c in world.collisions if c.check for name in c.what}
    avoided = [o for o in world.obstacles if checked & {o.name, "all"}]
    if task and avoided:
        raise _fail(world, f"obstacle {avoided[0].name!r} must be avoided ([COLLISIONS] checks it): a prehension "
                    "task has one object and no other obstacle", avoided[0].line)


def _transform(rows) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(rows, dtype=float)
    return t[:3, :3], t[:3, 3]


def _moved(joint: WorldJoint, side: int, R: np.ndarray, p: np.ndarray, into: str) -> WorldJoint:
    """``joint`` with what it writes in the frame of its link ``side`` (1 or 2) expressed in
    ``into``'s frame (``x_into = R x + p``)."""
    point = lambda v: None if v is None else tuple(float(x) for x in R @ np.asarray(v, float) + p)  # noqa: E731
    vector = lambda v: None if v is None else tuple(float(x) for x in R @ np.asarray(v, float))  # noqa: E731
    refs = list(joint.range_vectors)
    if side == 1:
        if refs:
            refs[0] = vector(refs[0])
        return replace(joint, link1=into, point1=point(joint.point1), axis1=vector(joint.axis1),
                       range_vectors=tuple(refs))
    if refs:
        refs[1] = vector(refs[1])
    patch = None if joint.patch is None else tuple(point(c) for c in joint.patch)
    return replace(joint, link2=into, point2=point(joint.point2), axis2=vector(joint.axis2),
                   range_vectors=tuple(refs), patch=patch)


def fold_fixed(world: WorldFile) -> WorldFile:
    """The world with every ``fix`` joint folded: its second link merged into its first
    (or the first into the second when the second is the ground link)."""
    joints = list(world.joints)
    links = {link.name: link for link in world.links}
    while any(j.kind == "fix" for j in joints):
        fix = next(j for j in joints if j.kind == "fix")
        joints.remove(fix)
        R, p = _transform(fix.transform)
        keep, gone = fix.link1, fix.link2
        if gone == world.ground:
            keep, gone, R, p = gone, keep, R.T, -R.T @ p
        if keep == gone:
            raise _fail(world, f"fix joint: {fix.link1!r} and {fix.link2!r} are already fixed to each other "
                        "(a loop of fix joints)", fix.line)
        for i, j in enumerate(joints):
            for side, link in ((1, j.link1), (2, j.link2)):
                if link == gone:
                    j = _moved(j, side, R, p, keep)
            joints[i] = j
        links.pop(gone, None)
    return replace(world, joints=tuple(joints), links=tuple(links.values()))


def _flipped(joint: WorldJoint) -> WorldJoint:
    refs = joint.range_vectors[::-1]
    ranges = tuple((-hi, -lo) for lo, hi in joint.ranges)
    return replace(joint, link1=joint.link2, link2=joint.link1, point1=joint.point2, point2=joint.point1,
                   axis1=joint.axis2, axis2=joint.axis1, range_vectors=refs, ranges=ranges)


def orient_from_ground(world: WorldFile) -> tuple[WorldFile, frozenset[int]]:
    """The world with its tree joints leading away from the ground link, and the indices
    (into ``world.joints``) of those turned round.  A joint between two links already
    reached (a loop) and the joints not reachable from the ground stay as written (the
    importer refuses them)."""
    tree = [i for i, j in enumerate(world.joints) if j.kind in _TREE]
    reached, frontier, seen, flipped = {world.ground}, [world.ground], set(), set()
    while frontier:
        link = frontier.pop(0)
        for i in tree:
            j = world.joints[i]
            if i in seen or not ((j.link1 == link and j.link2 not in reached) or
                                 (j.link2 == link and j.link1 not in reached)):
                continue
            seen.add(i)
            if j.link2 == link:
                if j.kind == "universal":
                    raise _fail(world, f"universal joint written from {j.link1!r} (the outer link) to {j.link2!r}: "
                                "write it from the link nearer the ground", j.line)
                flipped.add(i)
            outer = j.link1 if j.link2 == link else j.link2
            reached.add(outer)
            frontier.append(outer)
    joints = tuple(_flipped(j) if i in flipped else j for i, j in enumerate(world.joints))
    return replace(world, joints=joints), frozenset(flipped)


def crevolute_couplings(world: WorldFile) -> list[tuple[int, int]]:
    """``(crevolute, source)``: for each crevolute joint, the revolute joint whose angle it
    takes (the last revolute before it, through a run of crevolute joints right after it),
    as indices among the joints that are not ``fix``."""
    out, source, index = [], None, -1
    for joint in world.joints:
        index += joint.kind != "fix"
        if joint.kind == "revolute":
            source = (index, joint)
        elif joint.kind == "crevolute":
            if source is None:
                raise _fail(world, "crevolute joint: a coupled revolute joint needs a revolute joint right before "
                            "it (whose angle it takes)", joint.line)
            if not joint.ranges or not source[1].ranges:
                raise _fail(world, "crevolute joint: CuikSuite couples revolute joints with ranges only; give this "
                            f"joint and the revolute joint at line {source[1].line} a range", joint.line)
            out.append((index, source[0]))
        else:
            source = None
    return out


def prepare_world(world: WorldFile, *, task: bool) -> tuple[WorldFile, list[tuple[str, str, float]]]:
    """The world ready to import (refused, folded, oriented) and its crevolute couplings
    ``(dof, source dof, ratio)``, a revolute joint's dof named after its child link (as
    the importer names it); the ratio is -1 when exactly one of the two was turned round."""
    refuse_unmodelled(world, task=task)
    if world.ground is None:
        raise _fail(world, "the file has no [LINKS]; its first link is the palm", None)
    pairs = crevolute_couplings(world)
    oriented, flipped = orient_from_ground(fold_fixed(world))
    joints = oriented.joints
    return oriented, [(joints[c].link2, joints[s].link2, -1.0 if (c in flipped) != (s in flipped) else 1.0)
                      for c, s in pairs]
