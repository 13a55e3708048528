"""Validation of small geometric values given by users (clear errors, read-only arrays)."""

from __future__ import annotations

import numpy as np

from ..errors import InvalidGeometry, PrehensionError

__all__ = ["vec3", "unit3", "cross3"]


def vec3(value, what: str, error: type[PrehensionError] = InvalidGeometry) -> np.ndarray:
    """``value`` as a read-only float array of shape (3,); ``error`` names ``what`` otherwise."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise error(f"{what} must be 3 finite numbers, got {value!r}") from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise error(f"{what} must be 3 finite numbers, got {arr.tolist()!r}")
    arr.setflags(write=False)
    return arr


def unit3(value, what: str, error: type[PrehensionError] = InvalidGeometry) -> np.ndarray:
    """``value`` normalised to unit length (read-only, shape (3,)); a zero vector is refused."""
    arr = vec3(value, what, error)
    norm = float(np.linalg.norm(arr))
    if norm < 1e-9:
        raise error(f"{what} must be a non-zero vector, got {arr.tolist()}")
    arr = arr / norm
    arr.setflags(write=False)
    return arr


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products of ``(..., 3)`` vectors (broadcast), the same bits as ``np.cross``
    (the same products and differences: component ``i`` is
    ``a[i+1] b[i+2] - a[i+2] b[i+1]``, indices mod 3) without its generic axis handling:
    several times faster on the small arrays of one configuration."""
    return a[..., _NEXT] * b[..., _AFTER] - a[..., _AFTER] * b[..., _NEXT]


_NEXT = np.array([1, 2, 0])  # i + 1 (mod 3) per component i
_AFTER = np.array([2, 0, 1])  # i + 2 (mod 3)
