"""The interface through which the complete solver verifies its boxes: it is given one.

A box's point is only a candidate: the search refines points of the box on the original
constraints (local iterations, which may leave the box) and judges what they reach by the
residual function alone (:func:`prehension.results.make_solution`), so that a returned
solution is a solution of the task.  The iterations are not the complete solver's own: the
caller gives them as a :class:`BoxVerifier` in
:attr:`~prehension.solvers.complete.search.BranchAndPruneOptions.verifier` --
:func:`prehension.solve` and the other callers give the local solver's
(:class:`prehension.solvers.local.verifier.LocalVerifier`, around
:func:`~prehension.solvers.local.refine_local`).  Without one the search still prunes and
proves infeasibility, but no box is verified (a box narrower than ``sigma`` is then kept
as holding no verified solution).

A verifier travels with the options to the executor's workers: it must pickle.
"""

from __future__ import annotations

from typing import Any, Protocol, Sequence, runtime_checkable

from ...tasks.model import Configuration, Task

__all__ = ["BoxVerifier", "Reached"]


class Reached(Protocol):
    """What the iterations reached from each start."""

    configurations: Sequence[Configuration | None]  # per start: the configuration reached, or None

    def best(self) -> tuple[float, float]:
        """``(contact_mm, normal_deg)``: how close the closest start came."""


@runtime_checkable
class BoxVerifier(Protocol):
    """Local iterations from given starts (joint angles, object pose and contact parameters).

    Attributes:
        options: the iterations' own options (a dataclass): recorded with the search's
            options, under ``"refine"``, in the result's stats and in a checkpoint's
            fingerprint (another verification is another search).
    """

    options: Any

    def __call__(self, task: Task, starts: Sequence[Configuration]) -> Reached:
        """Iterate from every start; a configuration is kept when it meets the strict tolerances."""
