"""Which finger goes where: the finger <-> region assignment of a task, searched (issue 30).

* :class:`OpenContact`, :class:`OpenTask` -- a task whose contacts may leave the hand
  region open (``hand: any`` or a list of candidates in a task file), :class:`Assignment`,
  :func:`enumerate_assignments`, :func:`concrete_task` (:mod:`.model`);
* :class:`SpanProof`, :func:`prove_by_span`, :func:`check_span_proof` -- an assignment
  proven impossible by the hand's span (:mod:`.span`);
* :func:`search_assignments` with :class:`AssignmentOptions` -- every assignment decided:
  feasible (ranked by grasp quality), infeasible (with its proof) or undecided
  (:class:`AssignmentReport`; :mod:`.search`, :mod:`.solving`).

See ``docs/assignment.md``.
"""

from .model import Assignment, OpenContact, OpenTask, concrete_task, enumerate_assignments
from .search import (
    AssignmentOptions,
    AssignmentOutcome,
    AssignmentProgress,
    AssignmentReport,
    Impossible,
    Undecided,
    assignment_seed,
    search_assignments,
)
from .span import SpanProof, check_span_proof, prove_by_span

__all__ = [
    "OpenContact", "OpenTask", "Assignment", "enumerate_assignments", "concrete_task", "AssignmentOptions",
    "AssignmentOutcome", "AssignmentProgress", "AssignmentReport", "Impossible", "Undecided", "assignment_seed",
    "search_assignments", "SpanProof", "prove_by_span", "check_span_proof",
]  # fmt: skip
