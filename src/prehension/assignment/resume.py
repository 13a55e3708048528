"""Going on from an earlier run's undecided assignments (``--retry-undecided``) without
trying again the initial poses it had tried.

An undecided record of the journal (``gave_up``) keeps the local solver's statistics of its
assignment (its own, or under ``stats["local"]`` when the complete solver ran after it): the
initial poses tried and the Jacobian iterations of each.  Initial pose ``k`` of an
assignment starts from the same point whatever poses came before
(:func:`~prehension.solvers.local.solve_local_batch` with ``poses=``), so the search can go on
from the start of the round (:func:`~.rounds.round_ranges`) that holds the first pose not
tried: an assignment whose every pose was tried goes straight to the complete solver; one
the time limit stopped inside a round starts that round again.  Its answer is the one a run
from the first pose gives; its statistics count the poses before the resumed round from the
record (their iterations exactly; their collision rejections and closest miss only when the
record covers exactly those poses, else they are left out and ``stats["resumed_at_pose"]``
says from which pose this run solved).

An earlier record is used only when its seed is the assignment's seed in this run (the
same base seed), it had as many initial poses as this run (``--initial-poses``: the poses
beyond the sequence's are drawn for that number, so pose ``k`` of 32 is not pose ``k`` of
64), and the search runs in rounds (the default initial pose sequence); else the assignment
starts again from its first pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Mapping

from ..results import SolveResult
from ..tasks.model import Task

__all__ = ["Earlier", "earlier_runs", "resume_point"]


@dataclass(frozen=True)
class Earlier:
    """What an earlier run left of one undecided assignment: the seed it was solved with,
    the initial poses it had (``i_max``), its local solver's statistics
    (``initial_poses_tried``, ``per_pose_iterations``...) and the seconds it took."""

    seed: int
    i_max: int
    local_stats: Mapping
    seconds: float = 0.0

    @property
    def poses_tried(self) -> int:
        return int(self.local_stats["initial_poses_tried"])


def earlier_runs(records: Iterable[dict]) -> dict[str, Earlier]:
    """``{assignment label: Earlier}`` of a journal's undecided (``gave_up``) records whose
    local solver's statistics can be read; other records are left out (their assignments
    start again from the first pose)."""
    out = {}
    for record in records:
        if record.get("status") != "gave_up" or not isinstance(record.get("id"), str):
            continue
        result = record.get("result") if isinstance(record.get("result"), dict) else {}
        stats = result.get("stats") if isinstance(result.get("stats"), dict) else {}
        local = stats if record.get("method") == "local" else stats.get("local")
        named = record.get("assignment") if isinstance(record.get("assignment"), dict) else {}
        i_max, seed = named.get("initial_poses"), record.get("seed")
        if _readable(local) and isinstance(seed, int) and isinstance(i_max, int) and i_max >= 1:
            seconds = result.get("seconds")
            out[record["id"]] = Earlier(seed, i_max, local, float(seconds) if isinstance(seconds, (int, float)) else 0.0)
    return out


def _readable(stats) -> bool:
    if not isinstance(stats, dict):
        return False
    tried, per = stats.get("initial_poses_tried"), stats.get("per_pose_iterations")
    return (isinstance(tried, int) and tried >= 0 and isinstance(per, list) and len(per) == tried
            and all(isinstance(n, int) and n >= 0 for n in per))  # fmt: skip


def resume_point(earlier: Earlier, ranges: list, task: Task, local_options) -> tuple[int | None, object, SolveResult]:
    """Where ``earlier``'s assignment goes on: ``(round, record, result)`` -- the index in
    ``ranges`` (:func:`~.rounds.round_ranges`) of the round to start (``None``: every pose
    was tried, the complete solver is next), the
    :class:`~prehension.solvers.local.LocalRecord` of the poses before it (passed on as the
    next round's ``earlier``) and its :class:`SolveResult` (``gave_up``).  ``local_options``:
    the search's :class:`~prehension.solvers.local.LocalOptions` (``None``: the defaults)."""
    from ..solvers.local import LocalOptions, LocalRecord

    local_options = local_options or LocalOptions()
    tried = earlier.poses_tried
    starts = [0 if r is None else r[0] for r in ranges]  # [None]: one round of every pose
    round_ = None if tried >= local_options.i_max else max(i for i, s in enumerate(starts) if s <= tried)
    start = local_options.i_max if round_ is None else starts[round_]
    per = tuple(int(n) for n in earlier.local_stats["per_pose_iterations"][:start])
    exact = start == earlier.poses_tried
    miss = (earlier.local_stats.get("max_contact_distance_mm"), earlier.local_stats.get("max_normal_angle_deg"))
    miss = tuple(float(x) if exact and isinstance(x, (int, float)) else math.nan for x in miss)
    record = LocalRecord(index=0, success=False, tolerance=None, joint_angles=None, T_palm_object=None, contact_params=None,
                         solved_with_pose=0, initial_poses_tried=start, iterations=sum(per), per_pose_iterations=per,
                         polish_iterations=0, collision_rejections=int(earlier.local_stats.get("collision_rejections", 0) or 0)
                         if exact else 0, max_distance_mm=miss[0], max_normal_deg=miss[1], i_max=local_options.i_max)  # fmt: skip
    extra = {} if exact else {"resumed_at_pose": start + 1}
    result = record.to_result(task, local_options, earlier.seconds, extra)
    return round_, record, result
