"""The compiled entry points: ahead-of-time machine code when it is installed and fresh, else numba's JIT.

``pip install`` compiles the functions Python calls into the compiled kernels (the *entry
points*, :mod:`prehension.kernels.manifest`) into the extension module ``prehension._aot``
(:mod:`prehension._aot_build`; numba's ``pycc``), so that a fresh install's first solve runs
at once instead of spending one to two minutes in numba's JIT.  A Python call site reads

    aot(run_states)(problem, x0, ...)

and gets the extension's function when

* the extension imports (it is optional: an install without a C compiler, or with
  ``PREHENSION_NO_AOT=1``, has none), and
* it was built from the same sources: it exports a marker ``source_<hash>`` of every file
  the compiled code is built from (``SOURCES``), and the hash of the files as they are now
  must equal it -- an edited checkout never runs stale machine code, it falls back to the
  JIT (which compiles and caches as before);

else the numba dispatcher itself.  ``PREHENSION_AOT=0`` forces the JIT (tests compare both).
Calls between compiled functions stay inside the JIT world (or inside the extension): only
Python's calls go through :func:`aot`.

The extension's functions take exactly the types recorded in the manifest (the
call sites pass writable C-contiguous arrays of the recorded dtypes, as the JIT's one
signature per function already requires); :func:`aot` checks the array arguments'
dtype, rank, contiguity and writability against them on every call (microseconds), and a
call that does not match (e.g. a read-only angle array given to ``forward_kinematics``) runs
in the JIT instead, never in machine code that would read its memory the wrong way.

This module imports neither numba nor the kernels; it reads the manifest (data only).
"""

from __future__ import annotations

import hashlib
import importlib
import os
from functools import lru_cache
from pathlib import Path

from .manifest import SIGNATURES, SOURCES

__all__ = [
    "aot", "aot_available", "use_aot", "source_hash", "export_name", "array_arguments", "loaded_dispatchers",
    "STAMP_PREFIX", "EXTENSION",
]  # fmt: skip

EXTENSION = "prehension._aot"
STAMP_PREFIX = "source_"
_PACKAGE = Path(__file__).resolve().parent.parent  # src/prehension: SOURCES are relative to it


def export_name(key: str) -> str:
    """The extension's name of an entry point ``"module:function"`` (an identifier)."""
    module, function = key.split(":")
    return module.removeprefix("prehension.").replace(".", "__") + "___" + function


def source_hash() -> str:
    """A hash of every source file the compiled entry points are built from (24 hex digits)."""
    h = hashlib.sha256()
    for rel in SOURCES:
        h.update(rel.encode() + b"\0" + (_PACKAGE / rel).read_bytes() + b"\0")
    return h.hexdigest()[:24]


_ENABLED = [os.environ.get("PREHENSION_AOT", "1") != "0"]


def use_aot(enabled: bool) -> bool:
    """Let :func:`aot` serve the extension (``True``, the default unless ``PREHENSION_AOT=0``)
    or always the JIT (``False``); returns the previous setting.  For tests and benchmarks
    that compare the two in one process."""
    previous, _ENABLED[0] = _ENABLED[0], bool(enabled)
    _CHOSEN.clear()
    return previous


@lru_cache(maxsize=None)
def _module():
    """The extension module when it is importable and fresh, else None."""
    try:
        module = importlib.import_module(EXTENSION)
    except ImportError:
        return None
    return module if hasattr(module, STAMP_PREFIX + source_hash()) else None


def _extension():
    return _module() if _ENABLED[0] else None


def aot_available() -> bool:
    """True when the installed extension is fresh and will serve the entry points."""
    return _extension() is not None


_CHOSEN: dict[int, object] = {}


def aot(function):
    """The callable to use for the compiled entry point ``function`` (a numba dispatcher, or
    the plain function without numba): the extension's, checked, or ``function`` itself."""
    chosen = _CHOSEN.get(id(function))
    if chosen is None:
        chosen = _CHOSEN[id(function)] = _choose(function)
    return chosen


def _choose(function):
    py = getattr(function, "py_func", function)
    key = f"{py.__module__}:{py.__qualname__}"
    module = _extension()
    compiled = getattr(module, export_name(key), None) if module is not None else None
    if compiled is None:
        return function
    return _Checked(key, compiled, array_arguments(SIGNATURES[key][1]), function)


def array_arguments(arguments: tuple) -> tuple:
    """``((path into the arguments), dtype, ndim)`` of every array among a manifest's
    argument types (:data:`~prehension.kernels.manifest.SIGNATURES`): what
    :class:`_Checked` checks on each call."""
    found = []

    def walk(spec, path):
        if isinstance(spec, tuple) and spec[0] == "array":
            found.append((path, spec[1], spec[2]))
        elif isinstance(spec, tuple):
            for i, item in enumerate(spec[-1]):
                walk(item, path + (i,))

    for i, spec in enumerate(arguments):
        walk(spec, (i,))
    return tuple(found)


class _Checked:
    """An extension function behind a check of its array arguments (dtype, rank, C order,
    writable: the extension's own unboxing checks none of them).  A call that does not match
    the compiled signature goes to the JIT instead (which compiles a specialisation for it,
    as it always did), never to machine code that would read the memory the wrong way."""

    __slots__ = ("key", "function", "arrays", "jit")

    def __init__(self, key: str, function, arrays: tuple, jit):
        import numpy as np

        self.key, self.function, self.jit = key, function, jit
        self.arrays = tuple((path, np.dtype(dtype), ndim) for path, dtype, ndim in arrays)

    def mismatch(self, args) -> str | None:
        """Why ``args`` do not fit the compiled signature, or None when they do."""
        for path, dtype, ndim in self.arrays:
            value = args[path[0]]
            for i in path[1:]:
                value = value[i]
            try:
                flags = value.flags
                fits = value.dtype == dtype and value.ndim == ndim and flags.c_contiguous and flags.writeable
            except AttributeError:  # not an array
                fits = False
            if not fits:
                got = f"{getattr(value, 'dtype', type(value).__name__)}{f' {value.ndim}-d' if hasattr(value, 'ndim') else ''}"
                return f"argument {'.'.join(map(str, path))} is not a writable C-contiguous {ndim}-d {dtype} array: {got}"
        return None

    def __call__(self, *args):
        if self.mismatch(args) is not None:
            return self.jit(*args)
        return self.function(*args)


def loaded_dispatchers() -> dict:
    """Every numba dispatcher defined in a loaded ``prehension`` module, keyed by its code's
    ``(file, first line, name)`` (as cProfile names a call): ``(module:qualname, dispatcher)``.
    For ``scripts/aot_signatures.py`` and the tests that find Python's calls of compiled
    functions."""
    import sys

    from numba.core.dispatcher import Dispatcher

    found = {}
    for name, module in list(sys.modules.items()):
        if name.startswith("prehension"):
            for value in vars(module).values():
                if isinstance(value, Dispatcher) and value.py_func.__module__ == name:
                    code = value.py_func.__code__
                    found[(code.co_filename, code.co_firstlineno, code.co_name)] = (f"{name}:{value.py_func.__qualname__}", value)
    return found
