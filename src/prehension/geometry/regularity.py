r"""The regularity certificate of a Bézier patch: its normal :math:`p_u \times p_v` does
not vanish on :math:`[0, 1]^2`.

By the convex-hull property, if some unit vector :math:`w` satisfies :math:`w \cdot c > 0`
for every control point :math:`c` of the normal patch restricted to a box, the normal
cannot vanish on that box.  :func:`certify_normal` covers :math:`[0, 1]^2` with such
boxes by recursive subdivision (:meth:`~prehension.geometry.bezier.BezierPatch.check_nondegenerate`).
"""

from __future__ import annotations

import numpy as np

from prehension.errors import DegeneratePatch

from .bernstein import subdivide_nets

__all__ = ["certify_normal", "REGULARITY_ADVICE"]

_EPS = np.finfo(np.float64).eps
REGULARITY_ADVICE = (
    "a contact region needs a regular patch (its corners must not coincide and its "
    "control net must not fold)"
)


def certify_normal(normal, diagonal: float, depth_limit: int) -> None:
    """Certify that the normal patch ``normal`` (a 3-D :class:`~prehension.geometry.bezier.BezierPatch`,
    ``p_u x p_v`` of a patch whose bounding box has diagonal ``diagonal`` [mm]) does not
    vanish on ``[0, 1]^2``, subdividing at most ``depth_limit`` levels.

    Raises:
        DegeneratePatch: the normal is tiny at a sample, or a box is still uncertified.
    """
    tiny = 1e-12 * diagonal**2
    net = normal.control_points
    margin = tiny + 256.0 * _EPS * float(np.max(np.linalg.norm(net, axis=-1)))
    boxes = np.array([[0.0, 1.0, 0.0, 1.0]])
    for depth in range(depth_limit + 1):
        centres = _reject_vanishing_samples(normal, boxes, tiny)
        boxes = boxes[~_certified_boxes(net, boxes, centres, margin)]
        if len(boxes) == 0:
            return
        if depth < depth_limit:
            boxes = _split_boxes(boxes)
    _raise_uncertified(normal, boxes, depth_limit)


_SAMPLE_OFFSETS = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, 0.5]])


def _reject_vanishing_samples(normal, boxes: np.ndarray, tiny: float) -> np.ndarray:
    """Raise if the normal is tiny at a box corner or centre.

    Args:
        normal: Normal patch, ``D = 3``.
        boxes: Boxes ``(u0, u1, v0, v1)``, shape ``(K, 4)``.
        tiny: Threshold on ``|n|``, mm^2.

    Returns:
        Normals at the box centres, shape ``(K, 3)``.
    """
    u = boxes[:, None, 0] + _SAMPLE_OFFSETS[None, :, 0] * (boxes[:, None, 1] - boxes[:, None, 0])
    v = boxes[:, None, 2] + _SAMPLE_OFFSETS[None, :, 1] * (boxes[:, None, 3] - boxes[:, None, 2])
    values = normal.evaluate(u.ravel(), v.ravel()).reshape(len(boxes), len(_SAMPLE_OFFSETS), 3)
    norms = np.linalg.norm(values, axis=-1)
    bad = np.argwhere(norms <= tiny)
    if len(bad):
        k, s = bad[0]
        raise DegeneratePatch(
            f"Bézier patch normal p_u x p_v vanishes near (u, v) = ({u[k, s]:.2f}, {v[k, s]:.2f}); "
            + REGULARITY_ADVICE
        )
    return values[:, -1]


def _certified_boxes(net: np.ndarray, boxes: np.ndarray, centres: np.ndarray, margin: float) -> np.ndarray:
    """Convex-hull test of the normal on each box.

    Args:
        net: Normal-patch control net, shape ``(2M, 2N, 3)``, mm^2.
        boxes: Boxes, shape ``(K, 4)``.
        centres: Normals at the box centres, shape ``(K, 3)``, mm^2.
        margin: Required positive margin of ``w . c``, mm^2.

    Returns:
        Boolean mask, shape ``(K,)``: True where the box is certified.
    """
    sub = subdivide_nets(net, boxes).reshape(len(boxes), -1, 3)
    w_centre = _unit(centres)
    ok = np.all(np.einsum("kpd,kd->kp", sub, w_centre) > margin, axis=1)
    w_mean = _unit(_unit(sub).mean(axis=1))
    ok |= np.all(np.einsum("kpd,kd->kp", sub, w_mean) > margin, axis=1)
    return ok


def _split_boxes(boxes: np.ndarray) -> np.ndarray:
    """Split each box into four at its midpoint: ``(K, 4) -> (4K, 4)``."""
    um = 0.5 * (boxes[:, 0] + boxes[:, 1])
    vm = 0.5 * (boxes[:, 2] + boxes[:, 3])
    u0, u1, v0, v1 = boxes.T
    quads = [
        np.stack([u0, um, v0, vm], axis=1),
        np.stack([um, u1, v0, vm], axis=1),
        np.stack([u0, um, vm, v1], axis=1),
        np.stack([um, u1, vm, v1], axis=1),
    ]
    return np.concatenate(quads, axis=0)


def _raise_uncertified(normal, boxes: np.ndarray, depth: int) -> None:
    """Raise :class:`DegeneratePatch` naming the uncertified box with the smallest normal."""
    uc = 0.5 * (boxes[:, 0] + boxes[:, 1])
    vc = 0.5 * (boxes[:, 2] + boxes[:, 3])
    norms = np.linalg.norm(normal.evaluate(uc, vc), axis=-1)
    k = int(np.argmin(norms))
    raise DegeneratePatch(
        "Bézier patch normal p_u x p_v could not be shown to be non-zero on [0, 1]^2 "
        f"after {depth} subdivision levels ({len(boxes)} boxes left; smallest sampled "
        f"|p_u x p_v| = {norms[k]:.3g} near (u, v) = ({uc[k]:.2f}, {vc[k]:.2f})); "
        + REGULARITY_ADVICE
    )


def _unit(x: np.ndarray) -> np.ndarray:
    """Normalise the last axis; zero vectors stay zero.  Shape preserved."""
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    return np.divide(x, norm, out=np.zeros_like(x), where=norm > 0)
