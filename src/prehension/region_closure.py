"""Can any choice of contact points in the object regions be force closure?  (``solve --hold``)

Force closure depends on the contacts' object points and normals alone (their primitive
wrenches, :mod:`prehension.quality.wrenches`), not on the hand.  So when *no* choice of
one point in each object region is force closure, no grasp of the task is -- whatever the
hand can reach -- and the proof needs no kinematics: a branch-and-prune over the object
regions' parameters only (two per region: a Bézier patch's ``(s, t)``, a cap's normal
when it has no patch parameters), a box of ``2C`` dimensions instead of the complete
solver's hundreds.

Each box ``B`` of the object parameters (every other variable of the task's system kept
at its initial box) is

* **pruned** when the complete solver's force-closure certificate holds for it
  (:func:`prehension.solvers.complete.closure.closure_prune`: a direction ``w`` with
  ``w . wrench <= -1e-6`` for every primitive wrench of every contact point and normal
  that the box's enclosures hold -- sound by interval arithmetic, so a box holding a
  force-closure choice of points is never pruned);
* a **witness** when the contact points at its centre are force closure (the LP of
  :func:`prehension.quality.force_closure`): the regions admit force-closure points and
  the search stops (the hand may still not reach them: the complete solver decides);
* otherwise split in two across its widest parameter (widths measured relative to the
  region's initial range, weighted by how far the region's point and normal enclosures
  extend [mm]), depth first.

Every box pruned: **proven** -- no choice of contact points in the regions is force
closure with that friction model, so no grasp of the task is.  The search also stops
(undecided) at its time limit, at ``max_boxes`` boxes, or at a box narrower than
``MIN_WIDTH`` of its ranges that is neither pruned nor a witness (a choice of points on
the frontier of force closure).  The search is deterministic: ``prehension check``
re-derives a stored proof by running it again (:func:`regions_closure`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .quality import QualityOptions, force_closure, primitive_wrenches, torque_reference
from .solvers.complete.closure import closure_prune, contact_enclosures
from .system.formulation import build_system
from .system.regions import form_of
from .tasks.model import Task

__all__ = ["RegionClosure", "regions_closure", "MIN_WIDTH", "MAX_BOXES"]

MIN_WIDTH = 1e-6  # a box this narrow (relative to each parameter's range) that is neither pruned nor a witness: undecided
MAX_BOXES = 200_000  # boxes examined at most


@dataclass(frozen=True)
class RegionClosure:
    """What :func:`regions_closure` found.

    Attributes:
        status: ``"infeasible"`` (proven: no choice of contact points in the regions is
            force closure), ``"witness"`` (one is: ``witness``) or ``"gave_up"``.
        boxes: boxes examined; pruned: of them, pruned by a certificate.
        seconds: wall time [s].
        witness: per contact, the object region's parameters of the force-closure points
            found (``None`` unless ``status == "witness"``).
        message: one line saying so.
    """

    status: str
    boxes: int
    pruned: int
    seconds: float
    witness: tuple | None
    message: str

    def to_dict(self) -> dict:
        return {"status": self.status, "boxes": self.boxes, "pruned": self.pruned, "seconds": round(self.seconds, 3),
                "message": self.message}  # fmt: skip


def regions_closure(task: Task, quality: QualityOptions, time_limit_s: float | None = 10.0,
                    max_boxes: int = MAX_BOXES) -> RegionClosure:  # fmt: skip
    """The branch-and-prune of the module docstring over ``task``'s object regions, force
    closure meaning ``quality``'s friction model; ``time_limit_s`` (``None``: none)."""
    started = time.perf_counter()
    form = build_system(task)
    lower, upper = form.system.lower.copy(), form.system.upper.copy()
    split, weight = _split_variables(form, lower, upper, quality)
    span = np.maximum(upper[split] - lower[split], 1e-300)
    centre, rho = torque_reference(task, quality)
    stack, boxes, pruned = [(lower, upper)], 0, 0
    while stack:
        if (time_limit_s is not None and time.perf_counter() - started > time_limit_s) or boxes >= max_boxes:
            return _answer("gave_up", boxes, pruned, started, None, "stopped at the limit before every box was decided")
        lo, hi = stack.pop()
        boxes += 1
        if closure_prune(form, lo, hi, quality) is not None:
            pruned += 1
            continue
        mid = 0.5 * (lo + hi)
        params = _params_at(form, mid)
        if _closed(task, params, centre, rho, quality):
            return _answer("witness", boxes, pruned, started, params, "the points at a box's centre are force closure")
        relative = (hi[split] - lo[split]) / span
        if np.max(relative) < MIN_WIDTH:
            return _answer("gave_up", boxes, pruned, started, None, "a box on the frontier of force closure stays undecided")
        k = split[int(np.argmax(weight * relative))]
        left_hi, right_lo = hi.copy(), lo.copy()
        left_hi[k] = right_lo[k] = mid[k]
        stack += [(right_lo, hi), (lo, left_hi)]
    return _answer("infeasible", boxes, pruned, started, None,
                   f"every one of {boxes} boxes of the object regions' parameters carries a certificate")  # fmt: skip


def _answer(status: str, boxes: int, pruned: int, started: float, witness, message: str) -> RegionClosure:
    return RegionClosure(status, boxes, pruned, time.perf_counter() - started, witness, message)


def _split_variables(form, lower, upper, quality: QualityOptions) -> tuple[np.ndarray, np.ndarray]:
    """The system variables the search splits (per contact its object patch's ``(s, t)``,
    else its normal's, else none) and each one's weight: how far its contact's point and
    normal (times the torque radius) enclosures extend over the initial box [mm]."""
    _, rho = torque_reference(form.task, quality)
    p_lo, p_hi, nu_lo, nu_hi = contact_enclosures(form, lower, upper)
    extent = np.max(p_hi - p_lo, axis=1) + rho * np.max(np.minimum(nu_hi - nu_lo, 2.0), axis=1)
    split, weight = [], []
    for c, cv in enumerate(form.contact_vars):
        own = cv.object_params if cv.object_params is not None else (cv.object_normal or ())
        split += list(own)
        weight += [max(float(extent[c]), 1e-9)] * len(own)
    return np.asarray(split, dtype=np.intp), np.asarray(weight)


def _params_at(form, x: np.ndarray) -> tuple:
    """Per contact, its object region's parameters at the system's point ``x``."""
    task = form.task
    return tuple(form_of(task.object_region(c)).object_params(task.object_region(c), cv, x)
                 for c, cv in zip(task.contacts, form.contact_vars))  # fmt: skip


def _closed(task: Task, params: tuple, centre, rho: float, quality: QualityOptions) -> bool:
    """Whether the contacts at the object regions' ``params`` are force closure."""
    points, inward = [], []
    for contact, u in zip(task.contacts, params):
        p, n = task.object_region(contact).evaluate(np.asarray(u, float)[None])
        points.append(p[0])
        inward.append(-n[0])
    return force_closure(primitive_wrenches(np.array(points), np.array(inward), centre, rho, quality)).force_closure
