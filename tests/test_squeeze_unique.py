"""Stored squeeze targets are re-derived as a least-squares step as good as the one found
now (:func:`prehension.sim.squeeze.as_good_a_squeeze`), not as the same numbers: the
stacked contact Jacobian has more joint angles than rows, and with a joint at its limit
``lsq_linear`` stops at different equally good steps for contacts 1e-9 mm apart (two
Allegro contact sets 3e-11 mm apart gave targets 0.29 rad apart, and ``prehension check``
called the squeeze of ``test_cli_hands``' Allegro result false)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from conftest import random_angles
from fk_tasks import build_fk_case
from prehension.sim.squeeze import as_good_a_squeeze, squeeze_targets

FINGERS = ("thumb", "index", "middle")


def _contacts(case, shift=0.0):
    normals = -case.hand_normals  # the object's outward normal opposes the hand's
    return [SimpleNamespace(hand_point=p + shift, object_normal=n) for p, n in zip(case.hand_points, normals)]


def _case(hand, rng):
    """Three fingers, a flexion of the index or middle at a limit (the step's bound active)."""
    q = random_angles(hand, rng, 1)[0]
    i = hand.dof_index(str(rng.choice([d for d in hand.dof_names if d.startswith(("index", "middle"))])))
    q[i] = hand.upper[i] if rng.random() < 0.5 else hand.lower[i]
    return build_fk_case(hand, rng, fingers=FINGERS, q=q, palm=False, kinds=("point",) * 3)


@pytest.mark.parametrize("seed", range(8))
def test_a_step_from_contacts_a_hair_apart_is_as_good(sa_hand, seed):
    rng = np.random.default_rng(seed)
    case = _case(sa_hand, rng)
    q, contacts = case.config.joint_angles, _contacts(case)
    assert as_good_a_squeeze(case.task, q, contacts, 5.0, None, squeeze_targets(case.task, q, contacts, 5.0))
    for _ in range(3):
        other = squeeze_targets(case.task, q, _contacts(case, rng.normal(scale=1e-9, size=3)), 5.0)
        assert as_good_a_squeeze(case.task, q, contacts, 5.0, None, other)


@pytest.mark.parametrize("seed", range(8))
def test_a_worse_or_foreign_step_is_refused(sa_hand, seed):
    rng = np.random.default_rng(seed)
    case = _case(sa_hand, rng)
    q, contacts = case.config.joint_angles, _contacts(case)
    best = squeeze_targets(case.task, q, contacts, 5.0)
    hand = sa_hand
    movable = [i for i in np.flatnonzero(case.task.active_mask) if hand.lower[i] + 0.1 < best[i] < hand.upper[i] - 0.1
               and hand.dof_names[i] not in {c.dof for c in hand.couplings}]  # fmt: skip
    worse = best.copy()
    worse[movable] += rng.choice([-0.1, 0.1], size=len(movable))  # every free angle 0.1 rad off
    assert not as_good_a_squeeze(case.task, q, contacts, 5.0, None, worse)
    idle = best.copy()
    ring = hand.dof_index("ring_pip")  # the ring finger takes no part: it does not move
    idle[ring] = np.clip(q[ring] + 0.05, hand.lower[ring], hand.upper[ring]) if q[ring] + 0.05 <= hand.upper[ring] else q[ring] - 0.05
    assert not as_good_a_squeeze(case.task, q, contacts, 5.0, None, idle)
