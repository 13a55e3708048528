"""A read-only mapping that, unlike ``types.MappingProxyType``, can be pickled.

Frozen model values (hands, objects, tasks) travel to worker processes and cluster
workers, so everything they hold must pickle.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Iterator, TypeVar

__all__ = ["FrozenMap"]

K = TypeVar("K")
V = TypeVar("V")


class FrozenMap(Mapping[K, V]):
    """An immutable view of a copy of a mapping (order preserved)."""

    __slots__ = ("_data",)

    def __init__(self, data=()):
        object.__setattr__(self, "_data", dict(data))

    def __getitem__(self, key: K) -> V:
        return self._data[key]

    def __iter__(self) -> Iterator[K]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __repr__(self) -> str:
        return f"FrozenMap({self._data!r})"

    def __setattr__(self, name, value):
        raise AttributeError("FrozenMap is read-only")

    def __reduce__(self):
        return (FrozenMap, (self._data,))
