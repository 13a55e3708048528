"""Assignment verdicts as batch records: one ``.jsonl`` line per assignment.

The output of an assignment search is a batch journal (:mod:`prehension.batch.journal`):
the same record format, the same task lines (each distinct concrete task once), the same
resume and the same ``prehension check``.  A record's ``id`` is the assignment's label
(``"thumb_tip->A, index_tip->B"``) and ``"assignment"`` names it::

    {"prehension": "batch/1", "id": "thumb_tip->A, index_tip->B", "task": NAME, "source": FILE,
     "method": "local" | "complete" | "span", "seed": ..., "status": ..., "seconds": ...,
     "message": ..., "task_ref": ..., "result": {...},
     "assignment": {"hand_regions": [...], "object_regions": [...], "initial_poses": N}}

``result`` is the result file of the assignment's concrete task: its verified solutions
(with their quality), the complete solver's ``infeasible`` (re-proved by ``check``), or,
for an assignment the span rules out, ``method: "span"`` with the proof in
``stats["proof"]`` (:class:`~.span.SpanProof`; ``check`` derives it again).  An undecided
assignment's status is ``gave_up``.
"""

from __future__ import annotations

from ..batch.loading import LoadedTask
from ..batch.records import RecordHead, RecordLine, result_line
from ..results import SolveResult, Status
from .search import AssignmentOutcome, Impossible, Undecided, assignment_seed
from .span import SpanProof

__all__ = ["verdict_result", "verdict_line", "ASSIGNMENT_KEY"]

ASSIGNMENT_KEY = "assignment"


def verdict_result(item) -> SolveResult:
    """The :class:`~prehension.results.SolveResult` a verdict is recorded as."""
    if isinstance(item, AssignmentOutcome):
        return item.result
    if isinstance(item, Impossible) and isinstance(item.proof, SpanProof):
        proof = item.proof
        return SolveResult(item.task, "span", Status.INFEASIBLE, proof.message, stats={"proof": proof.to_dict()})
    if isinstance(item, Impossible):
        return item.proof
    if isinstance(item, Undecided):
        return item.result
    raise TypeError(f"not an assignment verdict: {type(item).__name__}")


def verdict_line(item, source: str, seed: int, initial_poses: int | None = None) -> tuple[RecordLine, LoadedTask]:
    """The record of one verdict (``item``: :class:`~.search.AssignmentOutcome`,
    :class:`~.search.Impossible` or :class:`~.search.Undecided`) of the open task read from
    ``source``, searched with base seed ``seed`` and ``initial_poses`` initial poses per
    assignment (kept in the record's ``assignment`` entry, for a retry to go on from it:
    :mod:`.resume`; ``None``: not said); and its loaded task (its task and file lines)."""
    result = verdict_result(item)
    assignment = item.assignment
    entry = {"id": assignment.label, "name": result.task.name, "source": source}
    loaded = LoadedTask(result.task)
    qualities = item.qualities if isinstance(item, AssignmentOutcome) else ()
    named = {"hand_regions": list(assignment.hand_regions), "object_regions": list(assignment.object_regions)}
    extra = {ASSIGNMENT_KEY: named if initial_poses is None else {**named, "initial_poses": initial_poses}}
    if isinstance(item, AssignmentOutcome) and item.physics:
        extra["physics"] = list(item.physics)
    head = RecordHead(entry, result.method, assignment_seed(seed, assignment))
    return result_line(head, result, loaded, result.seconds, list(qualities), extra), loaded
