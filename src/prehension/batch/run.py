"""The client side of a batch: chunks to Dask, records to the journal as chunks finish.

At most ``2 x`` (worker threads) chunks are in flight (Dask's ``as_completed``, refilled
as chunks finish), so the scheduler holds a few small payloads whatever the size of the
input, and a crash loses at most those chunks.  When a worker dies, Dask reschedules its
chunks on the others (a chunk that kills ``distributed.scheduler.allowed-failures``
workers is given up with ``KilledWorker``: its tasks get ``error`` records); since only
this client writes, and each future is consumed once, nothing is written twice.

The client stays off the critical path: workers send records already serialised
(:mod:`.records`); the client queues each finished chunk -- its new task lines, then its
records -- for a writer thread (:class:`~.journal.Appender`: one write and one fsync for
what is queued), updates the progress once per chunk, and never waits for the disk.
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator, Mapping, Sequence

from ..errors import PrehensionError
from ..parallel import worker_count
from .inputs import TASK_SUFFIXES, BatchEntry, read_inputs
from .journal import Appender, is_done, open_journal
from .records import ChunkOutput, RecordHead, error_line
from .solving import BatchOptions, solve_chunk, task_seed

__all__ = ["BatchProgress", "BatchSummary", "run_batch", "check_output"]


@dataclass(frozen=True)
class BatchProgress:
    """Where a run is (passed to ``progress`` after each chunk).

    Attributes:
        total: tasks to solve in this run.
        done: tasks solved so far in this run.
        skipped: tasks of the input already done in the journal.
        counts: statuses of this run's records so far.
    """

    total: int
    done: int
    skipped: int
    counts: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class BatchSummary:
    """What a run did.

    Attributes:
        output: the journal.
        tasks: tasks in the input.
        skipped: tasks already done in the journal (not solved again).
        counts: statuses of the records written by this run.
        remaining: tasks of the input without an answer (solved, infeasible or gave up)
            after this run: not reached (``max_tasks``, an interrupt), ``invalid`` or ``error``.
        seconds: wall-clock time of the run.
        notes: what the repair of the journal did.
        interrupted: the run was stopped by Ctrl-C (what finished is in the journal).
    """

    output: Path
    tasks: int
    skipped: int
    counts: Mapping[str, int]
    remaining: int
    seconds: float
    notes: tuple[str, ...] = ()
    interrupted: bool = False

    @property
    def written(self) -> int:
        return sum(self.counts.values())


def _wire(entry: BatchEntry) -> dict:
    return {"id": entry.id, "name": entry.name, "source": entry.source, "payload": dict(entry.payload)}


def _chunks(entries: Sequence[BatchEntry], size: int) -> Iterator[list[dict]]:
    for start in range(0, len(entries), size):
        yield [_wire(e) for e in entries[start : start + size]]


def _output(future, chunk: list[dict], options: BatchOptions) -> ChunkOutput:
    try:
        return future.result()
    except Exception as exc:  # e.g. KilledWorker: the chunk killed several workers
        message = f"the Dask task failed: {type(exc).__name__}: {exc}"
        seed = options.seed
        return ChunkOutput([error_line(RecordHead(e, options.method, task_seed(seed, e["id"])), "error", message, 0.0) for e in chunk], {})


class _WorkerCount:
    """The cluster's worker threads, asked of the scheduler at most every ``every_s``
    seconds (each question is a round trip; workers join and leave far less often)."""

    def __init__(self, client, every_s: float = 1.0):
        self.client, self.every_s = client, every_s
        self._value, self._when = 0, -float("inf")

    def now(self) -> int:
        if time.monotonic() - self._when >= self.every_s:
            self._value, self._when = worker_count(self.client), time.monotonic()
        return self._value


def _stream(client, chunks: Iterator[list[dict]], options: BatchOptions) -> Iterator[ChunkOutput]:
    """The records of every chunk, in the order chunks finish; a bounded number in flight."""
    from distributed import as_completed

    window = as_completed()
    owners: dict = {}  # future -> its chunk
    threads = _WorkerCount(client)

    def refill() -> None:
        limit = 2 * threads.now()
        while len(owners) < limit:
            chunk = next(chunks, None)
            if chunk is None:
                return
            future = client.submit(solve_chunk, chunk, options, pure=False, retries=1)
            owners[future] = chunk
            window.add(future)

    refill()
    try:
        for future in window:
            yield _output(future, owners.pop(future), options)
            refill()
    finally:
        if owners:
            client.cancel(list(owners))


def check_output(inputs, output) -> None:
    """Raise a :class:`PrehensionError` unless the journal ``output`` can be written:
    not a folder, not the input (nor a file in an input folder), in a writable folder."""
    from ..atomic import check_output_path

    inputs = Path(inputs)
    if Path(output).resolve() == inputs.resolve():
        raise PrehensionError(f"the output {output} is the input: choose another file for the results (-o)")
    inside = inputs.is_dir() and inputs.resolve() in Path(output).resolve().parents
    if inside and Path(output).suffix.lower() in TASK_SUFFIXES:
        raise PrehensionError(f"the output {output} lies in the input folder {inputs} and would be read as a task: write it elsewhere")
    check_output_path(output, "batch output (-o)", inputs=[inputs] if inputs.is_file() else [])


def run_batch(
    inputs,
    output,
    client,
    options: BatchOptions = BatchOptions(),
    progress: Callable[[BatchProgress], None] | None = None,
) -> BatchSummary:
    """Solve every task of ``inputs`` on the Dask ``client``, appending records to ``output``.

    Args:
        inputs: a ``.jsonl`` file or a folder of task files (:func:`read_inputs`), or a
            list of :class:`BatchEntry`.
        output: the journal (``.jsonl``): tasks already done in it are skipped, the rest
            appended as they finish (see :mod:`prehension.batch.journal`).
        client: a :class:`distributed.Client` (:func:`prehension.parallel.cluster`).
        options: :class:`BatchOptions`.
        progress: called with a :class:`BatchProgress` at the start and after each chunk.

    Returns:
        A :class:`BatchSummary`.  Ctrl-C stops the run cleanly (``interrupted``): what
        finished is in the journal, and a re-run goes on from there.

    Raises:
        PrehensionError: a malformed input (naming file and line) or journal.
    """
    started = time.perf_counter()
    if not isinstance(inputs, (list, tuple)):
        check_output(inputs, output)
    entries = list(inputs) if isinstance(inputs, (list, tuple)) else read_inputs(inputs)
    with open_journal(output, options.retry_gave_up) as (journal, state):
        todo = [e for e in entries if e.id not in state.done]
        chosen = todo if options.max_tasks is None else todo[: options.max_tasks]
        run = _Run(len(chosen), len(entries) - len(todo), progress, journal)
        try:
            run.solve(client, chosen, options)
        finally:
            run.close()
    done_now = sum(n for status, n in run.counts.items() if is_done(status))  # a new gave_up is an answer too
    return BatchSummary(Path(output), len(entries), run.skipped, dict(run.counts), len(todo) - done_now,
                        time.perf_counter() - started, state.notes, run.interrupted)  # fmt: skip


class _Run:
    """The client loop of one run: records to the journal, each id once, progress reported.

    The journal is written by an :class:`~.journal.Appender` thread: the loop that takes
    finished chunks and hands out new ones never waits for the disk.
    """

    def __init__(self, total: int, skipped: int, progress, journal):
        self.total, self.skipped, self.progress = total, skipped, progress
        self.journal, self.appender = journal, Appender(journal)
        self.counts: Counter = Counter()
        self.written: set[str] = set()
        self.interrupted = False

    def close(self) -> None:
        """Write what is queued (also after Ctrl-C: those chunks are finished)."""
        self.appender.close()

    def report(self) -> None:
        if self.progress:
            self.progress(BatchProgress(self.total, len(self.written), self.skipped, dict(self.counts)))

    def accept(self, output: ChunkOutput) -> None:
        """Queue a finished chunk for the journal: the file lines and task lines its new
        records need, then the records (written together: one write, one fsync); then report progress."""
        fresh = [r for r in output.records if r.id not in self.written]  # never twice, whatever happens
        needed = {r.task_ref for r in fresh if r.task_ref is not None} - self.journal.task_refs
        files = sorted(set(output.files) - self.journal.file_shas) if needed else []  # each file once, before its task lines
        self.appender.put([output.files[sha] for sha in files] + [output.tasks[ref] for ref in sorted(needed)]
                          + [r.line for r in fresh])  # fmt: skip
        self.journal.task_refs |= needed
        self.journal.file_shas |= set(files)
        self.written.update(r.id for r in fresh)
        self.counts.update(r.status for r in fresh)
        self.report()

    def solve(self, client, chosen: Sequence[BatchEntry], options: BatchOptions) -> None:
        self.report()
        size = options.chunk_size_for(len(chosen), worker_count(client))
        stream = _stream(client, _chunks(chosen, size), options)
        try:
            for output in stream:
                self.accept(output)
        except KeyboardInterrupt:
            self.interrupted = True
        finally:
            stream.close()  # cancels the chunks still in flight
