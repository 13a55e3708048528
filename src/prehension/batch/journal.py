"""The output of a batch: a ``.jsonl`` journal, one record per task, appended as results arrive.

A record is one line (``prehension: batch/1``)::

    {"prehension": "batch/1", "id": ..., "task": NAME, "source": "tasks.jsonl:3",
     "status": "solved" | "infeasible" | "gave_up" | "invalid" | "error",
     "method": ..., "seed": ..., "seconds": ..., "message": ..., "result": {...} | null}

``result`` is the whole result file (:func:`prehension.results.result_to_dict`, the task
embedded), so any record can be re-checked alone.  Only the client writes (never a
worker): the records of each finished chunk are appended with one ``write`` per line,
then flushed and fsynced, so a crash loses at most the chunks still in flight and leaves
at worst a torn last line.

**Resume** (:func:`open_journal`) reads the journal and repairs it first:

* a torn tail (a cut record after the last newline, and lines of NUL bytes or cut
  records after the last good record: what a crash can leave) is cut off;
* records that are not *done* are dropped, by an atomic rewrite, so that their tasks are
  solved again and the journal keeps **one record per task id**.  Done: ``solved`` and
  ``infeasible`` (proven), and ``gave_up`` unless ``retry_gave_up``; never done:
  ``invalid`` (the task file may have been fixed) and ``error`` (a crash or a bug);
* any other line is not a crash's doing (is ``-o`` the right file?): the error names the
  file and line, and nothing is changed.

A lock (``.NAME.lock`` beside the journal, ``flock``) keeps two runs from writing one
journal.
"""

from __future__ import annotations

import contextlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator, Mapping

from ..atomic import open_atomic
from ..errors import PrehensionError

__all__ = ["RECORD_TAG", "DONE", "JournalState", "open_journal", "read_records", "is_done"]

RECORD_TAG = "batch/1"
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
    """

    done: Mapping[str, str] = field(default_factory=dict)
    notes: tuple[str, ...] = ()


def _parse(line: bytes) -> dict | None:
    try:
        record = json.loads(line)
    except (json.JSONDecodeError, UnicodeDecodeError):
        return None
    ok = isinstance(record, dict) and record.get("prehension") == RECORD_TAG and isinstance(record.get("id"), str)
    return record if ok else None


_RECORD_START = b'{"prehension":"' + RECORD_TAG.encode() + b'"'  # how every record line starts


def _is_debris(raw: bytes) -> bool:
    """What a crash can leave: a cut record (a prefix of one) or bytes never written (NULs)."""
    head = raw.rstrip(b"\n").replace(b" ", b"")[: len(_RECORD_START)]
    return b"\0" in raw or head == _RECORD_START[: len(head)]


@dataclass(frozen=True)
class _Line:
    """One complete line of a journal: its id and status, or ``None`` when not a record."""

    key: tuple[str, str] | None
    kind: str  # "record", "blank", "debris" (a crash's) or "foreign" (not ours)


def _line(raw: bytes) -> _Line:
    record = _parse(raw)
    if record is not None:
        return _Line((record["id"], str(record.get("status"))), "record")
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
    n_good = 1 + max((i for i, line in enumerate(lines) if line.kind == "record"), default=-1)
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
    return JournalState(done, tuple(notes))


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
    """The open journal: :meth:`append` writes records, flushed and fsynced."""

    def __init__(self, fh):
        self._fh = fh

    def append(self, records: Iterable[dict]) -> None:
        """Append ``records`` (one line each), then flush and fsync once."""
        for record in records:
            self._fh.write((json.dumps(record, separators=(",", ":")) + "\n").encode("utf-8"))
        self._fh.flush()
        os.fsync(self._fh.fileno())


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
            yield Journal(fh), state


def read_records(path) -> list[dict]:
    """Every complete record of a journal, in file order (a torn last line is skipped)."""
    with open(path, "rb") as fh:
        return [r for r in (_parse(raw) for raw in fh if raw.endswith(b"\n")) if r is not None]
