"""Quality inside the search: move a verified grasp along its solution set to a better one.

:func:`improve_grasp` takes a task and a verified solution and climbs the grasp measure
(the Ferrari-Canny epsilon, hard or soft fingers as :class:`~prehension.quality.QualityOptions`
says) while every constraint of the task keeps holding: the contacts slide within their
regions, the joint angles and the object pose follow.  Each step of the ascent

1. takes the gradient ``g`` of the smooth surrogate :func:`.surrogate.support_surrogate`
   in the object regions' parameters (forward differences);
2. projects it onto the tangent space of the solution set (scaled units, :mod:`.manifold`),

   .. math::

       d = N N^\\top g, \\qquad J N = 0,\\; N^\\top N = I,

   ``J`` the constraints' Jacobian, the unknowns that ``d`` would carry to a bound held;
3. moves by ``r d / |d|`` (``r`` the trust radius [mm], shortened at a bound) and returns
   onto the set by Levenberg-Marquardt steps (:meth:`.manifold.GraspChart.project`);
4. **verifies** the configuration reached with :func:`~prehension.results.make_solution`
   (the one residual function, strict tolerances: contacts, limits, couplings, self- and
   object collision) and measures its *exact* epsilon; the step is accepted only when the
   grasp is verified and its merit rises (epsilon; for a grasp that is not force closure,
   the signed distance from the origin to its wrench hull, negative), and ``r`` grows by
   half; otherwise it is rejected -- never returned -- and ``r`` is halved.

The ascent stops after ``steps`` steps, when ``r`` falls below ``min_radius_mm``, or at
the time limit.  It returns the best verified grasp met (the start when no step was
accepted).  See ``docs/quality.md``, "Quality inside the search".
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import PrehensionError
from ..quality import GraspQuality, QualityOptions, force_closure, grasp_quality, hull_facets, primitive_wrenches, torque_reference

from ..results import Solution, make_solution
from ..tasks.model import Task
from .manifold import GraspChart
from .surrogate import support_surrogate

__all__ = ["AscentOptions", "Improvement", "improve_grasp", "merit", "wrench_merit"]


@dataclass(frozen=True)
class AscentOptions:
    """Settings of :func:`improve_grasp`.

    Attributes:
        steps: ascent steps tried at most (accepted or not; >= 0).
        radius_mm: first trust radius, scaled units [mm] (> 0).
        min_radius_mm: the ascent stops when the radius falls below this [mm].
        max_radius_mm: the radius never grows beyond this [mm].
        temperature: the surrogate's ``tau`` as a fraction of the current merit's size (> 0).
        time_limit_s: stop after this long [s] (``None``: no limit).
    """

    steps: int = 20
    radius_mm: float = 8.0
    min_radius_mm: float = 0.25
    max_radius_mm: float = 40.0
    temperature: float = 0.1
    time_limit_s: float | None = None

    def __post_init__(self):
        if not (isinstance(self.steps, (int, np.integer)) and not isinstance(self.steps, bool) and self.steps >= 0):
            raise PrehensionError(f"ascent: steps must be an integer >= 0, got {self.steps!r}")
        for name in ("radius_mm", "min_radius_mm", "max_radius_mm", "temperature"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise PrehensionError(f"ascent: {name} must be a positive number, got {value!r}")
        if self.time_limit_s is not None and not self.time_limit_s > 0:
            raise PrehensionError(f"ascent: time_limit_s must be > 0 s (or None), got {self.time_limit_s!r}")


@dataclass(frozen=True, eq=False)
class Improvement:
    """What :func:`improve_grasp` reached.

    Attributes:
        solution: the best verified grasp met (``make_solution`` built it).
        quality: its quality.
        start: the quality of the grasp the ascent started from.
        accepted, tried: ascent steps accepted, and tried in all.
        seconds: wall time [s].
    """

    solution: Solution
    quality: GraspQuality
    start: GraspQuality
    accepted: int
    tried: int
    seconds: float


def merit(task: Task, solution, options: QualityOptions = QualityOptions()) -> float:
    """What the ascent raises: epsilon of a force-closure grasp (> 0); otherwise the signed
    distance from the origin to the nearest facet plane of the hull of its primitive
    wrenches (<= 0; 0 for a flat hull)."""
    return wrench_merit(_wrenches_of(task, solution, options))


def wrench_merit(W: np.ndarray) -> float:
    """:func:`merit` of primitive wrenches ``W (K, 6)`` (any contacts, not only a solution's)."""
    return _measured(W)[0]


def _measured(W: np.ndarray) -> tuple[float, np.ndarray | None]:
    """``(merit, outward unit facet normals (F, 6) or None)`` of primitive wrenches ``W (K, 6)``:
    one hull and one LP; the merit equals :func:`grasp_quality`'s epsilon for a force-closure
    grasp (the same hull of the same wrenches)."""
    facets = hull_facets(W)
    if facets is None:
        return 0.0, None
    normals, offsets = facets
    distance = float(np.min(-offsets))
    return (max(distance, 0.0) if force_closure(W).force_closure else min(distance, 0.0)), normals


def _wrenches_of(task: Task, solution, options: QualityOptions) -> np.ndarray:
    """The primitive wrenches ``(K, 6)`` of a solution's contacts (as :func:`grasp_quality` takes them)."""
    R, t = solution.T_palm_object[:3, :3], solution.T_palm_object[:3, 3]
    p = (np.array([c.object_point for c in solution.contacts]) - t) @ R
    n = -(np.array([c.object_normal for c in solution.contacts]) @ R)
    centre, radius = torque_reference(task, options)
    return primitive_wrenches(p, n, centre, radius, options).reshape(-1, 6)


def improve_grasp(task: Task, solution: Solution, quality: QualityOptions = QualityOptions(),
                  options: AscentOptions = AscentOptions()) -> Improvement:  # fmt: skip
    """Climb ``quality``'s epsilon from ``solution`` along ``task``'s solution set (module docstring)."""
    started = time.perf_counter()
    deadline = None if options.time_limit_s is None else started + options.time_limit_s
    centre, rho = torque_reference(task, quality)
    chart, z = GraspChart.at(task, solution.configuration(), rho)
    T = solution.T_palm_object.copy()
    best = solution
    value, normals = _measured(_wrenches_of(task, solution, quality))
    radius, accepted, tried = options.radius_mm, 0, 0
    while normals is not None and tried < options.steps and radius >= options.min_radius_mm:
        if deadline is not None and time.perf_counter() > deadline:
            break
        tau = options.temperature * max(abs(value), 1e-3)
        _, J = chart.jacobian(z, T)
        d = chart.tangent(z, J, _gradient(chart, z, centre, rho, quality, normals, tau), radius)
        if not np.any(d):
            break
        tried += 1
        z1, T1, converged = chart.project(*chart.step(z, T, d), J)
        found = make_solution(task, chart.configuration(z1, T1)) if converged else None
        if found is not None:
            v1, n1 = _measured(_wrenches_of(task, found, quality))
            if v1 > value + 1e-12 * max(abs(value), 1.0) and n1 is not None:
                best, value, normals, z, T = found, v1, n1, z1, T1
                accepted += 1
                radius = min(1.5 * radius, options.max_radius_mm)
                continue
        radius *= 0.5
    start_quality = grasp_quality(task, solution, quality)
    return Improvement(best, grasp_quality(task, best, quality), start_quality, accepted, tried, time.perf_counter() - started)


def _gradient(chart: GraspChart, z: np.ndarray, centre, rho: float, quality: QualityOptions, normals: np.ndarray,
              tau: float) -> np.ndarray:  # fmt: skip
    """``d S_tau / d z`` (nz + 6,) with the hull's facet ``normals (F, 6)``: forward
    differences in the object parameters (0 elsewhere)."""
    slices = chart.object_slices()
    task = chart.task
    cols = np.concatenate([np.arange(s.start, s.stop) for s in slices]).astype(np.intp)
    h = 1e-6 / chart.scale[cols]
    Z = np.repeat(z[None], cols.size + 1, axis=0)
    Z[np.arange(1, cols.size + 1), cols] += h
    points, inward = [], []
    for contact, s in zip(task.contacts, slices):
        p, n = task.object_region(contact).evaluate(Z[:, s])
        points.append(p)
        inward.append(-n)
    S = support_surrogate(np.stack(points, axis=1), np.stack(inward, axis=1), centre, rho, quality, normals, tau)  # (B,)
    gradient = np.zeros(chart.nz + 6)
    gradient[cols] = (S[1:] - S[0]) / h
    return gradient
