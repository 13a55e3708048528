"""Pairs of contacts shown makeable by a solution: the pair test has nothing to prove there.

The pose-free pair test (:mod:`.pair`) proves a task infeasible by proving that two of its
contacts cannot be made together.  A strict solution of the *two-contact sub-task* (the
task with only those two contacts; every other constraint -- limits, couplings, the
object's solid, self-collision -- kept) makes both, so the pair's conditions, which every
configuration making the two contacts meets, hold there: the test, which is sound, can
never prove that pair, and its budget is better spent on the others.

Near a frontier that three or four contacts make together (a 4-contact task with its
palm's region moved: every pair can still be made 9-57 mm farther out, ``frontier.py
--anatomy``) every pair is makeable and the pair test, which cannot prove any, took about
half of the search's time (57 of 131 s over 20 boxes); at a frontier made by one pair, the
others are makeable and that pair gets the whole budget instead of its share.

The sub-tasks are solved by the search's own verifier (the local iterations it is given,
:mod:`.verifier`) from the points it verifies the first box from, and judged by the
residual function with the strict tolerances (:func:`prehension.results.make_solution`,
whatever tolerances the search was given): a pair is skipped only on a strict solution, so
skipping loses no proof (and skipping a test never makes one).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

from ...results import make_solution
from ...tasks.model import Configuration, Task
from .verifier import BoxVerifier

__all__ = ["pair_task", "makeable_pairs"]


def pair_task(task: Task, a: int, b: int) -> Task:
    """``task`` with only its contacts ``a`` and ``b`` (the same fingers, hand and object)."""
    return replace(task, name=f"{task.name} [contacts {a}, {b}]", contacts=(task.contacts[a], task.contacts[b]))


def makeable_pairs(task: Task, verifier: BoxVerifier | None, starts: Sequence[Configuration]) -> frozenset[tuple[int, int]]:
    """The pairs ``(a, b)``, ``a < b``, of ``task``'s contacts whose two-contact sub-task
    (:func:`pair_task`) has a strict solution reached by ``verifier`` from ``starts``
    (configurations of ``task``, read down to the pair's contact parameters), judged with
    the strict tolerances.  None without a verifier or with fewer than three contacts (a
    pair that is the whole task is the task: a solution would have ended the search)."""
    n = len(task.contacts)
    if verifier is None or n < 3 or not starts:
        return frozenset()
    found = set()
    for a in range(n):
        for b in range(a + 1, n):
            sub = pair_task(task, a, b)
            reached = verifier(sub, [_pair_start(c, a, b) for c in starts])
            if any(c is not None and make_solution(sub, c) is not None for c in reached.configurations):
                found.add((a, b))
    return frozenset(found)


def _pair_start(config: Configuration, a: int, b: int) -> Configuration:
    return Configuration(config.joint_angles, config.T_palm_object, (config.contact_params[a], config.contact_params[b]))
