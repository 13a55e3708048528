"""Which collision geometry judged a result: the ``collision_geometry`` entry of a result file.

A solution is "collision-free" only with respect to some geometry: the hand's collision
capsules (which may enclose each link's own shapes or not, :attr:`~prehension.hands.model.Link.fit`),
the link pairs left out of self-collision checks, and the object's solid.  Every result
file (and batch record) states that geometry, and ``prehension check`` re-derives it
from the embedded task (:func:`check_collision_geometry`)::

    "collision_geometry": {
      "hand": "schunk-sa: 14 links, 14 capsules, 0 pairs excluded",
      "object": "mesh file teapot.off (x1 mm per unit)",
      "digest": "sha256:9f1c...",        # of every capsule, fit and exclusion, and the object line
      "encloses": "no: capsules miss up to 48.31 mm of a link's shape (palm)",
      "links": {"palm": {"capsules": 3, "geometry": "published mesh ...", "miss_mm": 48.31,
                         "stick_out_mm": 16.5}, ...}
    }

``links`` lists only links with a recorded fit (a hand given inline as capsules has none);
batch records leave ``links`` out (``compact``): the digest and the summary lines
identify the geometry, and the task line holds the hand.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from ..hands.model import Hand
from ..objects.model import GraspObject
from .model import Task

__all__ = ["collision_geometry", "check_collision_geometry", "hand_geometry_line", "enclosure_line"]


def hand_geometry_line(hand: Hand) -> str:
    n_caps = sum(len(link.collision) for link in hand.links)
    return f"{hand.name}: {len(hand.links)} links, {n_caps} capsules, {len(hand.collision_exclusions)} pairs excluded"


def enclosure_line(hand: Hand) -> str:
    """Whether the capsules enclose every link's own shapes, and the worst miss/stick-out."""
    fits = {link.name: link.fit for link in hand.links if link.fit is not None}
    if not fits:
        return "unknown: the capsules are the hand's only geometry (no link shapes recorded)"
    worst = max(fits, key=lambda n: fits[n].miss_mm)
    out = max(fits, key=lambda n: fits[n].stick_out_mm)
    stick = f"; stick out up to {fits[out].stick_out_mm:.2f} mm ({out})"
    if fits[worst].miss_mm > 0:
        return f"no: capsules miss up to {fits[worst].miss_mm:.2f} mm of a link's shape ({worst}){stick}"
    unfitted = [link.name for link in hand.links if link.fit is None and link.collision]
    whose = f" (not recorded for {', '.join(unfitted)})" if unfitted else ""
    return f"yes: every recorded link's shape is inside its capsules{whose}{stick}"


def _object_line(obj: GraspObject) -> str:
    if obj.solid is None:
        return "none: the object has no collision solid (only its regions constrain a grasp)"
    solid = obj.solid
    what = f"mesh file {Path(solid.path).name} (x{solid.scale:g} mm per unit)" if hasattr(solid, "path") else solid.describe()
    return what if obj.collisions else f"not checked (collisions: false): {what}"


def _digest(hand: Hand, object_line: str) -> str:
    links = [
        [link.name, [[*map(float, c.a), *map(float, c.b), float(c.radius)] for c in link.collision],
         None if link.fit is None else [link.fit.geometry, link.fit.miss_mm, link.fit.stick_out_mm]]
        for link in hand.links
    ]  # fmt: skip
    text = json.dumps([links, sorted(map(sorted, hand.collision_exclusions)), object_line], separators=(",", ":"))
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()[:16]


def collision_geometry(task: Task, *, compact: bool = False) -> dict:
    """The ``collision_geometry`` entry of a result of ``task`` (see the module docstring)."""
    hand, object_line = task.hand, _object_line(task.object)
    out = {
        "hand": hand_geometry_line(hand),
        "object": object_line,
        "digest": _digest(hand, object_line),
        "encloses": enclosure_line(hand),
    }
    if not compact:
        out["links"] = {
            link.name: {"capsules": len(link.collision), "geometry": link.fit.geometry,
                        "miss_mm": link.fit.miss_mm, "stick_out_mm": link.fit.stick_out_mm}
            for link in hand.links if link.fit is not None
        }  # fmt: skip
    return out


def check_collision_geometry(task: Task, stored) -> tuple[bool, str]:
    """``(holds, detail)``: the stored entry equals the one re-derived from ``task`` (the
    compact form of a batch record is compared without ``links``)."""
    if not isinstance(stored, dict):
        return False, f"expected a mapping, got {type(stored).__name__}"
    derived = collision_geometry(task, compact="links" not in stored)
    wrong = [k for k in derived if stored.get(k) != derived[k]] + [k for k in stored if k not in derived]
    if wrong:
        k = wrong[0]
        return False, f"{k}: the file says {stored.get(k)!r}, the embedded task gives {derived.get(k)!r}"
    return True, f"{derived['hand']}; object {derived['object']}; encloses {derived['encloses'].split(':')[0]} ({derived['digest']})"
