r"""Angle couplings on a box: interval contraction and chord cuts (any ratio).

An :class:`~prehension.system.canonical.AngleCoupling` says ``theta_d = r theta_s + o``
where each angle is known by its cosine and sine variables and lies in its joint's range.
On a box ``B``:

1. :func:`angle_hull`: the hull ``Theta`` of the angles ``theta`` in the range whose
   ``(cos theta, sin theta)`` lies in the box's rectangle.  On the circle, ``cos theta in
   [c_l, c_u]`` is two arcs ``+-[acos c_u, acos c_l]`` and ``sin theta in [s_l, s_u]`` two
   arcs ``[asin s_l, asin s_u]``, ``pi - [asin s_u, asin s_l]``; their intersections,
   repeated every ``2 pi`` and cut by the range, give ``Theta`` (or nothing: no angle of
   the range fits the box, which is then empty).
2. ``Theta_d <- Theta_d ∩ (r Theta_s + o)`` and ``Theta_s <- Theta_s ∩ (Theta_d - o) / r``.
3. :func:`cos_sin_ranges`: the cosines and sines of each ``Theta`` tighten the box.
4. :func:`coupling_rows`: each ``Theta = [a, b]`` narrower than ``2 pi`` gives the chord
   cut ``cos(m) x_cos + sin(m) x_sin >= cos(w / 2)`` (``m`` its middle, ``w`` its width):
   every point of the arc lies on the far side of its chord.  These rows join the linear
   programs.

Rounding.  ``acos``, ``asin``, ``cos`` and ``sin`` of numpy are accurate to a few ulps;
every angle bound is moved outwards by ``ANGLE_PAD + 8 eps |theta|`` and every cosine or
sine bound by ``ANGLE_PAD``, and the chord cut's right-hand side is lowered by
``4 ANGLE_PAD`` (``ANGLE_PAD = 1e-12``, thousands of times those errors), so no solution
of the box is ever removed.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["ANGLE_PAD", "angle_hull", "cos_sin_ranges", "contract_couplings", "coupling_rows"]

ANGLE_PAD = 1e-12
_TWO_PI = 2.0 * math.pi


def _pad(theta: float) -> float:
    return ANGLE_PAD + 8.0 * np.finfo(float).eps * abs(theta)


def _circle_arcs(cl: float, cu: float, sl: float, su: float) -> list[tuple[float, float]]:
    """Arcs ``(start, end)`` of the circle where ``cos in [cl, cu]`` and ``sin in [sl, su]``."""
    if cl > 1.0 or cu < -1.0 or sl > 1.0 or su < -1.0 or cl > cu or sl > su:
        return []
    if cl <= -1.0 and cu >= 1.0:
        by_cos = [(-math.pi, math.pi)]
    else:
        a1, a2 = math.acos(min(cu, 1.0)), math.acos(max(cl, -1.0))
        by_cos = [(a1, a2), (-a2, -a1)]
    if sl <= -1.0 and su >= 1.0:
        by_sin = [(-math.pi, math.pi)]
    else:
        b1, b2 = math.asin(max(sl, -1.0)), math.asin(min(su, 1.0))
        by_sin = [(b1, b2), (math.pi - b2, math.pi - b1)]
    arcs = []
    for a, b in by_cos:
        a, b = a - _pad(a), b + _pad(b)
        for c, d in by_sin:
            c, d = c - _pad(c), d + _pad(d)
            for k in (-1, 0, 1):
                lo, hi = max(a, c + k * _TWO_PI), min(b, d + k * _TWO_PI)
                if lo <= hi:
                    arcs.append((lo, hi))
    return arcs


def angle_hull(lo: float, hi: float, cl: float, cu: float, sl: float, su: float) -> tuple[float, float] | None:
    """Hull of ``{theta in [lo, hi]: cos theta in [cl, cu], sin theta in [sl, su]}`` (padded
    outwards), or None when that set is empty."""
    a_min, b_max = math.inf, -math.inf
    for a, b in _circle_arcs(cl, cu, sl, su):
        for k in range(math.floor((lo - b) / _TWO_PI), math.ceil((hi - a) / _TWO_PI) + 1):
            s, e = max(lo, a + k * _TWO_PI), min(hi, b + k * _TWO_PI)
            if s <= e:
                a_min, b_max = min(a_min, s), max(b_max, e)
    return None if a_min > b_max else (a_min, b_max)


def cos_sin_ranges(a: float, b: float) -> tuple[float, float, float, float]:
    """``(cos_lo, cos_hi, sin_lo, sin_hi)`` over ``theta in [a, b]`` (padded outwards)."""
    if b - a >= _TWO_PI:
        return -1.0, 1.0, -1.0, 1.0

    def contains(phase: float) -> bool:  # some phase + 2 pi k in [a, b]
        return math.floor((b - phase) / _TWO_PI) * _TWO_PI + phase >= a

    ca, cb, sa, sb = math.cos(a), math.cos(b), math.sin(a), math.sin(b)
    cos_hi = 1.0 if contains(0.0) else max(ca, cb) + ANGLE_PAD
    cos_lo = -1.0 if contains(math.pi) else min(ca, cb) - ANGLE_PAD
    sin_hi = 1.0 if contains(0.5 * math.pi) else max(sa, sb) + ANGLE_PAD
    sin_lo = -1.0 if contains(-0.5 * math.pi) else min(sa, sb) - ANGLE_PAD
    return max(cos_lo, -1.0), min(cos_hi, 1.0), max(sin_lo, -1.0), min(sin_hi, 1.0)


def _map(interval: tuple[float, float], ratio: float, offset: float) -> tuple[float, float]:
    """``ratio * interval + offset``, padded outwards."""
    ends = (ratio * interval[0] + offset, ratio * interval[1] + offset)
    lo, hi = min(ends), max(ends)
    return lo - _pad(lo), hi + _pad(hi)


def _intersect(x: tuple[float, float], y: tuple[float, float]) -> tuple[float, float] | None:
    lo, hi = max(x[0], y[0]), min(x[1], y[1])
    return (lo, hi) if lo <= hi else None


def coupled_intervals(c, lower: np.ndarray, upper: np.ndarray):
    """``(Theta_d, Theta_s)`` of one coupling on the box, each narrowed by the other; None
    when the box holds no angles that satisfy it."""
    theta_d = angle_hull(*c.range_d, lower[c.cos_d], upper[c.cos_d], lower[c.sin_d], upper[c.sin_d])
    theta_s = angle_hull(*c.range_s, lower[c.cos_s], upper[c.cos_s], lower[c.sin_s], upper[c.sin_s])
    if theta_d is None or theta_s is None:
        return None
    theta_d = _intersect(theta_d, _map(theta_s, c.ratio, c.offset))
    if theta_d is None:
        return None
    if c.ratio != 0.0:
        theta_s = _intersect(theta_s, _map(theta_d, 1.0 / c.ratio, -c.offset / c.ratio))
        if theta_s is None:
            return None
    return theta_d, theta_s


def contract_couplings(couplings, lower: np.ndarray, upper: np.ndarray) -> bool:
    """Tighten the cosine and sine intervals of every coupling in place; ``True`` when the
    box provably holds no solution."""
    for c in couplings:
        both = coupled_intervals(c, lower, upper)
        if both is None:
            return True
        for (a, b), (ci, si) in zip(both, ((c.cos_d, c.sin_d), (c.cos_s, c.sin_s))):
            cl, cu, sl, su = cos_sin_ranges(a, b)
            lower[ci], upper[ci] = max(lower[ci], cl), min(upper[ci], cu)
            lower[si], upper[si] = max(lower[si], sl), min(upper[si], su)
            if lower[ci] > upper[ci] or lower[si] > upper[si]:
                return True
    return False


def coupling_rows(couplings, lower: np.ndarray, upper: np.ndarray):
    """Chord cuts of the coupled angles' intervals on the box, as a relaxation block:
    ``(cols (B, 2), coef (B, 1, 2), rhs (B, 1))`` with ``coef @ (x_cos, x_sin) <= rhs``."""
    cols, coef, rhs = [], [], []
    for c in couplings:
        both = coupled_intervals(c, lower, upper)
        if both is None:
            continue  # the contraction reports the empty box; no row is needed here
        for (a, b), (ci, si) in zip(both, ((c.cos_d, c.sin_d), (c.cos_s, c.sin_s))):
            if b - a >= math.pi:  # the cut would not beat the box (cos(w/2) <= 0)
                continue
            m = 0.5 * (a + b)
            half = max(m - a, b - m) + _pad(m)
            cols.append((ci, si))
            coef.append([[-math.cos(m), -math.sin(m)]])
            rhs.append([-(math.cos(half) - 4.0 * ANGLE_PAD)])
    if not cols:
        return None
    return np.array(cols, dtype=int), np.array(coef), np.array(rhs)
