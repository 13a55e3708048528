"""Batch records as they travel from a worker to the client: JSON lines, made on the worker.

A worker serialises every record itself, so the client only appends bytes: its own cost
per task stays a fraction of a millisecond whatever the size of a record (issue 16).
:class:`ChunkOutput` is what a chunk returns: per task ``(id, status, task ref, line)``,
and the task line of every ref its records use (see :mod:`.journal`).
"""

from __future__ import annotations

import json
from typing import Any, Mapping, NamedTuple, Sequence

from .journal import RECORD_TAG

__all__ = ["ChunkOutput", "RecordLine", "RecordHead", "STAGES", "encode", "result_line", "error_line"]

STAGES = ("load", "solve", "quality", "record")  # where a worker's time on a chunk goes (ChunkOutput.stages)


class RecordLine(NamedTuple):
    """One task's record, ready to append."""

    id: str
    status: str
    task_ref: str | None  # the task line it needs in the journal (compact records), else None
    line: bytes  # the JSON record, newline included


class ChunkOutput(NamedTuple):
    """What a chunk sends back: its records, the task lines they refer to (by ref), the
    worker's ``(wall, CPU)`` seconds per stage of the chunk (:data:`STAGES`; CPU of the
    worker's thread; for benchmarks and profiling: nothing of it is written), and the file
    lines of the files those tasks name (by SHA-256; the client writes each once)."""

    records: list
    tasks: dict
    stages: Mapping[str, tuple[float, float]] = {}
    files: Mapping[str, bytes] = {}


def encode(data: Mapping[str, Any]) -> bytes:
    """One JSON line (compact separators, newline included)."""
    return (json.dumps(data, separators=(",", ":"), check_circular=False) + "\n").encode("utf-8")  # a tree: no cycles


class RecordHead(NamedTuple):
    """Whom a record is about: the batch entry (``{"id", "name", "source", ...}``), and the
    method and seed its task was solved with."""

    entry: Mapping[str, Any]
    method: str
    seed: int

    def record(self, **fields) -> dict:
        """A record's fields in their order (see :mod:`.journal`)."""
        entry = self.entry
        return {
            "prehension": RECORD_TAG, "id": entry["id"], "task": entry["name"], "source": entry["source"],
            "method": self.method, "seed": self.seed, **fields,
        }  # fmt: skip


def error_line(head: RecordHead, status: str, message: str, seconds: float) -> RecordLine:
    """The record of a task that could not be solved (``invalid`` or ``error``): no result."""
    data = head.record(status=status, seconds=seconds, message=message, result=None)
    return RecordLine(head.entry["id"], status, None, encode(data))


def result_line(head: RecordHead, result, loaded, seconds: float, qualities: Sequence[dict],
                extra: Mapping[str, Any] | None = None, self_contained: bool = False, physics=None) -> RecordLine:  # fmt: skip
    """The record of a solved (or given up, or proven infeasible) task.

    Args:
        result: its :class:`~prehension.results.SolveResult`.
        loaded: its :class:`~.loading.LoadedTask` (the task dict and ref, built once).
        seconds: the task's time on the worker [s].
        qualities: the ``"quality"`` entry of each solution
            (:func:`~prehension.quality.quality_entries`), measured by the caller.
        extra: fields after ``result`` (``physics``, ``held``).
        self_contained: embed the task in the result, else refer to its task line.
        physics: per solution, its physics verdict stored with it (``batch --hold``, as
            ``solve --hold`` stores it; :func:`~prehension.results.result_to_dict`), or ``None``.
    """
    from ..results import result_to_dict

    data = result_to_dict(result, qualities, embed_task=False, physics=physics)  # no pre-grasp: docs/batch.md
    fields = dict(status=result.status, seconds=seconds, message=result.message)
    entry_id = head.entry["id"]
    if self_contained:
        top = {k: data[k] for k in ("prehension", "units", "frames")}
        carried = {"files": loaded.files} if loaded.files else {}  # self-contained: its own copy of the mesh
        whole = {**top, "task": loaded.task_dict, **carried, **data}
        return RecordLine(entry_id, result.status, None, encode(head.record(**fields, result=whole, **(extra or {}))))
    record = head.record(**fields, task_ref=loaded.ref, result=data, **(extra or {}))
    return RecordLine(entry_id, result.status, loaded.ref, encode(record))
