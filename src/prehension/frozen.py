"""Frozen model values: a read-only mapping that, unlike ``types.MappingProxyType``, can
be pickled, and the cache of what is derived from a frozen value.

Frozen model values (hands, objects, tasks) travel to worker processes and cluster
workers, so everything they hold must pickle; what a module derives from one (tables,
solids, probes) is kept beside it by :func:`cached_per_value`, never written onto it.
"""

from __future__ import annotations

import functools
import weakref
from collections.abc import Mapping
from typing import Callable, Iterator, TypeVar

__all__ = ["FrozenMap", "IdentityCache", "cached_per_value"]

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


R = TypeVar("R")


def cached_per_value(build: Callable[[K], R]) -> Callable[[K], R]:
    """``build(value)`` computed once per value object and held in a weak cache keyed by it
    (gone with the value; the value is not written to).  For frozen values compared by
    identity (``eq=False``: hands, objects, tasks, formulations).  A build that raises
    caches nothing; ``None`` is cached like any result."""
    cache: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()

    @functools.wraps(build)
    def get(value: K) -> R:
        try:
            return cache[value]
        except KeyError:
            result = cache[value] = build(value)
            return result

    return get


class IdentityCache:
    """Values built once per tuple of objects taken by identity, for objects that cannot be
    weakly referenced (numba's named-tuple bundles, arrays), at most ``maxsize`` entries
    (all dropped when full).  An entry holds its objects, so their ids are not reused while
    it lives; nothing is written onto them."""

    def __init__(self, maxsize: int = 256):
        self.maxsize = maxsize
        self._held: dict = {}

    def get(self, objects: tuple, extra, build: Callable[[], R]) -> R:
        """The value of ``(objects, extra)`` (``extra`` hashable, compared by value), made by
        ``build()`` the first time."""
        key = (tuple(map(id, objects)), extra)
        hit = self._held.get(key)
        if hit is None:
            if len(self._held) >= self.maxsize:
                self._held.clear()
            hit = self._held[key] = (objects, build())
        return hit[1]

