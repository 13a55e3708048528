"""What a worker does with a chunk of batch entries: solve them, return their records.

**The local solver, a chunk at a time.**  With ``method="local"`` (and the local stage of
``"auto"``) the chunk's tasks go to the local solver's batch path in one call (one per
initial-pose sequence given with ``--sequence``;
:func:`~prehension.solvers.local.solve_local_batch`: tasks of one structure are solved
together), each with its own seed (:func:`task_seed`).  Every scale of that call is per
task and every task draws from its own generator, so a task's answer is, bit for bit,
the one :func:`prehension.solve.solve` gives it alone with that seed: it depends neither
on the worker, nor on the order, nor on the other tasks of its chunk.  Each answer is
re-verified by :meth:`~prehension.solvers.local.LocalRecord.to_result` (the residual
function, strict tolerances) before it becomes a record.  ``"auto"`` then hands each answer
that is not a solution to :func:`prehension.solve.complete_after_local` -- the one ``auto``
policy, which :func:`~prehension.solve.solve` follows too: the complete solver runs on the
task, the answer carrying the local one's message and stats, and the local solver never
runs twice on a task; ``"complete"`` solves every task
with :func:`~prehension.solve.solve`, one at a time.

**Parsed once.**  Tasks are parsed once per worker process (:mod:`.loading`) and their
records are serialised here (:mod:`.records`), the task stored once per distinct task.

**Seconds.**  A record's ``seconds`` is the task's share of the chunk's work on the
worker: its loading, an equal share of the batch call it took part in, its own
verification (and, with ``auto``, its complete solve) and the quality of its solutions.  Times are the only fields of a
record that depend on the chunking.
"""

from __future__ import annotations

import hashlib
import math
import time
import traceback
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Any, Mapping, Sequence

from ..errors import PrehensionError
from .records import STAGES, ChunkOutput, RecordHead, RecordLine, error_line, result_line

__all__ = ["BatchOptions", "task_seed", "solve_chunk"]

METHODS = ("auto", "local", "complete")
MAX_LOCAL_CHUNK = 64  # tasks per Dask task for the local solver, at most (default)


@dataclass(frozen=True)
class BatchOptions:
    """How to solve the tasks of a batch.

    Attributes:
        method: ``"auto"`` (local, then complete), ``"local"`` or ``"complete"``.
        seed: base seed; task ``id`` is solved with ``task_seed(seed, id)``.
        time_limit_s: give up on a task after this long [s]: the local solver's call on a
            chunk stops after this long times its tasks, and a task the local solver did not
            solve gets what is left of its own limit for ``auto`` (its share of that call
            deducted; nothing left: its record is the local solver's ``gave_up``, its
            message saying so).
        chunk_size: tasks per Dask task (default: see :meth:`chunk_size_for`).
        retry_gave_up: solve again the tasks whose record says ``gave_up``.
        max_tasks: solve at most this many tasks in this run (then stop; re-run to go on).
        self_contained: every record embeds its task (else the task is stored once per
            distinct task, and records refer to it; see :mod:`.journal`).
        delay_s: testing only: sleep this long before each task [s], to make a run slow
            enough to kill a worker in the middle of it.
        best: a :class:`~prehension.best.BestOptions`: solve each task as ``solve --best N``
            (one task at a time).
        quality: the :class:`~prehension.quality.QualityOptions` of the stored quality.
        simulate: a :class:`~prehension.sim.SimOptions`: each record also gets ``"physics"``,
            the physics test of every solution (:func:`prehension.batch_extras.physics_records`).
        hold: a :class:`~prehension.sim.SimOptions`: each task as ``solve --hold`` (needs
            ``best``: its candidates): the result keeps the first candidate that holds,
            or every candidate tried when none does, each solution's verdict stored with
            it (``"physics"``, as in a result file) and the record gets ``"held"``
            (``true``/``false``; ``null``: not judged) (:func:`prehension.batch_extras.hold_task`).
        hold_closure_time_s: with ``hold``, the complete solver's budget [s] for a
            force-closure grasp when no candidate holds (``None``: ``solve --hold``'s
            default, :data:`prehension.hold.CLOSURE_TIME_S`; 0: not asked).
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
    self_contained: bool = False
    delay_s: float = 0.0
    best: Any = None
    quality: Any = None
    simulate: Any = None
    hold: Any = None
    hold_closure_time_s: float | None = None
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
        need(self.hold is None or self.best is not None, "hold runs the candidates of best: give best (e.g. BestOptions(n=5))")
        need(self.hold is None or self.simulate is None,
             "hold already stores the physics verdict of every solution it keeps: give hold or simulate, not both")  # fmt: skip
        need(self.hold_closure_time_s is None or (self.hold is not None and self.hold_closure_time_s >= 0),
             f"hold_closure_time_s is the budget of hold's force-closure search: >= 0 s with hold, got {self.hold_closure_time_s}")  # fmt: skip
        hands = [s.get("hand") for s in self.sequences]
        need(len(set(hands)) == len(hands), f"give one initial-pose sequence per hand, got several for {hands}")

    def sequence_for(self, hand_name: str):
        """The :class:`InitialPoseSequence` given for hand ``hand_name``, or None."""
        from ..solvers.local.sequence import InitialPoseSequence

        for data in self.sequences:
            if data.get("hand") == hand_name:
                return InitialPoseSequence.from_dict(data, f"sequence of hand {hand_name!r}")
        return None

    def chunk_size_for(self, tasks: int, workers: int) -> int:
        """Tasks per Dask task: ``chunk_size`` if given; else, for the local solver
        (milliseconds a task), enough to make Dask's ~4 ms per Dask task negligible and to
        solve tasks together -- up to :data:`MAX_LOCAL_CHUNK` -- while giving every worker
        at least four chunks; one task per Dask task for ``auto`` and ``complete``, and
        with ``best``, ``simulate`` or ``hold`` (seconds a task: balance first)."""
        if self.chunk_size is not None:
            return self.chunk_size
        if self.method != "local" or self.best is not None or self.simulate is not None or self.hold is not None:
            return 1
        return max(1, min(MAX_LOCAL_CHUNK, math.ceil(tasks / (4 * max(workers, 1)))))


def task_seed(base_seed: int, task_id: str) -> int:
    """The seed of task ``task_id``: 63 bits of SHA-256 of the base seed and the id."""
    digest = hashlib.sha256(f"{base_seed}\0{task_id}".encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def _failure(exc: Exception) -> tuple[str, str]:
    """``(status, message)`` of an exception: ``invalid`` for ours, ``error`` (with where) for a bug."""
    if isinstance(exc, PrehensionError):
        return "invalid", str(exc)
    last = traceback.extract_tb(exc.__traceback__)[-1]
    return "error", f"{type(exc).__name__}: {exc} ({last.filename}:{last.lineno})"


class _Chunk:
    """The records of one chunk as they are made, and the task lines they refer to."""

    def __init__(self, options: BatchOptions):
        self.options = options
        self.records: list[RecordLine] = []
        self.tasks: dict[str, bytes] = {}
        self.files: dict[str, bytes] = {}  # file lines of the files the tasks name, by SHA-256
        self.stages: dict[str, tuple[float, float]] = dict.fromkeys(STAGES, (0.0, 0.0))  # ChunkOutput.stages
        self._sequences: dict = {}

    def spent(self, stage: str, started: tuple[float, float]) -> float:
        """Add the wall and CPU time since ``started`` (:func:`_clock`) to ``stage``; return the wall time [s]."""
        wall, cpu = time.perf_counter() - started[0], time.thread_time() - started[1]
        before = self.stages[stage]
        self.stages[stage] = (before[0] + wall, before[1] + cpu)
        return wall

    def seed(self, entry) -> int:
        return task_seed(self.options.seed, entry["id"])

    def head(self, entry) -> RecordHead:
        return RecordHead(entry, self.options.method, self.seed(entry))

    def sequence(self, hand_name: str):
        """The initial-pose sequence given for this hand (``--sequence``), else ``None``;
        read once per chunk and hand."""
        if hand_name not in self._sequences:
            self._sequences[hand_name] = self.options.sequence_for(hand_name)
        return self._sequences[hand_name]

    def solve_options(self, entry, loaded):
        """The :class:`~prehension.solve.SolveOptions` of one task: the batch's method and
        time limit, the task's seed and initial-pose sequence."""
        from ..solve import SolveOptions

        return SolveOptions(method=self.options.method, seed=self.seed(entry), time_limit_s=self.options.time_limit_s,
                            sequence=self.sequence(loaded.task.hand.name))  # fmt: skip

    def fail(self, entry, exc: Exception, seconds: float) -> None:
        status, message = _failure(exc)
        self.records.append(error_line(self.head(entry), status, message, seconds))

    def add(self, entry, loaded, result, seconds: float) -> None:
        """The record of ``result`` (its ``seconds`` set to the task's time so far): the
        physics test (``simulate`` or ``hold``, counted as solving), the quality of every
        solution, then the JSON line."""
        from ..quality import quality_entries

        started = _clock()
        try:
            result, extra, physics = self._physics(entry, loaded, result)
            seconds += self.spent("solve", started)
            started = _clock()
            qualities = quality_entries(result, self.options.quality)
            seconds += self.spent("quality", started)
            started = _clock()
            line = result_line(self.head(entry), result, loaded, seconds, qualities, extra, self.options.self_contained, physics)
            if line.task_ref is not None:
                self.tasks.setdefault(line.task_ref, loaded.task_line)
                self.files.update(loaded.file_lines)
        except Exception as exc:  # a bug must not stop the other tasks; the record says what happened
            self.fail(entry, exc, seconds + self.spent("record", started))
            return
        self.spent("record", started)
        self.records.append(line)

    def _physics(self, entry, loaded, result):
        """``(result, record fields, per-solution verdicts or None)`` after the physics test
        the options ask for: ``simulate`` (record field ``physics``) or ``hold`` (the
        result as ``solve --hold`` answers, record field ``held``)."""
        if self.options.simulate is not None:
            from ..batch_extras import physics_records

            return result, {"physics": physics_records(loaded.task, result, self.options.simulate, self.seed(entry))}, None
        if self.options.hold is not None:
            from ..batch_extras import hold_task

            held = hold_task(result, self.options.hold, self.seed(entry), self.options.hold_closure_time_s)
            return held.result, {"held": held.held}, held.physics
        return result, {}, None

    def output(self) -> ChunkOutput:
        return ChunkOutput(self.records, self.tasks, self.stages, self.files)


def _clock() -> tuple[float, float]:
    """``(wall, CPU of this thread)`` now [s], for :meth:`_Chunk.spent`."""
    return time.perf_counter(), time.thread_time()


def _load(chunk: _Chunk, entries) -> list[tuple[Mapping, Any, float]]:
    """``(entry, loaded task, seconds)`` of the entries whose task is valid; records for the others."""
    from .loading import load_entry

    out = []
    for entry in entries:
        if chunk.options.delay_s:
            time.sleep(chunk.options.delay_s)
        started = _clock()
        try:
            loaded = load_entry(entry["payload"])
        except Exception as exc:
            chunk.fail(entry, exc, chunk.spent("load", started))
            continue
        out.append((entry, loaded, chunk.spent("load", started)))
    return out


def _solve_alone(chunk: _Chunk, entry, loaded, seconds: float) -> None:
    """One task as ``prehension solve`` (or ``solve --best N``) solves it: the complete
    solver, ``best``, or a fallback (:func:`prehension.batch_extras.solve_task`)."""
    from ..batch_extras import solve_task

    started = _clock()
    try:
        result = solve_task(loaded.task, chunk.solve_options(entry, loaded), chunk.options.best)
    except Exception as exc:
        chunk.fail(entry, exc, seconds + chunk.spent("solve", started))
        return
    chunk.add(entry, loaded, result, seconds + chunk.spent("solve", started))


def _local_batch(chunk: _Chunk, todo, sequence) -> list | None:
    """The local solver's records of every task of ``todo`` (tasks of hands that share
    ``sequence``) in one call, and the share of its time per task [s]; ``None`` if the
    call raised (each task is then solved alone)."""
    from ..solvers.local import solve_local_batch

    started = _clock()
    try:
        options = _local_options()
        if chunk.options.time_limit_s is not None:
            options = replace(options, time_limit_s=chunk.options.time_limit_s * len(todo))
        batch = solve_local_batch([loaded.task for _, loaded, _ in todo], options, sequence,
                                  [chunk.seed(entry) for entry, _, _ in todo])  # fmt: skip
    except Exception:
        chunk.spent("solve", started)
        return None
    share = chunk.spent("solve", started) / len(todo)
    return [(record, share) for record in batch]


def _verified(record, task, sequence, share: float):
    """The record as a verified result, as :func:`~prehension.solvers.local.solve_local` makes
    it.  A record the time limit stopped does not ask for its hand's default sequence (which
    the local solver may not have finished drawing: drawing it here would take the time again)."""
    from ..solvers.local import default_sequence

    started = time.perf_counter()
    if sequence is None and record.time_limit_s is None:
        sequence = default_sequence(task.hand)  # made (and kept) by the local solver's call
    origin = sequence.meta.get("origin", sequence.hand) if sequence is not None else None
    result = record.to_result(task, _local_options(), 0.0, {"sequence": origin})
    return replace(result, seconds=share + time.perf_counter() - started)


@lru_cache(maxsize=1)
def _local_options():
    """The local solver's options of a batch: the defaults, as ``prehension solve`` uses
    (made once: they are immutable)."""
    from ..solvers.local import LocalOptions

    return LocalOptions()


def _by_sequence(chunk: _Chunk, todo) -> dict:
    """``todo`` split by the initial-pose sequence its tasks use (``None``: their hand's
    default); a task whose given sequence does not fit its hand gets its record here."""
    from ..solve import check_sequence

    groups: dict = {}
    for item in todo:
        entry, loaded, seconds = item
        sequence = chunk.sequence(loaded.task.hand.name)
        if sequence is not None:
            try:
                check_sequence(sequence, loaded.task.hand)
            except Exception as exc:
                chunk.fail(entry, exc, seconds)
                continue
        groups.setdefault(id(sequence), (sequence, []))[1].append(item)
    return groups


def _solve_local_first(chunk: _Chunk, todo) -> None:
    """``local`` and ``auto``: the local solver on the whole chunk (one call per initial-pose
    sequence), then (``auto``) the complete solver on each task it did not solve, from its
    answer (:func:`prehension.solve.complete_after_local`: the one ``auto`` policy)."""
    from ..solve import complete_after_local

    for sequence, group in _by_sequence(chunk, todo).values():
        solved = _local_batch(chunk, group, sequence)
        if solved is None:
            for entry, loaded, seconds in group:
                _solve_alone(chunk, entry, loaded, seconds)
            continue
        for (entry, loaded, seconds), (record, share) in zip(group, solved):
            started = _clock()
            try:
                result = _verified(record, loaded.task, sequence, share)
                if chunk.options.method == "auto":
                    result = complete_after_local(loaded.task, result, chunk.solve_options(entry, loaded))
            except Exception as exc:
                chunk.fail(entry, exc, seconds + share + chunk.spent("solve", started))
                continue
            chunk.add(entry, loaded, result, seconds + share + chunk.spent("solve", started))


def solve_chunk(entries: Sequence[Mapping[str, Any]], options: BatchOptions) -> ChunkOutput:
    """Solve every entry (``{"id", "name", "source", "payload"}``) of a chunk; one record each.

    Runs on a Dask worker; takes plain data and returns a :class:`~.records.ChunkOutput`
    (the records as JSON lines, in the order of ``entries`` but for invalid tasks, first).
    """
    chunk = _Chunk(options)
    todo = _load(chunk, entries)
    if options.method == "complete" or options.best is not None:
        for entry, loaded, seconds in todo:
            _solve_alone(chunk, entry, loaded, seconds)
    else:
        _solve_local_first(chunk, todo)
    return chunk.output()
