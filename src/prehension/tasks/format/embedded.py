"""The files a task names, carried inside a result so that it can be re-checked anywhere.

A task file names its object's mesh by path (``object.mesh``, ``object.display.mesh_file``);
a result file embeds the task, so a result moved to another folder or machine would name a
path that is not there (``check`` and ``view`` would fail: "mesh file not found").  So a
result carries the bytes of every file its task names, **by content**:

* a result file (``prehension: result/1``) has a top-level ``files`` mapping, one entry
  per path as the embedded task writes it::

      "files": {"/home/me/objects/mug.ply": {"name": "mug.ply", "sha256": "9f2c...",
                                             "size": 175031, "zlib_base64": "eJzs..."}}

  (the file's bytes, zlib-compressed, base64; the SHA-256 and size of the bytes);
* a batch output stores each distinct file **once** (a batch writes thousands of records,
  many of them on one mesh): a ``batch-file/1`` line with the same fields, written before
  the first task line that needs it; a task line names its files by path and SHA-256
  (``"files": {path: {"sha256": ...}}``), and a record refers to its task line
  (:mod:`prehension.batch.journal`).

Reading (:func:`task_with_files`): a path that has an entry is read **from the entry**,
never from the disk -- also when the original file is still there, since it may have
changed since: the check is against the object the result was computed with.  The bytes
are checked against the SHA-256 (a damaged or edited entry is an error naming the path)
and written once per process to a private temporary folder as ``<sha256[:16]>/<name>``
(the name keeps the file's format).  A path without an entry (a result written before
files were carried) is read from the disk as before.

Hands need nothing of this: a result holds its hand inline (links, joints, fitted
collision capsules and fingertip caps), so a hand read from a URDF or MJCF file needs
neither the file nor its meshes to be checked or drawn; its ``source`` (path and SHA-256)
is only a record of where it came from.

Why embedded and not a file beside the result: a result is one file that can be mailed,
attached to an issue or copied alone, and nothing can get separated from it.  The cost
is the compressed mesh (the built-in teapot: 70 KB; a batch output pays it once).
"""

from __future__ import annotations

import atexit
import base64
import functools
import hashlib
import shutil
import tempfile
import zlib
from pathlib import Path
from typing import Any, Mapping

from ...errors import InvalidTask, PrehensionError

__all__ = ["FILE_FIELDS", "task_file_paths", "file_entry", "embedded_files", "task_with_files"]

FILE_FIELDS = (("object", "mesh"), ("object", "display", "mesh_file"))  # where a task dict names a file


def task_file_paths(task_dict: Mapping[str, Any]) -> list[str]:
    """The file paths a task dict names (object mesh, display mesh), in that order."""
    out = []
    for keys in FILE_FIELDS:
        value: Any = task_dict
        for key in keys:
            value = value.get(key) if isinstance(value, Mapping) else None
        if isinstance(value, str) and value not in out:
            out.append(value)
    return out


def file_entry(path: str) -> dict:
    """The entry of one file: its name, SHA-256, size and zlib-compressed bytes (base64);
    made once per file version (path, size, modification time) in a process: a batch
    worker meets one mesh in many distinct tasks.  Do not modify the returned dict."""
    st = Path(path).stat()
    return _entry_of(str(path), st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=16)
def _entry_of(path: str, size: int, mtime_ns: int) -> dict:
    data = Path(path).read_bytes()
    return {
        "name": Path(path).name, "sha256": hashlib.sha256(data).hexdigest(), "size": len(data),
        "zlib_base64": base64.b64encode(zlib.compress(data)).decode("ascii"),
    }  # fmt: skip


def embedded_files(task_dict: Mapping[str, Any]) -> dict[str, dict]:
    """``{path: entry}`` of every file the task dict names (read now; the task was read
    from these files, so a file that cannot be read any more is left out)."""
    out = {}
    for path in task_file_paths(task_dict):
        try:
            out[path] = file_entry(path)
        except OSError:
            continue
    return out


_FOLDER: list[Path] = []  # this process's folder of written-out entries (made when first needed)
_WRITTEN: dict[str, Path] = {}  # sha256 -> its file there


def _folder() -> Path:
    if not _FOLDER:
        folder = Path(tempfile.mkdtemp(prefix="prehension-files-"))
        atexit.register(shutil.rmtree, folder, ignore_errors=True)
        _FOLDER.append(folder)
    return _FOLDER[0]


def _decoded(entry: Mapping[str, Any], path: str, source: str) -> bytes:
    def bad(why: str) -> InvalidTask:
        return InvalidTask(f"{source}: the copy of {path} that the file carries {why}; it cannot be checked "
                           "against the object it was computed with")  # fmt: skip

    if not isinstance(entry, Mapping) or not all(isinstance(entry.get(k), str) for k in ("name", "sha256", "zlib_base64")):
        raise bad("is not a mapping {name, sha256, size, zlib_base64}")
    try:
        data = zlib.decompress(base64.b64decode(entry["zlib_base64"], validate=True))
    except (ValueError, zlib.error) as exc:
        raise bad(f"cannot be decoded ({exc})") from None
    if hashlib.sha256(data).hexdigest() != entry["sha256"]:
        raise bad("does not match its SHA-256 (damaged or edited)")
    return data


def _written(entry: Mapping[str, Any], path: str, source: str) -> str:
    """The entry's bytes, checked, as a file of this process (written once per SHA-256)."""
    data = _decoded(entry, path, source)  # checked every time: another entry may claim the same SHA-256
    sha = entry["sha256"]
    if sha not in _WRITTEN or not _WRITTEN[sha].is_file():
        name = Path(str(entry["name"])).name  # a bare file name: the entry cannot point elsewhere
        target = _folder() / sha[:16] / (name if name not in ("", ".", "..") else "mesh")
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        except OSError as exc:
            raise PrehensionError(f"{source}: cannot write the copy of {path} it carries to {target} ({exc}); "
                                  "free some space in the temporary folder (TMPDIR)") from None  # fmt: skip
        _WRITTEN[sha] = target
    return str(_WRITTEN[sha])


def task_with_files(task_dict: Mapping[str, Any], files, source: str) -> Mapping[str, Any]:
    """``task_dict`` with each path that ``files`` carries replaced by its copy (see the
    module docstring); the dict itself when it carries none.

    Raises:
        InvalidTask: ``files`` is not a mapping, or an entry is damaged.
    """
    if files is None or not isinstance(task_dict, Mapping):
        return task_dict
    if not isinstance(files, Mapping):
        raise InvalidTask(f"{source}: 'files' must map each file path of the task to its copy, got {type(files).__name__}")
    carried = [p for p in task_file_paths(task_dict) if p in files]
    if not carried:
        return task_dict
    out = _copy(task_dict)
    for keys in FILE_FIELDS:
        holder: Any = out
        for key in keys[:-1]:
            holder = holder.get(key) if isinstance(holder, dict) else None
        if isinstance(holder, dict) and holder.get(keys[-1]) in carried:
            holder[keys[-1]] = _written(files[holder[keys[-1]]], holder[keys[-1]], source)
    return out


def _copy(task_dict: Mapping[str, Any]) -> dict:
    """A copy deep enough to replace the file fields (``object`` and its ``display``)."""
    out = dict(task_dict)
    if isinstance(out.get("object"), Mapping):
        out["object"] = dict(out["object"])
        if isinstance(out["object"].get("display"), Mapping):
            out["object"]["display"] = dict(out["object"]["display"])
    return out
