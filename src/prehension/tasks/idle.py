"""Idle fingers clear of the object: the step every solver's answer goes through.

Fingers that do not take part in a task make no contact, so their angles do not affect
any constraint but collisions.  Solvers hold them at their idle values
(:attr:`~prehension.tasks.model.Task.idle_vector`); where an idle finger then passes
through the object (or through another link), :func:`settle_idle_fingers` moves it
within its limits to a place where it is clear:

1. if every idle finger is already clear (object depth within the tolerance, no
   self-collision), the configuration is returned unchanged;
2. otherwise, one idle finger at a time (in hand order), the finger's idle dofs are
   sampled: the current angles, the corners of their limit box and 256 seeded uniform
   samples (couplings applied).  Among the samples that are clear of the object (depth
   at most half the tolerance) and of every other link, the one nearest to the current
   angles (largest change over the finger's dofs, in radians) is taken; when none is
   clear, the finger is left where it was and verification reports the penetration.
   (The candidates are tested nearest first, a few at a time, stopping at the first
   clear one: the same choice as testing them all, at a fraction of the cost.)

Deterministic (fixed seed): the same answer gives the same settled configuration.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..hands.collision import capsule_clearances, collision_pairs
from ..hands.kinematics import forward_kinematics
from .model import Configuration, Task
from .object_collision import batch_link_depths

__all__ = ["settle_idle_fingers", "idle_fingers", "N_SAMPLES"]

N_SAMPLES = 256
CHUNK = 32  # candidates tested at a time, nearest first


def idle_fingers(task: Task) -> list[tuple[str, np.ndarray, list[int]]]:
    """Per idle finger with idle dofs: ``(name, independent idle dof indices, link indices)``."""
    hand, active = task.hand, task.active_mask
    coupled = {hand.dof_index(c.dof) for c in hand.couplings}
    out = []
    for f in hand.fingers:
        if f.name in task.fingers:
            continue
        dofs = sorted({d for link in f.links for d in hand.chain_dofs(link) if not active[d] and d not in coupled})
        if dofs:
            out.append((f.name, np.array(dofs, dtype=int), [hand.link_index(link) for link in f.links]))
    return out


def _apply_couplings(hand, q: np.ndarray) -> np.ndarray:
    for c in hand.couplings:
        q[:, hand.dof_index(c.dof)] = c.ratio * q[:, hand.dof_index(c.source)] + c.offset
    return q


def _clear(task: Task, q: np.ndarray, T, links, limit_mm: float) -> np.ndarray:
    """Per configuration (B,): whether ``links`` are clear of the object (depth at most
    ``limit_mm``) and of every other link."""
    pose = forward_kinematics(task.hand, q)
    depth = batch_link_depths(task, pose, T, links, cap=limit_mm).max(axis=1)
    clearance, _ = capsule_clearances(task.hand, pose)
    pairs = collision_pairs(task.hand)
    moved = np.zeros(len(task.hand.link_names), dtype=bool)
    moved[links] = True  # a lookup table: np.isin sorts, at ~20x the cost for these few links
    mine = moved[pairs.link[pairs.first]] | moved[pairs.link[pairs.second]]
    self_ok = np.all(clearance[:, mine] >= 0.0, axis=1) if mine.any() else np.ones(len(q), bool)
    return (depth <= limit_mm) & self_ok


def _candidates(hand, q0: np.ndarray, dofs: np.ndarray, rng) -> np.ndarray:
    lo, hi = hand.lower[dofs], hand.upper[dofs]
    corners = np.array(np.meshgrid(*[(a, b) for a, b in zip(lo, hi)], indexing="ij")).reshape(len(dofs), -1).T
    samples = rng.uniform(lo, hi, size=(N_SAMPLES, len(dofs)))
    q = np.repeat(q0[None], 1 + len(corners) + N_SAMPLES, axis=0)
    q[1:, dofs] = np.concatenate([corners, samples])
    return _apply_couplings(hand, q)


def settle_idle_fingers(task: Task, config: Configuration, tolerance_mm: float = 0.5) -> Configuration:
    """``config`` with idle fingers moved clear of the object (see the module docstring)."""
    if not task.object.collides:
        return config
    fingers = idle_fingers(task)
    if not fingers:
        return config
    T, q = config.T_palm_object, config.joint_angles.copy()
    all_links = [li for _, _, links in fingers for li in links]
    if _clear(task, q[None], T, all_links, tolerance_mm)[0]:
        return config
    rng = np.random.default_rng(0)
    for _, dofs, links in fingers:
        cand = _candidates(task.hand, q, dofs, rng)
        change = np.max(np.abs(cand[:, dofs] - q[dofs]), axis=1)
        nearest = _nearest_clear(task, cand, np.argsort(change, kind="stable"), T, links, 0.5 * tolerance_mm)
        if nearest:  # None: nothing clear, leave it; 0: the finger is clear where it is
            q = cand[nearest]
    return replace(config, joint_angles=q)


def _nearest_clear(task: Task, cand: np.ndarray, order: np.ndarray, T, links, limit_mm: float) -> int | None:
    """The first candidate in ``order`` (nearest first) that is clear, or None: tested
    :data:`CHUNK` at a time, so that the usual case (a near candidate is clear) tests few."""
    for start in range(0, len(order), CHUNK):
        idx = order[start : start + CHUNK]
        ok = _clear(task, cand[idx], T, links, limit_mm)
        if ok.any():
            return int(idx[np.argmax(ok)])
    return None
