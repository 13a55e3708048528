"""Options of the grasp quality measures: the friction model and the torque scale."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import PrehensionError

__all__ = ["QualityOptions", "DEFAULT_FRICTION"]

DEFAULT_FRICTION = 0.6  # the sliding friction of the physics test (DexGraspBench), so both agree


@dataclass(frozen=True)
class QualityOptions:
    """How contacts are modelled when the quality of a grasp is measured.

    Attributes:
        friction: Coulomb friction coefficient ``mu`` (unitless, >= 0; 0: frictionless).
        cone_edges: edges of the pyramid that linearises each friction cone (>= 3).  The
            pyramid is inscribed in the cone, so the measures never overstate the grasp.
        torsion_mm: soft-finger torsional friction ``gamma`` [mm]: a contact can also
            resist a moment about its normal of up to ``gamma`` times its normal force
            (0: hard fingers, point contacts with friction).  Two-finger pinches need it
            to resist a moment about the line through the contacts.
        radius_mm: the object radius ``rho`` that scales torques into forces
            (``w = (f, tau / rho)``) [mm]; ``None``: the object's own radius, the largest
            distance from its centre to its surface (:func:`prehension.quality.object_reference`).
        center_mm: the point (object frame) [mm] torques are taken about; ``None``: the
            object's centre of volume (where the physics test applies its forces).
    """

    friction: float = DEFAULT_FRICTION
    cone_edges: int = 8
    torsion_mm: float = 0.0
    radius_mm: float | None = None
    center_mm: tuple[float, float, float] | None = None

    def __post_init__(self):
        def need(ok: bool, message: str) -> None:
            if not ok:
                raise PrehensionError(f"quality options: {message}")

        need(_finite(self.friction) and self.friction >= 0, f"friction must be a number >= 0, got {self.friction!r}")
        need(isinstance(self.cone_edges, (int, np.integer)) and not isinstance(self.cone_edges, bool)
             and self.cone_edges >= 3, f"cone_edges must be an integer >= 3, got {self.cone_edges!r}")  # fmt: skip
        need(_finite(self.torsion_mm) and self.torsion_mm >= 0, f"torsion_mm must be a number of mm >= 0, got {self.torsion_mm!r}")
        need(self.radius_mm is None or (_finite(self.radius_mm) and self.radius_mm > 0),
             f"radius_mm must be a positive number of mm (or None: the object's radius), got {self.radius_mm!r}")  # fmt: skip
        if self.center_mm is not None:
            c = np.asarray(self.center_mm, dtype=float) if _numeric(self.center_mm) else np.zeros(0)
            need(c.shape == (3,) and bool(np.all(np.isfinite(c))),
                 f"center_mm must be three finite numbers [mm] (or None: the object's centre), got {self.center_mm!r}")  # fmt: skip
            object.__setattr__(self, "center_mm", tuple(float(x) for x in c))
        object.__setattr__(self, "friction", float(self.friction))
        object.__setattr__(self, "cone_edges", int(self.cone_edges))
        object.__setattr__(self, "torsion_mm", float(self.torsion_mm))

    def to_dict(self) -> dict:
        """Plain values, as stored in a result file."""
        out = asdict(self)
        out["center_mm"] = None if self.center_mm is None else list(self.center_mm)
        return out

    @classmethod
    def from_dict(cls, data) -> "QualityOptions":
        """The options stored by :meth:`to_dict`; a :class:`PrehensionError` names a bad entry."""
        if not isinstance(data, dict):
            raise PrehensionError(f"quality options must be a mapping, got {type(data).__name__}")
        known = {"friction", "cone_edges", "torsion_mm", "radius_mm", "center_mm"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise PrehensionError(f"quality options: unknown {unknown}; known: {sorted(known)}")
        return cls(**data)


def _finite(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool) and bool(np.isfinite(x))


def _numeric(x) -> bool:
    try:
        np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        return False
    return True
