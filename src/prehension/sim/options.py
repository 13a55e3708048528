"""Settings of the physics test, with the DexGraspBench protocol's values."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import PrehensionError

__all__ = ["SimOptions", "PUSH_DIRECTIONS"]

#: The six push directions (palm frame): -x, +x, -y, +y, -z, +z, in DexGraspBench's order.
PUSH_DIRECTIONS = (("-x", (-1.0, 0, 0)), ("+x", (1.0, 0, 0)), ("-y", (0, -1.0, 0)),
                   ("+y", (0, 1.0, 0)), ("-z", (0, 0, -1.0)), ("+z", (0, 0, 1.0)))  # fmt: skip


@dataclass(frozen=True)
class SimOptions:
    """The physics test (``prehension simulate``; see ``docs/quality.md``).

    Protocol (DexGraspBench, from the BODex work): no gravity; the object weighs
    ``mass_kg``; every contact has friction ``friction`` (sliding) and ``torsion_mm``
    (torsional, MuJoCo's elliptic soft contacts, ``condim`` 4); the hand is held by
    position actuators (gain ``kp``) at the solved angles, then squeezed: the targets move
    over ``squeeze_s`` to angles that would carry each contact further into the object
    (``squeeze``: ``"push"``, by default, targets whose actuator torques press the
    object with the set of contact forces of zero net wrench that resists the largest
    push, every contact aimed at most ``squeeze_mm`` in (:mod:`.aim`); ``"forces"``, the
    same with one such set picked without regard to the pushes, the deepest contact aimed
    ``squeeze_mm`` in; ``"balanced"``, each contact ``squeeze_mm`` times its normal force in
    such a set over the largest; ``"uniform"``, DexGraspBench's, every contact
    ``squeeze_mm``; :mod:`.squeeze`); then a force of ``push_accel`` x ``mass_kg`` pushes the object's centre of
    mass along one of six directions for ``hold_s``.  A direction *holds* when the object's
    centre of mass moves less than ``max_shift_mm`` and it turns less than
    ``max_turn_deg`` (both from the pose before the squeeze).  A grasp that starts with a
    hand-object penetration deeper than ``max_penetration_mm`` is rejected unsimulated.

    Attributes:
        mass_kg: object mass (0.1 kg).
        friction: sliding friction coefficient (0.6).
        torsion_mm: torsional friction [mm] (20 mm: DexGraspBench's 0.02 m).
        kp: position gain of every joint actuator [N m / rad] (5).
        damping: joint damping [N m s / rad] (keeps the stiff hand stable).
        squeeze_mm: how far each contact is aimed into the object [mm] (with the forces
            and the balanced squeeze: the contact aimed deepest; the others less).
        squeeze: ``"push"`` (default), ``"forces"``, ``"balanced"`` or ``"uniform"`` (DexGraspBench's).
        squeeze_s: duration of the squeeze [s] (0.4 s: 100 steps of 4 ms).
        push_accel: push force per kg [N/kg = m/s^2] (10).
        hold_s: duration of the push [s] (2).
        max_shift_mm, max_turn_deg: what still counts as held (50 mm, 15 deg).
        max_penetration_mm: deeper initial penetrations reject the grasp (10 mm).
        timestep_s: simulation step (4 ms).
        jitter_mm, jitter_deg: robustness test: the object starts displaced by a random
            translation of this size and turned by a random rotation of this angle, drawn
            from the seed (0: the solved pose exactly, the DexGraspBench protocol).
    """

    mass_kg: float = 0.1
    friction: float = 0.6
    torsion_mm: float = 20.0
    kp: float = 5.0
    damping: float = 0.1
    squeeze_mm: float = 10.0
    squeeze: str = "push"
    squeeze_s: float = 0.4
    push_accel: float = 10.0
    hold_s: float = 2.0
    max_shift_mm: float = 50.0
    max_turn_deg: float = 15.0
    max_penetration_mm: float = 10.0
    timestep_s: float = 0.004
    jitter_mm: float = 0.0
    jitter_deg: float = 0.0

    def __post_init__(self):
        positive = ("mass_kg", "kp", "squeeze_s", "hold_s", "max_shift_mm", "max_turn_deg", "timestep_s")
        non_negative = ("friction", "torsion_mm", "damping", "squeeze_mm", "push_accel", "max_penetration_mm",
                        "jitter_mm", "jitter_deg")  # fmt: skip
        for name in positive + non_negative:
            value = getattr(self, name)
            ok = isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value)
            ok = ok and (value > 0 if name in positive else value >= 0)
            if not ok:
                need = "a positive number" if name in positive else "a number >= 0"
                raise PrehensionError(f"simulation options: {name} must be {need}, got {value!r}")
        if self.squeeze not in ("forces", "balanced", "uniform", "push"):
            raise PrehensionError(f"simulation options: squeeze must be 'forces', 'push', 'balanced' or 'uniform', got {self.squeeze!r}")
        if self.timestep_s > 0.05:
            raise PrehensionError(f"simulation options: timestep_s must be at most 0.05 s, got {self.timestep_s}")

    def to_dict(self) -> dict:
        return asdict(self)
