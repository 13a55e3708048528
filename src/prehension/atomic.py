"""Files a user keeps: atomic writes (a reader, or a crash, sees the old file or the new one,
never half) and output paths checked before any work starts (:func:`check_output_path`)."""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import stat
from pathlib import Path
from typing import BinaryIO, Iterator

import numpy as np

__all__ = [
    "open_atomic", "write_text_atomic", "write_bytes_atomic", "to_plain", "write_json_atomic", "read_json",
    "check_output_path",
]  # fmt: skip


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
    """``value`` with numpy arrays and scalars turned into plain Python (JSON-ready).

    A non-finite float (NaN, +-inf) becomes ``None``: JSON has no such numbers, and a file
    holding a literal ``NaN`` is not valid JSON for other programs.
    """
    if isinstance(value, dict):
        return {str(k): to_plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_plain(value.tolist())
    if isinstance(value, np.generic):
        return to_plain(value.item())
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def write_json_atomic(path, data) -> None:
    """``data`` as indented JSON (strict: no NaN), written atomically."""
    write_text_atomic(Path(path), json.dumps(to_plain(data), indent=1, allow_nan=False) + "\n")


def check_output_path(path, what: str, *, inputs=(), suffixes: tuple[str, ...] = ()) -> Path:
    """Check, before any work starts, that ``path`` can be written without losing anything.

    Args:
        path: the file to write.
        what: what it is, for messages ("result file", "--html").
        inputs: files the command reads; the output must not be one of them.
        suffixes: allowed suffixes (lower case, with the dot); empty: any.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        PrehensionError: ``path`` is a folder, one of the inputs, has a suffix not in
            ``suffixes``, or its folder is missing or not writable (probed by creating and
            removing a temporary file there, which also catches read-only file systems).
    """
    from .errors import PrehensionError

    path = Path(path)
    if path.is_dir():
        raise PrehensionError(f"{what} {path} is a folder; give a file name (e.g. {path / ('out' + (suffixes[0] if suffixes else ''))})")
    if suffixes and path.suffix.lower() not in suffixes:
        raise PrehensionError(f"{what} {path}: the file name must end in {' or '.join(suffixes)}")
    for item in inputs:
        if item is not None and _same_file(path, Path(item)):
            raise PrehensionError(f"{what} {path} is an input of this command; writing it would destroy the input: choose another file")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise PrehensionError(f"{what} {path}: folder {folder} does not exist; create it first or choose another file")
    try:
        with open_atomic_probe(folder):
            pass
    except OSError as exc:
        raise PrehensionError(f"{what} {path}: cannot write in folder {folder} ({exc.strerror or exc})") from None
    return path


@contextlib.contextmanager
def open_atomic_probe(folder: Path):
    """Create and remove a hidden temporary file in ``folder`` (raises ``OSError`` if it cannot)."""
    tmp = folder / f".prehension-probe.{secrets.token_hex(6)}.tmp"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:
        yield
    finally:
        os.close(fd)
        with contextlib.suppress(OSError):
            os.unlink(tmp)


def _same_file(a: Path, b: Path) -> bool:
    with contextlib.suppress(OSError):
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    return a.resolve() == b.resolve()


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
