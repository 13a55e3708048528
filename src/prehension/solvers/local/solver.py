"""The local solver: Algorithm 1 of Claret & Suárez over batches of problems.

:func:`solve_local_batch` solves many problems of one hand in one call; :func:`solve_local`
solves one task and returns the :class:`~prehension.results.SolveResult` both solvers
share.  The outer loop of Algorithm 1 runs in *waves*: wave ``i`` starts every problem
not solved yet from its ``i``-th initial pose, so each problem sees exactly the sequence
of initial poses the paper's algorithm would give it, while the compiled kernel
(:mod:`._kernel`) runs the inner loops of the whole wave at once.  After each wave the
local solutions are checked with the foundation's own batch functions
(:func:`~prehension.hands.kinematics.forward_kinematics`,
:func:`~prehension.hands.collision.capsule_clearances` -- the paper's Check_Collisions --,
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
from dataclasses import asdict, dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import InvalidTask
from ...geometry.rotations import angle_between
from ...hands.collision import capsule_clearances
from ...hands.kinematics import HandPose, forward_kinematics
from ...results import SolveResult, Status, make_solution
from ...tasks.model import Configuration, Task
from ...tasks.residuals import Tolerances, contact_residuals, coupling_violations, limit_violations
from . import _kernel as K
from ._group import Group
from .options import LocalOptions
from .problems import PointProblems, group_from_tasks, structure_key
from .sequence import InitialPoseSequence, default_sequence

__all__ = ["solve_local", "solve_local_batch", "refine_local", "Refinement", "LocalRecord", "LocalBatch", "STRICT"]

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
        return (
            f"no solution found after {self.initial_poses_tried} initial poses and {self.iterations} "
            f"Jacobian iterations{extra}"
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
        config = self.configuration()
        if config is None:
            return SolveResult(task, "local", Status.GAVE_UP, self.message, (), seconds, stats)
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
    """Contact residuals of tasks: the foundation's :func:`contact_residuals`, one task at a time."""
    out = [[], [], [], []]
    for s, i in enumerate(idx):
        sub = HandPose(pose.R_palm_link[s : s + 1], pose.r_palm_link[s : s + 1], pose.axis_palm[s : s + 1], pose.origin_palm[s : s + 1])
        prm = [(h[s : s + 1], o[s : s + 1]) for h, o in params]
        res = contact_residuals(tasks[i], sub, T[s : s + 1], prm)
        for k, key in enumerate(("distance_mm", "normal_angle_deg", "hand_region", "object_region")):
            out[k].append(res[key][0])
    return tuple(np.array(v) for v in out)


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
    clearance, _ = capsule_clearances(hand, pose)
    depth = np.max(np.maximum(-clearance, 0.0), axis=1) if clearance.shape[1] else np.zeros(S)
    lim = np.degrees(np.max(limit_violations(hand, q), axis=1))
    cpl = coupling_violations(hand, q)
    cpl = np.degrees(np.max(cpl, axis=1)) if cpl.shape[1] else np.zeros(S)
    dist, ang, hreg, oreg = contact_fn(idx, pose, T, params)
    dmax, amax = dist.max(axis=1), ang.max(axis=1)
    region = np.maximum(hreg.max(axis=1), oreg.max(axis=1))

    def passes(tol: Tolerances):
        return (
            (dmax <= tol.contact_mm) & (amax <= tol.normal_deg) & (region <= tol.region)
            & (lim <= tol.limit_deg) & (cpl <= tol.coupling_deg)
            & ((depth <= tol.penetration_mm) | (not options.check_collisions))
        )  # fmt: skip

    level = np.where(passes(STRICT), 2, np.where(passes(options.acceptance), 1, 0))
    return level, q, T, params, dmax, amax


# -- the waves ----------------------------------------------------------------------------
def _pose_index(group: Group, sequence: InitialPoseSequence) -> np.ndarray:
    names = {n: i for i, n in enumerate(sequence.names)}
    return np.array([names.get(n, -1) if n is not None else -1 for n in group.pose_names], dtype=np.int64)


def _solve_group(group: Group, contact_fn, options: LocalOptions, sequence: InitialPoseSequence, rng, t_start):
    P = group.n_problems
    imax = options.i_max
    nx = group.nx
    pidx = _pose_index(group, sequence)
    use = pidx >= 0
    opt = options.kernel_array()
    args = group.kernel_args()

    solved_with = np.zeros(P, dtype=np.int64)
    tried = np.zeros(P, dtype=np.int64)
    iters = np.zeros((P, imax), dtype=np.int64)
    polish = np.zeros(P, dtype=np.int64)
    rejected = np.zeros(P, dtype=np.int64)
    level = np.zeros(P, dtype=np.int64)
    retries = np.zeros(P, dtype=np.int64)
    out_q = np.zeros((P, group.hand.n_dof))
    out_T = np.zeros((P, 4, 4))
    out_x = np.zeros((P, nx))
    out_d = np.zeros(P)
    out_a = np.zeros(P)
    miss, miss_d, miss_a = np.full(P, np.inf), np.full(P, np.nan), np.full(P, np.nan)  # closest d_min miss
    wave_seconds = np.zeros(imax)
    todo = np.arange(P)
    kernel_s = check_s = 0.0
    for i in range(imax):
        if todo.size == 0:
            wave_seconds[i] = time.perf_counter() - t_start
            continue
        S = todo.size
        if options.initial == "sequence" and i < len(sequence):
            lam = np.repeat(sequence.lambdas[i : i + 1], S, axis=0)
        elif isinstance(rng, list):  # one generator per problem: draws independent of the batch
            lam = np.array([rng[p].uniform(0.0, 1.0, 2) for p in todo]).reshape(S, 2)
        else:
            lam = rng.uniform(0.0, 1.0, (S, 2))
        poses = sequence.poses(lam)
        x0 = np.repeat(group.x_default[None], S, axis=0)
        x0[:, use] = poses[:, pidx[use]]
        status = np.zeros(S, dtype=np.int64)
        it = np.zeros(S, dtype=np.int64)
        pit = np.zeros(S, dtype=np.int64)
        xo = np.zeros((S, nx))
        Ro = np.zeros((S, 3, 3))
        to = np.zeros((S, 3))
        eo = np.zeros((S, 2))
        t0 = time.perf_counter()
        K.run_states(todo, x0, group.pdata, group.piv_off, *args, opt, status, it, pit, xo, Ro, to, eo)
        t1 = time.perf_counter()
        kernel_s += t1 - t0
        tried[todo] += 1
        iters[todo, i] = it
        local = (status == K.SOLVED_STRICT) | (status == K.SOLVED_DMIN)
        rejected[todo[status == K.FAILED_COLLISION]] += 1
        had_fallback = level[todo] == 1
        got_strict = np.zeros(S, dtype=bool)
        if local.any():
            sel = np.flatnonzero(local)
            lev, q, T, params, dmax, amax = _check(group, contact_fn, todo[sel], xo[sel], Ro[sel], to[sel], options)
            closer = (lev == 1) & (np.maximum(dmax, amax) < miss[todo[sel]])
            miss_d[todo[sel[closer]]], miss_a[todo[sel[closer]]] = dmax[closer], amax[closer]
            miss[todo[sel[closer]]] = np.maximum(dmax, amax)[closer]
            # keep a strict answer always; a d_min answer only when asked for and there is none yet
            keep = (lev == 2) | ((lev == 1) & (level[todo[sel]] == 0) & options.approximate)
            g = sel[keep]
            pi = todo[g]
            solved_with[pi] = i + 1
            polish[pi] = pit[g]
            level[pi] = lev[keep]
            out_q[pi] = q[keep]
            out_T[pi] = T[keep]
            out_x[pi] = xo[g]
            out_d[pi] = dmax[keep]
            out_a[pi] = amax[keep]
            rejected[todo[sel[lev == 0]]] += 1
            got_strict[sel[lev == 2]] = True
            new_fb = sel[(lev == 1) & keep]
            retries[todo[new_fb]] = options.strict_retries
        # a problem is done with a strict answer, or with a d_min answer and no retries left
        retries[todo[had_fallback & ~got_strict]] -= 1
        done = got_strict | ((level[todo] == 1) & (retries[todo] <= 0))
        check_s += time.perf_counter() - t1
        todo = todo[~done]
        wave_seconds[i] = time.perf_counter() - t_start
    params_all = group.params_of(out_x)
    records = []
    for p in range(P):
        held = solved_with[p] > 0
        n_tried = int(tried[p])
        records.append(
            LocalRecord(
                p, bool(level[p] == 2), ("strict" if level[p] == 2 else "d_min") if held else None,
                out_q[p].copy() if held else None, out_T[p].copy() if held else None,
                tuple((h[p].copy(), o[p].copy()) for h, o in params_all) if held else None,
                int(solved_with[p]), n_tried, int(iters[p, :n_tried].sum()),
                tuple(int(v) for v in iters[p, :n_tried]), int(polish[p]), int(rejected[p]),
                float(out_d[p] if held else miss_d[p]), float(out_a[p] if held else miss_a[p]), imax,
            )  # fmt: skip
        )
    strict = level == 2
    solved_after = np.array([strict & (solved_with <= i + 1) for i in range(imax)]).sum(axis=1)
    return records, wave_seconds, solved_after, {"kernel": kernel_s, "checks": check_s}


def _as_rng(rng, n: int):
    """One generator for the batch, or a list of ``n`` (one per problem) from a sequence."""
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, (list, tuple, np.ndarray)):
        if len(rng) != n:
            raise InvalidTask(f"solve_local_batch: rng holds {len(rng)} seeds for {n} problems; give one per problem")
        return [r if isinstance(r, np.random.Generator) else np.random.default_rng(r) for r in rng]
    return np.random.default_rng(0 if rng is None else rng)


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
            nothing but speed: every scale is per problem too).

    Returns:
        A :class:`LocalBatch` with one :class:`LocalRecord` per problem, in input order.
        Unreachable problems get ``success = False`` and a "no solution found" message;
        the solver does not raise on them.
    """
    t_start = time.perf_counter()
    if isinstance(problems, PointProblems):
        rng = _as_rng(rng, len(problems))
        hand = problems.hand
        sequence = sequence if sequence is not None else default_sequence(hand)
        if len(problems) == 0:
            return LocalBatch([], 0.0, np.zeros(options.i_max), np.zeros(options.i_max, dtype=int), options, sequence)
        group = problems.group(options.joint_scale_mm)
        records, waves, after, timings = _solve_group(
            group, lambda idx, pose, T, prm: _contact_checks_points(problems, idx, pose, T, prm),
            options, sequence, rng, t_start,
        )  # fmt: skip
        return LocalBatch(records, time.perf_counter() - t_start, waves, after, options, sequence, timings)

    tasks = list(problems)
    rng = _as_rng(rng, len(tasks))
    if not tasks:
        return LocalBatch([], 0.0, np.zeros(options.i_max), np.zeros(options.i_max, dtype=int), options, sequence)
    for t in tasks:
        if not isinstance(t, Task):
            raise InvalidTask(f"solve_local_batch takes PointProblems or a list of Task; got {type(t).__name__}")
    groups: dict = {}
    for i, t in enumerate(tasks):
        groups.setdefault(structure_key(t), []).append(i)
    records: list = [None] * len(tasks)
    waves = np.zeros(options.i_max)
    after = np.zeros(options.i_max, dtype=int)
    timings = {"kernel": 0.0, "checks": 0.0}
    seq_used = sequence
    for members in groups.values():
        sub = [tasks[i] for i in members]
        seq = sequence if sequence is not None else default_sequence(sub[0].hand)
        seq_used = seq
        group = group_from_tasks(sub, options.joint_scale_mm)
        recs, w, a, tm = _solve_group(
            group, lambda idx, pose, T, prm, sub=sub: _contact_checks_tasks(sub, idx, pose, T, prm),
            options, seq, _subset(rng, members), time.perf_counter(),
        )  # fmt: skip
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
    for s, cfg in enumerate(starts):
        x0[s, : group.nf] = np.asarray(cfg.joint_angles, dtype=float)[group.free]
        for c, (hp, op) in enumerate(cfg.contact_params or ()):
            xh, kh, xo, ko = (int(group.cint[c, k]) for k in (K.C_XH, K.C_KH, K.C_XO, K.C_KO))
            x0[s, xh : xh + kh] = hp
            x0[s, xo : xo + ko] = op
    return np.clip(x0, group.lo, group.hi)


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
    x0 = _unknowns_of(group, starts)
    status = np.zeros(S, dtype=np.int64)
    it, pit = np.zeros(S, dtype=np.int64), np.zeros(S, dtype=np.int64)
    xo, Ro, to, eo = np.zeros((S, group.nx)), np.zeros((S, 3, 3)), np.zeros((S, 3)), np.zeros((S, 2))
    K.run_states(np.zeros(S, dtype=np.int64), x0, group.pdata, group.piv_off, *group.kernel_args(),
                 options.kernel_array(), status, it, pit, xo, Ro, to, eo)  # fmt: skip
    out: list[Configuration | None] = [None] * S
    sel = np.flatnonzero((status == K.SOLVED_STRICT) | (status == K.SOLVED_DMIN))
    if sel.size:
        idx = np.zeros(sel.size, dtype=np.int64)
        level, q, T, params, _, _ = _check(
            group, lambda i, pose, T_, prm: _contact_checks_tasks([task], i, pose, T_, prm), idx, xo[sel], Ro[sel],
            to[sel], options,
        )  # fmt: skip
        for k, s in enumerate(sel):
            if level[k] == 2:
                out[s] = Configuration(q[k].copy(), T[k].copy(), tuple((h[k].copy(), o[k].copy()) for h, o in params))
    # eo[:, 1] = w_n |n_hand + n_object| [mm], and |n_h + n_o| = 2 sin(angle / 2)
    chord = np.clip(eo[:, 1] / (2.0 * options.normal_weight_mm), 0.0, 1.0)
    return Refinement(tuple(out), eo[:, 0].copy(), np.degrees(2.0 * np.arcsin(chord)))
