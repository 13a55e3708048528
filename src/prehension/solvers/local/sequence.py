"""Sequences of initial hand poses (Claret & Suárez, sec. 3.2, eq. 11).

A *hand pose* ``Q`` is the vector of the independent joint angles and the two "virtual
joints" of each fingertip (the sphere-cap parameters ``(alpha, gamma)``): for the SA hand
13 angles + 4 x 2 = 21 numbers (the paper's 25 less its 4 coupled angles).  A sequence is

.. math::

    Q_i = m + 3\\sigma_1 (2\\lambda_i^1 - 1) c_1 + 3\\sigma_2 (2\\lambda_i^2 - 1) c_2,
    \\qquad i = 1 \\dots i_{max},

with ``m`` the mean of a sample of hand poses, ``c_1``, ``c_2`` its first two principal
directions and ``sigma_j`` the standard deviations along them.  The samples are uniform
within the joint limits (couplings exact) and the fingertip cones, without self-collision
(the paper says only "randomly generated").

Files are JSON (``prehension: initial-poses/1``), written atomically.  The SA hand's
sequence ships with the package (``data/schunk-sa.json``, made by
:func:`prehension.solvers.local.offline.offline_sequence`); other hands get
:func:`default_sequence`: the same PCA with the paper's Table 1 lambdas.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from importlib import resources
from typing import Any, Mapping

import numpy as np

from ...atomic import read_json, to_plain, write_json_atomic
from ...errors import InvalidTask
from ...hands.model import Hand
from ._regions import virtual_joints

__all__ = [
    "InitialPoseSequence",
    "SEQUENCE_TAG",
    "PAPER_TABLE1",
    "pose_space",
    "sample_poses",
    "principal_directions",
    "default_sequence",
    "shipped_sequence",
]

SEQUENCE_TAG = "initial-poses/1"

#: Table 1 of Claret & Suárez: lambda_1 .. lambda_12 for their SA hand model (M = 5000, N = 30).
PAPER_TABLE1 = np.array(
    [
        [0.517, 0.483], [0.793, 0.552], [0.310, 0.690], [0.0, 0.517], [0.690, 0.448], [0.138, 0.241],
        [0.034, 0.827], [0.655, 0.241], [0.690, 0.0], [0.690, 0.448], [0.724, 0.276], [0.276, 0.827],
    ]
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class InitialPoseSequence:
    """An off-line sequence of initial hand poses.

    Attributes:
        hand: name of the hand it was made for.
        names: (D,) name of each pose component: joint-angle names and
            ``"<finger>.tip.alpha"`` / ``"<finger>.tip.gamma"`` for fingertip parameters.
        mean: (D,) mean pose ``m`` [rad].
        components: (2, D) unit principal directions ``c_1``, ``c_2``.
        sigmas: (2,) standard deviations along them [rad].
        lambdas: (i_max, 2) the sequence, each in [0, 1]^2.
        success: per step, the (N, N) grid of success rates ``E_ijk`` of the off-line
            search (empty for sequences not made by it).
        meta: how it was made (M, N, seed, seconds, options...).
    """

    hand: str
    names: tuple[str, ...]
    mean: np.ndarray
    components: np.ndarray
    sigmas: np.ndarray
    lambdas: np.ndarray
    success: tuple[np.ndarray, ...] = ()
    meta: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "names", tuple(self.names))
        for k in ("mean", "components", "sigmas", "lambdas"):
            object.__setattr__(self, k, np.asarray(getattr(self, k), dtype=float))
        object.__setattr__(self, "success", tuple(np.asarray(s, dtype=float) for s in self.success))
        D = len(self.names)
        lam = self.lambdas.reshape(-1, 2) if self.lambdas.size else np.zeros((0, 2))
        object.__setattr__(self, "lambdas", lam)
        if self.mean.shape != (D,) or self.components.shape != (2, D) or self.sigmas.shape != (2,):
            raise InvalidTask(
                f"initial-pose sequence: mean, components and sigmas must have shapes ({D},), (2, {D}), (2,); "
                f"got {self.mean.shape}, {self.components.shape}, {self.sigmas.shape}"
            )
        if np.any(lam < 0) or np.any(lam > 1):
            raise InvalidTask("initial-pose sequence: every lambda must lie in [0, 1]")

    def __len__(self) -> int:
        return self.lambdas.shape[0]

    def poses(self, lambdas) -> np.ndarray:
        """Eq. 11 for ``lambdas (S, 2)`` -> poses (S, D)."""
        lam = np.atleast_2d(np.asarray(lambdas, dtype=float))
        k = 3.0 * self.sigmas * (2.0 * lam - 1.0)  # (S, 2)
        # elementwise, not a matrix product: each row's rounding independent of the batch size
        return self.mean + k[:, 0:1] * self.components[0] + k[:, 1:2] * self.components[1]

    def pose(self, i: int) -> np.ndarray:
        """The ``i``-th pose of the sequence (0-based), (D,)."""
        return self.poses(self.lambdas[i])[0]

    def with_lambdas(self, lambdas, success=(), **meta) -> "InitialPoseSequence":
        return InitialPoseSequence(
            self.hand, self.names, self.mean, self.components, self.sigmas, lambdas, tuple(success),
            {**self.meta, **meta},
        )  # fmt: skip

    # -- files ------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {
            "prehension": SEQUENCE_TAG,
            "hand": self.hand,
            "units": "rad",
            "equation": "Q_i = mean + 3 sigma_1 (2 lambda_i1 - 1) c_1 + 3 sigma_2 (2 lambda_i2 - 1) c_2",
            "names": list(self.names),
            "mean": self.mean.tolist(),
            "components": self.components.tolist(),
            "sigmas": self.sigmas.tolist(),
            "lambdas": self.lambdas.tolist(),
            "success": [s.tolist() for s in self.success],
            "meta": to_plain(dict(self.meta)),
        }

    @classmethod
    def from_dict(cls, data: dict, source: str = "sequence") -> "InitialPoseSequence":
        if not isinstance(data, dict) or data.get("prehension") != SEQUENCE_TAG:
            raise InvalidTask(f"{source}: not an initial-pose sequence (expected 'prehension: {SEQUENCE_TAG}')")
        try:
            return cls(
                data["hand"], data["names"], data["mean"], data["components"], data["sigmas"], data["lambdas"],
                tuple(data.get("success", ())), data.get("meta", {}),
            )  # fmt: skip
        except KeyError as exc:
            raise InvalidTask(f"{source}: missing field {exc.args[0]!r}") from None

    def save(self, path) -> None:
        """Write the sequence as JSON, atomically."""
        write_json_atomic(path, self.to_dict())

    @classmethod
    def load(cls, path) -> "InitialPoseSequence":
        return cls.from_dict(read_json(path, "initial-pose sequence"), str(path))


# -- the pose space of a hand -------------------------------------------------------------
def pose_space(hand: Hand, fingers=None) -> tuple[tuple[str, ...], list, list]:
    """Names of a hand's pose components, with the dofs and fingertip caps behind them.

    Returns ``(names, free_dofs, tips)``: the independent angles of ``fingers`` (default:
    all) in hand order, then ``(alpha, gamma)`` of each finger whose tip link carries a
    sphere-cap region (the first such region of the hand).
    """
    fingers = [f.name for f in hand.fingers] if fingers is None else list(fingers)
    coupled = {c.dof for c in hand.couplings}
    moving = set()
    for f in fingers:
        for link in hand.finger(f).links:
            moving |= set(hand.chain_dofs(link))
    free = [d for d in range(hand.n_dof) if d in moving and hand.dof_names[d] not in coupled]
    tips = []
    for f in fingers:
        tip = hand.finger(f).tip_link
        cap = next((r.region for r in hand.regions.values() if r.link == tip and virtual_joints(r.region)), None)
        if cap is not None:
            tips.append((f, cap))
    names = tuple(hand.dof_names[d] for d in free) + tuple(n for f, _ in tips for n in (f"{f}.tip.alpha", f"{f}.tip.gamma"))
    return names, free, tips


def sample_poses(hand: Hand, n: int, rng, fingers=None, *, deadline: float | None = None) -> tuple[tuple[str, ...], np.ndarray]:
    """``n`` random hand poses, as ``(names, (n, D))``: without self-collision, unless the
    hand almost never gives such poses (then the missing ones self-collide: they are
    starting points; see :func:`.problems.random_hand_configurations` with ``fill``).
    Stops at ``deadline`` (:class:`~prehension.deadline.TimeLimitReached`)."""
    from .problems import random_hand_configurations, random_params

    names, free, tips = pose_space(hand, fingers)
    fingers = [f.name for f in hand.fingers] if fingers is None else list(fingers)
    q = random_hand_configurations(hand, fingers, n, rng, collision_free=True, deadline=deadline, fill=True)
    cols = [q[:, free]] + [random_params(cap, rng, n, deadline=deadline) for _, cap in tips]
    return names, np.concatenate(cols, axis=1)


def principal_directions(samples: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(mean (D,), components (2, D), sigmas (2,))`` of a sample (PCA, signs fixed so
    that each component's largest entry is positive)."""
    mean = samples.mean(axis=0)
    cov = np.cov(samples - mean, rowvar=False)
    w, V = np.linalg.eigh(cov)
    order = np.argsort(w)[::-1][:2]
    comps = V[:, order].T
    for k in range(2):
        if comps[k, np.argmax(np.abs(comps[k]))] < 0:
            comps[k] = -comps[k]
    return mean, comps, np.sqrt(np.maximum(w[order], 0.0))


_DEFAULTS: dict = {}


def default_sequence(hand: Hand, n_samples: int = 1000, seed: int = 0, *, deadline: float | None = None) -> InitialPoseSequence:
    """The shipped sequence of a hand if there is one, else PCA + the paper's lambdas (cached).

    The sampling stops at ``deadline`` (:class:`~prehension.deadline.TimeLimitReached`;
    nothing is cached then, so the sequence never depends on the time it was given)."""
    from ._layout import hand_arrays

    key = (hand_arrays(hand)[1], n_samples, seed)
    if key in _DEFAULTS:
        return _DEFAULTS[key]
    seq = shipped_sequence(hand)
    if seq is None:
        names, samples = sample_poses(hand, n_samples, np.random.default_rng(seed), deadline=deadline)
        mean, comps, sig = principal_directions(samples)
        seq = InitialPoseSequence(
            hand.name, names, mean, comps, sig, PAPER_TABLE1,
            meta={"origin": "default: PCA of random poses with the paper's Table 1 lambdas",
                  "n_samples": n_samples, "seed": seed},
        )  # fmt: skip
    _DEFAULTS[key] = seq
    return seq


def shipped_sequence(hand: Hand) -> InitialPoseSequence | None:
    """The precomputed sequence shipped for ``hand`` (by name), if its pose names match."""
    resource = resources.files("prehension.solvers.local").joinpath("data", f"{hand.name}.json")
    if not resource.is_file():
        return None
    seq = InitialPoseSequence.from_dict(json.loads(resource.read_text(encoding="utf-8")), f"shipped {hand.name}.json")
    names, _, _ = pose_space(hand)
    return seq if set(seq.names) <= set(names) and seq.names else None
