"""The off-line search for a sequence of initial poses (Claret & Suárez, sec. 3.2).

1. Sample hand poses, take their mean and first two principal directions (PCA).
2. Discretise ``lambda = (lambda^1, lambda^2)`` in an ``N x N`` grid of [0, 1]^2
   (``lambda_j = j / (N - 1)``: the paper's Table 1 values are multiples of 1/29).
3. For ``i = 1 .. i_max``: draw ``M`` random feasible problems that the poses chosen so
   far do not solve; run Algorithm 1 with the single initial pose of every grid point
   on all of them; append the grid point with the highest success rate ``E_i`` (ties:
   the first in grid order).

The grid points of a step are split in chunks, each run by ``executor.submit`` (any
:class:`concurrent.futures.Executor`: a process pool, or a Dask cluster through
:class:`prehension.parallel.DaskExecutor`; default: run inline).  Each grid point's count
is computed alone on the same problems, so the sequence does not depend on the executor
or the chunking: the same ``seed`` gives the same sequence.  ``progress(done, total,
message)`` is called after each chunk, for a progress bar; the command line is
:mod:`prehension.cli.offline`.  The problems are the
paper's: four fingertip contacts, points with normals, made by forward kinematics
(:func:`.problems.random_point_problems`).

With ``time_limit_s`` every step stops at the deadline (the problems' drawing, the grid's
chunks, each grid point of a chunk): the sequence of the steps finished by then is
returned, ``meta["stopped"]`` saying why; none finished is
:class:`~prehension.deadline.TimeLimitReached`.
"""

from __future__ import annotations

import time
from concurrent.futures import Executor
from dataclasses import asdict, replace
from typing import Callable

import numpy as np

from ...deadline import TimeLimitReached, check_deadline, deadline_after, seconds_left
from ...errors import PrehensionError
from ...hands.model import Hand
from .options import LocalOptions
from .problems import SA_FOUR_TIPS, PointProblems, random_point_problems
from .sequence import PAPER_TABLE1, InitialPoseSequence, principal_directions, sample_poses

__all__ = ["offline_sequence", "grid_values", "compare_with_paper"]

Progress = Callable[[int, int, str], None]


def grid_values(N: int) -> np.ndarray:
    """The ``N`` values of each lambda: ``j / (N - 1)``, j = 0 .. N-1."""
    if N < 2:
        raise PrehensionError(f"the lambda grid needs N >= 2 values, got N = {N}")
    return np.arange(N) / (N - 1)


# -- hands across processes ----------------------------------------------------------------
def _hand_spec(hand: Hand):
    """A small picklable recipe for ``hand``: the built-in SA hand by name, any other hand
    itself (a Hand pickles whole, its opposing finger and frames included)."""
    from ...hands.sa_hand import schunk_sa_hand
    from ._layout import hand_arrays

    if hand.name == "schunk-sa" and hand_arrays(hand)[1] == hand_arrays(schunk_sa_hand())[1] and set(hand.regions) == set(
        schunk_sa_hand().regions
    ):
        return ("schunk-sa",)
    return ("hand", hand)


_HANDS: dict = {}


def _hand_from_spec(spec) -> Hand:
    key = repr(spec) if spec[0] == "schunk-sa" else id(spec)
    if spec[0] == "schunk-sa":
        if key not in _HANDS:
            from ...hands.sa_hand import schunk_sa_hand

            _HANDS[key] = schunk_sa_hand()
        return _HANDS[key]
    return spec[1]


def _evaluate_chunk(payload) -> np.ndarray:
    """Problems solved by each single initial pose of a chunk of lambdas: (G,) counts."""
    from .solver import solve_local_batch

    hand = _hand_from_spec(payload["hand"])
    problems = PointProblems(hand, payload["regions"], payload["points"], payload["normals"])
    base = InitialPoseSequence.from_dict(payload["sequence"])
    options = replace(payload["options"], i_max=1, initial="sequence")
    counts = np.zeros(len(payload["lambdas"]), dtype=np.int64)
    deadline = deadline_after(payload.get("seconds_left"))  # measured from the chunk's start
    for g, lam in enumerate(payload["lambdas"]):
        check_deadline(deadline, "off-line search")
        batch = solve_local_batch(problems, options, base.with_lambdas([lam]))
        counts[g] = int(batch.solved_after[0])
    return counts


def _executor_workers(executor: Executor) -> int:
    """Workers of an executor: ``max_workers`` (a Dask cluster, now) or a pool's ``_max_workers``."""
    workers = getattr(executor, "max_workers", None) or getattr(executor, "_max_workers", 1)
    return max(int(workers), 1)


def _unsolved_problems(hand, regions, M, base, lambdas, options, rng, max_candidates, deadline=None):
    """``M`` random problems that the poses ``lambdas`` do not solve, and the fraction unsolved."""
    from .solver import solve_local_batch

    kept_p, kept_n = [], []
    n_kept = n_tried = 0
    batch_size = max(M, 500)
    while n_kept < M:
        if n_tried >= max_candidates:
            raise PrehensionError(
                f"off-line search: fewer than {M} of {n_tried} random problems are left unsolved by "
                f"{len(lambdas)} initial poses; use a smaller M or a smaller i_max"
            )
        cand = random_point_problems(batch_size, hand, regions, rng, deadline=deadline)
        n_tried += batch_size
        if lambdas:
            run = replace(options, i_max=len(lambdas), initial="sequence", time_limit_s=_left(deadline))
            batch = solve_local_batch(cand, run, base.with_lambdas(lambdas))
            check_deadline(deadline, "off-line search")  # a batch cut short says nothing about what it left unsolved
            cand = cand.subset(np.flatnonzero(~batch.success))
        kept_p.append(cand.points)
        kept_n.append(cand.normals)
        n_kept += len(cand)
        if lambdas:  # later steps: draw more at once
            frac = max(n_kept / n_tried, 1e-3)
            batch_size = int(min(max((M - n_kept) / frac * 1.2, 500), 50000))
    points = np.concatenate(kept_p)[:M]
    normals = np.concatenate(kept_n)[:M]
    return points, normals, n_kept / n_tried if lambdas else 1.0


def _left(deadline: float | None) -> float | None:
    """Seconds left until ``deadline`` (at least a millisecond), ``None`` without one."""
    left = seconds_left(deadline)
    return None if left is None else max(left, 1e-3)


def offline_sequence(
    hand: Hand | None = None,
    M: int = 5000,
    N: int = 30,
    imax: int = 12,
    executor: Executor | None = None,
    progress: Progress | None = None,
    seed: int = 0,
    *,
    options: LocalOptions = LocalOptions(),
    n_samples: int = 5000,
    hand_regions=SA_FOUR_TIPS,
    chunks_per_step: int | None = None,
    max_candidates: int = 2_000_000,
    time_limit_s: float | None = None,
) -> InitialPoseSequence:
    """Search a sequence of ``imax`` initial poses (sec. 3.2); see the module docstring.

    Args:
        hand: the hand (default: the SA hand).
        M: random unsolved problems per step.
        N: grid values per lambda (``N^2`` candidate poses per step).
        imax: length of the sequence.
        executor: runs the chunks (``submit``); ``None`` runs them inline.
        progress: ``progress(done, total, message)`` after each chunk.
        seed: seed of the pose samples and of the problems.
        options: solver options for the single-pose runs (``i_max`` is set to 1).
        n_samples: hand poses sampled for the PCA.
        hand_regions: the contacts of the random problems.
        chunks_per_step: chunks the grid is split into (default: ``4 x`` the executor's
            workers, or 1 inline); the answer does not depend on it.
        time_limit_s: stop after this long [s] (see the module docstring).

    Returns:
        An :class:`InitialPoseSequence` with the lambdas, the success grid of every step
        and ``meta`` (parameters, seconds, success rates).
    """
    from ...hands.sa_hand import schunk_sa_hand

    for name, v, lo in (("M", M, 1), ("N", N, 2), ("imax", imax, 1), ("n_samples", n_samples, 3)):
        if not isinstance(v, (int, np.integer)) or v < lo:
            raise PrehensionError(f"offline_sequence: {name} must be an integer >= {lo}, got {v!r}")
    t0 = time.perf_counter()
    deadline = deadline_after(time_limit_s, t0)
    hand = schunk_sa_hand() if hand is None else hand
    rng = np.random.default_rng(seed)
    names, samples = sample_poses(hand, n_samples, rng, deadline=deadline)
    mean, comps, sig = principal_directions(samples)
    base = InitialPoseSequence(hand.name, names, mean, comps, sig, np.zeros((0, 2)))
    values = grid_values(N)
    grid = np.array([(a, b) for a in values for b in values])
    if chunks_per_step is None:
        chunks_per_step = 1 if executor is None else 4 * _executor_workers(executor)
    chunks = [c for c in np.array_split(np.arange(len(grid)), min(chunks_per_step, len(grid))) if len(c)]
    total = imax * len(chunks)
    done = 0
    spec = _hand_spec(hand)
    lambdas: list = []
    tables, rates, unsolved_frac = [], [], []
    stopped = ""

    def tick(message: str) -> None:
        nonlocal done
        done += 1
        if progress:
            progress(done, total, message)

    for i in range(imax):
        try:
            points, normals, frac = _unsolved_problems(
                hand, tuple(hand_regions), M, base, lambdas, options, rng, max_candidates, deadline
            )
            payload_base = {
                "hand": spec, "regions": tuple(hand_regions), "points": points, "normals": normals,
                "sequence": base.to_dict(), "options": options, "seconds_left": _left(deadline),
            }  # fmt: skip
            counts = _step_counts(executor, chunks, grid, payload_base, deadline, lambda: tick(f"pose {i + 1}/{imax}"))
        except TimeLimitReached:
            if not lambdas:
                raise TimeLimitReached(f"off-line search of hand {hand.name!r} (no pose found in {time_limit_s:g} s)") from None
            stopped = f"time limit ({time_limit_s:g} s) reached after {len(lambdas)} of {imax} poses"
            break
        unsolved_frac.append(frac)
        best = int(np.argmax(counts))
        lambdas.append(grid[best].tolist())
        tables.append((counts / M).reshape(N, N))
        rates.append(float(counts[best] / M))
    # success on fresh problems after i poses: the fraction left unsolved before step i
    # times the fraction of those the i-th pose does not solve
    cumulative = [1.0 - u * (1.0 - e) for u, e in zip(unsolved_frac, rates)]
    seconds = time.perf_counter() - t0
    meta = {
        "origin": f"offline_sequence(M={M}, N={N}, imax={imax}, seed={seed})",
        "M": M, "N": N, "imax": imax, "seed": seed, "n_samples": n_samples,
        "hand_regions": list(hand_regions), "seconds": seconds,
        "best_rate_per_step": rates,
        "unsolved_fraction_per_step": unsolved_frac,
        "estimated_cumulative_success": cumulative,
        "options": {k: v for k, v in asdict(options).items() if k != "tolerances"},
    }  # fmt: skip
    if stopped:
        meta["stopped"] = stopped
    return base.with_lambdas(np.array(lambdas), tables, **meta)


def _step_counts(executor: Executor | None, chunks, grid: np.ndarray, payload_base: dict, deadline,
                 tick: Callable[[], None]) -> np.ndarray:  # fmt: skip
    """Problems solved by each grid point's single pose: the chunks inline or on ``executor``,
    ``tick()`` after each (:class:`TimeLimitReached` at ``deadline``: the chunks still
    queued are cancelled)."""
    counts = np.zeros(len(grid), dtype=np.int64)
    if executor is None:
        for idx in chunks:
            check_deadline(deadline, "off-line search")
            counts[idx] = _evaluate_chunk({**payload_base, "lambdas": grid[idx]})
            tick()
        return counts
    from concurrent.futures import as_completed
    from concurrent.futures import TimeoutError as FuturesTimeout

    futures = {executor.submit(_evaluate_chunk, {**payload_base, "lambdas": grid[idx]}): idx for idx in chunks}
    try:
        for fut in as_completed(futures, timeout=_left(deadline)):
            counts[futures[fut]] = fut.result()
            tick()
    except FuturesTimeout:
        raise TimeLimitReached("off-line search") from None
    finally:
        for fut in futures:
            fut.cancel()
    return counts


def compare_with_paper(sequence: InitialPoseSequence) -> list[tuple[int, tuple | None, tuple | None]]:
    """Rows ``(i, ours (l1, l2) or None, paper's Table 1 (l1, l2) or None)``."""
    n = max(len(sequence), len(PAPER_TABLE1))
    rows = []
    for i in range(n):
        ours = tuple(float(v) for v in sequence.lambdas[i]) if i < len(sequence) else None
        paper = tuple(float(v) for v in PAPER_TABLE1[i]) if i < len(PAPER_TABLE1) else None
        rows.append((i + 1, ours, paper))
    return rows
