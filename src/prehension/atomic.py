"""Atomic file writes: a reader (or a crash) sees the old file or the new one, never half."""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import stat
from pathlib import Path
from typing import BinaryIO, Iterator

import numpy as np

__all__ = ["open_atomic", "write_text_atomic", "write_bytes_atomic", "to_plain", "write_json_atomic", "read_json"]


def _fsync_dir(directory: Path) -> None:
    with contextlib.suppress(OSError, AttributeError):  # not possible on every platform
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


@contextlib.contextmanager
def open_atomic(path) -> Iterator[BinaryIO]:
    """A binary file to write ``path`` through: a temporary file in the same folder,
    fsynced and moved over ``path`` when the block ends; removed if the block raises."""
    path = Path(path)
    tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "wb") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        with contextlib.suppress(OSError):  # keep an existing file's permissions
            os.chmod(tmp, stat.S_IMODE(os.stat(path).st_mode))
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_dir(path.parent)


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) atomically (see :func:`open_atomic`)."""
    with open_atomic(path) as fh:
        fh.write(text.encode("utf-8"))


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` atomically (see :func:`open_atomic`)."""
    with open_atomic(path) as fh:
        fh.write(data)


def to_plain(value):
    """``value`` with numpy arrays and scalars turned into plain Python (JSON-ready)."""
    if isinstance(value, dict):
        return {str(k): to_plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_json_atomic(path, data) -> None:
    """``data`` as indented JSON, written atomically."""
    write_text_atomic(Path(path), json.dumps(to_plain(data), indent=1) + "\n")


def read_json(path, what: str):
    """The JSON document in ``path``; errors name the file and ``what`` was expected."""
    from .errors import InvalidTask

    path = Path(path)
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise InvalidTask(f"cannot read {what} {path}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise InvalidTask(f"{path}: not a {what} (invalid JSON at line {exc.lineno})") from None
