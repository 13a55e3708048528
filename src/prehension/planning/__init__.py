"""Grasps planned on a bare mesh: contact regions proposed, then the assignment searched.

See ``docs/planning.md``: :func:`~.hand_side.hand_side` (which hand regions may touch and
how far apart), :func:`~.propose.propose_regions` (candidate object regions on the mesh).
"""

from .hand_side import HandSide, hand_side
from .plan import PlannedGrasp, PlanOptions, PlanProgress, PlanReport, SetVerdict, open_task_of, plan_grasps, region_names
from .grow import MeshSurface
from .propose import (
    CandidateSet, NoGraspError, PointSets, Proposal, ProposalOptions, grow_set, propose_points, propose_regions, sample_surface,
)

__all__ = [
    "HandSide", "hand_side", "MeshSurface", "PointSets", "grow_set", "propose_points", "CandidateSet", "NoGraspError", "Proposal", "ProposalOptions", "propose_regions",
    "sample_surface", "PlannedGrasp", "PlanOptions", "PlanProgress", "PlanReport", "SetVerdict", "open_task_of", "plan_grasps",
    "region_names",
]  # fmt: skip
