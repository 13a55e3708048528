"""Where the complete solver splits a box: the widest scaled interval, or a rotation's quaternion.

By default a box is split through the middle of its base variable of largest *scaled*
width (width over the variable's width in the initial box).  Past a frontier made by 3-4
contacts together that is, split after split, one of a link rotation's nine entries, and the
linear programs narrow the other eight by a few percent (CHANGELOG, issue 32).  Two options
(:class:`.shrink.ShrinkOptions`, off by default) split whole rotations instead:

* ``quaternions="palm" | "links"``: the system also carries the unit quaternion
  ``q = (w, x, y, z)``, ``w >= 0``, of the palm's rotation (or every link's), with
  ``R = R(q)`` (:func:`prehension.system.build_system`), and the split takes the widest
  quaternion component while its scaled width exceeds ``branch_width``: one split halves a
  set of whole rotations (a slab of the hemisphere of unit quaternions), and the
  contraction and the LPs carry that to the nine entries;
* ``angles=True``: each joint angle of half range ``h < 90 deg`` also has the variable
  ``sin(theta - mid)``, monotone over the range, and once the quaternion components are
  narrower than ``branch_width`` the widest of these is split while wider than it: one
  split halves the angle's range, so the rotations of the link and of every link after it.

Below the threshold the default rule applies (docs/complete-solver.md, "Quaternion and
angle branching").  Any choice of variable is sound: the two halves cover the box.
"""

from __future__ import annotations

import numpy as np

from ...system.formulation import Formulation
from .shrink import ShrinkOptions

__all__ = ["scaled_widths", "shrink_variables", "split_variable"]


def _scaled(form: Formulation, lower, upper, indices) -> np.ndarray:
    system = form.system
    ref = np.maximum(system.upper - system.lower, 1e-12)
    return (upper[indices] - lower[indices]) / ref[indices]


def scaled_widths(form: Formulation, lower, upper) -> np.ndarray:
    """The widths of the base variables relative to their widths in the initial box."""
    return _scaled(form, lower, upper, form.base_indices)


def shrink_variables(form: Formulation) -> tuple[int, ...]:
    """The variables the LPs bound: the base variables, and the angles' ``sin(theta - mid)``
    when the system has them (their widths decide the splits)."""
    return tuple(form.base_indices.tolist()) + tuple(sorted(form.angle_vars.values()))


def split_variable(form: Formulation, lower, upper, options: ShrinkOptions) -> int:
    """The index (into the system's variables) of the variable the box is split through."""
    groups = []
    if form.quaternion_vars and options.quaternions != "none":
        groups.append(np.concatenate(list(form.quaternion_vars.values())))
    if form.angle_vars and options.angles:
        groups.append(np.array(sorted(form.angle_vars.values())))
    for indices in groups:
        widths = _scaled(form, lower, upper, indices)
        if widths.max() > options.branch_width:
            return int(indices[int(np.argmax(widths))])
    return int(form.base_indices[int(np.argmax(scaled_widths(form, lower, upper)))])
