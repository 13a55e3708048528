"""Grasps planned on a bare mesh: proposed regions, then the assignment of fingertips searched.

:func:`plan_grasps` proposes candidate sets of ``K`` object regions on the mesh
(:func:`~.propose.propose_points`, best first), and for each set in turn grows its regions
(:meth:`~.grow.MeshSurface.grow`), makes the object (the mesh as its solid, the ``K``
regions named ``set<k>_<i>``) and an :class:`~prehension.assignment.OpenTask` whose every
contact may take any candidate hand region (the fingertips, and the palm's with
``palm``), and decides its assignments with
:func:`~prehension.assignment.search_assignments` (span proofs, the local solver's batch
path, the complete solver when :attr:`PlanOptions.search` gives it time; on its executor).
A set's grasp is its best feasible assignment's result (ranked by grasp quality); every
set yields one grasp at most, so grasps of distinct sets are distinct grasps.  It stops
when :attr:`PlanOptions.grasps` grasps are found, the sets run out, or the time limit passes.

Each grasp is a full :class:`~prehension.results.SolveResult` of a closed task (the
chosen assignment): verified by the one residual function, re-checkable from its record.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping, NamedTuple

from ..assignment import AssignmentOptions, AssignmentOutcome, OpenContact, OpenTask, search_assignments
from ..errors import InvalidObject, PrehensionError
from ..hands.model import Hand
from ..objects.model import GraspObject
from ..objects.solid import MeshFileSolid
from ..solvers.local import LocalOptions
from .grow import MeshSurface
from .hand_side import HandSide, hand_side
from .propose import CandidateSet, PointSets, ProposalOptions, grow_set, propose_points

_LOG = logging.getLogger("prehension.planning")

__all__ = ["PlanOptions", "PlannedGrasp", "SetVerdict", "PlanProgress", "PlanReport", "plan_grasps", "region_names", "open_task_of"]


@dataclass(frozen=True)
class PlanOptions:
    """How :func:`plan_grasps` plans.

    Attributes:
        fingers: contacts per grasp (``K >= 2``).
        palm: the palm's regions are candidates too (besides the fingertips).
        oppose: the opposition rule (:mod:`.hand_side`): the thumb on each set's first
            contact, the other fingertips on the others.
        grasps: stop once this many grasps are found (``None``: try every candidate set).
        proposal: the :class:`~.propose.ProposalOptions` of the candidate sets.
        search: the :class:`~prehension.assignment.AssignmentOptions` of each set's search
            (default: the local solver only, ``complete_time_s=0``: the assignments it
            does not solve stay undecided; 16 initial poses per assignment, as the paper's
            12, not the 64 of a single task: a planner has many sets to try, and a pose
            budget spent on an unsolvable assignment is the planner's main cost; the
            executor, when given, runs its chunks).
        time_limit_s: no new set is started after this many seconds (``None``: no limit).
    """

    fingers: int = 3
    palm: bool = False
    oppose: bool = True
    grasps: int | None = 10
    proposal: ProposalOptions = field(default_factory=ProposalOptions)
    search: AssignmentOptions = field(default_factory=lambda: AssignmentOptions(complete_time_s=0.0, local_options=LocalOptions(i_max=16)))
    time_limit_s: float | None = None

    def __post_init__(self):
        if self.grasps is not None and (isinstance(self.grasps, bool) or not isinstance(self.grasps, int) or self.grasps < 1):
            raise PrehensionError(f"plan options: grasps must be a positive integer (or None: every set), got {self.grasps!r}")
        if self.time_limit_s is not None and not (isinstance(self.time_limit_s, (int, float)) and self.time_limit_s > 0):
            raise PrehensionError(f"plan options: time_limit_s must be > 0 s (or None), got {self.time_limit_s!r}")


class PlannedGrasp(NamedTuple):
    """One planned grasp: candidate set ``set_index``, its regions and its best assignment."""

    set_index: int
    candidate: CandidateSet
    outcome: AssignmentOutcome


class SetVerdict(NamedTuple):
    """What one candidate set came to: its grasp, or (``grasp`` None) the verdict recorded
    for it (an undecided assignment when there is one, else one proven impossible; None
    when its regions could not be grown), and its assignments decided."""

    set_index: int
    grasp: PlannedGrasp | None
    verdict: object
    assignments: int


class PlanProgress(NamedTuple):
    sets_tried: int
    sets: int
    grasps: int
    assignments: int


@dataclass
class PlanReport:
    """What :func:`plan_grasps` did.

    Attributes:
        grasps: the grasps found in this run, in the order found (best candidate set first).
        sets: the candidate sets proposed; ``tried``: how many this run decided.
        assignments: assignments decided in this run.
        points: the proposal (:class:`~.propose.PointSets`: samples, pairs, scores).
        side: the hand's candidate regions and spans.
        seconds: wall time [s] (proposal included).
    """

    grasps: list[PlannedGrasp]
    sets: int
    tried: int
    assignments: int
    points: PointSets
    side: HandSide
    seconds: float


def region_names(k: int, fingers: int) -> tuple[str, ...]:
    """The object region names of candidate set ``k``: ``set<k>_1 .. set<k>_<K>``."""
    return tuple(f"set{k}_{i + 1}" for i in range(fingers))


def open_task_of(name: str, solid: MeshFileSolid, side: HandSide, k: int, candidate: CandidateSet) -> OpenTask:
    """The open task of candidate set ``k``: its regions on the object, any candidate hand region on each."""
    names = region_names(k, len(candidate.regions))
    obj = GraspObject(name, dict(zip(names, candidate.regions)), solid=solid)
    contacts = tuple(OpenContact(n, side.candidates(i == 0)) for i, n in enumerate(names))
    return OpenTask(f"{name}-set{k}", side.hand, obj, contacts,
                    description=f"grasp planned on {Path(solid.path).name} by prehension plan (candidate set {k})")  # fmt: skip


def _verdict(report):
    """The verdict recorded for a set with no feasible assignment."""
    if report.undecided:
        return report.undecided[0]
    return report.infeasible[0] if report.infeasible else None


def _decide(name, solid, side, surface, points, k, options: PlanOptions) -> SetVerdict:
    candidate = grow_set(surface, points, k)
    try:
        task = None if candidate is None else open_task_of(name, solid, side, k, candidate)
    except InvalidObject as exc:  # a region the object's own surface check refuses: the set is skipped, logged
        _LOG.info("set %d skipped: %s", k, exc)
        task = None
    if task is None:
        return SetVerdict(k, None, None, 0)
    report = search_assignments(task, options.search)
    decided = len(report.feasible) + len(report.infeasible) + len(report.undecided)
    if report.feasible:
        return SetVerdict(k, PlannedGrasp(k, candidate, report.feasible[0]), report.feasible[0], decided)
    return SetVerdict(k, None, _verdict(report), decided)


def plan_grasps(solid: MeshFileSolid, hand: Hand, options: PlanOptions | None = None, *, name: str | None = None,
                skip: Mapping[int, bool] | None = None, progress: Callable[[PlanProgress], None] | None = None,
                on_set: Callable[[SetVerdict], None] | None = None) -> PlanReport:  # fmt: skip
    """Plan grasps of ``hand`` on the mesh of ``solid`` (see the module docstring).

    Args:
        solid: the object's mesh file and scale (mm per file unit).
        name: the object's name (default: the mesh file's stem).
        skip: candidate sets decided by an earlier run, by index: whether each gave a grasp
            (they count towards :attr:`PlanOptions.grasps` and are not decided again).
        progress: called with a :class:`PlanProgress` after each set.
        on_set: called with each set's :class:`SetVerdict` as it is decided.

    Raises:
        PrehensionError: more fingers than the hand has candidate regions; a mesh that
            cannot be read; :class:`~.propose.NoGraspError` when no set fits the hand.
    """
    options, skip = options or PlanOptions(), dict(skip or {})
    started = time.perf_counter()
    side = hand_side(hand, options.fingers, palm=options.palm, oppose=options.oppose)
    surface = MeshSurface(solid.mesh())
    points = propose_points(surface, side, options.fingers, options.proposal)
    name = name or Path(solid.path).stem
    found, grasps, tried, assignments = sum(skip.values()), [], 0, 0
    for k in range(len(points.sets)):
        if options.grasps is not None and found >= options.grasps:
            break
        if options.time_limit_s is not None and time.perf_counter() - started >= options.time_limit_s:
            break
        if k in skip:
            continue
        verdict = _decide(name, solid, side, surface, points, k, options)
        tried, assignments = tried + 1, assignments + verdict.assignments
        if verdict.grasp is not None:
            grasps.append(verdict.grasp)
            found += 1
        if on_set is not None:
            on_set(verdict)
        if progress is not None:
            progress(PlanProgress(tried + len(skip), len(points.sets), found, assignments))
    return PlanReport(grasps, len(points.sets), tried, assignments, points, side, time.perf_counter() - started)
