"""Plain arrays kept on disk between processes, under a content key (``.npz`` entries).

The on-disk cache of :mod:`prehension.objects.geometry_cache` (an object's checked mesh
and distance tree) of :mod:`prehension.hands.link_cache` (a file hand's fitted
collision capsules and their fit) and of :mod:`prehension.sim.pieces` (the physics test's
convex decomposition) share this folder and these rules:

* where: ``$PREHENSION_CACHE_DIR`` if set (``off``, ``0`` or an empty value: no cache),
  else ``$XDG_CACHE_HOME/prehension/geometry`` (``~/.cache/prehension/geometry``);
* an entry's name is a hex SHA-256 of everything its content depends on (the caller's
  inputs, the source of the code that computes it, library versions), so a change misses
  the cache instead of returning a stale answer;
* entries are plain arrays read with ``allow_pickle=False`` and written atomically
  (:mod:`prehension.atomic`); a folder that cannot be written, or an entry that cannot be
  read whole, only costs the rebuild: the cache is never needed for a correct answer.
"""

from __future__ import annotations

import hashlib
import io
import os
from importlib import metadata
from pathlib import Path

import numpy as np

from .atomic import write_bytes_atomic

__all__ = ["CACHE_ENV", "cache_folder", "code_fingerprint", "content_key", "load_arrays", "store_arrays"]

CACHE_ENV = "PREHENSION_CACHE_DIR"
_OFF = ("", "0", "off", "none", "false")


def cache_folder() -> Path | None:
    """The folder of the entries, or ``None`` when the cache is switched off."""
    value = os.environ.get(CACHE_ENV)
    if value is not None:
        return None if value.strip().lower() in _OFF else Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME")
    if not base:
        try:
            base = Path.home() / ".cache"
        except RuntimeError:  # no home folder known: no cache
            return None
    return Path(base) / "prehension" / "geometry"


def code_fingerprint(sources, libraries) -> bytes:
    """SHA-256 of the bytes of the files ``sources`` and of the versions of ``libraries``."""
    h = hashlib.sha256()
    for path in sources:
        h.update(Path(path).read_bytes())
    for lib in libraries:
        try:
            h.update(f"{lib}={metadata.version(lib)};".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{lib}=absent;".encode())
    return h.digest()


def content_key(*parts) -> str:
    """A hex SHA-256 of ``parts`` (bytes as they are, arrays by dtype, shape and bytes,
    anything else by its ``repr``): the entry name of something derived from them only."""
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            part = repr((part.dtype.str, part.shape)).encode() + np.ascontiguousarray(part).tobytes()
        elif not isinstance(part, bytes):
            part = repr(part).encode()
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest()


def _entry(key: str | None) -> Path | None:
    folder = cache_folder()
    return None if (folder is None or key is None) else folder / f"{key}.npz"


def load_arrays(key: str | None, names) -> list[np.ndarray] | None:
    """The arrays ``names`` of an entry, in that order; ``None`` if there is no entry (or
    it cannot be read whole)."""
    path = _entry(key)
    if path is None or not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            return [data[name] for name in names]
    except Exception:  # noqa: BLE001 - a damaged entry (cut short, not a zip, a missing array, ...)
        return None  # rebuilt (and rewritten) by the caller


def store_arrays(key: str | None, arrays) -> None:
    """Write an entry of the named ``arrays`` (atomically); silently nothing if the folder
    cannot be written."""
    path = _entry(key)
    if path is None:
        return
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(path, buffer.getvalue())
    except OSError:
        pass  # a read-only home, a full disk: the next process builds it again
