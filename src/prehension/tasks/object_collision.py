"""Hand–object collision: how deep each link's capsules, and each touching pad, reach into the object's solid.

A capsule (segment ``a``-``b`` and radius ``r``, :class:`~prehension.hands.model.Capsule`)
is clear of the object when every point of its segment lies outside the solid at least
``r`` away from the surface.  Its **penetration depth** is

.. math::

    \\text{depth} = \\max\\bigl(0,\\; r - \\min_{s \\in [a, b]} \\mathrm{sd}(s)\\bigr),

with ``sd`` the signed distance to the surface (negative inside).  It is computed exactly
where it matters: a segment that stays outside has ``min sd`` = its exact distance to the
surface (:meth:`~prehension.objects.distance.MeshDistance.segment_distance`), so the
0.5 mm tolerance is judged without sampling.  A segment that reaches inside is already
deeper than ``r``; its depth below the surface is then sampled
(:func:`~prehension.objects.distance._sampled_min_sd`: ``sd`` being 1-Lipschitz, within
0.125 mm of the true value, from below, as samples 0.25 mm apart would be, measuring
only where the minimum could be).

**The exception is the pad, nothing more.**  Each contact's hand region has a *pad*: the
solid that touches the object there.

* A sphere cap's pad is its whole ball ``P = B(c, rho)`` (centre ``c`` and radius ``rho``
  fixed on the link).  On the contact's link, a capsule ball ``B(s, r)`` (``s`` on the
  segment) is excused only where it lies inside the pad:

  .. math::

      B(s, r) \\subseteq B(c, \\rho) \\iff |s - c| \\le \\rho - r,

  so nothing of a capsule at least as thick as the pad is excused.  The excused part is
  fixed on the link (it does not move with the contact point): on the SA hand's distal
  capsules (``r`` = 10 mm, ``rho`` = 13 mm, ``c`` at the capsule's end) the last 3 mm of
  the 17 mm segment, against a zone of ``r + rho`` = 23 mm around the contact point before.
* A point or patch hand region has no volume: its pad is the region itself, no capsule
  ball lies inside it, and nothing is excused (``rho = 0``, the pad the hand point).

**The pad is itself checked**: it may touch the object at the contact, and nowhere sink
more than the tolerance.  Its depth is

.. math::

    \\text{pad depth} = \\max\\bigl(0,\\; \\rho - \\mathrm{sd}(c)\\bigr)

(``c`` the cap's centre, or the hand point of a point or patch region with ``rho = 0``;
exact: one signed-distance query, a ball's depth being ``rho`` minus its centre's signed
distance).  Every other part of a contact's link, and every other link, is checked as
any link is.  An excused ball lies inside its pad, so it reaches no deeper than the pad:
excusing it never changes whether a configuration passes, it only keeps a link's depth
from repeating its pad's tolerated one.
"""

from __future__ import annotations

import numpy as np

from ..hands.collision import collision_pairs
from ..hands.kinematics import HandPose
from .model import Task

__all__ = [
    "link_penetrations", "pad_penetrations", "batch_link_depths", "moving_links", "capsule_segments", "pad_solids",
    "pad_radius", "pad_centre_in_link", "segment_depths", "SAMPLE_MM",
]  # fmt: skip

SAMPLE_MM = 0.25  # spacing of the depth samples of a segment that reaches inside [mm]


def capsule_segments(task: Task, pose: HandPose, T_palm_object: np.ndarray):
    """Every capsule's segment in the object frame: ``starts (S, 3)``, ``ends (S, 3)`` [mm],
    and ``radius (S,)``, ``link (S,)`` of the hand's flat shape list (one configuration)."""
    shapes = collision_pairs(task.hand)
    R, r = pose.R_palm_link[0, shapes.link], pose.r_palm_link[0, shapes.link]  # (S, 3, 3), (S, 3)
    a = np.einsum("sij,sj->si", R, shapes.a) + r  # palm frame
    b = np.einsum("sij,sj->si", R, shapes.b) + r
    T = np.asarray(T_palm_object, dtype=float)
    Rt, t = T[:3, :3].T, T[:3, 3]
    return (a - t) @ Rt.T, (b - t) @ Rt.T, shapes.radius, shapes.link


def pad_radius(hand_region) -> float:
    """The radius ``rho`` of a contact's pad [mm]: a sphere cap's radius, 0 for a point or
    patch hand region (no volume; see the module docstring)."""
    ball = hand_region.region.ball()
    return 0.0 if ball is None else float(ball[1])


def pad_centre_in_link(hand_region) -> np.ndarray | None:
    """A sphere cap's centre in its link's frame [mm]; ``None`` for a point or patch region
    (its pad is the hand point of the contact)."""
    ball = hand_region.region.ball()
    return None if ball is None else np.asarray(ball[0], dtype=float)


def pad_solids(task: Task, pose: HandPose, T_palm_object, contact_points_object) -> list[tuple[int, np.ndarray, float]]:
    """Per contact, its pad: ``(link index, centre (3,) in the object frame [mm], rho [mm])``
    (see the module docstring): a sphere cap's ball, its centre placed by ``pose`` (one
    configuration) and ``T_palm_object``; a point or patch region's hand point
    ``contact_points_object[c]`` (object frame [mm]) with ``rho = 0``.  Empty when no
    contact point is given (then nothing is excused and no pad is checked)."""
    T = np.asarray(T_palm_object, dtype=float)
    out = []
    for c, point in zip(task.contacts, contact_points_object):
        hr = task.hand_region(c)
        li, c_link = task.hand.link_index(hr.link), pad_centre_in_link(hr)
        if c_link is None:
            centre = np.asarray(point, dtype=float)
        else:
            centre = (pose.R_palm_link[0, li] @ c_link + pose.r_palm_link[0, li] - T[:3, 3]) @ T[:3, :3]
        out.append((li, centre, pad_radius(hr)))
    return out


def pad_penetrations(task: Task, pose: HandPose, T_palm_object, contact_points_object) -> dict[str, float]:
    """Depth of each contact's pad into the object, ``max(0, rho - sd(centre))`` [mm], by
    contact name (see the module docstring); empty when no contact point is given."""
    pads = pad_solids(task, pose, T_palm_object, contact_points_object)
    if not pads:
        return {}
    sd = task.object.distance.signed_distance(np.array([centre for _, centre, _ in pads]))
    return {c.name: max(0.0, rho - float(d)) for c, (_, _, rho), d in zip(task.contacts, pads, sd)}


def _kept_pieces(a, b, radius, pads) -> list[tuple[np.ndarray, np.ndarray]]:
    """The pieces of segment a-b whose capsule balls (radius ``radius``) do not lie inside
    any pad ball ``(centre, rho)``: the segment less ``|s - centre| <= rho - radius``."""
    pieces = [(0.0, 1.0)]
    d = b - a
    dd = float(d @ d)
    for centre, rho in pads:
        R = rho - radius
        if R <= 0.0:
            continue  # the capsule is at least as thick as the pad: nothing of it is inside
        f = a - centre
        if dd <= 1e-18:
            lo, hi = (0.0, 1.0) if f @ f <= R * R else (1.0, 0.0)
        else:
            bq, cq = float(f @ d) / dd, (float(f @ f) - R * R) / dd
            disc = bq * bq - cq
            if disc <= 0:
                continue
            lo, hi = -bq - np.sqrt(disc), -bq + np.sqrt(disc)
        pieces = [p for s, e in pieces for p in ((s, min(e, lo)), (max(s, hi), e)) if p[1] > p[0]]
    return [(a + s * d, a + e * d) for s, e in pieces]


def moving_links(task: Task) -> list[int]:
    """Indices of the links that idle fingers do not own (the palm and the fingers taking part)."""
    idle = {link for f in task.hand.fingers if f.name not in task.fingers for link in f.links}
    return [i for i, name in enumerate(task.hand.link_names) if name not in idle]


def link_penetrations(
    task: Task, pose: HandPose, T_palm_object, contact_points_object=(), links=None
) -> dict[str, float]:
    """Penetration depth of each link that has capsules into the object's solid [mm], by link name.

    Args:
        task: the task; its object must have a solid (``task.object.collides``).
        pose: forward kinematics of one configuration.
        T_palm_object: (4, 4) object pose.
        contact_points_object: per contact, the hand point in the object frame [mm]
            (what lies inside each contact's pad is excused, see the module docstring);
            empty: nothing excused.
        links: indices of the links to check (default: every link with capsules).
    """
    starts, ends, radius, link = capsule_segments(task, pose, T_palm_object)
    if links is not None:
        keep = np.isin(link, list(links))
        starts, ends, radius, link = starts[keep], ends[keep], radius[keep], link[keep]
    balls: dict[int, list] = {}
    for li, centre, rho in pad_solids(task, pose, T_palm_object, contact_points_object):
        balls.setdefault(li, []).append((centre, rho))
    p0, p1, rad, owner = [], [], [], []
    for s in range(len(radius)):
        for a, b in _kept_pieces(starts[s], ends[s], radius[s], balls.get(int(link[s]), ())):
            p0.append(a), p1.append(b), rad.append(radius[s]), owner.append(link[s])
    depth = {task.hand.link_names[li]: 0.0 for li in sorted(set(int(x) for x in link))}
    if p0:
        d = segment_depths(task.object.distance, np.array(p0), np.array(p1), np.array(rad))
        for li, v in zip(owner, d):
            name = task.hand.link_names[int(li)]
            depth[name] = max(depth[name], float(v))
    return depth


def segment_depths(distance, starts, ends, radius, cap: float = np.inf) -> np.ndarray:
    """Penetration depth of capsules ``starts (N, 3)``-``ends (N, 3)``, ``radius (N,)`` into a
    closed surface given by a :class:`~prehension.objects.distance.MeshDistance`, (N,) [mm]
    (depths above ``cap`` may come back as any value above it)."""
    return distance.capsule_depth(starts, ends, radius, SAMPLE_MM, cap)


def batch_link_depths(task: Task, pose: HandPose, T_palm_object, links, cap: float = np.inf) -> np.ndarray:
    """Penetration depth into the object of the links ``links`` (indices) for ``B``
    configurations, no pad excepted: (B, len(links)) [mm]; a depth above ``cap`` may come
    back as any value above it (a yes/no test against ``cap`` is then much cheaper)."""
    shapes = collision_pairs(task.hand)
    links = list(links)
    sel = np.flatnonzero(np.isin(shapes.link, links))
    B = pose.r_palm_link.shape[0]
    out = np.zeros((B, len(links)))
    if sel.size == 0:
        return out
    R, r = pose.R_palm_link[:, shapes.link[sel]], pose.r_palm_link[:, shapes.link[sel]]  # (B, s, 3, 3), (B, s, 3)
    a = np.einsum("bsij,sj->bsi", R, shapes.a[sel]) + r
    b = np.einsum("bsij,sj->bsi", R, shapes.b[sel]) + r
    T = np.asarray(T_palm_object, dtype=float)
    a, b = (a - T[:3, 3]) @ T[:3, :3], (b - T[:3, 3]) @ T[:3, :3]  # palm -> object frame
    radius = np.broadcast_to(shapes.radius[sel], (B, sel.size))
    d = segment_depths(task.object.distance, a.reshape(-1, 3), b.reshape(-1, 3), radius.reshape(-1), cap).reshape(B, -1)
    for k, li in enumerate(links):
        mine = shapes.link[sel] == li
        if mine.any():
            out[:, k] = d[:, mine].max(axis=1)
    return out
