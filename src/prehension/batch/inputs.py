"""The input of a batch: a ``.jsonl`` file of tasks, or a folder of task files.

**A ``.jsonl`` file** holds one JSON object per line (blank lines are skipped):

* ``{"task": "teapot-service"}`` -- a built-in task, or ``{"task": "mug.yaml"}`` /
  ``{"task": "mug/grasp.world"}`` -- a task file, relative paths taken from the
  ``.jsonl`` file's folder;
* ``{"prehension": "task/1", "name": ..., "hand": ..., ...}`` -- a task written inline in
  the task-file format (``docs/task-format.md``), or the same object as the value of
  ``"task"``;
* each may carry an ``"id"`` (a non-empty string).

**A folder**: every ``.yaml`` / ``.yml`` / ``.world`` file below it (hidden files
skipped), in sorted order.

**Task ids** (what resume and seeds key on) must be stable when the input is edited:

1. the explicit ``"id"`` of a line;
2. else ``NAME-HASH``: the task's name (a folder file: its path relative to the folder,
   without the suffix) and the first 12 hex digits of the SHA-256 of the line's content
   (keys sorted, the ``"id"`` left out) and of the task file's bytes (a task file or a
   built-in task) -- inserting, deleting or reordering lines or files keeps every id;
   editing a task changes its id, so that the next run solves it again.

Line numbers are not used: one inserted line would shift every id after it.  Two lines
with the same id are an error (naming both lines): give them distinct ``"id"`` values to
solve the same task twice.

Only cheap checks run here (JSON syntax, the shape of a line, built-in names, files
exist): a task's full validation runs on the worker that solves it, whose error names
the file and line (status ``invalid`` in the output).  YAML task files travel to the
workers as text (they need not share this machine's disk, save for files the task
itself references); ``.world`` files travel as paths, so they must be readable at the
same path on every worker.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterable, Mapping

from ..errors import InvalidTask, not_a_file
from ..tasks.library import builtin_task_names

__all__ = ["BatchEntry", "read_inputs", "entry_task"]

TASK_SUFFIXES = (".yaml", ".yml", ".world")


@dataclass(frozen=True)
class BatchEntry:
    """One task of a batch.

    Attributes:
        id: stable id (see the module docstring).
        name: the task's name (a built-in name, a file's stem, an inline task's name).
        source: where it was read (``tasks.jsonl:3`` or a file path), for messages.
        payload: what travels to the worker: plain JSON-ready data (see :func:`entry_task`).
    """

    id: str
    name: str
    source: str
    payload: Mapping[str, Any]


def read_inputs(path) -> list[BatchEntry]:
    """The entries of a ``.jsonl`` file or a folder of task files (see the module docstring).

    Raises:
        InvalidTask: naming the file and line of a malformed entry, a duplicated id, or
            an input with no task.
    """
    path = Path(path)
    if path.is_dir():
        entries = [_file_entry(f, path) for f in _task_files(path)]
    elif path.suffix.lower() in TASK_SUFFIXES:
        raise InvalidTask(f"{path} is one task file; a batch reads a .jsonl file or a folder (one task: 'prehension solve')")
    elif path.is_file():
        entries = list(_jsonl_entries(path))
    else:
        raise InvalidTask(f"batch input {path} does not exist (give a .jsonl file or a folder of task files)")
    if not entries:
        raise InvalidTask(f"batch input {path} holds no task")
    _check_unique(entries)
    return entries


def _check_unique(entries: list[BatchEntry]) -> None:
    seen: dict[str, str] = {}
    for entry in entries:
        if entry.id in seen:
            raise InvalidTask(
                f"{entry.source}: task id {entry.id!r} is already used by {seen[entry.id]}; "
                "give the two distinct \"id\" values to solve the task twice"
            )
        seen[entry.id] = entry.source


# -- folders ------------------------------------------------------------------------------
def _task_files(folder: Path) -> list[Path]:
    return sorted(
        p for p in folder.rglob("*")
        if p.is_file() and p.suffix.lower() in TASK_SUFFIXES
        and not any(part.startswith(".") for part in p.relative_to(folder).parts)
    )  # fmt: skip


def _file_payload(file: Path, source: str) -> tuple[dict, bytes]:
    try:
        data = file.read_bytes()
    except OSError as exc:
        raise InvalidTask(f"{source}: cannot read {file}: {exc.strerror or exc}") from None
    if file.suffix.lower() == ".world":
        return {"kind": "world", "path": str(file.resolve())}, data
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise InvalidTask(f"{source}: {file} is not a UTF-8 text file") from None
    return {"kind": "yaml", "text": text, "source": str(file), "base_dir": str(file.resolve().parent)}, data


def _file_entry(file: Path, folder: Path) -> BatchEntry:
    payload, data = _file_payload(file, str(file))
    name = file.relative_to(folder).with_suffix("").as_posix()
    return BatchEntry(f"{name}-{_digest({}, data)}", name, str(file), payload)


# -- .jsonl files -------------------------------------------------------------------------
def _jsonl_entries(path: Path) -> Iterable[BatchEntry]:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InvalidTask(f"cannot read batch input {path}: {exc}") from None
    for number, line in enumerate(text.split("\n"), start=1):  # not splitlines(): JSON may hold U+2028
        if not line.strip():
            continue
        yield _line_entry(line, path, f"{path}:{number}")


def _line_entry(line: str, path: Path, source: str) -> BatchEntry:
    try:
        data = json.loads(line)
    except json.JSONDecodeError as exc:
        raise InvalidTask(f"{source}: not valid JSON ({exc.msg} at column {exc.colno})") from None
    if not isinstance(data, dict):
        raise InvalidTask(f"{source}: a line must be a JSON object such as {{\"task\": \"teapot-service\"}}")
    explicit = data.get("id")
    if explicit is not None and (not isinstance(explicit, str) or not explicit.strip()):
        raise InvalidTask(f"{source}: \"id\" must be a non-empty string, got {explicit!r}")
    body = {k: v for k, v in data.items() if k != "id"}
    payload, name, content = _line_payload(body, path.parent, source)
    return BatchEntry(explicit or f"{name}-{_digest(body, content)}", name, source, payload)


def _line_payload(body: dict, base: Path, source: str) -> tuple[dict, str, bytes]:
    """``(payload, task name, extra bytes hashed into the id)`` of a line without its id."""
    if "prehension" in body:
        task = body
    elif set(body) == {"task"}:
        task = body["task"]
    else:
        raise InvalidTask(
            f"{source}: a line is {{\"task\": NAME_OR_PATH}}, {{\"task\": {{...}}}} or an inline task "
            f"starting with \"prehension\": \"task/1\", each with an optional \"id\"; got keys {sorted(body)}"
        )
    if isinstance(task, dict):
        payload = {"kind": "dict", "data": task, "source": source, "base_dir": str(base.resolve())}
        return payload, str(task.get("name", "task")), b""
    if not isinstance(task, str) or not task.strip():
        raise InvalidTask(f"{source}: \"task\" must be a built-in name, a file path or a task object, got {task!r}")
    return _named_payload(task, base, source)


def _named_payload(spec: str, base: Path, source: str) -> tuple[dict, str, bytes]:
    suffix = Path(spec).suffix.lower()
    if suffix not in TASK_SUFFIXES:
        if spec not in builtin_task_names():
            raise InvalidTask(
                f"{source}: {spec!r} is neither a built-in task nor a task file (.yaml, .world); "
                f"built-in tasks are: {', '.join(builtin_task_names())}"
            )
        return {"kind": "builtin", "name": spec}, spec, _builtin_bytes(spec)
    file = Path(spec) if Path(spec).is_absolute() else base / spec
    if not file.is_file():
        raise InvalidTask(f"{source}: {not_a_file('task file', file)}")
    payload, data = _file_payload(file, source)
    return payload, file.stem, data


@lru_cache(maxsize=None)
def _builtin_bytes(name: str) -> bytes:
    from importlib import resources

    return resources.files("prehension.tasks").joinpath("builtin", f"{name}.yaml").read_bytes()


def _digest(body: dict, content: bytes) -> str:
    h = hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":")).encode())
    h.update(hashlib.sha256(content).digest())
    return h.hexdigest()[:12]


# -- on the worker ------------------------------------------------------------------------
@lru_cache(maxsize=32)
def _builtin_task(name: str):
    """Built-in tasks, parsed once per worker process (a Task is immutable)."""
    from ..tasks.library import load_builtin_task

    return load_builtin_task(name)


def entry_task(payload: Mapping[str, Any]):
    """The :class:`~prehension.tasks.model.Task` of an entry's payload (runs on a worker).

    Raises:
        PrehensionError: the task is invalid; the message names the file and line.
    """
    kind = payload["kind"]
    if kind == "builtin":
        return _builtin_task(payload["name"])
    if kind == "yaml":
        from ..tasks.yaml_io import loads_task

        return loads_task(payload["text"], payload["source"], base_dir=Path(payload["base_dir"]))
    if kind == "dict":
        from ..tasks.yaml_io import task_from_dict

        return task_from_dict(dict(payload["data"]), base_dir=Path(payload["base_dir"]), source=payload["source"])
    if kind == "world":
        from ..tasks.cuik_import import import_world

        return import_world(Path(payload["path"]))
    raise InvalidTask(f"unknown batch entry kind {kind!r}")
