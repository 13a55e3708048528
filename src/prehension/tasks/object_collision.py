"""Hand–object collision: how deep each link's capsules reach into the object's solid.

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

**The touching pads are excepted.**  A link that makes a contact touches the object there
by design, and its capsules (coarser than its pad) may reach the surface near the
contact.  For each contact, on the link that carries the contact's hand region, the part
of each capsule's segment within ``r + rho`` of the contact point (the hand point) is not
checked, where ``r`` is the capsule's radius and ``rho`` the pad's radius: a sphere
cap's radius, or for a patch or point hand region the link's largest capsule radius.
That is, a capsule ball is excepted when it overlaps the ball of radius ``rho`` around the
contact point.  Everything else of that link, and every other link, is checked.
"""

from __future__ import annotations

import numpy as np

from ..geometry.regions import SphereCap
from ..hands.collision import collision_pairs
from ..hands.kinematics import HandPose
from .model import Task

__all__ = [
    "link_penetrations", "batch_link_depths", "moving_links", "capsule_segments", "pad_exclusions", "segment_depths",
    "SAMPLE_MM",
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


def pad_radius(task: Task, hand_region) -> float:
    """The radius of a contact's pad [mm] (see the module docstring)."""
    if isinstance(hand_region.region, SphereCap):
        return float(hand_region.region.radius)
    link = task.hand.links[task.hand.link_index(hand_region.link)]
    return max((float(c.radius) for c in link.collision), default=0.0)


def pad_exclusions(task: Task, contact_points_object) -> list[tuple[int, np.ndarray, float]]:
    """Per contact: ``(link index, contact point (3,) in the object frame [mm], pad radius [mm])``."""
    out = []
    for c, point in zip(task.contacts, contact_points_object):
        hr = task.hand_region(c)
        out.append((task.hand.link_index(hr.link), np.asarray(point, dtype=float), pad_radius(task, hr)))
    return out


def _kept_pieces(a, b, radius, balls) -> list[tuple[np.ndarray, np.ndarray]]:
    """The pieces of segment a-b outside every ball ``(centre, rho)`` grown by ``radius``."""
    pieces = [(0.0, 1.0)]
    d = b - a
    dd = float(d @ d)
    for centre, rho in balls:
        R = radius + rho
        f = a - centre
        if dd <= 1e-18:
            lo, hi = (0.0, 1.0) if f @ f < R * R else (1.0, 0.0)
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
            (the pads there are excepted, see the module docstring); empty: nothing excepted.
        links: indices of the links to check (default: every link with capsules).
    """
    starts, ends, radius, link = capsule_segments(task, pose, T_palm_object)
    if links is not None:
        keep = np.isin(link, list(links))
        starts, ends, radius, link = starts[keep], ends[keep], radius[keep], link[keep]
    balls: dict[int, list] = {}
    for li, point, rho in pad_exclusions(task, contact_points_object):
        balls.setdefault(li, []).append((point, rho))
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
