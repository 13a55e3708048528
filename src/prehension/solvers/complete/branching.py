"""Where the complete solver splits a box: the widest scaled interval, or a rotation's quaternion.

By default a box is split through the middle of its base variable of largest *scaled*
width (width over the variable's width in the initial box).  Past a frontier made by 3-4
contacts together that is, split after split, one of a link rotation's nine entries, and the
linear programs narrow the other eight by a few percent (CHANGELOG, issue 32).  With
``ShrinkOptions(quaternions="palm" | "links")`` the system also carries the unit quaternion
``q = (w, x, y, z)``, ``w >= 0``, of those rotations (:func:`prehension.system.build_system`)
and the split takes the widest quaternion component while its scaled width exceeds
``quaternion_split``: one split then halves a set of whole rotations (a slab of the
hemisphere of unit quaternions), and the contraction and the LPs carry that to the nine
entries through ``R = R(q)`` (docs/complete-solver.md, "Quaternion branching").  Below the
threshold the default rule applies (to the quaternion variables too).

Any choice of variable is sound: the two halves cover the box.
"""

from __future__ import annotations

import numpy as np

from ...system.formulation import Formulation
from .shrink import ShrinkOptions

__all__ = ["scaled_widths", "split_variable"]


def scaled_widths(form: Formulation, lower, upper) -> np.ndarray:
    """The widths of the base variables relative to their widths in the initial box."""
    system = form.system
    ref = np.maximum(system.upper - system.lower, 1e-12)
    base = form.base_indices
    return (upper[base] - lower[base]) / ref[base]


def split_variable(form: Formulation, widths: np.ndarray, options: ShrinkOptions) -> int:
    """The index (into the system's variables) of the variable a box of these scaled
    ``widths`` (:func:`scaled_widths`) is split through."""
    base = form.base_indices
    if form.quaternion_vars and options.quaternions != "none":
        q = np.flatnonzero(np.isin(base, np.concatenate(list(form.quaternion_vars.values()))))
        widest = q[int(np.argmax(widths[q]))]
        if widths[widest] > options.quaternion_split:
            return int(base[widest])
    return int(base[int(np.argmax(widths))])
