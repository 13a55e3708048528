"""What the local solver reports: one :class:`LocalRecord` per problem, in a :class:`LocalBatch`.

A record is light (arrays and counts); :meth:`LocalRecord.to_result` turns it into the
:class:`~prehension.results.SolveResult` both solvers share, re-checking its configuration
with :func:`~prehension.results.make_solution`, so a :class:`SolveResult` never holds an
unverified configuration.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from typing import Any, Mapping, Sequence

import numpy as np

from ...results import SolveResult, Status, make_solution
from ...tasks.model import Configuration, Task
from .options import STRICT, LocalOptions
from .sequence import InitialPoseSequence

__all__ = ["LocalRecord", "LocalBatch"]


@dataclass(eq=False)
class LocalRecord:
    """What the local solver found for one problem (light; see :meth:`to_result`).

    Attributes:
        index: position of the problem in the batch.
        success: a configuration passed the checks with the strict tolerances.
        tolerance: ``"strict"`` (solved), ``"d_min"`` (an approximate answer, held only
            with :attr:`LocalOptions.approximate`), else ``None``.
        joint_angles, T_palm_object, contact_params: the configuration held (strict or
            approximate), else ``None``.
        solved_with_pose: 1-based index of the initial pose that gave it (0: none).
        initial_poses_tried: initial poses started.
        iterations: Jacobian iterations over all initial poses.
        per_pose_iterations: Jacobian iterations of each initial pose tried.
        polish_iterations: Gauss-Newton polishing iterations of the answer.
        collision_rejections: local solutions rejected for self-collision (or a failed check).
        max_distance_mm, max_normal_deg: achieved contact residuals of the answer held;
            without one, of the closest miss (a local solution within ``d_min`` that
            was not strict), ``nan`` when there was none.
    """

    index: int
    success: bool
    tolerance: str | None
    joint_angles: np.ndarray | None
    T_palm_object: np.ndarray | None
    contact_params: tuple | None
    solved_with_pose: int
    initial_poses_tried: int
    iterations: int
    per_pose_iterations: tuple[int, ...]
    polish_iterations: int
    collision_rejections: int
    max_distance_mm: float
    max_normal_deg: float
    i_max: int = 12
    verified: tuple | None = field(default=None, repr=False)  # (task, Solution) checked strictly in the waves
    time_limit_s: float | None = None  # set when the time limit stopped this problem's search

    @property
    def status(self) -> str:
        if self.success:
            return Status.SOLVED
        return Status.APPROXIMATE if self.tolerance == "d_min" else Status.GAVE_UP

    @property
    def message(self) -> str:
        if self.joint_angles is not None:
            what = "solved" if self.success else "approximate answer (no strict solution found)"
            return (
                f"{what} with initial pose {self.solved_with_pose} of {self.i_max} after {self.iterations} "
                f"Jacobian iterations in all (+{self.polish_iterations} polishing); contacts within "
                f"{self.max_distance_mm:.2g} mm and {self.max_normal_deg:.2g} deg ({self.tolerance} tolerances)"
            )
        extra = f"; {self.collision_rejections} local solution(s) rejected by the checks" if self.collision_rejections else ""
        if np.isfinite(self.max_distance_mm):
            extra += (f"; the closest came within {self.max_distance_mm:.2g} mm and {self.max_normal_deg:.2g} deg "
                      f"(not a solution: the strict tolerances are 1e-6 mm and 1e-6 deg)")  # fmt: skip
        limit = f" (stopped by the time limit of {self.time_limit_s:g} s)" if self.time_limit_s is not None else ""
        return (
            f"no solution found after {self.initial_poses_tried} initial poses and {self.iterations} "
            f"Jacobian iterations{limit}{extra}"
        )

    @property
    def stats(self) -> dict:
        return {
            "initial_poses_tried": self.initial_poses_tried,
            "iterations": self.iterations,
            "per_pose_iterations": list(self.per_pose_iterations),
            "polish_iterations": self.polish_iterations,
            "solved_with_pose": self.solved_with_pose,
            "collision_rejections": self.collision_rejections,
            "tolerances": self.tolerance,
            "max_contact_distance_mm": _finite_or_none(self.max_distance_mm),
            "max_normal_angle_deg": _finite_or_none(self.max_normal_deg),
        }

    def followed_by(self, later: "LocalRecord") -> "LocalRecord":
        """This record (a problem not solved by its poses) followed by ``later``, the
        record of the next poses (``solve_local_batch(poses=...)``): what one call over
        both ranges records -- poses, iterations and rejections summed, the answer or
        else the closest miss of the two (the earlier on a tie)."""
        if self.joint_angles is not None:
            raise ValueError("followed_by: this record holds an answer; its problem has no later poses")
        out = replace(later, index=self.index, initial_poses_tried=self.initial_poses_tried + later.initial_poses_tried,
                      iterations=self.iterations + later.iterations,
                      per_pose_iterations=self.per_pose_iterations + later.per_pose_iterations,
                      collision_rejections=self.collision_rejections + later.collision_rejections)  # fmt: skip
        if later.joint_angles is None and not _closer(later, self):
            out = replace(out, max_distance_mm=self.max_distance_mm, max_normal_deg=self.max_normal_deg)
        return out

    def configuration(self) -> Configuration | None:
        if self.joint_angles is None:
            return None
        return Configuration(self.joint_angles, self.T_palm_object, self.contact_params)

    def to_result(self, task: Task, options: LocalOptions = LocalOptions(), seconds: float = 0.0,
                  extra_stats: Mapping[str, Any] | None = None) -> SolveResult:  # fmt: skip
        """A :class:`SolveResult` whose solution has been re-verified by :func:`make_solution`.

        ``"solved"`` only with the strict tolerances; an approximate answer (held only
        with :attr:`LocalOptions.approximate`) is re-verified with
        :attr:`LocalOptions.acceptance` and returned as ``"approximate"``, with those
        tolerances in ``stats["acceptance"]``.
        """
        stats = {**self.stats, **(extra_stats or {})}
        if self.joint_angles is None:
            return SolveResult(task, "local", Status.GAVE_UP, self.message, (), seconds, stats)
        if self.verified is not None and self.success and self.verified[0] is task:
            sol = self.verified[1]  # made by make_solution (strict tolerances) when the waves checked it
            return SolveResult(task, "local", Status.SOLVED, self.message, (sol,), seconds,
                               {**stats, "max_contact_distance_mm": sol.report.worst("contact_distance"),
                                "max_normal_angle_deg": sol.report.worst("contact_normal")})  # fmt: skip
        config = self.configuration()
        sol = make_solution(task, config, STRICT)
        status = Status.SOLVED
        if sol is None and options.approximate:
            sol, status = make_solution(task, config, options.acceptance), Status.APPROXIMATE
            stats["acceptance"] = asdict(options.acceptance)
        if sol is None:  # the batch checks and evaluate() disagree: never call it a solution
            report_msg = "the local solution failed the re-check of the residual function"
            stats["tolerances"] = None
            return SolveResult(task, "local", Status.GAVE_UP, f"no solution found: {report_msg}", (), seconds, stats)
        level = "strict" if status == Status.SOLVED else "d_min"
        stats["tolerances"] = level
        stats["max_contact_distance_mm"] = sol.report.worst("contact_distance")
        stats["max_normal_angle_deg"] = sol.report.worst("contact_normal")
        msg = self.message
        if level != self.tolerance:
            msg = msg.replace(f"({self.tolerance} tolerances)", f"({level} tolerances)").replace(
                "approximate answer (no strict solution found)", "solved")
        return SolveResult(task, "local", status, msg, (sol,), seconds, stats)


@dataclass(eq=False)
class LocalBatch:
    """The answers of :func:`solve_local_batch`, one :class:`LocalRecord` per problem.

    Attributes:
        records: one per problem, in input order.
        seconds: wall-clock time of the whole call.
        wave_seconds: (i_max,) time spent until the end of each wave (cumulative): the
            time the batch would have taken with ``i_max = 1, 2, ...``.
        solved_after: (i_max,) problems solved within the first 1, 2, ... initial poses.
        options: the options used.
        sequence: the initial-pose sequence used.
    """

    records: list[LocalRecord]
    seconds: float
    wave_seconds: np.ndarray
    solved_after: np.ndarray
    options: LocalOptions
    sequence: InitialPoseSequence | None = None
    timings: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.records)

    def __getitem__(self, i) -> LocalRecord:
        return self.records[i]

    def __iter__(self):
        return iter(self.records)

    @property
    def success(self) -> np.ndarray:
        return np.array([r.success for r in self.records], dtype=bool)

    @property
    def success_rate(self) -> float:
        return float(self.success.mean()) if self.records else 0.0

    def results(self, tasks: Sequence[Task]) -> list[SolveResult]:
        """Every record as a verified :class:`SolveResult` (``tasks`` in batch order)."""
        per = self.seconds / max(len(self.records), 1)
        return [r.to_result(t, self.options, per) for r, t in zip(self.records, tasks)]


def _closer(a: LocalRecord, b: LocalRecord) -> bool:
    """``a``'s closest miss is strictly closer than ``b``'s (none: infinitely far)."""
    worst = lambda r: max(r.max_distance_mm, r.max_normal_deg) if np.isfinite(r.max_distance_mm) else np.inf  # noqa: E731
    return worst(a) < worst(b)


def _finite_or_none(value: float) -> float | None:
    """A residual for a JSON file: ``None`` where there is none (never a literal NaN)."""
    return float(value) if np.isfinite(value) else None
