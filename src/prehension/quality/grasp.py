"""The quality of a grasp: force closure, epsilon and volume of its contacts' wrench set.

:func:`grasp_quality` measures a solution (anything with ``T_palm_object`` and
``contacts`` carrying palm-frame ``object_point`` and outward ``object_normal``, such as a
:class:`~prehension.results.Solution`).  The contacts are taken where the object is
touched, in the object frame, pushing into it; torques are taken about the object's
centre and scaled by its radius (:func:`~prehension.quality.solid.object_reference`)
unless :class:`~prehension.quality.options.QualityOptions` states them.

**Measured once per distinct grasp.**  The measures are a pure function of the contacts'
object-frame points and normals, the centre, the radius and the options; each process
keeps the last :data:`MEMO_SIZE` of them keyed by the exact bytes of those inputs, so a
grasp met again (a batch solving one task many times, ``prehension check`` after
``solve``) is not measured again, and gets bit for bit the same values.  Any other
grasp -- one bit apart -- is measured afresh.  The object's own centre and radius (the
default options) are computed once per object.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import PrehensionError
from ..frozen import cached_per_value
from ..tasks.model import Task
from .measures import force_closure, hull_measures
from .options import QualityOptions
from .solid import object_center, object_reference
from .wrenches import primitive_wrenches

__all__ = ["GraspQuality", "grasp_quality", "contacts_quality", "configuration_quality", "contact_quality", "torque_reference", "QUALITY_KEYS"]

MEMO_SIZE = 4096  # distinct grasps whose measures a process keeps (a few hundred bytes each)
QUALITY_KEYS = ("force_closure", "epsilon", "volume", "closure_margin", "center_mm", "radius_mm", "options")


@dataclass(frozen=True)
class GraspQuality:
    """How well a grasp holds its object.

    Attributes:
        force_closure: the contacts can resist every external wrench (the LP of
            :mod:`.measures`).
        epsilon: Ferrari-Canny Q1: the radius of the largest ball about the origin in the
            convex hull of the primitive wrenches (unitless: wrench per unit total normal
            force, torques divided by ``radius_mm``); 0 unless force closure.
        volume: 6-D volume of that hull (unitless).
        closure_margin: the LP's ``t*`` (0 unless force closure).
        center_mm: (3,) the point torques were taken about, object frame [mm].
        radius_mm: the torque scale [mm].
        options: the friction model (as given: ``radius_mm``/``center_mm`` ``None`` when
            they came from the object).
    """

    force_closure: bool
    epsilon: float
    volume: float
    closure_margin: float
    center_mm: tuple[float, float, float]
    radius_mm: float
    options: QualityOptions

    def to_dict(self) -> dict:
        """Plain values, as stored under ``"quality"`` in a result file."""
        return {
            "force_closure": self.force_closure, "epsilon": self.epsilon, "volume": self.volume,
            "closure_margin": self.closure_margin, "center_mm": list(self.center_mm), "radius_mm": self.radius_mm,
            "options": self.options.to_dict(),
        }  # fmt: skip

    def describe(self) -> str:
        """One line for people."""
        verdict = "force closure" if self.force_closure else "NOT force closure"
        o = self.options
        soft = f", torsion {o.torsion_mm:g} mm" if o.torsion_mm else ""
        return (f"{verdict}: epsilon {self.epsilon:.4g}, volume {self.volume:.3g} "
                f"(mu {o.friction:g}, {o.cone_edges} cone edges{soft}, torque radius {self.radius_mm:.4g} mm)")  # fmt: skip


def contact_quality(points_mm, inward_normals, center_mm, radius_mm: float, options: QualityOptions = QualityOptions()) -> GraspQuality:
    """The quality of contacts at ``points_mm (C, 3)`` pushing along ``inward_normals (C, 3)``
    (object frame), torques about ``center_mm (3,)`` scaled by ``radius_mm``."""
    def exact(x) -> bytes:
        return np.ascontiguousarray(x, dtype=float).tobytes()

    return _measured(exact(points_mm), exact(inward_normals), exact(center_mm), float(radius_mm), options)


def clear_memo() -> None:
    """Forget every grasp measured so far (benchmarks timing the measures; nothing else needs it)."""
    _measured.cache_clear()


@lru_cache(maxsize=MEMO_SIZE)
def _measured(points: bytes, inward: bytes, center: bytes, radius_mm: float, options: QualityOptions) -> GraspQuality:
    """:func:`contact_quality` of float64 inputs given by their bytes (the memo's key)."""
    p, n, c = (np.frombuffer(b, dtype=float) for b in (points, inward, center))
    W = primitive_wrenches(p.reshape(-1, 3), n.reshape(-1, 3), c, radius_mm, options).reshape(-1, 6)
    closure = force_closure(W)
    distance, volume = hull_measures(W)
    epsilon = max(distance, 0.0) if closure.force_closure else 0.0
    centre = tuple(float(x) for x in c)
    return GraspQuality(closure.force_closure, epsilon, volume, closure.margin, centre, radius_mm, options)


def grasp_quality(task: Task, solution, options: QualityOptions = QualityOptions()) -> GraspQuality:
    """The quality of ``solution`` (a grasp of ``task``'s object), see the module docstring."""
    return contacts_quality(task, solution.T_palm_object, solution.contacts, options)


def contacts_quality(task: Task, T_palm_object, contacts, options: QualityOptions = QualityOptions()) -> GraspQuality:
    """The quality of ``contacts`` (each with palm-frame ``object_point`` [mm] and outward
    ``object_normal``) made on ``task``'s object placed at ``T_palm_object (4, 4)``."""
    T = np.asarray(T_palm_object, dtype=float)
    R, t = T[:3, :3], T[:3, 3]
    if not contacts:
        raise PrehensionError("a grasp without contacts has no quality to measure")
    p_palm = np.array([c.object_point for c in contacts], dtype=float)  # (C, 3)
    n_palm = np.array([c.object_normal for c in contacts], dtype=float)
    p_obj = (p_palm - t) @ R  # R^T (p - t), row-wise
    inward = -(n_palm @ R)
    centre, radius = torque_reference(task, options)
    return contact_quality(p_obj, inward, centre, radius, options)


def configuration_quality(task: Task, config, options: QualityOptions = QualityOptions()) -> GraspQuality:
    """The quality of the contacts a configuration states (``config.contact_params``), read
    on the object's regions in the object frame: no kinematics, so cheap enough to rank
    thousands of candidates before verifying the few that are kept."""
    if config.contact_params is None:
        raise PrehensionError("configuration_quality needs the contact parameters of the configuration")
    points, inward = [], []
    for contact, (_, op) in zip(task.contacts, config.contact_params):
        p, n = task.object_region(contact).evaluate(np.asarray(op, dtype=float)[None])
        points.append(p[0])
        inward.append(-n[0])
    centre, radius = torque_reference(task, options)
    return contact_quality(np.array(points), np.array(inward), centre, radius, options)


def torque_reference(task: Task, options: QualityOptions = QualityOptions()) -> tuple[np.ndarray, float]:
    """The centre (3,) [mm, object frame] torques are taken about and the radius [mm] that
    scales them: as stated in ``options``, else the object's own."""
    if options.center_mm is None and options.radius_mm is None:
        centre, radius = _own_reference(task.object)
        return centre.copy(), radius
    centre = np.asarray(options.center_mm, float) if options.center_mm is not None else object_center(task.object)
    if options.radius_mm is not None:
        return centre, options.radius_mm
    return object_reference(task.object, centre)


@cached_per_value
def _own_reference(obj) -> tuple[np.ndarray, float]:
    """The object's own centre and radius (:func:`object_reference` about :func:`object_center`), once per object."""
    return object_reference(obj, object_center(obj))
