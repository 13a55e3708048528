r"""Tensor-product Bézier patches: evaluation, exact normal patch, subdivision.

Mathematics
-----------
A contact region is the tensor-product Bézier patch (Rosales et al., IJRR 2011, eq. 3)

.. math::

    p(u, v) = \sum_{i=0}^{M} \sum_{j=0}^{N} b_{ij} B_{i,M}(u) B_{j,N}(v),
    \qquad u, v \in [0, 1],

with the Bernstein basis :math:`B_{i,n}(t) = \binom{n}{i} t^i (1-t)^{n-i}` and control
points :math:`b_{ij} \in \mathbb{R}^D` (``D = 3`` for geometric patches, in mm;
``D = 1`` for scalar Bernstein polynomials).  The univariate algebra (basis,
derivatives, products, subdivision matrices; eqs. 19 and 33) is
:mod:`prehension.geometry.bernstein`, whose public names this module re-exports.

*Derivatives.*  The partial :math:`p_u` is a Bézier patch of degree :math:`(M-1, N)` with
control points :math:`M (b_{i+1,j} - b_{ij})`, and :math:`p_v` one of degree
:math:`(M, N-1)` with control points :math:`N (b_{i,j+1} - b_{ij})`.

*Normal patch* (eq. 19).  By the product rule of Bernstein polynomials,
:math:`n = p_u \times p_v` is *exactly* a Bézier patch of degree :math:`(2M-1, 2N-1)`
whose control points are the correspondingly weighted sums of the cross products of the
control points of :math:`p_u` and :math:`p_v`.

*Subdivision* (eq. 33): the subdivision matrices act on each parameter separately.

*Regularity certificate.*  :meth:`BezierPatch.check_nondegenerate` shows that the normal
does not vanish on :math:`[0, 1]^2` by the convex-hull property on recursively
subdivided boxes (:mod:`prehension.geometry.regularity`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from prehension.errors import DegeneratePatch, InvalidGeometry

from .bernstein import bernstein, bernstein_derivative, check_degree, cross_nets, subdivide_nets, subdivision_matrix
from .regularity import certify_normal

__all__ = [
    "bernstein",
    "bernstein_derivative",
    "subdivision_matrix",
    "subdivide_nets",
    "BezierPatch",
    "PatchDerivatives",
    "ensure_regular",
]


def _as_params(u, v) -> tuple[np.ndarray, np.ndarray]:
    """Broadcast parameters to two ``(B,)`` float arrays (scalars give ``B = 1``)."""
    try:
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        v = np.atleast_1d(np.asarray(v, dtype=np.float64))
        u, v = np.broadcast_arrays(u, v)
    except (TypeError, ValueError) as exc:
        raise InvalidGeometry(f"patch parameters u, v must be real scalars or (B,) arrays: {exc}") from exc
    if u.ndim != 1:
        raise InvalidGeometry(f"patch parameters u, v must be scalars or (B,) arrays, got shape {u.shape}")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(v))):
        raise InvalidGeometry("patch parameters u, v must be finite")
    return u, v


@dataclass(frozen=True, eq=False)
class PatchDerivatives:
    """Values and partial derivatives of a patch at a batch of parameters.

    Every field has shape ``(B, D)`` (units of the control points, e.g. mm, per unit
    parameter to the derivative's order).  Second-order fields are ``None`` when only
    first-order derivatives were requested.
    """

    p: np.ndarray
    p_u: np.ndarray
    p_v: np.ndarray
    p_uu: np.ndarray | None = None
    p_uv: np.ndarray | None = None
    p_vv: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class BezierPatch:
    """Immutable tensor-product Bézier patch ``p: [0, 1]^2 -> R^D``.

    Attributes:
        control_points: Control net ``b_ij``, shape ``(M+1, N+1, D)`` with the first
            index along ``u``; float64, read-only.  Units: mm for geometric patches
            (``D = 3``); arbitrary for scalar Bernstein polynomials (``D = 1``).

    Equality and hashing compare the control nets exactly.
    """

    control_points: np.ndarray

    def __post_init__(self) -> None:
        raw = self.control_points
        try:
            net = np.array(raw, dtype=np.float64, copy=True)
        except (TypeError, ValueError) as exc:
            raise InvalidGeometry(
                "control_points must be a numeric array of shape (M+1, N+1, D) with "
                f"M, N >= 0 and D >= 1; could not convert {type(raw).__name__}: {exc}"
            ) from exc
        if net.ndim != 3 or min(net.shape, default=0) < 1:
            raise InvalidGeometry(
                "control_points must have shape (M+1, N+1, D) with M, N >= 0 and D >= 1 "
                f"(D = 3 for a geometric patch); got shape {net.shape}"
            )
        if not np.all(np.isfinite(net)):
            bad = tuple(int(x) for x in np.argwhere(~np.isfinite(net))[0])
            raise InvalidGeometry(
                f"control_points must be finite; got {net[bad]} at index {bad} of an "
                f"array of shape {net.shape}"
            )
        net.setflags(write=False)
        object.__setattr__(self, "control_points", net)

    # -- basic properties ---------------------------------------------------------
    @property
    def degree(self) -> tuple[int, int]:
        """Degrees ``(M, N)`` in ``u`` and ``v``."""
        return self.control_points.shape[0] - 1, self.control_points.shape[1] - 1

    @property
    def dim(self) -> int:
        """Dimension ``D`` of the control points."""
        return self.control_points.shape[2]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, BezierPatch):
            return NotImplemented
        return bool(np.array_equal(self.control_points, other.control_points))

    def __hash__(self) -> int:
        return hash((self.control_points.shape, self.control_points.tobytes()))

    # -- evaluation ---------------------------------------------------------------
    def _eval(self, u: np.ndarray, v: np.ndarray, du: int, dv: int, bases: dict | None = None) -> np.ndarray:
        """``d^(du+dv) p / du^du dv^dv`` at ``(B,)`` parameters, shape ``(B, D)``.

        ``bases`` keeps the Bernstein bases already computed for these ``u, v`` (one
        :meth:`derivatives` call needs each of them several times)."""
        m, n = self.degree
        bases = {} if bases is None else bases
        if ("u", du) not in bases:
            bases["u", du] = bernstein_derivative(m, u, du)
        if ("v", dv) not in bases:
            bases["v", dv] = bernstein_derivative(n, v, dv)
        return np.einsum("bi,bj,ijd->bd", bases["u", du], bases["v", dv], self.control_points)

    def evaluate(self, u, v) -> np.ndarray:
        """Points ``p(u, v)``.

        Args:
            u: Parameters, shape ``(B,)`` or scalar; values outside ``[0, 1]`` give the
                polynomial extension.
            v: Parameters, shape ``(B,)`` or scalar (broadcast against ``u``).

        Returns:
            Points, shape ``(B, D)`` (``(1, D)`` for scalars), units of the control points.
        """
        u, v = _as_params(u, v)
        return self._eval(u, v, 0, 0)

    def partial_u(self, u, v) -> np.ndarray:
        """Partial derivative ``p_u``; arguments as :meth:`evaluate`, result ``(B, D)``."""
        u, v = _as_params(u, v)
        return self._eval(u, v, 1, 0)

    def partial_v(self, u, v) -> np.ndarray:
        """Partial derivative ``p_v``; arguments as :meth:`evaluate`, result ``(B, D)``."""
        u, v = _as_params(u, v)
        return self._eval(u, v, 0, 1)

    def derivatives(self, u, v, order: int = 2) -> PatchDerivatives:
        """Point and partial derivatives up to ``order`` (1 or 2).

        Args:
            u: Parameters, shape ``(B,)`` or scalar.
            v: Parameters, shape ``(B,)`` or scalar (broadcast against ``u``).
            order: 1 for ``p, p_u, p_v``; 2 adds ``p_uu, p_uv, p_vv``.

        Returns:
            :class:`PatchDerivatives` whose fields have shape ``(B, D)``.
        """
        if order not in (1, 2):
            raise InvalidGeometry(f"derivative order must be 1 or 2, got {order!r}")
        u, v = _as_params(u, v)
        b: dict = {}
        first = {"p": self._eval(u, v, 0, 0, b), "p_u": self._eval(u, v, 1, 0, b), "p_v": self._eval(u, v, 0, 1, b)}
        if order == 1:
            return PatchDerivatives(**first)
        return PatchDerivatives(
            **first,
            p_uu=self._eval(u, v, 2, 0, b),
            p_uv=self._eval(u, v, 1, 1, b),
            p_vv=self._eval(u, v, 0, 2, b),
        )

    # -- derived patches ----------------------------------------------------------
    def _require_3d(self, what: str) -> None:
        if self.dim != 3:
            raise InvalidGeometry(f"{what} needs a patch with 3-D control points (D = 3); got D = {self.dim}")

    def normal_patch(self) -> BezierPatch:
        """The exact normal patch ``n = p_u x p_v`` (eq. 19).

        Returns:
            Bézier patch of degree ``(2M-1, 2N-1)``, ``D = 3``, control points in mm^2.

        Raises:
            InvalidGeometry: If ``D != 3``.
            DegeneratePatch: If ``M == 0`` or ``N == 0`` (the normal is identically zero).
        """
        self._require_3d("normal_patch")
        m, n = self.degree
        if m == 0 or n == 0:
            raise DegeneratePatch(
                f"Bézier patch of degree (M, N) = ({m}, {n}) is constant along "
                f"{'u' if m == 0 else 'v'}, so its normal p_u x p_v is identically zero; "
                "a contact region needs degree >= 1 in both u and v"
            )
        net = self.control_points
        d_u = m * (net[1:] - net[:-1])
        d_v = n * (net[:, 1:] - net[:, :-1])
        return BezierPatch(cross_nets(d_u, d_v))

    def subdivide(self, u0: float, u1: float, v0: float, v1: float) -> BezierPatch:
        """The patch restricted to ``[u0, u1] x [v0, v1]``, re-parameterised to ``[0, 1]^2``.

        ``sub.evaluate(s, t) == self.evaluate(u0 + s (u1 - u0), v0 + t (v1 - v0))``
        exactly (up to rounding), for any finite reals (``u0 > u1`` reverses ``u``).

        Args:
            u0: Start of the ``u`` interval (unitless).
            u1: End of the ``u`` interval.
            v0: Start of the ``v`` interval.
            v1: End of the ``v`` interval.

        Returns:
            Patch of the same degree and dimension.
        """
        box = np.array([[u0, u1, v0, v1]], dtype=np.float64)
        if not np.all(np.isfinite(box)):
            raise InvalidGeometry(f"subdivision bounds must be finite, got {box[0].tolist()}")
        return BezierPatch(subdivide_nets(self.control_points, box)[0])

    def transformed(self, R: np.ndarray, t: np.ndarray) -> BezierPatch:
        """The patch mapped by ``x -> R x + t`` (exact: affine maps act on control points).

        Args:
            R: Matrix, shape ``(3, 3)`` (normally a rotation; the normal then rotates too).
            t: Translation, shape ``(3,)``, mm.

        Returns:
            Transformed patch, same degree.
        """
        self._require_3d("transformed")
        R = np.asarray(R, dtype=np.float64)
        t = np.asarray(t, dtype=np.float64)
        if R.shape != (3, 3) or t.shape != (3,):
            raise InvalidGeometry(
                f"transformed needs R of shape (3, 3) and t of shape (3,); got {R.shape} and {t.shape}"
            )
        if not (np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
            raise InvalidGeometry("transformed needs finite R and t")
        return BezierPatch(self.control_points @ R.T + t)

    def reversed_orientation(self) -> BezierPatch:
        """Swap ``u`` and ``v`` (transpose the control net); the normal flips sign.

        Returns:
            Patch ``q(u, v) = p(v, u)`` of degree ``(N, M)``.
        """
        return BezierPatch(np.swapaxes(self.control_points, 0, 1))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned box containing ``p([0, 1]^2)`` (box of the control points).

        Returns:
            ``(lo, hi)``, each of shape ``(D,)``, units of the control points.
        """
        flat = self.control_points.reshape(-1, self.dim)
        return flat.min(axis=0), flat.max(axis=0)

    # -- regularity ---------------------------------------------------------------
    def check_nondegenerate(self, max_depth: int = 8) -> None:
        """Certify that ``p_u x p_v`` does not vanish on ``[0, 1]^2``.

        Recursively subdivides ``[0, 1]^2``; a box is certified when a unit vector
        ``w`` (the normalised normal at the box centre, else the normalised mean of the
        normalised control normals) has ``w . c > margin`` for every control point
        ``c`` of the normal patch on that box, where the margin dominates
        floating-point rounding.  Sampled normals (box corners and centres) with
        norm ``<= 1e-12 * scale^2`` (``scale`` = diagonal of :meth:`bounds`) are
        rejected immediately.

        Args:
            max_depth: Maximum number of subdivision levels (``>= 0``).

        Raises:
            DegeneratePatch: If the normal vanishes (or is ``<= 1e-12 scale^2``) at a
                sample, if a direction has degree 0, or if some box is still not
                certified after ``max_depth`` levels.
            InvalidGeometry: If ``D != 3`` or ``max_depth`` is invalid.
        """
        depth_limit = check_degree(max_depth, "max_depth")
        normal = self.normal_patch()
        lo, hi = self.bounds()
        certify_normal(normal, float(np.linalg.norm(hi - lo)), depth_limit)

    @classmethod
    def bilinear(cls, P00, P01, P10, P11) -> BezierPatch:
        """Degree-(1, 1) patch with ``control_points[i, j] = P_ij`` (first index ``u``).

        Args:
            P00: Corner ``p(0, 0)``, shape ``(D,)``.
            P01: Corner ``p(0, 1)``, shape ``(D,)``.
            P10: Corner ``p(1, 0)``, shape ``(D,)``.
            P11: Corner ``p(1, 1)``, shape ``(D,)``.

        Returns:
            The bilinear patch ``p = P00 + u (P10 - P00) + v (P01 - P00)
            + u v (P00 - P01 - P10 + P11)``.
        """
        corners = [np.asarray(c, dtype=np.float64) for c in (P00, P01, P10, P11)]
        shapes = {c.shape for c in corners}
        if len(shapes) != 1 or corners[0].ndim != 1:
            raise InvalidGeometry(
                "bilinear needs four corners of the same shape (D,); got shapes "
                f"{[c.shape for c in corners]}"
            )
        return cls(np.array([[corners[0], corners[1]], [corners[2], corners[3]]]))


def ensure_regular(patch: BezierPatch, max_depth: int = 8) -> BezierPatch:
    """Return ``patch`` after :meth:`BezierPatch.check_nondegenerate` succeeds.

    Args:
        patch: A 3-D Bézier patch.
        max_depth: Passed to :meth:`BezierPatch.check_nondegenerate`.

    Returns:
        The same patch object.

    Raises:
        DegeneratePatch: If the patch's normal may vanish on ``[0, 1]^2``.
    """
    patch.check_nondegenerate(max_depth=max_depth)
    return patch
