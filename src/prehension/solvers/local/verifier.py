"""The local solver's iterations as the complete solver's box verifier.

:class:`LocalVerifier` is a :class:`~prehension.solvers.complete.verifier.BoxVerifier`:
the complete solver is given it (it does not import the local solver) by
:func:`prehension.solve` and the other callers of
:func:`~prehension.solvers.complete.search.solve_complete`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

from ...tasks.model import Configuration, Task
from .options import LocalOptions
from .solver import Refinement, refine_local

__all__ = ["LocalVerifier"]


@dataclass(frozen=True)
class LocalVerifier:
    """:func:`~prehension.solvers.local.refine_local` with ``options`` (a picklable value)."""

    options: LocalOptions = field(default_factory=LocalOptions)

    def __call__(self, task: Task, starts: Sequence[Configuration]) -> Refinement:
        return refine_local(task, starts, self.options)
