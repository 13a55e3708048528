"""The local iterations from given starts: how the complete solver verifies its boxes.

:func:`refine_local` runs the local solver's Jacobian steps, polishing and collision
repair from starting configurations (points read from boxes) instead of from the
initial-pose sequence, and keeps what meets the strict tolerances.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...tasks.model import Configuration, Task
from . import _kernel as K
from ._checks import check, contact_checks_tasks
from ._layout import S_K, S_X, Group
from ._waves import run_kernel
from .options import LocalOptions
from .problems import group_from_tasks

__all__ = ["refine_local", "Refinement"]


def _unknowns_of(group: Group, starts: Sequence[Configuration]) -> np.ndarray:
    """The kernel's unknowns (S, nx) for starting configurations (joint angles, region params).

    The object pose is not an unknown of the kernel: it is placed from the hand, as for
    the initial poses of the sequence.
    """
    x0 = np.repeat(group.x_default[None], len(starts), axis=0)
    sides = group.layout.sides
    for s, cfg in enumerate(starts):
        x0[s, : group.nf] = np.asarray(cfg.joint_angles, dtype=float)[list(group.free)]
        for c, (hp, op) in enumerate(cfg.contact_params or ()):
            (xh, kh), (xo, ko) = sides[c, 0, [S_X, S_K]], sides[c, 1, [S_X, S_K]]
            x0[s, xh : xh + kh] = hp
            x0[s, xo : xo + ko] = op
    return np.clip(x0, group.layout.lo, group.layout.hi)


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
    out = run_kernel(group, np.zeros(S, dtype=np.int64), _unknowns_of(group, starts), options)
    configs: list[Configuration | None] = [None] * S
    sel = np.flatnonzero(np.isin(out.status, K.LOCAL_SOLUTIONS))
    if sel.size:
        level, q, T, params = check(
            group, lambda i, pose, T_, prm: contact_checks_tasks([task], i, pose, T_, prm), np.zeros(sel.size, dtype=np.int64),
            out.x[sel], out.R[sel], out.t[sel], options,
        )[:4]  # fmt: skip
        for k, s in enumerate(sel):
            if level[k] == 2:
                configs[s] = Configuration(q[k].copy(), T[k].copy(), tuple((h[k].copy(), o[k].copy()) for h, o in params))
    # err[:, 1] = w_n |n_hand + n_object| [mm], and |n_h + n_o| = 2 sin(angle / 2)
    chord = np.clip(out.err[:, 1] / (2.0 * options.normal_weight_mm), 0.0, 1.0)
    return Refinement(tuple(configs), out.err[:, 0].copy(), np.degrees(2.0 * np.arcsin(chord)))
