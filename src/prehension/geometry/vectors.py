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
    (the same products and differences) without its generic axis handling: several
    times faster on the small arrays of one configuration."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out
