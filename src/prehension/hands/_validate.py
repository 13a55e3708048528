"""Consistency checks of a :class:`~prehension.hands.model.Hand` (clear errors)."""

from __future__ import annotations

from collections import Counter

from ..errors import InvalidHand

__all__ = ["validate_hand"]


def _duplicates(names) -> list[str]:
    return sorted(n for n, c in Counter(names).items() if c > 1)


def validate_hand(hand) -> None:
    """Raise :class:`InvalidHand` naming the first inconsistency found."""
    _check_links(hand)
    _check_joint_tree(hand)
    _check_couplings(hand)
    _check_fingers_regions(hand)
    _check_frames(hand)


def _check_links(hand) -> None:
    if not hand.links:
        raise InvalidHand(f"hand {hand.name!r} has no links; the first link is the palm")
    dup = _duplicates(hand.link_names)
    if dup:
        raise InvalidHand(f"hand {hand.name!r}: duplicate link name(s) {dup}")
    dup = _duplicates(j.name for j in hand.joints)
    if dup:
        raise InvalidHand(f"hand {hand.name!r}: duplicate joint name(s) {dup}")
    dup = _duplicates(hand.dof_names)
    if dup:
        raise InvalidHand(f"hand {hand.name!r}: duplicate joint angle name(s) {dup}")


def _check_joint_tree(hand) -> None:
    names = hand.link_names
    placed = {hand.palm}
    for j in hand.joints:
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in names:
                raise InvalidHand(f"joint {j.name!r}: {role} link {link!r} not found; links are: {', '.join(names)}")
        if j.child == hand.palm:
            raise InvalidHand(f"joint {j.name!r}: the palm {hand.palm!r} is the root and cannot be a child")
        if j.child in placed:
            raise InvalidHand(f"joint {j.name!r}: link {j.child!r} already has a parent joint (links form a tree)")
        if j.parent not in placed:
            raise InvalidHand(
                f"joint {j.name!r}: its parent {j.parent!r} is not yet connected to the palm; "
                "list joints from the palm outwards"
            )
        placed.add(j.child)
    loose = [n for n in names if n not in placed]
    if loose:
        raise InvalidHand(f"hand {hand.name!r}: link(s) {loose} are not connected to the palm by any joint")


def _check_couplings(hand) -> None:
    dofs = set(hand.dof_names)
    coupled = [c.dof for c in hand.couplings]
    dup = _duplicates(coupled)
    if dup:
        raise InvalidHand(f"joint angle(s) {dup} are coupled more than once")
    for c in hand.couplings:
        for role, d in (("coupled angle", c.dof), ("source angle", c.source)):
            if d not in dofs:
                raise InvalidHand(
                    f"coupling: {role} {d!r} not found; angles are: {', '.join(hand.dof_names)}"
                )
        if c.source in coupled:
            raise InvalidHand(
                f"coupling of {c.dof!r}: its source {c.source!r} is itself coupled; "
                "couple every angle directly to an independent one"
            )


def _check_fingers_regions(hand) -> None:
    names = set(hand.link_names)
    for f in hand.fingers:
        missing = [l for l in f.links if l not in names]
        if missing:
            raise InvalidHand(f"finger {f.name!r}: link(s) {missing} not found; links are: {', '.join(hand.link_names)}")
    dup = _duplicates(f.name for f in hand.fingers)
    if dup:
        raise InvalidHand(f"hand {hand.name!r}: duplicate finger name(s) {dup}")
    for rname, reg in hand.regions.items():
        if reg.link not in names:
            raise InvalidHand(f"hand region {rname!r}: link {reg.link!r} not found; links are: {', '.join(hand.link_names)}")
    for a, b in hand.collision_exclusions:
        for link in (a, b):
            if link not in names:
                raise InvalidHand(f"collision exclusion ({a!r}, {b!r}): link {link!r} not found")


def _check_frames(hand) -> None:
    names = set(hand.link_names)
    for fname, frame in hand.frames.items():
        if fname in names:
            raise InvalidHand(f"named frame {fname!r} has the name of a link; frame and link names must differ")
        if frame.link not in names:
            raise InvalidHand(f"named frame {fname!r}: link {frame.link!r} not found; links are: {', '.join(hand.link_names)}")
    if hand.opposing_finger is not None and hand.opposing_finger not in {f.name for f in hand.fingers}:
        names = ", ".join(f.name for f in hand.fingers) or "(none defined)"
        raise InvalidHand(f"opposing finger {hand.opposing_finger!r} not found; fingers are: {names}")
