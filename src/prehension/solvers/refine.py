"""Local refinement of a configuration on the original constraints (bounded least squares).

Both solvers end here: the complete solver refines a point read from a box, and any
configuration that comes out is judged by :func:`prehension.results.make_solution`
(the residual function), never by this module.

Unknowns: the independent moving joint angles (coupled ones follow exactly), the object
pose as a rotation vector and a translation applied to the starting pose, and the region
parameters of every contact, all inside their bounds.  Residuals: per contact the hand
point minus the object point [mm] and ``w (n_hand + n_object)`` (w = 10 mm), plus soft
penalties that push sphere-cap normals into their cones and capsules apart.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..geometry.regions import SphereCap
from ..hands.collision import capsule_clearances
from ..hands.kinematics import forward_kinematics
from ..tasks.model import Configuration, Task
from ..tasks.residuals import contact_residuals

__all__ = ["RefineOptions", "refine"]

NORMAL_WEIGHT_MM = 10.0


@dataclass(frozen=True)
class RefineOptions:
    """Limits of one refinement."""

    max_evaluations: int = 400
    collision_margin_mm: float = 0.2  # penalise clearances below this
    tolerance: float = 1e-15


class _Problem:
    """The packed unknowns of one refinement and their residual function."""

    def __init__(self, task: Task, start: Configuration, movable: np.ndarray, options: RefineOptions):
        hand = task.hand
        coupled = {c.dof for c in hand.couplings}
        self.task, self.start, self.options = task, start, options
        self.free = [i for i, d in enumerate(hand.dof_names) if movable[i] and d not in coupled]
        self.regions = [(task.hand_region(c).region, task.object_region(c)) for c in task.contacts]
        self.sizes = [(h.n_params, o.n_params) for h, o in self.regions]

    def x0(self) -> np.ndarray:
        parts = [self.start.joint_angles[self.free], np.zeros(6)]
        for hp, op in self.start.contact_params:
            parts += [hp, op]
        return np.concatenate(parts)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        hand = self.task.hand
        lo = [hand.lower[self.free], np.full(6, -np.inf)]
        hi = [hand.upper[self.free], np.full(6, np.inf)]
        for h, o in self.regions:
            for region in (h, o):
                a, b = region.param_bounds()
                lo.append(a)
                hi.append(b)
        lo, hi = np.concatenate(lo), np.concatenate(hi)
        return lo, np.maximum(hi, lo + 1e-12)

    def unpack(self, x: np.ndarray) -> Configuration:
        hand = self.task.hand
        q = self.start.joint_angles.copy()
        q[self.free] = x[: len(self.free)]
        for c in hand.couplings:
            q[hand.dof_index(c.dof)] = c.ratio * q[hand.dof_index(c.source)] + c.offset
        k = len(self.free)
        T = self.start.T_palm_object.copy()
        T[:3, :3] = Rotation.from_rotvec(x[k : k + 3]).as_matrix() @ T[:3, :3]
        T[:3, 3] = T[:3, 3] + x[k + 3 : k + 6]
        k += 6
        params = []
        for kh, ko in self.sizes:
            params.append((x[k : k + kh].copy(), x[k + kh : k + kh + ko].copy()))
            k += kh + ko
        return Configuration(q, T, tuple(params))

    def residual(self, x: np.ndarray) -> np.ndarray:
        cfg = self.unpack(x)
        pose = forward_kinematics(self.task.hand, cfg.joint_angles)
        batch = [(h[None], o[None]) for h, o in cfg.contact_params]
        res = contact_residuals(self.task, pose, cfg.T_palm_object[None], batch)
        parts = [
            (res["hand_point"] - res["object_point"]).ravel(),
            NORMAL_WEIGHT_MM * (res["hand_normal"] + res["object_normal"]).ravel(),
            self._cone_penalty(cfg),
        ]
        clearance, _ = capsule_clearances(self.task.hand, pose)
        parts.append(np.maximum(self.options.collision_margin_mm - clearance[0], 0.0))
        return np.concatenate(parts)

    def _cone_penalty(self, cfg: Configuration) -> np.ndarray:
        out = []
        for (h, o), (hp, op) in zip(self.regions, cfg.contact_params):
            for region, p in ((h, hp), (o, op)):
                if isinstance(region, SphereCap):
                    n = region.normals(p[None])[0]
                    out.append(NORMAL_WEIGHT_MM * max(0.0, np.cos(region.half_angle) - float(n @ region.axis)))
        return np.array(out)


def refine(task: Task, start: Configuration, movable=None, options: RefineOptions = RefineOptions()) -> Configuration:
    """Bounded least squares from ``start`` (which must carry contact parameters).

    ``movable`` (n_dof,) bool selects the joint angles that may change (default: the
    task's active ones).  Returns the refined configuration, whatever its quality.
    """
    movable = task.active_mask if movable is None else np.asarray(movable, dtype=bool)
    problem = _Problem(task, start, movable, options)
    lo, hi = problem.bounds()
    x0 = np.clip(problem.x0(), lo, hi)
    tol = options.tolerance
    sol = least_squares(
        problem.residual, x0, bounds=(lo, hi), xtol=tol, ftol=tol, gtol=tol, max_nfev=options.max_evaluations
    )
    return problem.unpack(sol.x)
