"""Reading and writing the ``.npy`` files the field stores grasps in, safely.

``np.save`` of a dict (DexGraspBench, BODex) or of a list of dicts (DexGraspNet) pickles it,
and ``np.load(..., allow_pickle=True)`` would run whatever a pickle names: a grasp file
from the internet could execute code.  :func:`load_npy` reads the ``.npy`` header itself
and unpickles an object array with an unpickler that builds only numpy arrays, numpy
scalars and dtypes (and the plain containers pickle builds without naming a class:
dict, list, tuple, str, numbers); any other class is refused by name, before anything of
it is made.  A plain numeric array is read without pickle at all.
"""

from __future__ import annotations

import io
import pickle
from pathlib import Path

import numpy as np

from ..atomic import write_bytes_atomic
from ..errors import InvalidTask, not_a_file

__all__ = ["load_npy", "save_npy", "plain_value"]

_ALLOWED = {
    ("numpy", "ndarray"), ("numpy", "dtype"),
    ("numpy.core.multiarray", "_reconstruct"), ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"), ("numpy._core.multiarray", "scalar"),
    ("numpy.core.numeric", "_frombuffer"), ("numpy._core.numeric", "_frombuffer"),
    ("builtins", "complex"), ("_codecs", "encode"),
}  # fmt: skip


_HEADERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}


class _ArraysOnly(pickle.Unpickler):
    def find_class(self, module, name):
        if (module, name) in _ALLOWED:
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"the file names {module}.{name}; a grasp record holds only arrays, numbers and strings")


def load_npy(path, what: str = "grasp file"):
    """The value stored in a ``.npy`` file: a numeric array, or the object ``np.save``
    pickled (a dict or a list of dicts), unpickled safely (see the module docstring).

    Raises:
        InvalidTask: missing, not a ``.npy`` file, or a pickle naming anything other than
            numpy arrays, scalars and plain containers.
    """
    path = Path(path)
    if not path.is_file():
        raise InvalidTask(not_a_file(what, path))
    with open(path, "rb") as fh:
        try:
            version = np.lib.format.read_magic(fh)
            shape, fortran, dtype = _HEADERS[version](fh)
        except (KeyError, ValueError, OSError) as exc:
            raise InvalidTask(f"{path}: not a numpy .npy file ({exc})") from None
        if not dtype.hasobject:
            fh.seek(0)
            return np.load(fh, allow_pickle=False)
        try:
            array = _ArraysOnly(io.BytesIO(fh.read())).load()
        except Exception as exc:  # noqa: BLE001 -- a corrupt or hostile pickle: refuse it by name
            raise InvalidTask(f"{path}: refused ({type(exc).__name__}: {exc})") from None
    return array.item() if isinstance(array, np.ndarray) and array.shape == () else array


def plain_value(value, where: str):
    """``value`` checked to be an array, a number, a string, or a dict/list of them (what a
    grasp record may hold); returned as it is."""
    if isinstance(value, (str, bytes, int, float, bool, np.generic)) or value is None:
        return value
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            for v in value.flat:
                plain_value(v, where)
        return value
    if isinstance(value, dict):
        for k, v in value.items():
            if not isinstance(k, str):
                raise InvalidTask(f"{where}: key {k!r} is not a string")
            plain_value(v, f"{where}[{k!r}]")
        return value
    if isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            plain_value(v, f"{where}[{i}]")
        return value
    raise InvalidTask(f"{where}: holds a {type(value).__name__}; a grasp record holds only arrays, numbers and strings")


def save_npy(path, value) -> None:
    """``np.save(path, value)`` written atomically (a dict or a list is pickled, as the
    peers' own files are)."""
    buffer = io.BytesIO()
    np.save(buffer, np.asarray(value, dtype=object) if isinstance(value, list) else value, allow_pickle=True)
    write_bytes_atomic(Path(path), buffer.getvalue())
