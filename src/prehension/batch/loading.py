"""On a worker: the tasks of batch entries, parsed once per worker process and reused.

A worker solves thousands of tasks, most of them repeats of a few task files or built-in
tasks, or tasks that share one hand.  :func:`load_entry` keeps the last
:data:`CACHE_SIZE` distinct tasks it parsed, keyed by their content (a built-in task's
name; a YAML text's or an inline task's SHA-256 and folder; a ``.world`` file's path,
size and modification time), with what a record needs of them: the task dict of the
task-file format, its ref (:mod:`.journal`) and its task line.  A
:class:`~prehension.tasks.model.Task` is immutable, so sharing one is safe.  Invalid
tasks are not kept: each of them raises its own error, naming its own file and line.
"""

from __future__ import annotations

import hashlib
import json
from collections import OrderedDict
from functools import cached_property
from pathlib import Path
from typing import Any, Mapping

from .inputs import entry_task
from .journal import FILE_TAG, TASK_TAG

__all__ = ["LoadedTask", "load_entry", "CACHE_SIZE"]

CACHE_SIZE = 256  # distinct tasks kept per worker process


class LoadedTask:
    """A parsed task and what a record needs of it (each computed once, when first asked).

    Attributes:
        task: the task.
        task_dict: the task in the task-file format (what a result file embeds).
        files: the files the task names, ``{path: entry}``
            (:func:`~prehension.tasks.format.embedded.embedded_files`).
        ref: 16 hex digits of the SHA-256 of ``task_dict`` with sorted keys and of its
            files' SHA-256 (a mesh edited between runs makes another task line).
        task_line: the journal's task line for it (bytes, newline included).
        file_lines: the journal's file line of each file, by SHA-256.
    """

    def __init__(self, task):
        self.task = task

    @cached_property
    def task_dict(self) -> dict:
        from ..tasks.yaml_io import task_to_dict

        return task_to_dict(self.task, hand_inline=True)  # as a result file embeds it: re-checkable alone

    @cached_property
    def files(self) -> dict:
        from ..tasks.format.embedded import embedded_files

        return embedded_files(self.task_dict)

    @cached_property
    def _file_refs(self) -> dict:
        return {path: {"sha256": entry["sha256"]} for path, entry in self.files.items()}

    @cached_property
    def ref(self) -> str:
        content = [self.task_dict, self._file_refs] if self.files else self.task_dict
        canonical = json.dumps(content, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(canonical.encode("utf-8")).hexdigest()[:16]

    @cached_property
    def task_line(self) -> bytes:
        line = {"prehension": TASK_TAG, "ref": self.ref, "task": self.task_dict}
        if self.files:
            line["files"] = self._file_refs
        return (json.dumps(line, separators=(",", ":")) + "\n").encode("utf-8")

    @cached_property
    def file_lines(self) -> dict[str, bytes]:
        lines = {e["sha256"]: {"prehension": FILE_TAG, **e} for e in self.files.values()}
        return {sha: (json.dumps(line, separators=(",", ":")) + "\n").encode("utf-8") for sha, line in lines.items()}


_CACHE: OrderedDict = OrderedDict()


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _key(payload: Mapping[str, Any]) -> tuple:
    """What identifies a payload's task (``None`` parts never match a stale entry)."""
    kind = payload.get("kind")
    if kind == "builtin":
        return (kind, payload["name"])
    if kind == "yaml":
        return (kind, _digest(payload["text"]), payload["base_dir"])
    if kind == "dict":
        return (kind, _digest(json.dumps(payload["data"], sort_keys=True)), payload["base_dir"])
    if kind == "world":
        try:
            st = Path(payload["path"]).stat()
        except OSError:
            return (kind, payload["path"], None, None)
        return (kind, payload["path"], st.st_size, st.st_mtime_ns)
    return (kind, id(payload))  # unknown: entry_task raises


def load_entry(payload: Mapping[str, Any]) -> LoadedTask:
    """The task of an entry's payload, from the worker's cache or parsed now.

    Raises:
        PrehensionError: the task is invalid; the message names the file and line.
    """
    key = _key(payload)
    hit = _CACHE.get(key)
    if hit is not None:
        _CACHE.move_to_end(key)
        return hit
    loaded = LoadedTask(entry_task(payload))
    _CACHE[key] = loaded
    if len(_CACHE) > CACHE_SIZE:
        _CACHE.popitem(last=False)
    return loaded


def clear_cache() -> None:
    """Forget every parsed task (tests; a worker never needs it)."""
    _CACHE.clear()
