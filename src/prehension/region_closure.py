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

**Aimed starts** (:func:`aimed_grasps`).  When the regions do admit force-closure points
but no candidate is force closure, the local solver's iterations are aimed at force-closure
points of the regions (the witness, and the ``AIMED_POINTS`` best of ``AIMED_SAMPLES``
seeded random choices of one point per region, by the merit of
:func:`prehension.ascent.merit`, positive ones only).  The local solver's initial placement
(Obtain_Initial_Conf) puts the object's contact points at their regions' centres, so a
start cannot carry object parameters; instead each point's starts solve the task with every
object region restricted to its part within ``AIM_HALF_WIDTH`` of each parameter range
around the point (:meth:`~prehension.geometry.regions.Region.restricted`: a Bézier patch's
sub-patch, exact; caps and points stay whole), from ``AIMED_STARTS`` random hand
configurations shared among the points.  A grasp of the restricted task is one of the task
(its parameters mapped back onto the whole regions) whose contacts lie near the aimed
points.  Every grasp reached is verified on the task itself and measured again; the
force-closure ones, distinct, best merit first, each moved up by the quality ascent, are
``--hold``'s further candidates.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from .ascent import improve_grasp, merit, wrench_merit
from .best import BestOptions, distinct, random_starts
from .quality import QualityOptions, force_closure, primitive_wrenches, torque_reference
from .results import Solution, make_solution
from .solvers.complete.closure import closure_prune, contact_enclosures
from .solvers.local import LocalOptions, refine_local
from .system.formulation import build_system
from .system.regions import form_of
from .tasks.model import Configuration, Task

__all__ = ["RegionClosure", "regions_closure", "aimed_grasps", "MIN_WIDTH", "MAX_BOXES"]

MIN_WIDTH = 1e-6  # a box this narrow (relative to each parameter's range) that is neither pruned nor a witness: undecided
MAX_BOXES = 200_000  # boxes examined at most
AIMED_SAMPLES = 400  # random choices of points in the regions, measured (aimed starts)
AIMED_POINTS = 10  # the best force-closure ones the starts aim at
AIMED_STARTS = 100  # starts of the local iterations
AIM_HALF_WIDTH = 0.25  # an aimed start's object regions: within this fraction of each parameter range of the point
AIMED_KEPT = 8  # force-closure grasps returned at most


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
    centre, rho = torque_reference(task, quality)
    split, weight = _split_variables(form, lower, upper, rho)
    span = np.maximum(upper[split] - lower[split], 1e-300)
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
        if split.size == 0 or np.max(relative) < MIN_WIDTH:  # nothing left to split (point regions: one choice)
            return _answer("gave_up", boxes, pruned, started, None, "a box on the frontier of force closure stays undecided")
        k = split[int(np.argmax(weight * relative))]
        left_hi, right_lo = hi.copy(), lo.copy()
        left_hi[k] = right_lo[k] = mid[k]
        stack += [(right_lo, hi), (lo, left_hi)]
    return _answer("infeasible", boxes, pruned, started, None,
                   f"every one of {boxes} boxes of the object regions' parameters carries a certificate")  # fmt: skip


def _answer(status: str, boxes: int, pruned: int, started: float, witness, message: str) -> RegionClosure:
    return RegionClosure(status, boxes, pruned, time.perf_counter() - started, witness, message)


def _split_variables(form, lower, upper, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """The system variables the search splits (per contact its object patch's ``(s, t)``,
    else its normal's, else none) and each one's weight: how far its contact's point and
    normal (times the torque radius ``rho`` [mm]) enclosures extend over the initial box [mm]."""
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


def aimed_grasps(task: Task, quality: QualityOptions, seed: int, witness=None, aim: bool = True) -> list[Solution]:
    """Force-closure grasps of ``task`` (``quality``'s model) from the local iterations aimed
    at force-closure points of its regions (module docstring, "Aimed starts"); ``witness``:
    per contact, object parameters known to be force closure (:class:`RegionClosure`).
    ``aim=False``: plain random starts over the whole regions, no points sampled (a further
    round, once a first one has shown the regions to have force-closure points)."""
    rng = np.random.default_rng(seed)
    if aim:
        points = ([tuple(witness)] if witness is not None else []) + _closure_points(task, quality, rng)
        if not points:
            return []
        starts = random_starts(task, AIMED_STARTS, rng)
        found = [s for k, point in enumerate(points) for s in _aimed(task, point, starts[k :: len(points)])]
    else:
        configs = refine_local(task, random_starts(task, AIMED_STARTS, rng), LocalOptions()).configurations
        found = [make_solution(task, c) for c in configs if c is not None]
    scored = sorted(((merit(task, s, quality), k, s) for k, s in enumerate(found) if s is not None), key=lambda m: (-m[0], m[1]))
    kept: list[Solution] = []
    for value, _, solution in scored:
        if value <= 0.0 or len(kept) == AIMED_KEPT:
            break
        if all(distinct(solution, other, task, BestOptions()) for other in kept):
            kept.append(solution)
    return [improve_grasp(task, s, quality).solution for s in kept]


def _aimed(task: Task, point: tuple, starts: list[Configuration]) -> list[Solution | None]:
    """The grasps of ``task`` that the local iterations reach from ``starts`` with every
    object region restricted around ``point`` (per contact, its object parameters), verified
    on ``task`` itself."""
    if not starts:
        return []
    regions, contacts, boxes = dict(task.object.regions), [], []
    for c, (contact, at) in enumerate(zip(task.contacts, point)):
        region = task.object_region(contact)
        lower, upper = region.param_bounds()
        at = np.asarray(at, dtype=float)
        box = (np.maximum(lower, at - AIM_HALF_WIDTH * (upper - lower)), np.minimum(upper, at + AIM_HALF_WIDTH * (upper - lower)))
        part = region.restricted(*box) if np.all(box[1] > box[0]) else None  # None: a kind with no parts (caps, points)
        if part is None:
            contacts.append(contact)
            boxes.append(None)
            continue
        name = f"{contact.object_region}@aim{c}"  # one part per contact: two contacts may share a region
        regions[name] = part
        contacts.append(replace(contact, object_region=name))
        boxes.append((box, part.param_bounds()))
    aimed = replace(task, object=replace(task.object, regions=regions), contacts=tuple(contacts))
    configs = refine_local(aimed, starts, LocalOptions()).configurations  # a start's object parameters: placed anew
    return [make_solution(task, _unaimed(c, boxes)) for c in configs if c is not None]


def _unaimed(config: Configuration, boxes: list) -> Configuration:
    """A configuration of the restricted task as one of the task: each restricted contact's
    object parameters mapped affinely from its part's parameter box onto the box it covers."""
    params = []
    for (hp, op), box in zip(config.contact_params, boxes):
        if box is not None:
            (lower, upper), (part_lo, part_hi) = box
            op = lower + (upper - lower) * (np.asarray(op, dtype=float) - part_lo) / (part_hi - part_lo)
        params.append((hp, op))
    return Configuration(config.joint_angles, config.T_palm_object, tuple(params))


def _closure_points(task: Task, quality: QualityOptions, rng) -> list[tuple]:
    """The ``AIMED_POINTS`` best of ``AIMED_SAMPLES`` random choices of one point per object
    region whose merit is positive (force closure), best first: per contact, its parameters."""
    centre, rho = torque_reference(task, quality)
    regions = [task.object_region(c) for c in task.contacts]
    params = [rng.uniform(*r.param_bounds(), size=(AIMED_SAMPLES, r.param_bounds()[0].size)) for r in regions]
    at = [r.evaluate(u) for r, u in zip(regions, params)]
    points, inward = np.stack([p for p, _ in at], axis=1), -np.stack([n for _, n in at], axis=1)
    value = np.array([wrench_merit(primitive_wrenches(points[i], inward[i], centre, rho, quality).reshape(-1, 6))
                      for i in range(AIMED_SAMPLES)])  # fmt: skip
    order = [i for i in np.argsort(-value, kind="stable")[:AIMED_POINTS] if value[i] > 0.0]
    return [tuple(u[i] for u in params) for i in order]
