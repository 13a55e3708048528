"""The waves of Algorithm 1 (Claret & Suárez) for one group of problems.

The outer loop of Algorithm 1 runs in *waves*: wave ``i`` starts every problem not solved
yet from its ``i``-th initial pose (:mod:`._starts`), so each problem sees exactly the
sequence of initial poses the paper's algorithm would give it, while the compiled kernel
(:mod:`._kernel`, :func:`run_kernel`) runs the inner loops of the whole wave at once.
After each wave a *checker* judges the local solutions (:mod:`._checks`); a problem whose
local solution fails goes on to its next initial pose, as in the paper after a
collision.  :func:`solve_group` returns one :class:`~.records.LocalRecord` per problem.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ...kernels.aot import aot
from ...deadline import TimeLimitReached, seconds_left
from . import _kernel as K
from ._checks import Verdicts
from ._layout import Group
from ._starts import OwnGenerator, RandomPoses, wave_starts
from .options import LocalOptions
from .records import LocalRecord
from .sequence import InitialPoseSequence

__all__ = ["run_kernel", "solve_group"]


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

    def hold(self, pi, wave: int, out: K.Outputs, sel, verdicts: Verdicts):
        """Keep the answers ``sel`` (states of this wave, judged ``verdicts``) of problems ``pi``."""
        self.solved_with[pi], self.polish[pi], self.level[pi] = wave + 1, out.polish_iterations[sel], verdicts.level
        self.q[pi], self.T[pi], self.x[pi] = verdicts.q, verdicts.T, out.x[sel]
        self.d[pi], self.a[pi] = verdicts.dmax, verdicts.amax
        for p, solution in zip(pi, verdicts.solutions):
            self.verified[p] = solution

    def record(self, group: Group, p: int, task=None, time_limit_s: float | None = None, first: int = 0) -> "LocalRecord":
        held = self.solved_with[p] > 0
        n = int(self.tried[p])
        params = tuple((h[0], o[0]) for h, o in group.params_of(self.x[p])) if held else None
        lev = int(self.level[p])
        return LocalRecord(
            p, lev == 2, ("strict" if lev == 2 else "d_min") if held else None,
            self.q[p].copy() if held else None, self.T[p].copy() if held else None, params,
            int(self.solved_with[p]), n, int(self.iters[p, first : first + n].sum()),
            tuple(int(v) for v in self.iters[p, first : first + n]),
            int(self.polish[p]), int(self.rejected[p]),
            float(self.d[p] if held else self.miss_d[p]), float(self.a[p] if held else self.miss_a[p]), self.imax,
            (task, self.verified[p]) if (task is not None and self.verified[p] is not None) else None,
            None if held else time_limit_s,
        )  # fmt: skip


def _is_local_solution(status: np.ndarray) -> np.ndarray:
    """``np.isin(status, K.LOCAL_SOLUTIONS)`` for the kernel's few status codes, without isin's sorting."""
    found = np.zeros(status.shape, dtype=bool)
    for code in K.LOCAL_SOLUTIONS:
        found |= status == code
    return found


def _wave(group, checker, options, tally: _Tally, todo, wave, x0) -> tuple[np.ndarray, float]:
    """Run one wave for problems ``todo``; the problems done after it, and the check time.

    ``checker(idx, x, R, t) -> Verdicts`` (:class:`._checks.Verdicts`) judges the
    local solutions (:func:`check` for point problems, :func:`check_tasks` for tasks).
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
        verdicts = checker(pi, out.x[sel], out.R[sel], out.t[sel])
        lev = verdicts.level
        tally.closest_miss(pi, lev, verdicts.dmax, verdicts.amax)
        # keep a strict answer always; a d_min answer only when asked for and there is none yet
        keep = (lev == 2) | ((lev == 1) & (tally.level[pi] == 0) & options.approximate)
        tally.hold(pi[keep], wave, out, sel[keep], verdicts.select(keep))
        tally.rejected[pi[lev == 0]] += 1
        got_strict[sel[lev == 2]] = True
        tally.retries[pi[(lev == 1) & keep]] = options.strict_retries
    # done with a strict answer, or with a d_min answer and no retries left
    tally.retries[todo[had_fallback & ~got_strict]] -= 1
    done = got_strict | ((tally.level[todo] == 1) & (tally.retries[todo] <= 0))
    return done, time.perf_counter() - t1


def solve_group(group: Group, checker, options: LocalOptions, sequence: InitialPoseSequence | None, rng, clock,
                tasks=None, waves: range | None = None):  # fmt: skip
    """The waves of one group until every problem is done, the last wave is tried, or
    the deadline passes (no sequence: the deadline passed while it was drawn).
    ``clock = (t_start, deadline)``; ``waves``: the initial poses to try, 0-based
    (``None``: all ``i_max``; a later range gives what those waves give in a call from
    the first pose to a problem none of the earlier ones solved)."""
    t_start, deadline = clock
    P, imax = group.n_problems, options.i_max
    waves = range(imax) if waves is None else waves
    tally = _Tally(P, imax, group.nx, group.hand.n_dof)
    if isinstance(rng, list):
        seeds = [int(r.integers(2**62)) for r in rng]
    else:
        seeds = rng if isinstance(rng, OwnGenerator) else int(rng.integers(2**62))  # the former draws on use
    extra = RandomPoses(group.hand, seeds, max(imax - len(sequence or ()), 0), deadline)
    wave_seconds = np.zeros(imax)
    todo = np.arange(P)
    kernel_s = check_s = 0.0
    stopped = sequence is None
    for i in () if stopped else waves:
        if not todo.size:  # every problem done: the later waves take no time
            wave_seconds[i:] = wave_seconds[i - 1] if i > waves.start else time.perf_counter() - t_start
            break
        try:
            if deadline is not None and seconds_left(deadline) <= 0:
                raise TimeLimitReached("local solver")
            x0 = wave_starts(group, sequence, i, todo, options, rng, extra)
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
    records = [tally.record(group, p, tasks[p] if tasks is not None else None, limit, waves.start) for p in range(P)]
    strict = tally.level == 2
    solved_after = np.cumsum(np.bincount(tally.solved_with[strict], minlength=imax + 1))[1 : imax + 1]
    return records, wave_seconds, solved_after, {"kernel": kernel_s, "checks": check_s}
