"""What a worker does with a chunk of batch entries: solve each, return its record.

Each task is solved alone, by :func:`prehension.solve.solve` with its own seed
(:func:`task_seed`), so that its result depends neither on the worker, nor on the order,
nor on the other tasks of its chunk.  (Solving a chunk as one
:func:`~prehension.solvers.local.solve_local_batch` call would be faster, but that call
scales its unknowns by the median size of the objects in the batch, so a task's answer
would depend on its neighbours.)
"""

from __future__ import annotations

import hashlib
import time
import traceback
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from ..errors import PrehensionError
from .journal import RECORD_TAG

__all__ = ["BatchOptions", "task_seed", "solve_chunk", "error_record"]

METHODS = ("auto", "local", "complete")


@dataclass(frozen=True)
class BatchOptions:
    """How to solve the tasks of a batch.

    Attributes:
        method: ``"auto"`` (local, then complete), ``"local"`` or ``"complete"``.
        seed: base seed; task ``id`` is solved with ``task_seed(seed, id)``.
        time_limit_s: complete solver: give up on a task after this long [s].
        chunk_size: tasks per Dask task (default: 8 for ``local``, 1 otherwise).
        retry_gave_up: solve again the tasks whose record says ``gave_up``.
        max_tasks: solve at most this many tasks in this run (then stop; re-run to go on).
        delay_s: testing only: sleep this long before each task [s], to make a run slow
            enough to kill a worker in the middle of it.
        sequences: initial-pose sequences of ``prehension offline`` (their JSON
            mappings); a task uses the one made for its hand (by name), if any, else
            its hand's default.
    """

    method: str = "auto"
    seed: int = 0
    time_limit_s: float | None = None
    chunk_size: int | None = None
    retry_gave_up: bool = False
    max_tasks: int | None = None
    delay_s: float = 0.0
    sequences: tuple = ()

    def __post_init__(self):
        def need(ok, message):
            if not ok:
                raise PrehensionError(f"batch: {message}")

        need(self.method in METHODS, f"method must be one of {', '.join(METHODS)}, got {self.method!r}")
        need(isinstance(self.seed, int) and self.seed >= 0, f"seed must be an integer >= 0, got {self.seed!r}")
        need(self.time_limit_s is None or self.time_limit_s > 0, f"time limit must be > 0 s, got {self.time_limit_s}")
        need(self.chunk_size is None or self.chunk_size >= 1, f"chunk size must be >= 1, got {self.chunk_size}")
        need(self.max_tasks is None or self.max_tasks >= 0, f"max tasks must be >= 0, got {self.max_tasks}")
        need(self.delay_s >= 0, f"delay must be >= 0 s, got {self.delay_s}")
        hands = [s.get("hand") for s in self.sequences]
        need(len(set(hands)) == len(hands), f"give one initial-pose sequence per hand, got several for {hands}")

    def sequence_for(self, hand_name: str):
        """The :class:`InitialPoseSequence` given for hand ``hand_name``, or None."""
        from ..solvers.local.sequence import InitialPoseSequence

        for data in self.sequences:
            if data.get("hand") == hand_name:
                return InitialPoseSequence.from_dict(data, f"sequence of hand {hand_name!r}")
        return None

    @property
    def tasks_per_chunk(self) -> int:
        """Tasks per Dask task: many for the local solver (milliseconds each), one otherwise."""
        if self.chunk_size is not None:
            return self.chunk_size
        return 8 if self.method == "local" else 1


def task_seed(base_seed: int, task_id: str) -> int:
    """The seed of task ``task_id``: 63 bits of SHA-256 of the base seed and the id."""
    digest = hashlib.sha256(f"{base_seed}\0{task_id}".encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def _record(entry: Mapping[str, Any], options: BatchOptions, **fields) -> dict:
    return {
        "prehension": RECORD_TAG, "id": entry["id"], "task": entry["name"], "source": entry["source"],
        "method": options.method, "seed": task_seed(options.seed, entry["id"]), **fields,
    }  # fmt: skip


def error_record(entry: Mapping[str, Any], options: BatchOptions, status: str, message: str, seconds: float = 0.0) -> dict:
    """The record of a task that could not be solved (``invalid`` or ``error``)."""
    return _record(entry, options, status=status, seconds=seconds, message=message, result=None)


def _solve_one(entry: Mapping[str, Any], options: BatchOptions) -> dict:
    from ..results import result_to_dict
    from ..solve import solve
    from ..solvers.complete.search import BranchAndPruneOptions
    from .inputs import entry_task

    started = time.perf_counter()
    try:
        task = entry_task(entry["payload"])
        result = solve(
            task, options.method, complete_options=BranchAndPruneOptions(time_limit_s=options.time_limit_s),
            seed=task_seed(options.seed, entry["id"]), sequence=options.sequence_for(task.hand.name),
        )  # fmt: skip
        data = result_to_dict(result)
    except PrehensionError as exc:
        return error_record(entry, options, "invalid", str(exc), time.perf_counter() - started)
    except Exception as exc:  # a bug must not stop the other tasks; the record says what happened
        last = traceback.extract_tb(exc.__traceback__)[-1]
        message = f"{type(exc).__name__}: {exc} ({last.filename}:{last.lineno})"
        return error_record(entry, options, "error", message, time.perf_counter() - started)
    seconds = time.perf_counter() - started
    return _record(entry, options, status=result.status, seconds=seconds, message=result.message, result=data)


def solve_chunk(entries: Sequence[Mapping[str, Any]], options: BatchOptions) -> list[dict]:
    """Solve every entry (``{"id", "name", "source", "payload"}``) of a chunk; one record each.

    Runs on a Dask worker; takes and returns plain data only.
    """
    records = []
    for entry in entries:
        if options.delay_s:
            time.sleep(options.delay_s)
        records.append(_solve_one(entry, options))
    return records
