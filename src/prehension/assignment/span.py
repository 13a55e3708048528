"""Span proofs: the hand's own structure shows that an assignment has no grasp.

Contacts ``a`` and ``b`` put hand points ``h_a``, ``h_b`` on object points ``o_a``, ``o_b``
(within the strict contact tolerance).  Each hand region lies in a ball fixed to its link,
and the distance between two such balls' centres is bounded over the joint limits
(:func:`prehension.system.formulation.contact_reach`, by branch and bound over the joint
angles: :func:`prehension.hands.reach.max_point_distance`), so

.. math::

    |o_a - o_b| \\le |h_a - h_b| + 2\\,\\epsilon \\le \\mathrm{reach}_{ab} + 2\\,\\epsilon .

Each object region lies in the bounding box of points that hold it (a Bézier patch in the
convex hull of its control points, a cap in its sphere's box): the distance between the
two boxes, ``gap_ab``, bounds ``|o_a - o_b|`` from below.  ``gap_ab > reach_ab`` (plus a
margin far above rounding and the contact tolerance) is a proof that no configuration
within the joint limits makes both contacts: the assignment is impossible, whatever the
rest of the task.  The proof names the two contacts and both numbers; :func:`check_span_proof`
derives them again from the task (what ``prehension check`` runs on such a record).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..system.formulation import contact_reach
from ..system.regions import form_of
from ..tasks.model import Task
from ..verification.residuals import Tolerances

__all__ = ["SpanProof", "prove_by_span", "check_span_proof", "object_gap_mm", "SPAN_MARGIN_MM"]

#: Added to the reach before comparing: covers the contact tolerance (twice), region
#: parameters at their tolerance outside the unit square, and rounding.
SPAN_MARGIN_MM = 1e-3 + 2 * Tolerances().contact_mm
_REL = 1e-6


@dataclass(frozen=True)
class SpanProof:
    """Contacts ``contacts`` cannot both be made: their object regions are ``gap_mm`` apart
    at least, their hand regions ``reach_mm`` at most (module docstring)."""

    contacts: tuple[int, int]
    hand_regions: tuple[str, str]
    object_regions: tuple[str, str]
    reach_mm: float
    gap_mm: float
    kind: str = "span"

    @property
    def message(self) -> str:
        (ha, hb), (oa, ob) = self.hand_regions, self.object_regions
        return (f"proven impossible by the hand's span: {ha} and {hb} are at most {self.reach_mm:.2f} mm apart "
                f"over the joint limits, object regions {oa} and {ob} at least {self.gap_mm:.2f} mm")  # fmt: skip

    def to_dict(self) -> dict:
        data = asdict(self)
        return {"kind": data.pop("kind"), **{k: list(v) if isinstance(v, tuple) else v for k, v in data.items()}}


def object_gap_mm(task: Task, a: int, b: int) -> float:
    """A lower bound [mm] on the distance between the object regions of contacts ``a`` and
    ``b``: the distance between the bounding boxes that hold them (0 when they overlap)."""
    boxes = []
    for i in (a, b):
        points = np.asarray(form_of(task.object_region(task.contacts[i])).box_points(task.object_region(task.contacts[i])))
        boxes.append((points.min(axis=0), points.max(axis=0)))
    (lo_a, hi_a), (lo_b, hi_b) = boxes
    apart = np.maximum(0.0, np.maximum(lo_a - hi_b, lo_b - hi_a))  # (3,) per axis
    return float(np.linalg.norm(apart))


def _beyond(gap: float, reach: float) -> bool:
    return gap > reach * (1.0 + _REL) + SPAN_MARGIN_MM


def prove_by_span(task: Task) -> SpanProof | None:
    """The first pair of contacts of ``task`` whose object regions lie beyond its hand
    regions' reach (a :class:`SpanProof`), or ``None``: the span proves nothing."""
    n = len(task.contacts)
    pairs = sorted(((object_gap_mm(task, a, b), a, b) for a in range(n) for b in range(a + 1, n)), reverse=True)
    for gap, a, b in pairs:
        if gap <= SPAN_MARGIN_MM:
            return None  # sorted: the rest overlap too
        reach = contact_reach(task, a, b)
        if _beyond(gap, reach):
            ca, cb = task.contacts[a], task.contacts[b]
            return SpanProof((a, b), (ca.hand_region, cb.hand_region), (ca.object_region, cb.object_region), reach, gap)
    return None


def check_span_proof(task: Task, proof) -> tuple[bool, str]:
    """``(holds, detail)``: is the span proof ``proof`` (a :class:`SpanProof` or its
    :meth:`~SpanProof.to_dict`) a proof for ``task``?  Its contacts must name the task's
    regions, and the reach and gap derived again must prove it (the stored numbers are
    only reported)."""
    data = proof.to_dict() if isinstance(proof, SpanProof) else proof
    try:
        a, b = (int(i) for i in data["contacts"])
        hand, objects = tuple(data["hand_regions"]), tuple(data["object_regions"])
        stored = float(data["reach_mm"]), float(data["gap_mm"])
    except (KeyError, TypeError, ValueError) as exc:
        return False, f"malformed span proof ({type(exc).__name__}: {exc})"
    n = len(task.contacts)
    if not (0 <= a < n and 0 <= b < n and a != b):
        return False, f"its contacts {a}, {b} are not two contacts of the task ({n} contacts)"
    ca, cb = task.contacts[a], task.contacts[b]
    if hand != (ca.hand_region, cb.hand_region) or objects != (ca.object_region, cb.object_region):
        return False, "its regions are not those of the task's contacts"
    reach, gap = contact_reach(task, a, b), object_gap_mm(task, a, b)
    said = f"reach {reach:.4f} mm (stored {stored[0]:.4f}), gap {gap:.4f} mm (stored {stored[1]:.4f})"
    if not _beyond(gap, reach):
        return False, f"FALSE: derived again, the gap does not exceed the reach: {said}"
    return True, f"re-derived: {said}"
