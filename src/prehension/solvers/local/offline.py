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
from dataclasses import asdict, dataclass, replace
from typing import Callable

import numpy as np

from ...deadline import TimeLimitReached, check_deadline, deadline_after, seconds_left
from ...errors import PrehensionError
from ...hands.model import Hand
from ._regions import virtual_joints
from .options import LocalOptions
from .problems import SA_FOUR_TIPS, PointProblems, random_point_problems
from .sequence import PAPER_TABLE1, InitialPoseSequence, principal_directions, sample_poses

__all__ = ["offline_sequence", "OfflineSearch", "fingertip_regions", "grid_values", "compare_with_paper"]

Progress = Callable[[int, int, str], None]


def grid_values(N: int) -> np.ndarray:
    """The ``N`` values of each lambda: ``j / (N - 1)``, j = 0 .. N-1."""
    if N < 2:
        raise PrehensionError(f"the lambda grid needs N >= 2 values, got N = {N}")
    return np.arange(N) / (N - 1)


@dataclass(frozen=True)
class OfflineSearch:
    """What the off-line search does (sec. 3.2): the paper's ``M``, ``N``, ``i_max`` and ours.

    Attributes:
        M: random unsolved problems per step.
        N: grid values per lambda (``N^2`` candidate poses per step).
        imax: length of the sequence.
        seed: seed of the pose samples and of the problems.
        hand_regions: the contacts of the random problems; ``None`` (or empty): the hand's fingertips
            (:func:`fingertip_regions`: the SA hand's four, as in the paper).
        options: solver options for the single-pose runs (``i_max`` is set to 1).
        n_samples: hand poses sampled for the PCA.
        chunks_per_step: chunks the grid is split into (default: ``4 x`` the executor's
            workers, or 1 inline); the answer does not depend on it.
        max_candidates: random problems drawn at most per step to find ``M`` unsolved ones.
        time_limit_s: stop after this long [s] (see the module docstring).

    Raises:
        PrehensionError: ``M``, ``N``, ``imax`` or ``n_samples`` is not an integer of at
            least 1, 2, 1, 3.
    """

    M: int = 5000
    N: int = 30
    imax: int = 12
    seed: int = 0
    hand_regions: tuple[str, ...] | None = None
    options: LocalOptions = LocalOptions()
    n_samples: int = 5000
    chunks_per_step: int | None = None
    max_candidates: int = 2_000_000
    time_limit_s: float | None = None

    def __post_init__(self):
        for name, lo in (("M", 1), ("N", 2), ("imax", 1), ("n_samples", 3)):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or v < lo:
                raise PrehensionError(f"offline search: {name} must be an integer >= {lo}, got {v!r}")
        if self.hand_regions is not None:
            object.__setattr__(self, "hand_regions", tuple(self.hand_regions))

    def regions_of(self, hand: Hand) -> tuple[str, ...]:
        """The hand regions of the random problems on ``hand``."""
        return self.hand_regions if self.hand_regions else fingertip_regions(hand)


def fingertip_regions(hand: Hand) -> tuple[str, ...]:
    """The hand's ``<finger>_tip`` regions whose parameters are virtual fingertip joints
    (sphere caps, :func:`._regions.virtual_joints`), the opposing finger's first (the SA
    hand: the paper's thumb, index, middle, ring).

    Raises:
        PrehensionError: fewer than two such regions (then name the regions to use).
    """
    if hand.name == "schunk-sa" and set(SA_FOUR_TIPS) <= set(hand.regions):
        return SA_FOUR_TIPS
    order = sorted(hand.fingers, key=lambda f: f.name != hand.opposing_finger)
    tips = [f"{f.name}_tip" for f in order]
    tips = [t for t in tips if t in hand.regions and virtual_joints(hand.regions[t].region)]
    if len(tips) < 2:
        raise PrehensionError(
            f"hand {hand.name!r} has {len(tips)} fingertip region(s); the off-line search needs at least two "
            "(give --regions A,B,... or OfflineSearch(hand_regions=...))"
        )
    return tuple(tips)


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


def _unsolved_problems(hand, search: OfflineSearch, regions, base, lambdas, rng, deadline=None):
    """``search.M`` random problems on ``regions`` that the poses ``lambdas`` do not solve, and the fraction unsolved."""
    from .solver import solve_local_batch

    M, options, max_candidates = search.M, search.options, search.max_candidates
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


def offline_sequence(hand: Hand | None = None, search: OfflineSearch = OfflineSearch(), *,
                     executor: Executor | None = None, progress: Progress | None = None) -> InitialPoseSequence:  # fmt: skip
    """Search a sequence of ``search.imax`` initial poses (sec. 3.2); see the module docstring.

    Args:
        hand: the hand (default: the SA hand).
        search: what to search (:class:`OfflineSearch`: ``M``, ``N``, ``imax``, ``seed``...).
        executor: runs the chunks (``submit``); ``None`` runs them inline.
        progress: ``progress(done, total, message)`` after each chunk.

    Returns:
        An :class:`InitialPoseSequence` with the lambdas, the success grid of every step
        and ``meta`` (parameters, seconds, success rates).
    """
    from ...hands.sa_hand import schunk_sa_hand

    t0 = time.perf_counter()
    deadline = deadline_after(search.time_limit_s, t0)
    hand = schunk_sa_hand() if hand is None else hand
    regions = search.regions_of(hand)
    rng = np.random.default_rng(search.seed)
    names, samples = sample_poses(hand, search.n_samples, rng, deadline=deadline)
    mean, comps, sig = principal_directions(samples)
    base = InitialPoseSequence(hand.name, names, mean, comps, sig, np.zeros((0, 2)))
    chunks = _chunks(search, executor)
    steps = _Steps(search, len(chunks), progress)
    for i in range(search.imax):
        try:
            points, normals, frac = _unsolved_problems(hand, search, regions, base, steps.lambdas, rng, deadline)
            payload_base = {
                "hand": _hand_spec(hand), "regions": regions, "points": points, "normals": normals,
                "sequence": base.to_dict(), "options": search.options, "seconds_left": _left(deadline),
            }  # fmt: skip
            counts = _step_counts(executor, chunks, steps.grid, payload_base, deadline,
                                  lambda: steps.tick(f"pose {i + 1}/{search.imax}"))  # fmt: skip
        except TimeLimitReached:
            steps.stop(hand)
            break
        steps.add(counts, frac)
    meta = steps.meta(regions, time.perf_counter() - t0)
    return base.with_lambdas(np.array(steps.lambdas), steps.tables, **meta)


def _chunks(search: OfflineSearch, executor: Executor | None) -> list[np.ndarray]:
    """The grid points' indices split into the chunks of one step."""
    n = search.N * search.N
    per_step = search.chunks_per_step
    if per_step is None:
        per_step = 1 if executor is None else 4 * _executor_workers(executor)
    return [c for c in np.array_split(np.arange(n), min(per_step, n)) if len(c)]


class _Steps:
    """What the steps of :func:`offline_sequence` found so far, and its progress."""

    def __init__(self, search: OfflineSearch, n_chunks: int, progress: Progress | None):
        self.search, self.progress = search, progress
        values = grid_values(search.N)
        self.grid = np.array([(a, b) for a in values for b in values])
        self.total, self.done = search.imax * n_chunks, 0
        self.lambdas: list = []
        self.tables: list = []
        self.rates: list = []
        self.unsolved_frac: list = []
        self.stopped = ""

    def tick(self, message: str) -> None:
        self.done += 1
        if self.progress:
            self.progress(self.done, self.total, message)

    def add(self, counts: np.ndarray, frac: float) -> None:
        """Append the grid point solving the most (ties: the first in grid order)."""
        M, N = self.search.M, self.search.N
        self.unsolved_frac.append(frac)
        best = int(np.argmax(counts))
        self.lambdas.append(self.grid[best].tolist())
        self.tables.append((counts / M).reshape(N, N))
        self.rates.append(float(counts[best] / M))

    def stop(self, hand: Hand) -> None:
        """The time limit passed: keep the poses found, or raise when there is none."""
        limit, imax = self.search.time_limit_s, self.search.imax
        if not self.lambdas:
            raise TimeLimitReached(f"off-line search of hand {hand.name!r} (no pose found in {limit:g} s)") from None
        self.stopped = f"time limit ({limit:g} s) reached after {len(self.lambdas)} of {imax} poses"

    def meta(self, regions, seconds: float) -> dict:
        s = self.search
        # success on fresh problems after i poses: the fraction left unsolved before step i
        # times the fraction of those the i-th pose does not solve
        cumulative = [1.0 - u * (1.0 - e) for u, e in zip(self.unsolved_frac, self.rates)]
        meta = {
            "origin": f"offline_sequence(M={s.M}, N={s.N}, imax={s.imax}, seed={s.seed})",
            "M": s.M, "N": s.N, "imax": s.imax, "seed": s.seed, "n_samples": s.n_samples,
            "hand_regions": list(regions), "seconds": seconds,
            "best_rate_per_step": self.rates,
            "unsolved_fraction_per_step": self.unsolved_frac,
            "estimated_cumulative_success": cumulative,
            "options": {k: v for k, v in asdict(s.options).items() if k != "tolerances"},
        }  # fmt: skip
        if self.stopped:
            meta["stopped"] = self.stopped
        return meta


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
