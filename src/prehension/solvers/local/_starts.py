"""Where each wave of the local solver starts: the unknowns of the initial poses.

Wave ``i`` starts every problem not solved yet from the ``i``-th pose of the
:class:`~.sequence.InitialPoseSequence` (:func:`wave_starts`); beyond the sequence's
length, from random hand poses of the whole pose space drawn per problem
(:class:`RandomPoses`), so that a problem gets the same poses in any batch.  The random
generators of a batch (:func:`as_rng`: one for the batch or one per problem;
:class:`OwnGenerator`: made only when something is drawn) live here too.
"""

from __future__ import annotations

import zlib
from collections import OrderedDict
from functools import lru_cache

import numpy as np

from ...deadline import TimeLimitReached
from ...errors import InvalidTask
from ...frozen import IdentityCache, cached_per_value
from ._layout import Group, hand_arrays
from .options import LocalOptions
from .sequence import InitialPoseSequence, default_sequence, sample_poses

__all__ = ["pose_index", "wave_starts", "RandomPoses", "place_poses", "sequence_for", "as_rng", "OwnGenerator", "subset_rng"]


def pose_index(group: Group, sequence: InitialPoseSequence) -> np.ndarray:
    names = {n: i for i, n in enumerate(sequence.names)}
    return np.array([names.get(n, -1) if n is not None else -1 for n in group.pose_names], dtype=np.int64)


def wave_starts(group: Group, sequence: InitialPoseSequence, wave: int, todo: np.ndarray, options: LocalOptions,
            rng, extra: "RandomPoses") -> np.ndarray:  # fmt: skip
    """Unknowns (S, nx) of wave ``wave`` for problems ``todo``: the sequence's pose; beyond
    its length random hand poses of the whole pose space (:class:`RandomPoses`: the
    sequence's poses all lie in one plane); with ``initial="random"`` random lambdas."""
    S = len(todo)
    if options.initial == "sequence" and wave >= len(sequence):
        poses = np.array([extra.pose(group, p, wave - len(sequence)) for p in todo])
        # the first wave beyond the sequence has always started from the group's default
        # unknowns (the pose names were read before the first draw set them); kept so, by
        # wave, so that a call starting at a later wave gives what a call from the first does
        return place_poses(group, extra.names if wave > len(sequence) else (), poses)
    if options.initial == "sequence":  # the same row for every problem: placed once per group shape and wave
        return np.repeat(_sequence_start(group, sequence, wave), S, axis=0)
    if isinstance(rng, list):  # one generator per problem: its draws do not depend on the batch
        lam = np.array([rng[p].uniform(0.0, 1.0, 2) for p in todo]).reshape(S, 2)
    else:
        lam = rng.uniform(0.0, 1.0, (S, 2))
    return place_poses(group, sequence.names, sequence.poses(lam))


class RandomPoses:
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
            seed = seed.pose_seed if isinstance(seed, OwnGenerator) else seed
            self.names, self._poses[p] = _sampled(self.hand, self.count, seed, key, self.deadline)
        return self._poses[p][k]


_SAMPLED: OrderedDict = OrderedDict()  # (hand digest, count, seed, key) -> (names, poses): the last few thousand
_SAMPLED_SIZE = 2048


def _sampled(hand, count: int, seed, key: int, deadline: float | None):
    """``sample_poses(hand, count, default_rng([seed, key]))``, remembered: a problem run in
    several calls over ranges of its poses (``solve_local_batch(poses=...)``) draws its
    random poses once per process, not once per call (the same poses: the draw is
    deterministic; one stopped by the deadline raises and is not remembered)."""
    index = (hand_arrays(hand)[1], count, int(seed), key)
    if index in _SAMPLED:
        _SAMPLED.move_to_end(index)
        return _SAMPLED[index]
    names, poses = sample_poses(hand, count, np.random.default_rng([seed, key]), deadline=deadline)
    poses.setflags(write=False)
    _SAMPLED[index] = (names, poses)
    while len(_SAMPLED) > _SAMPLED_SIZE:
        _SAMPLED.popitem(last=False)
    return names, poses


def _sequence_start(group: Group, sequence: InitialPoseSequence, wave: int) -> np.ndarray:
    """``place_poses`` of the sequence's pose ``wave`` for one problem, (1, nx), read-only;
    kept per sequence for the group's default unknowns and pose names (eq. 11 and the
    placing are element by element: a row does not depend on the others)."""

    def place():
        row = place_poses(group, sequence.names, sequence.poses(sequence.lambdas[wave : wave + 1]))
        row.setflags(write=False)
        return row

    return _starts_of(sequence).get((group.x_default, group.pose_names), wave, place)


@cached_per_value
def _starts_of(sequence: InitialPoseSequence) -> IdentityCache:
    """The rows of :func:`_sequence_start` of one sequence, by group defaults and wave."""
    return IdentityCache()


def place_poses(group: Group, names, poses: np.ndarray) -> np.ndarray:
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


def sequence_for(hand, sequence, deadline):
    """``sequence``, else the hand's default; ``None`` when the deadline passed while the
    default was drawn (its problems then give up, saying so)."""
    if sequence is not None:
        return sequence
    try:
        return default_sequence(hand, deadline=deadline)
    except TimeLimitReached:
        return None


def as_rng(rng, n: int, one_group: bool = False):
    """One generator for the batch, or a list of ``n`` (one per problem) from a sequence.

    With ``one_group`` and a seed (not a generator): an :class:`OwnGenerator`, made only
    if a draw is asked for (most calls never draw: the sequence's poses are enough)."""
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, (list, tuple, np.ndarray)):
        if len(rng) != n:
            raise InvalidTask(f"solve_local_batch: rng holds {len(rng)} seeds for {n} problems; give one per problem")
        return [r if isinstance(r, np.random.Generator) else np.random.default_rng(r) for r in rng]
    seed = 0 if rng is None else rng
    plain = isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0  # numpy would accept it
    return OwnGenerator(seed) if one_group and plain else np.random.default_rng(seed)


class OwnGenerator:
    """``np.random.default_rng(seed)`` for one group, made on first use (~30 us saved on
    each call that draws nothing).  Its first draw is :attr:`pose_seed`, as
    :func:`solve_group` draws first from a generator it is given, so every draw is the
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


def subset_rng(rng, members):
    return [rng[k] for k in members] if isinstance(rng, list) else rng
