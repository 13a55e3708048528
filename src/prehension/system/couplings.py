r"""Joint couplings ``theta_d = r theta_s + o`` of any ratio in the polynomial system.

Every joint angle in the system is known by its cosine and sine variables.  A coupling
enters the system in two ways:

* **Exactly, for a simple rational ratio** ``r = p / q`` (``|p|, q <= MAX_MULTIPLE``, ``r``
  equal to ``p / q`` within ``1e-12 max(1, |r|)``): ``q theta_d = p theta_s + q o``, so

  .. math::

      \cos q\theta_d = \cos p\theta_s \cos qo - \sin p\theta_s \sin qo, \qquad
      \sin q\theta_d = \sin p\theta_s \cos qo + \cos p\theta_s \sin qo,

  where ``cos n theta`` and ``sin n theta`` are polynomials in ``cos theta`` and
  ``sin theta`` built by the recursion ``C_{n+1} = C_n c - S_n s``, ``S_{n+1} = S_n c + C_n s``
  (one product variable per term, so the system keeps its canonical form).  These
  equations hold at every configuration that satisfies the coupling: nothing is lost.
  They also admit ``theta_d = (p theta_s + q o + 2 pi k) / q`` for every integer ``k``
  (``q`` branches ``2 pi / q`` apart; ``r = +-1`` has only one): a superset, so proofs of
  infeasibility stay valid.
* **As an angle coupling for every ratio** (:class:`~.canonical.AngleCoupling`): the
  complete solver intersects, on each box, the interval of ``theta_s`` that the box's
  cosine and sine allow within the joint's limits, mapped through ``r theta_s + o``, with
  that of ``theta_d`` (and back), and adds the chord cut of each interval to its linear
  programs.  This is a sound relaxation of a ratio that has no exact polynomial form
  (e.g. a URDF ``<mimic multiplier="0.7311">``) which becomes exact as boxes shrink, and
  it cuts the spurious branches of the rational form.

Answers are verified on the task itself, whose residual function checks the coupling.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from ..hands.model import Coupling, Hand
from .builder import Builder, Lin
from .canonical import AngleCoupling

__all__ = ["MAX_MULTIPLE", "exact_ratio", "multiple_angle", "add_coupling"]

MAX_MULTIPLE = 12  # largest |p| and q of a ratio p / q written as exact polynomial equations


def exact_ratio(ratio: float) -> tuple[int, int] | None:
    """``(p, q)`` with ``ratio = p / q`` (``q >= 1``, both at most ``MAX_MULTIPLE`` in size), or None."""
    frac = Fraction(float(ratio)).limit_denominator(MAX_MULTIPLE)
    p, q = frac.numerator, frac.denominator
    if abs(p) > MAX_MULTIPLE or abs(p / q - ratio) > 1e-12 * max(1.0, abs(ratio)):
        return None
    return p, q


def multiple_angle(b: Builder, cos_i: int, sin_i: int, n: int, name: str) -> tuple[Lin, Lin]:
    """``(cos n theta, sin n theta)`` as linear expressions in new variables, ``n >= 0``."""
    if n == 0:
        return Lin.constant(1.0), Lin.constant(0.0)
    C, S = Lin.var(cos_i), Lin.var(sin_i)
    for k in range(2, n + 1):
        ck = b.as_var_bounded(C, f"cos{k - 1}_{name}", -1.0, 1.0) if k > 2 else cos_i
        sk = b.as_var_bounded(S, f"sin{k - 1}_{name}", -1.0, 1.0) if k > 2 else sin_i
        C = Lin.var(b.product(ck, cos_i)) - Lin.var(b.product(sk, sin_i))
        S = Lin.var(b.product(sk, cos_i)) + Lin.var(b.product(ck, sin_i))
    return C, S


def add_coupling(b: Builder, hand: Hand, cpl: Coupling, dof_vars: dict[str, tuple[int, int]]) -> bool:
    """Add ``cpl`` (both dofs in ``dof_vars``); returns whether it was written exactly."""
    cd, sd = dof_vars[cpl.dof]
    cs, ss = dof_vars[cpl.source]
    d, s = hand.dof_index(cpl.dof), hand.dof_index(cpl.source)
    range_d, range_s = (float(hand.lower[d]), float(hand.upper[d])), (float(hand.lower[s]), float(hand.upper[s]))
    b.coupling(AngleCoupling(cd, sd, cs, ss, float(cpl.ratio), float(cpl.offset), range_d, range_s))
    exact = exact_ratio(cpl.ratio)
    if exact is None:
        return False
    p, q = exact
    Cd, Sd = multiple_angle(b, cd, sd, q, cpl.dof)
    Cs, Ss = multiple_angle(b, cs, ss, abs(p), cpl.source)
    Ss = Ss * float(np.sign(p) or 1.0)  # sin(-n theta) = -sin(n theta)
    co, so = np.cos(q * cpl.offset), np.sin(q * cpl.offset)
    b.equation(Cd - (Cs * co - Ss * so))
    b.equation(Sd - (Ss * co + Cs * so))
    return True
