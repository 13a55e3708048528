"""Bounded memory: self-collision of hands with hundreds of capsules, and the local solver on them."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from dataclasses import replace

import numpy as np
import pytest

from prehension.hands.collision import capsule_clearances, collision_pairs, max_penetration
from prehension.hands.kinematics import forward_kinematics
from prehension.hands.model import Capsule, Link

from conftest import random_angles


def split_capsules(hand, pieces: int, name: str | None = None):
    """The same hand with each capsule cut into ``pieces`` capsules along its segment.

    The union of the pieces is the original capsule, so every penetration depth is the
    same as the original hand's while the number of pairs grows ``pieces**2`` times.
    """
    links = []
    for link in hand.links:
        caps = []
        for c in link.collision:
            ends = np.linspace(0.0, 1.0, pieces + 1)
            caps += [Capsule(c.a + s * (c.b - c.a), c.a + t * (c.b - c.a), c.radius) for s, t in zip(ends[:-1], ends[1:])]
        links.append(Link(link.name, tuple(caps)))
    return replace(hand, links=tuple(links), name=name or f"{hand.name}-split{pieces}")


def test_max_penetration_is_the_largest_depth_of_capsule_clearances(sa_hand, rng):
    q = random_angles(sa_hand, rng, 300)
    pose = forward_kinematics(sa_hand, q)
    clearance, names = capsule_clearances(sa_hand, pose)
    expected = np.max(np.maximum(-clearance, 0.0), axis=1)
    assert (expected > 0).any() and (expected == 0).any()
    np.testing.assert_allclose(max_penetration(sa_hand, pose), expected, atol=1e-12)
    first = max_penetration(sa_hand, pose, stop_at_first=True)
    np.testing.assert_array_equal(first > 0, expected > 0)
    assert np.all(first <= expected + 1e-12)
    assert len(names) == clearance.shape[1] == len(collision_pairs(sa_hand).first)


def test_split_capsules_give_the_same_depths(sa_hand, rng):
    many = split_capsules(sa_hand, 4)
    assert len(collision_pairs(many).first) == 16 * len(collision_pairs(sa_hand).first)
    pose = forward_kinematics(sa_hand, random_angles(sa_hand, rng, 200))
    np.testing.assert_allclose(max_penetration(many, pose), max_penetration(sa_hand, pose), atol=1e-9)


def test_the_pair_cache_is_not_written_onto_the_hand(sa_hand):
    many = split_capsules(sa_hand, 2, "cache-probe")
    collision_pairs(many)
    assert not any(k.startswith("_collision") for k in vars(many))


_BIG_HAND_RUN = textwrap.dedent(
    """
    import resource, sys
    resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
    sys.path.insert(0, {tests!r})
    import numpy as np
    from prehension.hands.sa_hand import schunk_sa_hand
    from prehension.hands.collision import capsule_clearances, collision_pairs
    from prehension.hands.kinematics import forward_kinematics
    from prehension.results import make_solution
    from prehension.solvers.local import LocalOptions, random_point_problems, solve_local_batch
    from test_memory import split_capsules

    hand = split_capsules(schunk_sa_hand(), 15, "sa-240-capsules")
    n_caps = sum(len(link.collision) for link in hand.links)
    n_pairs = len(collision_pairs(hand).first)
    problems = random_point_problems(100, hand, seed=5)  # rejection sampling against every pair
    batch = solve_local_batch(problems, LocalOptions(i_max=4))  # default sequence: sampled for this hand
    clearance, _ = capsule_clearances(hand, forward_kinematics(hand, problems.truth["q"][:20]))
    solved = [r for r in batch if r.success]
    assert all(make_solution(problems.task(r.index), r.configuration()) is not None for r in solved[:20])
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(n_caps, n_pairs, len(solved), clearance.shape[1], round(peak_mb))
    """
)


def test_a_hand_with_240_capsules_runs_within_2_gb():
    from conftest import SHARED  # noqa: F401  (only to locate tests/)

    tests_dir = str(__import__("pathlib").Path(__file__).resolve().parent)
    proc = subprocess.run(
        [sys.executable, "-c", _BIG_HAND_RUN.format(tests=tests_dir)], capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    n_caps, n_pairs, solved, n_clear, peak_mb = (int(v) for v in proc.stdout.split())
    assert n_caps == 240 and n_pairs == n_clear > 20_000
    assert solved >= 80
    assert peak_mb < 1500


def test_a_hand_without_capsules_has_no_pair_groups():
    from tiny_tasks import pincer_hand, pincer_task

    pairs = collision_pairs(pincer_hand())
    assert len(pairs.first) == 0 and pairs.group_start.tolist() == [0]
    from prehension.solvers.local import solve_local

    assert solve_local(pincer_task(40.0)).success
