"""The local solver: Algorithm 1 of Claret & Suárez over batches of problems.

:func:`solve_local_batch` solves many problems of one hand in one call; :func:`solve_local`
solves one task and returns the :class:`~prehension.results.SolveResult` both solvers
share.  The outer loop of Algorithm 1 runs in *waves*: wave ``i`` starts every problem
not solved yet from its ``i``-th initial pose, so each problem sees exactly the sequence
of initial poses the paper's algorithm would give it, while the compiled kernel
(:mod:`._kernel`) runs the inner loops of the whole wave at once.  After each wave the
local solutions are checked with the foundation's own batch functions
(:func:`~prehension.hands.kinematics.forward_kinematics`,
:func:`~prehension.hands.collision.max_penetration` -- the paper's Check_Collisions --,
:func:`~prehension.tasks.residuals.limit_violations`,
:func:`~prehension.tasks.residuals.coupling_violations` and the contact residuals of
:mod:`prehension.tasks.residuals`); a problem whose local solution fails them goes on to
its next initial pose, as in the paper after a collision.

A problem is *solved* only by a configuration that meets the strict default
:class:`~prehension.tasks.residuals.Tolerances`.  A configuration that meets only the
paper's ``d_min`` tolerances (:attr:`LocalOptions.acceptance`) is returned, with the status
``"approximate"``, only when :attr:`LocalOptions.approximate` asks for it; otherwise it is
the problem's *closest miss*, reported in ``stats``.  :meth:`LocalRecord.to_result`
re-checks every configuration with :func:`~prehension.results.make_solution`, so a
:class:`SolveResult` never holds an unverified configuration.
"""

from __future__ import annotations

import time
import zlib
from functools import lru_cache
from dataclasses import asdict, dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ...kernels.aot import aot
from ...deadline import TimeLimitReached, deadline_after, seconds_left
from ...errors import InvalidTask
from ...frozen import IdentityCache, cached_per_value
from ...geometry.rotations import angle_between
from ...hands.collision import max_penetration
from ...hands.kinematics import HandPose, forward_kinematics
from ...results import Solution, SolveResult, Status, first_solution, make_solution
from ...tasks.model import Configuration, Task
from ...tasks.residuals import Tolerances, contact_residuals, coupling_violations, limit_violations
from . import _kernel as K
from ._layout import S_K, S_X, Group
from .options import LocalOptions
from .problems import PointProblems, group_from_tasks, structure_key
from .sequence import InitialPoseSequence, default_sequence, sample_poses

__all__ = ["solve_local", "solve_local_batch", "refine_local", "run_kernel", "Refinement", "LocalRecord", "LocalBatch", "STRICT"]

STRICT = Tolerances()


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


def _finite_or_none(value: float) -> float | None:
    """A residual for a JSON file: ``None`` where there is none (never a literal NaN)."""
    return float(value) if np.isfinite(value) else None


# -- checks with the foundation's batch functions ------------------------------------------
def _contact_checks_points(problems: PointProblems, idx, pose: HandPose, T, params):
    """Contact residuals of point problems (as :func:`contact_residuals`, vectorised over problems)."""
    hand = problems.hand
    dist, ang, hreg_v = [], [], []
    for c, name in enumerate(problems.hand_regions):
        h = hand.region(name)
        hp = params[c][0]
        p_link, n_link = h.region.evaluate(hp)
        li = hand.link_index(h.link)
        ph, nh = pose.points(li, p_link), pose.directions(li, n_link)
        po = np.einsum("bij,bj->bi", T[:, :3, :3], problems.points[idx, c]) + T[:, :3, 3]
        no = np.einsum("bij,bj->bi", T[:, :3, :3], problems.normals[idx, c])
        dist.append(np.linalg.norm(ph - po, axis=1))
        ang.append(np.degrees(angle_between(nh, -no)))
        hreg_v.append(h.region.domain_violation(hp))
    z = np.zeros((len(idx), len(problems.hand_regions)))
    return np.stack(dist, 1), np.stack(ang, 1), np.stack(hreg_v, 1), z


def _contact_checks_tasks(tasks, idx, pose: HandPose, T, params):
    """Contact residuals of tasks: the foundation's :func:`contact_residuals`, one task at a
    time, and the object penetration of the links that move with the task (idle fingers are
    cleared afterwards by :func:`~prehension.tasks.idle.settle_idle_fingers`) [mm]."""
    out = [[], [], [], [], []]
    for s, i in enumerate(idx):
        sub = HandPose(pose.R_palm_link[s : s + 1], pose.r_palm_link[s : s + 1], pose.axis_palm[s : s + 1], pose.origin_palm[s : s + 1])
        prm = [(h[s : s + 1], o[s : s + 1]) for h, o in params]
        res = contact_residuals(tasks[i], sub, T[s : s + 1], prm)
        for k, key in enumerate(("distance_mm", "normal_angle_deg", "hand_region", "object_region")):
            out[k].append(res[key][0])
        out[4].append(_object_depth(tasks[i], sub, T[s], res["hand_point"][0]))
    return tuple(np.array(v) for v in out)


def _check_tasks(group: Group, tasks, idx, x, R, t, options: LocalOptions):
    """As :func:`_check`, for tasks, with the one residual function itself: each local
    solution goes through :func:`~prehension.results.make_solution` (strict, else with the
    acceptance tolerances; idle fingers moved clear of the object there).  Also returns
    the strict solutions made (``None`` elsewhere), which the records keep."""
    S = len(idx)
    q = group.q_of(x)
    T = np.zeros((S, 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R, t, 1.0
    params = group.params_of(x)
    level, dmax, amax, sols = np.zeros(S, dtype=np.int64), np.zeros(S), np.zeros(S), [None] * S
    for s, i in enumerate(idx):
        config = Configuration(q[s], T[s], tuple((h[s], o[s]) for h, o in params))
        k, held = first_solution(tasks[i], config, (STRICT, options.acceptance))  # evaluated once for both
        sols[s] = held if k == 0 else None
        level[s] = 2 if k == 0 else (1 if k == 1 else 0)
        if held is not None:
            dmax[s], amax[s] = held.report.worst("contact_distance"), held.report.worst("contact_normal")
        else:
            dmax[s] = amax[s] = np.inf
    return level, q, T, params, dmax, amax, sols


def _object_depth(task: Task, pose: HandPose, T, hand_points_palm) -> float:
    """The deepest moving link or pad in the object [mm] (as the residual function measures them)."""
    if not task.object.collides:
        return 0.0
    from ...tasks.object_collision import link_penetrations, moving_links, pad_penetrations

    points = (hand_points_palm - T[:3, 3]) @ T[:3, :3]
    links = link_penetrations(task, pose, T, points, moving_links(task)).values()
    return max(max(links, default=0.0), max(pad_penetrations(task, pose, T, points).values(), default=0.0))


def _check(group: Group, contact_fn, idx, x, R, t, options: LocalOptions):
    """Which local solutions pass: (level array: 2 strict, 1 acceptance, 0 fail), residuals."""
    hand = group.hand
    S = len(idx)
    q = group.q_of(x)
    T = np.zeros((S, 4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = t
    T[:, 3, 3] = 1.0
    params = group.params_of(x)
    pose = forward_kinematics(hand, q)
    depth = max_penetration(hand, pose)
    lim = np.degrees(np.max(limit_violations(hand, q), axis=1))
    cpl = coupling_violations(hand, q)
    cpl = np.degrees(np.max(cpl, axis=1)) if cpl.shape[1] else np.zeros(S)
    dist, ang, hreg, oreg, *rest = contact_fn(idx, pose, T, params)
    odepth = rest[0] if rest else np.zeros(S)  # object penetration (tasks with a solid)
    dmax, amax = dist.max(axis=1), ang.max(axis=1)
    region = np.maximum(hreg.max(axis=1), oreg.max(axis=1))

    def passes(tol: Tolerances):
        return (
            (dmax <= tol.contact_mm) & (amax <= tol.normal_deg) & (region <= tol.region)
            & (lim <= tol.limit_deg) & (cpl <= tol.coupling_deg)
            & ((depth <= tol.penetration_mm) | (not options.check_collisions))
            & ((odepth <= tol.object_penetration_mm) | (not options.check_collisions))
        )  # fmt: skip

    level = np.where(passes(STRICT), 2, np.where(passes(options.acceptance), 1, 0))
    return level, q, T, params, dmax, amax


# -- the waves ----------------------------------------------------------------------------
def _pose_index(group: Group, sequence: InitialPoseSequence) -> np.ndarray:
    names = {n: i for i, n in enumerate(sequence.names)}
    return np.array([names.get(n, -1) if n is not None else -1 for n in group.pose_names], dtype=np.int64)


def run_kernel(group: Group, problem: np.ndarray, x0: np.ndarray, options: LocalOptions) -> K.Outputs:
    """Run the kernel on states ``(problem[s], x0[s])`` of a group -> :class:`._kernel.Outputs`."""
    out = K.Outputs.allocate(len(problem), group.nx)
    if len(problem):
        aot(K.run_states)(np.asarray(problem, dtype=np.int64), np.ascontiguousarray(x0, dtype=float), group.pdata,
                     group.arrays, group.layout, options.kernel_options(), group.obj, out)  # fmt: skip
    return out


@dataclass
class _Tally:
    """What the waves found so far, per problem (see :class:`LocalRecord`)."""

    P: int
    imax: int
    nx: int
    n_dof: int

    def __post_init__(self):
        P = self.P
        counts = np.zeros((6, P), np.int64)  # one allocation per dtype, rows as views
        self.solved_with, self.tried, self.polish, self.rejected, self.level, self.retries = counts
        self.iters = np.zeros((P, self.imax), np.int64)
        self.q, self.T, self.x = np.zeros((P, self.n_dof)), np.zeros((P, 4, 4)), np.zeros((P, self.nx))
        self.d, self.a, self.miss, self.miss_d, self.miss_a = np.zeros((5, P))
        self.miss[:] = np.inf
        self.miss_d[:] = self.miss_a[:] = np.nan
        self.verified: list = [None] * P  # strict solutions already made by make_solution

    def closest_miss(self, pi, lev, dmax, amax):
        """Remember the closest ``d_min``-only answer of each problem."""
        worst = np.maximum(dmax, amax)
        closer = (lev == 1) & (worst < self.miss[pi])
        self.miss[pi[closer]], self.miss_d[pi[closer]], self.miss_a[pi[closer]] = worst[closer], dmax[closer], amax[closer]

    def hold(self, pi, wave, out, sel, lev, q, T, dmax, amax):
        """Keep the answers ``sel`` (states of this wave) of problems ``pi``."""
        self.solved_with[pi], self.polish[pi], self.level[pi] = wave + 1, out.polish_iterations[sel], lev
        self.q[pi], self.T[pi], self.x[pi], self.d[pi], self.a[pi] = q, T, out.x[sel], dmax, amax

    def record(self, group: Group, p: int, task=None, time_limit_s: float | None = None) -> "LocalRecord":
        held = self.solved_with[p] > 0
        n = int(self.tried[p])
        params = tuple((h[0], o[0]) for h, o in group.params_of(self.x[p])) if held else None
        lev = int(self.level[p])
        return LocalRecord(
            p, lev == 2, ("strict" if lev == 2 else "d_min") if held else None,
            self.q[p].copy() if held else None, self.T[p].copy() if held else None, params,
            int(self.solved_with[p]), n, int(self.iters[p, :n].sum()), tuple(int(v) for v in self.iters[p, :n]),
            int(self.polish[p]), int(self.rejected[p]),
            float(self.d[p] if held else self.miss_d[p]), float(self.a[p] if held else self.miss_a[p]), self.imax,
            (task, self.verified[p]) if (task is not None and self.verified[p] is not None) else None,
            None if held else time_limit_s,
        )  # fmt: skip


def _starts(group: Group, sequence: InitialPoseSequence, wave: int, todo: np.ndarray, options: LocalOptions,
            rng, extra: "_RandomPoses") -> np.ndarray:  # fmt: skip
    """Unknowns (S, nx) of wave ``wave`` for problems ``todo``: the sequence's pose; beyond
    its length random hand poses of the whole pose space (:class:`_RandomPoses`: the
    sequence's poses all lie in one plane); with ``initial="random"`` random lambdas."""
    S = len(todo)
    if options.initial == "sequence" and wave >= len(sequence):
        return _place_poses(group, extra.names, np.array([extra.pose(group, p, wave - len(sequence)) for p in todo]))
    if options.initial == "sequence":  # the same row for every problem: placed once per group shape and wave
        return np.repeat(_sequence_start(group, sequence, wave), S, axis=0)
    if isinstance(rng, list):  # one generator per problem: its draws do not depend on the batch
        lam = np.array([rng[p].uniform(0.0, 1.0, 2) for p in todo]).reshape(S, 2)
    else:
        lam = rng.uniform(0.0, 1.0, (S, 2))
    return _place_poses(group, sequence.names, sequence.poses(lam))


class _RandomPoses:
    """Random collision-free hand poses for the waves beyond the sequence, drawn per problem
    from a generator seeded by ``(seed, the problem's data)``: a problem gets the same
    poses in any batch, so a batch gives what one call per problem gives."""

    def __init__(self, hand, seed, count: int, deadline: float | None = None):
        self.hand, self.seed, self.count = hand, seed, count  # seed: one int, or one per problem
        self.deadline = deadline
        self.names: tuple = ()
        self._poses: dict[int, np.ndarray] = {}

    def pose(self, group: Group, p: int, k: int) -> np.ndarray:
        if p not in self._poses:
            key = zlib.crc32(np.ascontiguousarray(group.pdata[p]).tobytes())
            seed = self.seed[p] if isinstance(self.seed, list) else self.seed
            seed = seed.pose_seed if isinstance(seed, _OwnGenerator) else seed
            self.names, self._poses[p] = sample_poses(self.hand, self.count, np.random.default_rng([seed, key]),
                                                      deadline=self.deadline)  # fmt: skip
        return self._poses[p][k]


def _sequence_start(group: Group, sequence: InitialPoseSequence, wave: int) -> np.ndarray:
    """``_place_poses`` of the sequence's pose ``wave`` for one problem, (1, nx), read-only;
    kept per sequence for the group's default unknowns and pose names (eq. 11 and the
    placing are element by element: a row does not depend on the others)."""

    def place():
        row = _place_poses(group, sequence.names, sequence.poses(sequence.lambdas[wave : wave + 1]))
        row.setflags(write=False)
        return row

    return _starts_of(sequence).get((group.x_default, group.pose_names), wave, place)


@cached_per_value
def _starts_of(sequence: InitialPoseSequence) -> IdentityCache:
    """The rows of :func:`_sequence_start` of one sequence, by group defaults and wave."""
    return IdentityCache()


def _place_poses(group: Group, names, poses: np.ndarray) -> np.ndarray:
    """The group's unknowns (S, nx) with the named pose components ``poses (S, D)`` placed."""
    pidx, use = _pose_columns(tuple(group.pose_names), tuple(names))
    x0 = np.repeat(group.x_default[None], poses.shape[0], axis=0)
    x0[:, use] = poses[:, pidx[use]]
    return x0


@lru_cache(maxsize=64)
def _pose_columns(pose_names: tuple, names: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Per unknown, the column of its pose component in ``names`` (-1: none), and which have one."""
    where = {n: i for i, n in enumerate(names)}
    pidx = np.array([where.get(n, -1) if n is not None else -1 for n in pose_names], dtype=np.int64)
    pidx.setflags(write=False)
    use = pidx >= 0
    use.setflags(write=False)
    return pidx, use


def _is_local_solution(status: np.ndarray) -> np.ndarray:
    """``np.isin(status, K.LOCAL_SOLUTIONS)`` for the kernel's few status codes, without isin's sorting."""
    found = np.zeros(status.shape, dtype=bool)
    for code in K.LOCAL_SOLUTIONS:
        found |= status == code
    return found


def _wave(group, checker, options, tally: _Tally, todo, wave, x0) -> tuple[np.ndarray, float]:
    """Run one wave for problems ``todo``; the problems done after it, and the check time.

    ``checker(idx, x, R, t) -> (level, q, T, params, dmax, amax, solutions)`` judges the
    local solutions (:func:`_check` for point problems, :func:`_check_tasks` for tasks).
    """
    out = run_kernel(group, todo, x0, options)
    t1 = time.perf_counter()
    tally.tried[todo] += 1
    tally.iters[todo, wave] = out.iterations
    tally.rejected[todo[out.status == K.COLLIDING]] += 1
    had_fallback = tally.level[todo] == 1
    got_strict = np.zeros(len(todo), dtype=bool)
    sel = np.flatnonzero(_is_local_solution(out.status))
    if sel.size:
        pi = todo[sel]
        lev, q, T, _, dmax, amax, sols = checker(pi, out.x[sel], out.R[sel], out.t[sel])
        tally.closest_miss(pi, lev, dmax, amax)
        # keep a strict answer always; a d_min answer only when asked for and there is none yet
        keep = (lev == 2) | ((lev == 1) & (tally.level[pi] == 0) & options.approximate)
        tally.hold(pi[keep], wave, out, sel[keep], lev[keep], q[keep], T[keep], dmax[keep], amax[keep])
        for k in np.flatnonzero(keep):
            tally.verified[pi[k]] = sols[k]
        tally.rejected[pi[lev == 0]] += 1
        got_strict[sel[lev == 2]] = True
        tally.retries[pi[(lev == 1) & keep]] = options.strict_retries
    # done with a strict answer, or with a d_min answer and no retries left
    tally.retries[todo[had_fallback & ~got_strict]] -= 1
    done = got_strict | ((tally.level[todo] == 1) & (tally.retries[todo] <= 0))
    return done, time.perf_counter() - t1


def _solve_group(group: Group, checker, options: LocalOptions, sequence: InitialPoseSequence | None, rng, t_start,
                 tasks=None, deadline: float | None = None):  # fmt: skip
    """The waves of one group until every problem is done, ``i_max`` poses are tried, or
    ``deadline`` passes (no sequence: the deadline passed while it was drawn)."""
    P, imax = group.n_problems, options.i_max
    tally = _Tally(P, imax, group.nx, group.hand.n_dof)
    if isinstance(rng, list):
        seeds = [int(r.integers(2**62)) for r in rng]
    else:
        seeds = rng if isinstance(rng, _OwnGenerator) else int(rng.integers(2**62))  # the former draws on use
    extra = _RandomPoses(group.hand, seeds, max(imax - len(sequence or ()), 0), deadline)
    wave_seconds = np.zeros(imax)
    todo = np.arange(P)
    kernel_s = check_s = 0.0
    stopped = sequence is None
    for i in range(0 if stopped else imax):
        if not todo.size:  # every problem done: the later waves take no time
            wave_seconds[i:] = wave_seconds[i - 1] if i else time.perf_counter() - t_start
            break
        try:
            if deadline is not None and seconds_left(deadline) <= 0:
                raise TimeLimitReached("local solver")
            x0 = _starts(group, sequence, i, todo, options, rng, extra)
        except TimeLimitReached:
            stopped = True
            break
        t0 = time.perf_counter()
        done, dt = _wave(group, checker, options, tally, todo, i, x0)
        check_s += dt
        kernel_s += time.perf_counter() - t0 - dt
        todo = todo[~done]
        wave_seconds[i] = time.perf_counter() - t_start
    limit = options.time_limit_s if stopped else None
    records = [tally.record(group, p, tasks[p] if tasks is not None else None, limit) for p in range(P)]
    strict = tally.level == 2
    solved_after = np.cumsum(np.bincount(tally.solved_with[strict], minlength=imax + 1))[1 : imax + 1]
    return records, wave_seconds, solved_after, {"kernel": kernel_s, "checks": check_s}


def _sequence_for(hand, sequence, deadline):
    """``sequence``, else the hand's default; ``None`` when the deadline passed while the
    default was drawn (its problems then give up, saying so)."""
    if sequence is not None:
        return sequence
    try:
        return default_sequence(hand, deadline=deadline)
    except TimeLimitReached:
        return None


def _as_rng(rng, n: int, one_group: bool = False):
    """One generator for the batch, or a list of ``n`` (one per problem) from a sequence.

    With ``one_group`` and a seed (not a generator): an :class:`_OwnGenerator`, made only
    if a draw is asked for (most calls never draw: the sequence's poses are enough)."""
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, (list, tuple, np.ndarray)):
        if len(rng) != n:
            raise InvalidTask(f"solve_local_batch: rng holds {len(rng)} seeds for {n} problems; give one per problem")
        return [r if isinstance(r, np.random.Generator) else np.random.default_rng(r) for r in rng]
    seed = 0 if rng is None else rng
    plain = isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0  # numpy would accept it
    return _OwnGenerator(seed) if one_group and plain else np.random.default_rng(seed)


class _OwnGenerator:
    """``np.random.default_rng(seed)`` for one group, made on first use (~30 us saved on
    each call that draws nothing).  Its first draw is :attr:`pose_seed`, as
    :func:`_solve_group` draws first from a generator it is given, so every draw is the
    one the eager generator gives."""

    def __init__(self, seed):
        self.seed, self._generator, self._pose_seed = seed, None, 0

    def _made(self) -> np.random.Generator:
        if self._generator is None:
            self._generator = np.random.default_rng(self.seed)
            self._pose_seed = int(self._generator.integers(2**62))
        return self._generator

    @property
    def pose_seed(self) -> int:
        self._made()
        return self._pose_seed

    def uniform(self, low, high, size):
        return self._made().uniform(low, high, size)


def _subset(rng, members):
    return [rng[k] for k in members] if isinstance(rng, list) else rng


def solve_local_batch(
    problems: PointProblems | Sequence[Task],
    options: LocalOptions = LocalOptions(),
    sequence: InitialPoseSequence | None = None,
    rng=None,
) -> LocalBatch:
    """Solve many problems of one hand in one call.

    Args:
        problems: a :class:`PointProblems` (the fast compact form) or a list of tasks.
            Tasks are grouped by structure (:func:`.problems.structure_key`); each group
            runs as one batch.
        options: solver options.
        sequence: initial-pose sequence (default: the hand's shipped sequence, else
            :func:`.sequence.default_sequence`).
        rng: seed or ``numpy.random.Generator`` for random initial poses (the
            ``initial="random"`` option, and poses beyond the sequence's length); or a
            sequence of them, one per problem: each problem then draws from its own,
            and its answer is the one it gets alone with that seed (a batch changes
            nothing but speed).

    Returns:
        A :class:`LocalBatch` with one :class:`LocalRecord` per problem, in input order.
        Unreachable problems get ``success = False`` and a "no solution found" message;
        the solver does not raise on them.
    """
    t_start = time.perf_counter()
    deadline = deadline_after(options.time_limit_s, t_start)
    if isinstance(problems, PointProblems):
        rng = _as_rng(rng, len(problems), one_group=True)
        hand = problems.hand
        if len(problems) == 0:
            return LocalBatch([], 0.0, np.zeros(options.i_max), np.zeros(options.i_max, dtype=int), options, sequence)
        sequence = _sequence_for(hand, sequence, deadline)
        group = problems.group(options.joint_scale_mm)
        points = lambda idx, pose, T, prm: _contact_checks_points(problems, idx, pose, T, prm)  # noqa: E731
        checker = lambda idx, x, R, t: (*_check(group, points, idx, x, R, t, options), [None] * len(idx))  # noqa: E731
        records, waves, after, timings = _solve_group(group, checker, options, sequence, rng, t_start, None, deadline)
        return LocalBatch(records, time.perf_counter() - t_start, waves, after, options, sequence, timings)

    tasks = list(problems)
    if not tasks:
        return LocalBatch([], 0.0, np.zeros(options.i_max), np.zeros(options.i_max, dtype=int), options, sequence)
    for t in tasks:
        if not isinstance(t, Task):
            raise InvalidTask(f"solve_local_batch takes PointProblems or a list of Task; got {type(t).__name__}")
    groups: dict = {}
    for i, t in enumerate(tasks):
        groups.setdefault(structure_key(t), []).append(i)
    rng = _as_rng(rng, len(tasks), one_group=len(groups) == 1)
    records: list = [None] * len(tasks)
    waves = np.zeros(options.i_max)
    after = np.zeros(options.i_max, dtype=int)
    timings = {"kernel": 0.0, "checks": 0.0}
    seq_used = sequence
    for members in groups.values():
        sub = [tasks[i] for i in members]
        seq = _sequence_for(sub[0].hand, sequence, deadline)
        seq_used = seq
        group = group_from_tasks(sub, options.joint_scale_mm)
        checker = lambda idx, x, R, t, g=group, sub=sub: _check_tasks(g, sub, idx, x, R, t, options)  # noqa: E731
        recs, w, a, tm = _solve_group(group, checker, options, seq, _subset(rng, members), time.perf_counter(), sub,
                                      deadline)  # fmt: skip
        for k, r in zip(members, recs):
            r.index = k
            records[k] = r
        waves += w
        after += a
        for key in timings:
            timings[key] += tm[key]
    return LocalBatch(records, time.perf_counter() - t_start, waves, after, options, seq_used, timings)


def solve_local(
    task: Task,
    options: LocalOptions = LocalOptions(),
    sequence: InitialPoseSequence | None = None,
    rng=None,
    *,
    seed: int | None = None,
) -> SolveResult:
    """Solve one task with the local solver (method ``"local"``).

    Returns a :class:`~prehension.results.SolveResult`: status ``"solved"`` with one
    solution re-verified by :func:`~prehension.results.make_solution` (strict tolerances
    whenever polishing reached them, else :attr:`LocalOptions.acceptance`; ``stats``
    says which), or ``"gave_up"`` with the message "no solution found after i initial
    poses and k Jacobian iterations".  ``stats`` holds ``initial_poses_tried``,
    ``iterations``, ``per_pose_iterations`` and the achieved residuals.  ``rng`` (or its
    alias ``seed``) seeds the random initial poses, used only with ``initial="random"``
    or beyond the sequence's length.
    """
    t0 = time.perf_counter()
    batch = solve_local_batch([task], options, sequence, rng if rng is not None else seed)
    extra = {"sequence": batch.sequence.meta.get("origin", batch.sequence.hand) if batch.sequence else None}
    result = batch[0].to_result(task, options, 0.0, extra)
    from dataclasses import replace

    return replace(result, seconds=time.perf_counter() - t0)


# -- refinement from given starts ------------------------------------------------------------
def _unknowns_of(group: Group, starts: Sequence[Configuration]) -> np.ndarray:
    """The kernel's unknowns (S, nx) for starting configurations (joint angles, region params).

    The object pose is not an unknown of the kernel: it is placed from the hand, as for
    the initial poses of the sequence.
    """
    x0 = np.repeat(group.x_default[None], len(starts), axis=0)
    sides = group.layout.sides
    for s, cfg in enumerate(starts):
        x0[s, : group.nf] = np.asarray(cfg.joint_angles, dtype=float)[list(group.free)]
        for c, (hp, op) in enumerate(cfg.contact_params or ()):
            (xh, kh), (xo, ko) = sides[c, 0, [S_X, S_K]], sides[c, 1, [S_X, S_K]]
            x0[s, xh : xh + kh] = hp
            x0[s, xo : xo + ko] = op
    return np.clip(x0, group.layout.lo, group.layout.hi)


@dataclass(frozen=True, eq=False)
class Refinement:
    """What :func:`refine_local` reached from each start.

    Attributes:
        configurations: per start, the configuration reached when it meets the strict
            tolerances, else ``None``.
        contact_mm: per start, the largest contact distance at the end of the
            iterations [mm] (also for starts that failed: how close they came).
        normal_deg: per start, the largest normal misalignment at the end [deg].
    """

    configurations: tuple
    contact_mm: np.ndarray
    normal_deg: np.ndarray

    def best(self) -> tuple[float, float]:
        """``(contact_mm, normal_deg)`` of the start that came closest (a 1 mm miss
        weighs as much as a 1 degree one); ``(inf, inf)`` without starts."""
        if not self.contact_mm.size:
            return float("inf"), float("inf")
        k = int(np.argmin(np.maximum(self.contact_mm, self.normal_deg)))
        return float(self.contact_mm[k]), float(self.normal_deg[k])


def refine_local(task: Task, starts: Sequence[Configuration], options: LocalOptions = LocalOptions()) -> Refinement:
    """Run the local iterations (Jacobian steps, polishing, collision repair) from given starts.

    The complete solver verifies its boxes with this: ``starts`` are points read from
    boxes (joint angles and contact parameters; each start must carry
    ``contact_params``).  A start's configuration is kept when it meets the strict
    tolerances (limits, couplings, contacts and collisions checked as in
    :func:`solve_local`).  The iterations may leave the region of the start; callers
    re-verify with :func:`~prehension.results.make_solution`.
    """
    starts = list(starts)
    if not starts:
        return Refinement((), np.zeros(0), np.zeros(0))
    group = group_from_tasks([task], options.joint_scale_mm)
    S = len(starts)
    out = run_kernel(group, np.zeros(S, dtype=np.int64), _unknowns_of(group, starts), options)
    configs: list[Configuration | None] = [None] * S
    sel = np.flatnonzero(np.isin(out.status, K.LOCAL_SOLUTIONS))
    if sel.size:
        level, q, T, params, _, _ = _check(
            group, lambda i, pose, T_, prm: _contact_checks_tasks([task], i, pose, T_, prm), np.zeros(sel.size, dtype=np.int64),
            out.x[sel], out.R[sel], out.t[sel], options,
        )  # fmt: skip
        for k, s in enumerate(sel):
            if level[k] == 2:
                configs[s] = Configuration(q[k].copy(), T[k].copy(), tuple((h[k].copy(), o[k].copy()) for h, o in params))
    # err[:, 1] = w_n |n_hand + n_object| [mm], and |n_h + n_o| = 2 sin(angle / 2)
    chord = np.clip(out.err[:, 1] / (2.0 * options.normal_weight_mm), 0.0, 1.0)
    return Refinement(tuple(configs), out.err[:, 0].copy(), np.degrees(2.0 * np.arcsin(chord)))
