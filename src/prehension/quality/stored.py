"""Quality in result files: what a solution's ``"quality"`` entry holds, and its re-derivation.

Every solution of a result file carries (:func:`quality_entry`)::

    "quality": {"force_closure": true, "epsilon": 0.0123, "volume": 4.5e-05,
                "closure_margin": 0.0021, "center_mm": [x, y, z], "radius_mm": 159.5,
                "options": {"friction": 0.6, "cone_edges": 8, "torsion_mm": 0.0,
                            "radius_mm": null, "center_mm": null}}

or, when the object has no size to scale torques by, ``{"unavailable": "<why>",
"options": {...}}``.  ``prehension check`` recomputes the entry from the file's own
contacts with the stated options (:func:`check_quality_entry`), so a tampered epsilon is
caught.
"""

from __future__ import annotations

import math

from ..errors import PrehensionError
from ..tasks.model import Task
from .grasp import contacts_quality
from .options import QualityOptions

__all__ = ["quality_entry", "quality_entries", "check_quality_entry", "QUALITY_TOLERANCE"]

QUALITY_TOLERANCE = 1e-9  # largest relative gap between a stored measure and the recomputed one


def quality_entry(task: Task, T_palm_object, contacts, options: QualityOptions = QualityOptions()) -> dict:
    """The ``"quality"`` entry of one solution (see the module docstring)."""
    try:
        return contacts_quality(task, T_palm_object, contacts, options).to_dict()
    except PrehensionError as exc:
        return {"unavailable": str(exc), "options": options.to_dict()}


def quality_entries(result, options: QualityOptions | None = None) -> list[dict]:
    """The ``"quality"`` entry of each solution of ``result`` (a
    :class:`~prehension.results.SolveResult`), measured with ``options`` (``None``: the
    defaults): what :func:`~prehension.results.write_result` stores with each solution."""
    options = options if options is not None else QualityOptions()
    return [quality_entry(result.task, s.T_palm_object, s.contacts, options) for s in result.solutions]


def check_quality_entry(task: Task, T_palm_object, contacts, stored) -> tuple[bool, str]:
    """``(holds, detail)``: does ``stored`` equal the entry recomputed with its own options?"""
    if not isinstance(stored, dict):
        return False, f"expected a mapping, got {type(stored).__name__}"
    try:
        options = QualityOptions.from_dict(stored.get("options"))
    except (PrehensionError, TypeError) as exc:
        return False, f"its options cannot be read: {exc}"
    again = quality_entry(task, T_palm_object, contacts, options)
    if "unavailable" in again or "unavailable" in stored:
        same = again.get("unavailable") == stored.get("unavailable")
        return same, f"unavailable: {again.get('unavailable', 'no: it can be computed')}"
    wrong = [key for key in ("force_closure", "epsilon", "volume", "closure_margin", "radius_mm", "center_mm")
             if not _same(stored.get(key), again[key])]  # fmt: skip
    summary = (f"{'force closure' if again['force_closure'] else 'not force closure'}, "
               f"epsilon {again['epsilon']:.4g}, volume {again['volume']:.3g}")  # fmt: skip
    if wrong:
        return False, f"{', '.join(wrong)} differ from the recomputed ones ({summary})"
    return True, summary


def _same(stored, again) -> bool:
    if isinstance(again, bool):
        return stored is again
    if isinstance(again, list):
        return isinstance(stored, list) and len(stored) == len(again) and all(_same(a, b) for a, b in zip(stored, again))
    if not isinstance(stored, (int, float)) or isinstance(stored, bool):
        return False
    return math.isclose(float(stored), float(again), rel_tol=QUALITY_TOLERANCE, abs_tol=1e-15)
