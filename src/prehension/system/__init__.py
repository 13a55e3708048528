"""The polynomial system of a grasp task (Rosales et al. 2011, sec. 3): build first, solve second.

:func:`build_system` turns a :class:`~prehension.tasks.model.Task` into a
:class:`Formulation`: the canonical :class:`System` of eq. 29 (variables with an initial
box, linear equations and inequalities, ``x_k = x_i^2``, ``x_k = x_i x_j`` and Bernstein
equations) and the maps between its points and task configurations (:func:`embed`,
:func:`configuration_from_point`).  The complete solver
(:mod:`prehension.solvers.complete`) consumes it; nothing here depends on a solver.
"""

from .builder import Builder, Lin
from .canonical import BernsteinEquation, System
from .embedding import configuration_from_point, embed
from .formulation import Formulation, build_system

__all__ = [
    "BernsteinEquation",
    "Builder",
    "Formulation",
    "Lin",
    "System",
    "build_system",
    "configuration_from_point",
    "embed",
]
