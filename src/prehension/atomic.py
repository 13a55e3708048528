"""Files a user keeps: atomic writes (a reader, or a crash, sees the old file or the new one,
never half) and output paths checked before any work starts (:func:`check_output_path`).

An output is either absent or a regular file (or a symbolic link to one: the file it points
to is written, atomically in its own folder, and the link stays).  Anything else that
exists under the name -- a folder, a named pipe, a socket, a device node, a link to one of
them or a dangling link -- is refused with a message naming it, both by
:func:`check_output_path` (before any work) and by :func:`open_atomic` (every writer), so
no command ever replaces a special file by a regular one.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import stat
from pathlib import Path
from typing import BinaryIO, Iterator

import numpy as np

from .errors import InvalidTask, PrehensionError, not_a_file

__all__ = [
    "open_atomic", "write_text_atomic", "write_bytes_atomic", "to_plain", "write_json_atomic", "read_json",
    "check_output_path", "special_file_kind",
]  # fmt: skip

_KINDS = (
    (stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
)  # fmt: skip


def special_file_kind(path) -> str | None:
    """What ``path`` is when it exists and is not a regular file (nor a link to one), in
    words ("a named pipe (FIFO)", "a symbolic link to a character device", ...); ``None``
    when it is absent, a regular file or a symbolic link to a regular file."""
    path = Path(path)
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return None
    except OSError as exc:
        return f"unreadable ({exc.strerror or exc})"
    link = stat.S_ISLNK(mode)
    if link:
        try:
            mode = os.stat(path).st_mode
        except OSError:
            return f"a symbolic link to nothing ({os.readlink(path)} does not exist)"
    if stat.S_ISREG(mode):
        return None
    kind = next((word for test, word in _KINDS if test(mode)), "not a regular file")
    return f"a symbolic link to {kind} ({os.path.realpath(path)})" if link else kind


def _refuse_special(path: Path, what: str) -> None:
    kind = special_file_kind(path)
    if kind is not None:
        raise PrehensionError(
            f"{what} {path} exists and is {kind}, not a regular file; writing it would replace it: "
            "choose a new file name or an existing regular file"
        )


def _target(path: Path) -> Path:
    """The file a write of ``path`` changes: the file a symbolic link points to, else ``path``."""
    return Path(os.path.realpath(path)) if path.is_symlink() else path


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
    fsynced and moved over ``path`` when the block ends; removed if the block raises.

    A symbolic link to a regular file is written through (its target is replaced, the link
    kept).  Raises :class:`~prehension.errors.PrehensionError` when ``path`` exists and is
    not a regular file (a folder, a named pipe, a socket, a device...): nothing is written.
    """
    path = Path(path)
    _refuse_special(path, "output")
    path = _target(path)
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
        PrehensionError: ``path`` is a folder or another special file (a named pipe, a
            socket, a device node, a link to one of them: see :func:`special_file_kind`),
            one of the inputs, has a suffix not in ``suffixes``, or its folder is missing or
            not writable (probed by creating and removing a temporary file there, which also
            catches read-only file systems).
    """
    path = Path(path)
    if path.is_dir():
        raise PrehensionError(f"{what} {path} is a folder; give a file name (e.g. {path / ('out' + (suffixes[0] if suffixes else ''))})")
    _refuse_special(path, what)
    if suffixes and path.suffix.lower() not in suffixes:
        raise PrehensionError(f"{what} {path}: the file name must end in {' or '.join(suffixes)}")
    for item in inputs:
        if item is not None and _same_file(path, Path(item)):
            raise PrehensionError(f"{what} {path} is an input of this command; writing it would destroy the input: choose another file")
    folder = _target(path).parent if str(_target(path).parent) else Path(".")
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
    path = Path(path)
    article = "an" if what[:1].lower() in "aeiou" else "a"
    if not path.is_file():  # a folder, a missing file, a named pipe (reading one would wait for a writer)
        raise InvalidTask(not_a_file(what, path))
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise InvalidTask(f"{path}: not {article} {what} (not UTF-8 text, so not JSON)") from None
    except OSError as exc:
        raise InvalidTask(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    except json.JSONDecodeError as exc:
        raise InvalidTask(f"{path}: not {article} {what} (invalid JSON at line {exc.lineno})") from None
