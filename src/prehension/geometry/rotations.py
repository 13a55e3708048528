r"""Rotations and rigid transforms, batch-first.

Conventions
-----------
* Rotations are right-handed 3x3 matrices acting on column vectors, ``x' = R x``.
  Batched rotations have shape ``(B, 3, 3)``; batched vectors ``(B, 3)``.
* Angles are in radians; lengths (translations) in mm.
* Rodrigues' formula for a unit axis :math:`a` and angle :math:`\theta`:

  .. math::

      R = I + \sin\theta\, [a]_\times + (1 - \cos\theta)\, [a]_\times^2,

  with the skew matrix :math:`[a]_\times x = a \times x`.
* Homogeneous transforms are ``(..., 4, 4)`` matrices
  ``[[R, t], [0, 0, 0, 1]]`` mapping ``x -> R x + t``.
"""

from __future__ import annotations

import numpy as np

from prehension.errors import InvalidGeometry

from .vectors import cross3

__all__ = [
    "skew",
    "axis_angle_to_matrix",
    "matrix_to_axis_angle",
    "rotation_about",
    "random_rotations",
    "is_rotation",
    "orthonormal_frame",
    "angle_between",
    "signed_angle",
    "make_transform",
    "invert_transform",
]


def _vectors(x, name: str) -> np.ndarray:
    """Finite float array whose last axis has length 3, shape ``(..., 3)``."""
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 0 or x.shape[-1] != 3:
        raise InvalidGeometry(f"{name} must have shape (3,) or (B, 3); got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise InvalidGeometry(f"{name} must be finite")
    return x


def _unit_vectors(x, name: str) -> np.ndarray:
    """Normalise ``(..., 3)`` vectors; raise on zero length."""
    x = _vectors(x, name)
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    if np.any(norm <= 1e-12):
        raise InvalidGeometry(f"{name} must be non-zero (it is used as a direction)")
    return x / norm


def _matrices(R, name: str, size: int = 3) -> np.ndarray:
    """Float array of shape ``(..., size, size)``."""
    R = np.asarray(R, dtype=np.float64)
    if R.ndim < 2 or R.shape[-2:] != (size, size):
        raise InvalidGeometry(f"{name} must have shape ({size}, {size}) or (B, {size}, {size}); got shape {R.shape}")
    return R


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices ``[v]_x`` with ``[v]_x x = v x x``.

    Args:
        v: Vectors, shape ``(B, 3)`` (or ``(..., 3)``).

    Returns:
        Skew-symmetric matrices, shape ``(B, 3, 3)`` (``(..., 3, 3)``).
    """
    v = _vectors(v, "v")
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    zero = np.zeros_like(x)
    rows = [
        np.stack([zero, -z, y], axis=-1),
        np.stack([z, zero, -x], axis=-1),
        np.stack([-y, x, zero], axis=-1),
    ]
    return np.stack(rows, axis=-2)


def axis_angle_to_matrix(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices from axis and angle (Rodrigues, right-handed).

    Args:
        axis: Rotation axes, shape ``(3,)`` or ``(B, 3)``; normalised internally
            (zero axes raise :class:`InvalidGeometry`).
        angle: Angles in radians, shape ``(B,)`` or scalar (broadcast against ``axis``).

    Returns:
        Rotation matrices, shape ``(B, 3, 3)`` (``(1, 3, 3)`` if both inputs are single).
    """
    axis = np.atleast_2d(_unit_vectors(axis, "axis"))
    angle = np.atleast_1d(np.asarray(angle, dtype=np.float64))
    if axis.ndim != 2 or angle.ndim != 1:
        raise InvalidGeometry(
            f"axis must be (3,) or (B, 3) and angle scalar or (B,); got {axis.shape} and {angle.shape}"
        )
    try:
        batch = np.broadcast_shapes(axis.shape[:1], angle.shape)
    except ValueError as exc:
        raise InvalidGeometry(f"axis {axis.shape} and angle {angle.shape} have different batch sizes") from exc
    axis = np.broadcast_to(axis, batch + (3,))
    angle = np.broadcast_to(angle, batch)[:, None, None]
    k = skew(axis)
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def matrix_to_axis_angle(R: np.ndarray, atol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Axis and angle of rotation matrices (inverse of :func:`axis_angle_to_matrix`).

    Args:
        R: Rotation matrices, shape ``(B, 3, 3)`` or ``(3, 3)``.
        atol: Tolerance of the rotation check (see :func:`is_rotation`).

    Returns:
        ``(axis, angle)``: unit axes of shape ``(B, 3)`` and angles in ``[0, pi]``
        radians of shape ``(B,)``.  For (near-)identity rotations the axis is
        ``(0, 0, 1)``.  A single ``(3, 3)`` input gives ``B = 1``.

    Raises:
        InvalidGeometry: If some matrix is not a rotation within ``atol``.
    """
    R = _matrices(R, "R").reshape(-1, 3, 3)
    bad = ~np.atleast_1d(is_rotation(R, atol))
    if np.any(bad):
        raise InvalidGeometry(
            f"R[{int(np.argmax(bad))}] is not a rotation matrix (orthonormal, det +1) within atol={atol}"
        )
    from scipy.spatial.transform import Rotation  # here, not at import: scipy.spatial costs ~0.3 s to import

    rotvec = Rotation.from_matrix(R).as_rotvec().reshape(-1, 3)
    angle = np.linalg.norm(rotvec, axis=-1)
    axis = np.tile([0.0, 0.0, 1.0], (len(R), 1))
    nonzero = angle > 1e-12
    axis[nonzero] = rotvec[nonzero] / angle[nonzero, None]
    return axis, angle


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """Single rotation matrix about ``axis`` by ``angle``.

    Args:
        axis: Axis, shape ``(3,)`` (normalised internally).
        angle: Angle in radians (scalar).

    Returns:
        Rotation matrix, shape ``(3, 3)``.
    """
    axis = _vectors(axis, "axis")
    if axis.shape != (3,) or np.ndim(angle) != 0:
        raise InvalidGeometry(
            "rotation_about needs axis of shape (3,) and a scalar angle; "
            f"got {axis.shape} and {np.shape(angle)}"
        )
    return axis_angle_to_matrix(axis, angle)[0]


def random_rotations(rng: np.random.Generator, B: int) -> np.ndarray:
    """Uniformly distributed (Haar) random rotations.

    Args:
        rng: NumPy random generator.
        B: Number of rotations (``>= 0``).

    Returns:
        Rotation matrices, shape ``(B, 3, 3)``.
    """
    if isinstance(B, bool) or not isinstance(B, (int, np.integer)) or B < 0:
        raise InvalidGeometry(f"B must be a non-negative integer, got {B!r}")
    # Normalised 4-D Gaussians are uniform unit quaternions, hence Haar rotations.
    q = rng.standard_normal((int(B), 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    from scipy.spatial.transform import Rotation  # here, not at import: scipy.spatial costs ~0.3 s to import

    return Rotation.from_quat(q).as_matrix().reshape(int(B), 3, 3)


def is_rotation(R: np.ndarray, atol: float = 1e-9) -> bool | np.ndarray:
    """Whether matrices are rotations: ``R^T R = I`` and ``det R = +1`` within ``atol``.

    Args:
        R: Matrices, shape ``(3, 3)`` or ``(B, 3, 3)``.
        atol: Absolute tolerance on the entries of ``R^T R - I`` and on ``det R - 1``.

    Returns:
        A ``bool`` for a single matrix, else a boolean array of shape ``(B,)``.
    """
    R = _matrices(R, "R")
    finite = np.all(np.isfinite(R), axis=(-2, -1))
    gram = np.swapaxes(R, -1, -2) @ R
    ortho = np.all(np.abs(gram - np.eye(3)) <= atol, axis=(-2, -1))
    det = np.abs(np.linalg.det(np.where(finite[..., None, None], R, 0.0)) - 1.0) <= atol
    result = finite & ortho & det
    return bool(result) if R.ndim == 2 else result


def orthonormal_frame(z: np.ndarray) -> np.ndarray:
    """Right-handed orthonormal frame whose third column is ``z``.

    The first column is the coordinate axis least aligned with ``z`` (lowest index on
    ties), made orthogonal to ``z``; the second is ``z x x``.  Deterministic.

    Args:
        z: Direction, shape ``(3,)`` (or ``(B, 3)``); normalised internally.

    Returns:
        Rotation matrix ``[x y z]`` (columns), shape ``(3, 3)`` (``(B, 3, 3)``).
    """
    z = _unit_vectors(z, "z")
    e = np.eye(3)[np.argmin(np.abs(z), axis=-1)]
    x = e - np.sum(e * z, axis=-1, keepdims=True) * z
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-1)


def angle_between(a, b) -> np.ndarray:
    """Unsigned angle between vectors ``a (..., 3)`` and ``b (..., 3)`` [rad], in [0, pi].

    Computed as ``atan2(|a x b|, a . b)``, accurate near 0 and pi where ``arccos`` of a
    rounded cosine loses half the digits (an error of ~1e-8 rad at 0).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    c = cross3(a, b)
    # np.linalg.norm(c, axis=-1) and np.sum(a * b, axis=-1), the same operations without their wrappers
    return np.arctan2(np.sqrt(np.add.reduce(c * c, axis=-1)), np.add.reduce(a * b, axis=-1))


def signed_angle(a: np.ndarray, b: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Right-handed angle from ``a`` to ``b`` about ``axis``.

    Both vectors are projected onto the plane orthogonal to ``axis``; the result is the
    angle ``theta`` in ``(-pi, pi]`` radians such that rotating the projection of ``a``
    by ``theta`` about ``axis`` gives the direction of the projection of ``b``.

    Args:
        a: Start vectors, shape ``(B, 3)`` or ``(3,)``.
        b: End vectors, shape ``(B, 3)`` or ``(3,)``.
        axis: Axes, shape ``(B, 3)`` or ``(3,)``; normalised internally.

    Returns:
        Angles in radians, shape ``(B,)`` (a 0-d array if all inputs are ``(3,)``).
        The angle is 0 when a projection vanishes.
    """
    a = _vectors(a, "a")
    b = _vectors(b, "b")
    axis = _unit_vectors(axis, "axis")
    sine = np.sum(axis * np.cross(a, b), axis=-1)
    cosine = np.sum(a * b, axis=-1) - np.sum(a * axis, axis=-1) * np.sum(b * axis, axis=-1)
    return np.arctan2(sine, cosine)


def make_transform(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Homogeneous transforms ``[[R, t], [0, 1]]``.

    Args:
        R: Rotations, shape ``(..., 3, 3)``.
        t: Translations in mm, shape ``(..., 3)`` (broadcast against ``R``).

    Returns:
        Transforms, shape ``(..., 4, 4)``.
    """
    R = _matrices(R, "R")
    t = _vectors(t, "t")
    batch = np.broadcast_shapes(R.shape[:-2], t.shape[:-1])
    T = np.zeros(batch + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def invert_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid homogeneous transforms: ``[[R^T, -R^T t], [0, 1]]``.

    Args:
        T: Rigid transforms, shape ``(..., 4, 4)`` (the rotation block must be a
            rotation; it is not re-checked).

    Returns:
        Inverse transforms, shape ``(..., 4, 4)``.
    """
    T = _matrices(T, "T", size=4)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    return make_transform(Rt, -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3]))
