"""How numbers are written: plain floats, degrees rounded, unit vectors that read back exactly.

Every kind's writer (:mod:`.regions`, :mod:`.hands`, :mod:`.objects`, :mod:`.tasks`) writes
its numbers with these, so that reading a written file and writing it again gives the same
mapping.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

__all__ = ["DEG_DECIMALS", "written_deg", "plain_floats", "settled_unit"]

DEG_DECIMALS = 12  # degrees are written rounded to this many decimals (1e-12 deg ~ 2e-14 rad)


def written_deg(rad: float) -> float:
    """An angle [rad] as written [deg], rounded to :data:`DEG_DECIMALS` decimals."""
    return round(math.degrees(float(rad)), DEG_DECIMALS) + 0.0  # "+ 0.0" turns -0.0 into 0.0


def plain_floats(values) -> list:
    """A (nested) list of plain floats, without negative zeros."""
    arr = np.asarray(values, dtype=float) + 0.0
    return arr.tolist()


def settled_unit(vector, canon: Callable[[np.ndarray], np.ndarray]) -> list[float]:
    """A unit vector within a few ulps of ``vector`` that ``canon`` (the model's own
    normalisation) maps exactly onto itself, so that writing, reading and writing again
    gives the same numbers.  Deterministic; falls back to ``canon(vector)``."""
    y = canon(np.asarray(vector, dtype=float))
    for _ in range(8):
        z = canon(y)
        if np.array_equal(z, y):
            return plain_floats(y)
        y = z
    rng = np.random.default_rng(0)
    for _ in range(500):
        cand = canon(y + rng.integers(-2, 3, size=y.shape) * (y != 0) * np.spacing(y))
        if np.array_equal(canon(cand), cand):
            return plain_floats(cand)
    return plain_floats(y)
