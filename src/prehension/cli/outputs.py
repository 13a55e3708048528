"""Where the commands read and write: the files a task argument names, the files a loaded
task reads, and a saved file kept aside before it is replaced (nothing a user saved is lost).

Every command checks its outputs against these inputs before any work
(:func:`prehension.atomic.check_output_path`), so that no output overwrites an input.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["task_inputs", "files_of_task", "keep_previous"]


def task_inputs(text: str) -> list[Path]:
    """The files a task argument names (none for a built-in task name)."""
    path = Path(text)
    return [path] if path.is_file() else []


def files_of_task(task) -> list[Path]:
    """The files a loaded task reads: its object's mesh and display mesh, its hand's file."""
    solid, hand_source = getattr(task.object, "solid", None), getattr(task.hand, "source", None)
    names = (getattr(solid, "path", None), task.object.mesh_file, getattr(hand_source, "path", None))
    return [Path(name) for name in names if name]


def keep_previous(path: Path) -> Path | None:
    """Move an existing file aside as ``path.~N~`` so nothing a user saved is lost; the
    backup's path, or ``None`` when there was no file."""
    if not path.is_file():
        return None
    n = 1
    while Path(f"{path}.~{n}~").exists():
        n += 1
    backup = Path(f"{path}.~{n}~")
    os.replace(path, backup)
    return backup
