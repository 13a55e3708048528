"""The output of a batch: a ``.jsonl`` journal, one record per task, appended as results arrive.

A record is one line (``prehension: batch/1``)::

    {"prehension": "batch/1", "id": ..., "task": NAME, "source": "tasks.jsonl:3",
     "method": ..., "seed": ..., "status": "solved" | "infeasible" | "gave_up" | "approximate"
     | "invalid" | "error", "seconds": ..., "message": ..., "task_ref": "3f9c...",
     "result": {...} | null}

``result`` is the result file of the task (:func:`prehension.results.result_to_dict`).
**Compact records** (the default) hold the task by reference: ``task_ref`` names a *task
line* of the same journal, written once per distinct task before the first record that
refers to it::

    {"prehension": "batch-task/1", "ref": "3f9c...", "task": {...the task-file dict...}}

``ref`` is 16 hex digits of the SHA-256 of the task dict (keys sorted) and of the files it
names: two records refer to one line exactly when their tasks are the same.  The files a
task names (its object's mesh) travel with the journal, each distinct file **once**, in a
*file line* written before the first task line that names it; the task line refers to it
by SHA-256 (``"files": {path: {"sha256": ...}}``; see :mod:`prehension.tasks.format.embedded`)::

    {"prehension": "batch-file/1", "sha256": "9f2c...", "name": "mug.ply", "size": ..., "zlib_base64": "..."}
  :func:`with_task` puts the task back
into a compact record's result (what ``prehension check`` does); *self-contained* records
(``--self-contained``) embed the task in ``result`` and have no ``task_ref``.

Only the client writes (never a worker): the lines of each finished chunk are appended
with one ``write``, then flushed and fsynced, so a crash loses at most the chunks still
in flight and leaves at worst a torn last line.  A task line always precedes the records
that refer to it, in the same write: a record that survives a crash has its task.

**Resume** (:func:`open_journal`) reads the journal and repairs it first:

* a torn tail (a cut line after the last newline, and lines of NUL bytes or cut lines
  after the last good line: what a crash can leave) is cut off;
* file lines are kept like task lines;
* records that are not *done* are dropped, by an atomic rewrite, so that their tasks are
  solved again and the journal keeps **one record per task id**.  Done: ``solved`` and
  ``infeasible`` (proven), and ``gave_up`` / ``approximate`` unless ``retry_gave_up``;
  never done: ``invalid`` (the task file may have been fixed) and ``error`` (a crash or a
  bug).  Task lines are always kept;
* any other line is not a crash's doing (is ``-o`` the right file?): the error names the
  file and line, and nothing is changed.

A lock (``.NAME.lock`` beside the journal, ``flock``) keeps two runs from writing one
journal.
"""

from __future__ import annotations

import contextlib
import json
import os
import queue
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator, Mapping

from ..atomic import open_atomic
from ..errors import PrehensionError

__all__ = [
    "RECORD_TAG", "TASK_TAG", "FILE_TAG", "TaskLines", "DONE", "JournalState", "Journal", "Appender", "open_journal",
    "read_records", "read_tasks", "with_task", "is_done",
]  # fmt: skip

RECORD_TAG = "batch/1"
TASK_TAG = "batch-task/1"
FILE_TAG = "batch-file/1"
DONE = ("solved", "infeasible")  # plus "gave_up" unless retried


def is_done(status: str, retry_gave_up: bool = False) -> bool:
    """Whether a record with ``status`` counts as done (its task is skipped on a re-run)."""
    return status in DONE or (status in ("gave_up", "approximate") and not retry_gave_up)


@dataclass(frozen=True)
class JournalState:
    """What a journal holds after repair.

    Attributes:
        done: status of every done task, by id.
        notes: what the repair did, one sentence each (empty when nothing).
        task_refs: the refs of the task lines it holds.
        file_shas: the SHA-256 of the file lines it holds.
    """

    done: Mapping[str, str] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    task_refs: frozenset = frozenset()
    file_shas: frozenset = frozenset()


def _is_record(data) -> bool:
    return isinstance(data, dict) and data.get("prehension") == RECORD_TAG and isinstance(data.get("id"), str)


def _is_task_line(data) -> bool:
    return (isinstance(data, dict) and data.get("prehension") == TASK_TAG and isinstance(data.get("ref"), str)
            and isinstance(data.get("task"), dict))  # fmt: skip


def _is_file_line(data) -> bool:
    return isinstance(data, dict) and data.get("prehension") == FILE_TAG and isinstance(data.get("sha256"), str)


def _parse(line: bytes) -> dict | None:
    """A record, a task line or a file line, else ``None``."""
    try:
        data = json.loads(line)
    except (json.JSONDecodeError, UnicodeDecodeError):
        return None
    return data if _is_record(data) or _is_task_line(data) or _is_file_line(data) else None


_STARTS = tuple(b'{"prehension":"' + tag.encode() + b'"' for tag in (RECORD_TAG, TASK_TAG, FILE_TAG))  # how our lines start


def _is_debris(raw: bytes) -> bool:
    """What a crash can leave: a cut line (a prefix of one of ours) or bytes never written (NULs)."""
    head = raw.rstrip(b"\n").replace(b" ", b"")
    return b"\0" in raw or any(head[: len(start)] == start[: len(head)] for start in _STARTS)


@dataclass(frozen=True)
class _Line:
    """One complete line of a journal: a record's id and status, a task line's ref."""

    key: tuple[str, str] | None
    kind: str  # "record", "task", "blank", "debris" (a crash's) or "foreign" (not ours)
    ref: str | None = None


def _line(raw: bytes) -> _Line:
    data = _parse(raw)
    if data is not None and data["prehension"] == TASK_TAG:
        return _Line(None, "task", data["ref"])
    if data is not None and data["prehension"] == FILE_TAG:
        return _Line(None, "file", data["sha256"])
    if data is not None:
        return _Line((data["id"], str(data.get("status"))), "record")
    return _Line(None, "blank" if not raw.strip() else "debris" if _is_debris(raw) else "foreign")


def _lines(path: Path) -> tuple[list[_Line], int]:
    """The complete lines of the journal (streamed) and the length of a torn tail [bytes]."""
    lines = []
    with open(path, "rb") as fh:
        for raw in fh:
            if not raw.endswith(b"\n"):
                lines.append(_Line(None, "torn" if _is_debris(raw) else "foreign"))
                return lines, len(raw)
            lines.append(_line(raw))
    return lines, 0


def _not_a_journal(path: Path, number: int) -> PrehensionError:
    return PrehensionError(
        f"{path}:{number}: not a prehension batch record (expected one JSON object with "
        f"\"prehension\": \"{RECORD_TAG}\" per line); is {path} the output of 'prehension batch'? "
        "Nothing was changed"
    )


def _good_part(path: Path, lines: list[_Line], torn: int) -> tuple[int, list[str]]:
    """How many lines to keep (a crash's debris at the end is cut), and notes.

    Raises:
        PrehensionError: a line is not ours, or debris lies before a record.
    """
    n_good = 1 + max((i for i, line in enumerate(lines) if line.kind in ("record", "task", "file")), default=-1)
    for i, line in enumerate(lines):
        if line.kind == "foreign" or (i < n_good and line.kind == "debris"):
            raise _not_a_journal(path, i + 1)
    notes = [f"dropped a torn last line ({torn} bytes) left by an interrupted run"] if torn else []
    debris = sum(line.kind == "debris" for line in lines[n_good:])
    if debris:
        notes.append(f"dropped {debris} unreadable line(s) at the end, left by an interrupted run")
    return n_good, notes


def _selection(lines: list[_Line], retry_gave_up: bool) -> tuple[list[bool], dict[str, str], int, int]:
    """Which lines to keep (one done record per id), the done ids, and counts dropped."""
    keep, done = [], {}
    retried = duplicates = 0
    for line in lines:
        if line.kind in ("task", "file"):
            keep.append(True)
            continue
        ok = line.key is not None and line.key[0] not in done and is_done(line.key[1], retry_gave_up)
        if ok:
            done[line.key[0]] = line.key[1]
        elif line.key is not None:
            duplicates += line.key[0] in done
            retried += line.key[0] not in done
        keep.append(ok)
    return keep, done, retried, duplicates


def _rewrite(path: Path, keep: list[bool]) -> None:
    """Rewrite the journal with the kept lines only, atomically."""
    with open(path, "rb") as src, open_atomic(path) as dst:
        for raw, kept in zip(src, keep):
            if kept:
                dst.write(raw)


def _truncate(path: Path, lines: int) -> None:
    size = 0
    with open(path, "rb") as fh:
        for _, raw in zip(range(lines), fh):
            size += len(raw)
    with open(path, "r+b") as fh:
        fh.truncate(size)
        fh.flush()
        os.fsync(fh.fileno())


def _repair(path: Path, retry_gave_up: bool) -> JournalState:
    lines, torn = _lines(path)
    n_good, notes = _good_part(path, lines, torn)
    keep, done, retried, duplicates = _selection(lines[:n_good], retry_gave_up)
    if retried or duplicates:
        _rewrite(path, keep)
    elif n_good < len(lines):
        _truncate(path, n_good)
    if retried:
        what = "invalid, error" + (", gave up" if retry_gave_up else "")
        notes.append(f"{retried} task(s) whose record is not done ({what}) will be solved again")
    if duplicates:
        notes.append(f"dropped {duplicates} duplicated record(s) (did another run write this journal?)")
    refs = frozenset(line.ref for line in lines[:n_good] if line.kind == "task")
    shas = frozenset(line.ref for line in lines[:n_good] if line.kind == "file")
    return JournalState(done, tuple(notes), refs, shas)


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock
        yield
        return
    lock = path.parent / f".{path.name}.lock"
    with open(lock, "a") as fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise PrehensionError(f"another 'prehension batch' is writing {path} (lock {lock}); wait for it to finish") from None
        yield


class Journal:
    """The open journal: :meth:`append_lines` writes a chunk's lines, flushed and fsynced once."""

    def __init__(self, fh, task_refs: frozenset = frozenset(), path: Path | None = None, file_shas: frozenset = frozenset()):
        self._fh = fh
        self.path = path
        self.task_refs: set[str] = set(task_refs)  # the task lines it holds (or has been given)
        self.file_shas: set[str] = set(file_shas)  # the file lines it holds (or has been given)

    def append_lines(self, lines: Iterable[bytes]) -> None:
        """Append complete lines (each ends with a newline) in one write, then flush and fsync."""
        self._fh.write(b"".join(lines))
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def append(self, records: Iterable[dict]) -> None:
        """Append ``records`` (dicts, one line each), then flush and fsync once."""
        self.append_lines([(json.dumps(r, separators=(",", ":")) + "\n").encode("utf-8") for r in records])

    def lines_needed(self, loaded) -> list[bytes]:
        """The file and task lines a record of ``loaded`` (a :class:`~.loading.LoadedTask`)
        needs before it, those the journal does not hold yet (each file before its task
        line); they count as given from now on."""
        if loaded.ref in self.task_refs:
            return []
        lines = [v for k, v in sorted(loaded.file_lines.items()) if k not in self.file_shas]
        self.file_shas |= set(loaded.file_lines)
        self.task_refs.add(loaded.ref)
        return lines + [loaded.task_line]


class Appender:
    """Appends to a :class:`Journal` from a thread, so that the client never waits for the disk.

    :meth:`put` queues a chunk's lines and returns at once; the thread writes everything
    queued so far with one write and one fsync (so at most one fsync per chunk, fewer when
    chunks arrive faster than the disk syncs), in the order given.  :meth:`close` writes
    what is left and stops the thread.  A crash loses at most the chunks still queued:
    their tasks have no record, so the next run solves them again.
    """

    def __init__(self, journal: Journal):
        self._journal = journal
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._loop, name="prehension-journal", daemon=True)
        self._thread.start()

    def put(self, lines: list[bytes]) -> None:
        """Queue complete lines (each ends with a newline) for the journal.

        Raises:
            PrehensionError: an earlier write failed (the disk is full, ...).
        """
        self._raise()
        self._queue.put(lines)

    def close(self) -> None:
        """Write what is queued, then stop the thread."""
        self._queue.put(None)
        self._thread.join()
        self._raise()

    def _raise(self) -> None:
        if self._error is not None:
            raise PrehensionError(f"cannot write the batch output {self._journal.path}: {self._error}") from None

    def _loop(self) -> None:
        while True:
            batch = [self._queue.get()]
            while True:
                try:
                    batch.append(self._queue.get_nowait())
                except queue.Empty:
                    break
            lines = [line for item in batch if item is not None for line in item]
            if lines and self._error is None:
                try:
                    self._journal.append_lines(lines)
                except Exception as exc:  # reported to the client by its next put() or close()
                    self._error = exc
            if any(item is None for item in batch):
                return


@contextlib.contextmanager
def open_journal(path, retry_gave_up: bool = False) -> Iterator[tuple[Journal, JournalState]]:
    """Lock, repair (see the module docstring) and open the journal at ``path`` for appending.

    Yields:
        ``(journal, state)``: the writer and what the journal already holds.
    """
    path = Path(path)
    if path.suffix.lower() in (".yaml", ".yml", ".world"):
        raise PrehensionError(f"the batch output {path} must be a .jsonl file, not a task file")
    path.parent.mkdir(parents=True, exist_ok=True)
    with _locked(path):
        state = _repair(path, retry_gave_up) if path.exists() else JournalState()
        with open(path, "ab") as fh:
            yield Journal(fh, state.task_refs, path, state.file_shas), state


def _complete_lines(path) -> Iterator[dict]:
    with open(path, "rb") as fh:
        for raw in fh:
            data = _parse(raw) if raw.endswith(b"\n") else None  # a torn last line is skipped
            if data is not None:
                yield data


class TaskLines:
    """The task and file lines of a journal, read in order: :attr:`tasks` (task dict by
    ref) and :attr:`files` (by ref: the ``files`` entry a result of that task carries,
    ``{path: entry}``, from the file lines before it)."""

    def __init__(self):
        self.tasks: dict[str, dict] = {}
        self.files: dict[str, dict] = {}
        self._entries: dict[str, dict] = {}  # file lines by SHA-256

    def add(self, data: dict) -> bool:
        """Take a task or file line (True); anything else is left to the caller (False)."""
        if _is_file_line(data):
            self._entries[data["sha256"]] = {k: v for k, v in data.items() if k != "prehension"}
            return True
        if data.get("prehension") != TASK_TAG:
            return False
        ref = str(data.get("ref"))
        self.tasks[ref] = data.get("task")
        named = data.get("files") if isinstance(data.get("files"), dict) else {}
        carried = {p: self._entries[f["sha256"]] for p, f in named.items()
                   if isinstance(f, dict) and f.get("sha256") in self._entries}  # fmt: skip
        if carried:
            self.files[ref] = carried
        return True


def read_tasks(path) -> dict[str, dict]:
    """The task lines of a journal: task dict (task-file format) by ref."""
    return {d["ref"]: d["task"] for d in _complete_lines(path) if d["prehension"] == TASK_TAG}


def read_records(path, *, embed_tasks: bool = False) -> list[dict]:
    """Every complete record of a journal, in file order (a torn last line is skipped).

    With ``embed_tasks``, each compact record's ``result`` gets its task back, and the
    files it names (:func:`with_task`): every record is then self-contained, as a result file.
    """
    records, lines = [], TaskLines()
    for data in _complete_lines(path):
        if not lines.add(data):
            records.append(with_task(data, lines.tasks, str(path), lines.files) if embed_tasks else data)
    return records


def with_task(record: dict, tasks: Mapping[str, dict], source: str = "batch output",
              files: Mapping[str, dict] | None = None) -> dict:  # fmt: skip
    """``record`` with its task in ``result`` (a copy; the record itself when it has it already).

    Args:
        record: a batch record.
        tasks: task dicts by ref (the task lines read so far, see :func:`read_tasks`).
        source: where the record was read, for the message.
        files: by ref, the files the task names (:attr:`TaskLines.files`): put in
            ``result["files"]`` as a result file carries them.

    Raises:
        PrehensionError: the record refers to a task line that is not in ``tasks``.
    """
    result, ref = record.get("result"), record.get("task_ref")
    if not isinstance(result, dict) or "task" in result or ref is None:
        return record
    if ref not in tasks:
        raise PrehensionError(
            f"{source}: record {record.get('id')!r} refers to task {ref!r}, which is not in the file "
            f"(a compact record's task is a \"{TASK_TAG}\" line before it; was the file cut or edited?)"
        )
    head = {k: result[k] for k in ("prehension", "units", "frames") if k in result}
    carried = {"files": files[ref]} if files and ref in files else {}
    return {**record, "result": {**head, "task": tasks[ref], **carried, **result}}
