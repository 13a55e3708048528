"""The hand's side of a planned grasp: which hand regions may touch, and how far apart.

A planned grasp puts ``K`` hand regions on ``K`` object regions.  The candidates are the
hand's *fingertips* (each region whose link is a finger's tip link: the pads
:mod:`prehension.hands.fingertips` fits to a URDF hand, the SA hand's ``*_tip``), and
with ``palm=True`` the palm's regions too.  Two numbers of the hand bound the proposal:

* the **span** of every pair of candidates: a proven upper bound on the distance between
  any point of one region and any point of the other over the joint limits
  (:func:`~prehension.hands.reach.span_bound_mm` between the regions' ball centres, plus
  both ball radii); contact points farther apart than the largest span cannot be touched
  by any two of the regions at once;
* the **gap**: two pads of radius ``r_a``, ``r_b`` touching a surface side by side are
  about ``r_a + r_b`` apart, and two fingers side by side about the sum of their
  half-widths (how far the tip link's collision capsules reach to either side along its
  joint's axis: the Allegro's distal links are 44 mm wide around 12 mm pads); contact
  points on one side closer than the larger of the two smallest sums would ask two
  fingers to overlap, so the proposal keeps its points that far apart.

The **opposition rule** (on by default): a hand with an opposing finger (the thumb) grasps
with the thumb against the other fingers, so in a proposed set (whose first point faces
the others, :mod:`.propose`) the first contact may take only the thumb's tip and the
others only the other fingertips (the palm's regions, with ``palm``, may take any).  It
cuts the assignments of a 3-contact set on a four-fingered hand from 24 to 6; without it
(``oppose=False``) every contact may take every candidate.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from ..errors import PrehensionError
from ..hands.model import Hand
from ..hands.reach import span_bound_mm

__all__ = ["HandSide", "hand_side"]

_DEFAULT_GAP_MM = 10.0  # regions without a ball (points, patches on links): no pad radius to go by
_SPAN_TOL_MM = 2.0


@dataclass(frozen=True, eq=False)
class HandSide:
    """The candidate hand regions of a planned grasp and the bounds between them.

    Attributes:
        hand: the hand.
        regions: candidate hand region names (fingertips, then the palm's with ``palm``).
        spans_mm: ``{(a, b): bound}`` for every pair ``a < b`` of :attr:`regions`: a proven
            upper bound on the distance between a point of region ``a`` and one of ``b`` [mm].
        gap_mm: the smallest distance kept between two contact points of one grasp [mm].
        opposing: the candidate regions on the tip of the hand's opposing finger (its
            thumb, :attr:`~prehension.hands.model.Hand.opposing_finger`), when the
            opposition rule is on; empty otherwise.
        palms: the palm's candidate regions (with ``palm``).
    """

    hand: Hand
    regions: tuple[str, ...]
    spans_mm: dict
    gap_mm: float
    opposing: tuple[str, ...] = ()
    palms: tuple[str, ...] = ()

    def candidates(self, opposing: bool) -> tuple[str, ...]:
        """The hand regions a contact may take: with the opposition rule, the opposing
        contact (a set's first) takes the thumb's tip (or the palm), the others the other
        fingertips (or the palm); without it, every candidate."""
        if not self.opposing:
            return self.regions
        if opposing:
            return self.opposing + self.palms
        return tuple(r for r in self.regions if r not in self.opposing)

    @property
    def max_span_mm(self) -> float:
        """The farthest any two candidate regions reach apart [mm]."""
        return max(self.spans_mm.values())

    def span_mm(self, a: str, b: str) -> float:
        return self.spans_mm[(a, b) if (a, b) in self.spans_mm else (b, a)]


def _ball(hand: Hand, name: str) -> tuple[np.ndarray, float | None]:
    """Centre (link frame) and radius of a hand region's ball; for a region on no sphere,
    its centroid and the largest distance of its sample points from it."""
    region = hand.regions[name].region
    ball = region.ball()
    if ball is not None:
        return np.asarray(ball[0], float), float(ball[1])
    centre = np.asarray(region.centroid(), float)
    points, _ = region.evaluate(region.sample_params(9))
    reach = float(np.max(np.linalg.norm(points - centre, axis=1))) if len(points) else 0.0
    return centre, None if reach == 0.0 else reach * 1.05 + 1e-6


def _half_width(hand: Hand, link: str) -> float:
    """How far the link's collision capsules reach to either side of its joint's centre,
    along the joint's axis (a finger's half-width, in the link frame) [mm]; 0 without
    capsules or a joint."""
    joint = hand.joint_of_link(link)
    capsules = hand.links[hand.link_index(link)].collision
    if joint is None or not capsules:
        return 0.0
    axis = joint.R_parent_child_zero.T @ joint.axis_in_parent  # the hinge, in the child frame
    ends = [(c.a - joint.origin_in_child, c.b - joint.origin_in_child, c.radius) for c in capsules]
    return float(max(max(abs(a @ axis), abs(b @ axis)) + r for a, b, r in ends))


def _palm_regions(hand: Hand) -> list[str]:
    return [n for n, r in hand.regions.items() if r.link == hand.palm]


def _candidates(hand: Hand, palm: bool) -> tuple[tuple[str, ...], tuple[str, ...]]:
    tips = {f.tip_link for f in hand.fingers}
    names = [n for n, r in hand.regions.items() if r.link in tips]
    palms: list[str] = []
    if palm:
        palms = _palm_regions(hand)
        if not palms:
            raise PrehensionError(
                f"hand {hand.name!r} has no region on its palm ({hand.palm!r}) to plan with: drop --palm, or give the "
                "hand a palm region (a hand YAML file's regions)"
            )
    return tuple(names + palms), tuple(palms)


def _opposing(hand: Hand, names: tuple[str, ...], fingers: int) -> tuple[str, ...]:
    """The opposing finger's tip regions among ``names``, when the rule can apply: the hand
    has an opposing finger and, besides it, at least ``fingers - 1`` fingertips."""
    if hand.opposing_finger is None:
        return ()
    tip = hand.finger(hand.opposing_finger).tip_link
    thumb = tuple(n for n in names if hand.regions[n].link == tip)
    others = [n for n in names if hand.regions[n].link != tip and hand.regions[n].link != hand.palm]
    return thumb if thumb and len(others) >= fingers - 1 else ()


def hand_side(hand: Hand, fingers: int, *, palm: bool = False, oppose: bool = True) -> HandSide:
    """The :class:`HandSide` of ``fingers`` contacts on ``hand``; ``oppose``: the opposition
    rule (:meth:`HandSide.candidates`; it applies when the hand has an opposing finger).

    Raises:
        PrehensionError: ``fingers`` is not an integer >= 2, or more than the hand has
            candidate regions (naming them).
    """
    names, palms = _candidates(hand, palm)
    if isinstance(fingers, bool) or not isinstance(fingers, (int, np.integer)) or fingers < 2:
        raise PrehensionError(f"the number of fingers must be an integer >= 2 (a grasp needs two contacts), got {fingers!r}")
    if fingers > len(names):
        what = "fingertip and palm regions" if palm else "fingertip regions"
        listed = ", ".join(names) or "none"
        raise PrehensionError(
            f"{fingers} contacts asked for, but hand {hand.name!r} has {len(names)} {what} ({listed}); "
            f"give --fingers 2..{len(names)}" + ("" if palm or not _palm_regions(hand) else " (or add --palm)")
        )
    balls = {n: _ball(hand, n) for n in names}
    spans = {}
    for a, b in combinations(names, 2):
        (ca, ra), (cb, rb) = balls[a], balls[b]
        link_a, link_b = hand.regions[a].link, hand.regions[b].link
        spans[(a, b)] = span_bound_mm(hand, link_a, ca, link_b, cb, tol_mm=_SPAN_TOL_MM) + (ra or 0.0) + (rb or 0.0)
    radii = sorted(r for _, r in balls.values() if r)
    widths = sorted(_half_width(hand, hand.regions[n].link) for n in names)
    gap = max(radii[0] + radii[1] if len(radii) >= 2 else _DEFAULT_GAP_MM, widths[0] + widths[1])
    opposing = _opposing(hand, names, fingers) if oppose else ()
    return HandSide(hand, names, spans, float(gap), opposing, palms)
