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
:func:`~prehension.verification.residuals.limit_violations`,
:func:`~prehension.verification.residuals.coupling_violations` and the contact residuals of
:mod:`prehension.verification.residuals`); a problem whose local solution fails them goes on to
its next initial pose, as in the paper after a collision.

A problem is *solved* only by a configuration that meets the strict default
:class:`~prehension.verification.residuals.Tolerances`.  A configuration that meets only the
paper's ``d_min`` tolerances (:attr:`LocalOptions.acceptance`) is returned, with the status
``"approximate"``, only when :attr:`LocalOptions.approximate` asks for it; otherwise it is
the problem's *closest miss*, reported in ``stats``.  :meth:`LocalRecord.to_result`
re-checks every configuration with :func:`~prehension.results.make_solution`, so a
:class:`SolveResult` never holds an unverified configuration.

The stage's modules: :mod:`._starts` (the initial unknowns of each wave), :mod:`._waves`
(the waves of one group), :mod:`._checks` (the checks), :mod:`.records` (what is
reported), :mod:`.refine` (the iterations from given starts, for the complete solver).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Sequence

import numpy as np

from ...deadline import deadline_after
from ...errors import InvalidTask
from ...results import SolveResult
from ...tasks.model import Task
from ._checks import check, check_tasks, contact_checks_points
from ._starts import as_rng, sequence_for, subset_rng
from ._waves import run_kernel, solve_group
from .options import STRICT, LocalOptions
from .problems import PointProblems, group_from_tasks, structure_key
from .records import LocalBatch, LocalRecord
from .refine import Refinement, refine_local
from .sequence import InitialPoseSequence

__all__ = ["solve_local", "solve_local_batch", "refine_local", "run_kernel", "Refinement", "LocalRecord", "LocalBatch", "STRICT"]


def solve_local_batch(
    problems: PointProblems | Sequence[Task],
    options: LocalOptions = LocalOptions(),
    sequence: InitialPoseSequence | None = None,
    rng=None,
    *,
    poses: tuple[int, int] | None = None,
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
        poses: ``(start, stop)``: try only the initial poses ``start`` to ``stop - 1``
            (0-based, ``stop <= i_max``; ``None``: all ``i_max``).  A problem that none of
            the poses before ``start`` solved gets from them exactly what a call from the
            first pose gives it: the poses and draws of a wave do not depend on the
            earlier ones (the assignment search's rounds; records count the poses of the
            range only).  ``start > 0`` needs ``initial="sequence"`` and no
            ``approximate`` (whose retries carry from wave to wave).

    Returns:
        A :class:`LocalBatch` with one :class:`LocalRecord` per problem, in input order.
        Unreachable problems get ``success = False`` and a "no solution found" message;
        the solver does not raise on them.
    """
    t_start = time.perf_counter()
    deadline = deadline_after(options.time_limit_s, t_start)
    waves = _waves_of(poses, options)
    if isinstance(problems, PointProblems):
        return _solve_points(problems, options, sequence, rng, (t_start, deadline), waves)
    return _solve_tasks(list(problems), options, sequence, rng, (t_start, deadline), waves)


def _waves_of(poses, options: LocalOptions) -> range:
    """The waves of ``poses = (start, stop)`` (``None``: all), checked."""
    if poses is None:
        return range(options.i_max)
    ok = isinstance(poses, (tuple, list)) and len(poses) == 2 and all(isinstance(v, (int, np.integer)) for v in poses)
    if not ok or not 0 <= poses[0] < poses[1] <= options.i_max:
        raise InvalidTask(f"solve_local_batch: poses must be (start, stop) with 0 <= start < stop <= i_max = "
                          f"{options.i_max}, got {poses!r}")  # fmt: skip
    if poses[0] > 0 and (options.initial != "sequence" or options.approximate):
        raise InvalidTask("solve_local_batch: poses starting after the first need initial='sequence' and "
                          "approximate=False (random lambdas and d_min retries depend on the earlier poses)")  # fmt: skip
    return range(int(poses[0]), int(poses[1]))


def _empty(options: LocalOptions, sequence: InitialPoseSequence | None) -> LocalBatch:
    return LocalBatch([], 0.0, np.zeros(options.i_max), np.zeros(options.i_max, dtype=int), options, sequence)


def _solve_points(problems: PointProblems, options: LocalOptions, sequence, rng, clock, waves: range) -> LocalBatch:
    """:func:`solve_local_batch` of point problems: one group, judged by :func:`._checks.check`;
    ``clock = (start, deadline)``."""
    t_start, deadline = clock
    rng = as_rng(rng, len(problems), one_group=True)
    if len(problems) == 0:
        return _empty(options, sequence)
    sequence = sequence_for(problems.hand, sequence, deadline)
    group = problems.group(options.joint_scale_mm)
    points = lambda idx, pose, T, prm: contact_checks_points(problems, idx, pose, T, prm)  # noqa: E731
    checker = lambda idx, x, R, t: check(group, points, idx, x, R, t, options)  # noqa: E731
    records, seconds, after, timings = solve_group(group, checker, options, sequence, rng, clock, None, waves)
    return LocalBatch(records, time.perf_counter() - t_start, seconds, after, options, sequence, timings)


def _solve_tasks(tasks: list, options: LocalOptions, sequence, rng, clock, poses: range) -> LocalBatch:
    """:func:`solve_local_batch` of tasks: one group per structure, judged by
    :func:`._checks.check_tasks`; ``clock = (start, deadline)``."""
    t_start, deadline = clock
    if not tasks:
        return _empty(options, sequence)
    for t in tasks:
        if not isinstance(t, Task):
            raise InvalidTask(f"solve_local_batch takes PointProblems or a list of Task; got {type(t).__name__}")
    groups: dict = {}
    for i, t in enumerate(tasks):
        groups.setdefault(structure_key(t), []).append(i)
    rng = as_rng(rng, len(tasks), one_group=len(groups) == 1)
    records: list = [None] * len(tasks)
    waves = np.zeros(options.i_max)
    after = np.zeros(options.i_max, dtype=int)
    timings = {"kernel": 0.0, "checks": 0.0}
    seq_used = sequence
    for members in groups.values():
        sub = [tasks[i] for i in members]
        seq = sequence_for(sub[0].hand, sequence, deadline)
        seq_used = seq
        group = group_from_tasks(sub, options.joint_scale_mm)
        checker = lambda idx, x, R, t, g=group, sub=sub: check_tasks(g, sub, idx, x, R, t, options)  # noqa: E731
        recs, w, a, tm = solve_group(group, checker, options, seq, subset_rng(rng, members), (time.perf_counter(), deadline),
                                     sub, poses)  # fmt: skip
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
    return replace(result, seconds=time.perf_counter() - t0)
