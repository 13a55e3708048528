"""Options of the local solver (Claret & Suárez, sec. 3.1 and 4.1), with the paper's values.

Paper -> here:

==================  ==================  =========================================================
paper               option              meaning
==================  ==================  =========================================================
``i_max = 12``      ``i_max``           initial poses tried (outer loop of Algorithm 1); ours
                                        64: the sequence's 12, then random hand poses
``k_max = 100``     ``k_max``           Jacobian iterations per initial pose; ours 40: a
                                        start not within d_min after 40 rarely gets there,
                                        the next initial pose is cheaper
``d_min = 1.5 mm``  ``d_min_mm``        a contact holds when ``|p - p*| < d_min`` and
                                        ``|r - r*| < d_min`` (eq. 9)
``s_min = 1 mm``    ``s_min_mm``        "no progress": the contacts moved less than ``s_min``
                                        in total (eq. 10) ...
``n``               ``n_stall``         ... during ``n`` consecutive iterations (the paper
                                        gives no value)
``alpha``           ``alpha``           step size of ``Delta C' = J^+ alpha (P* - P)`` (eq. 7)
(pseudo-inverse)    ``damping_mm``      damped least squares instead of a plain pseudo-inverse
==================  ==================  =========================================================

The paper's second condition ``|r - r*| < d_min`` compares fingertip centres
``r = p - rho n``; the solver compares ``w_n |n_h + n_o|`` with ``d_min`` instead, with
``w_n = normal_weight_mm`` (13 mm, the SA fingertip radius), which is the same test for a
spherical fingertip and also makes sense for regions that are not spheres.

**Acceptance.**  A configuration whose contacts are within ``d_min`` is a *local*
solution in the paper's sense; the solver then *polishes* it with a few Gauss-Newton
iterations, which usually drive the contacts to ~1e-10 mm.  Only a configuration that
passes the **strict** default :class:`~prehension.verification.residuals.Tolerances` is a
solution (status ``"solved"``); a local solution that polishing could not make strict is
not one, and the solver goes on to its next initial pose.

**Approximate answers, only when asked for.**  With ``approximate=True`` a configuration
that meets only :attr:`LocalOptions.acceptance` -- contacts within ``d_min``, normals
within the angle that ``d_min`` allows (``2 asin(d_min / 2 w_n)``, 6.6 deg), limits,
couplings and self-collision exact: the paper's notion of success -- is returned with the
status ``"approximate"`` (never ``"solved"``) when no strict one is found within
``strict_retries`` further initial poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...errors import PrehensionError
from ...verification.residuals import Tolerances
from . import _kernel as K

__all__ = ["LocalOptions", "STRICT"]

#: The tolerances of a solution (status ``"solved"``): the strict defaults.
STRICT = Tolerances()


@dataclass(frozen=True)
class LocalOptions:
    """Settings of :func:`prehension.solvers.local.solve_local` (see the module docstring).

    Attributes:
        i_max: initial poses tried per problem (paper: 12; here 64: the off-line
            sequence's poses first, then random collision-free hand poses of the whole
            pose space, drawn per problem -- measured on forward-built problems with 30
            and 60 deg fingertip caps: 99.4% strictly solved with 12 poses, 99.97% with 64,
            the extra poses costing only the problems the first ones miss).
        k_max: Jacobian iterations per initial pose (paper: 100; here 40: on forward-built
            problems with 30 deg caps the starts that end within ``d_min`` take 7 iterations
            (median), 49 (99th percentile), while the 54 of 1513 that never get there spent
            5400 iterations; cutting them at 40 leaves the strict success unchanged,
            2999/3000, and saves a fifth of the kernel's time -- ``benchmarks/fig9.py``).
        d_min_mm: contact tolerance of the iterations [mm] (paper: 1.5).
        s_min_mm: smallest total motion of the contacts that counts as progress [mm]
            (paper: 1).
        n_stall: iterations without progress that end an initial pose.
        alpha: step size (paper's alpha).
        damping_mm: damping ``mu`` of the least-squares step [mm] (0: pseudo-inverse).
        max_step_mm: largest change of one unknown per iteration, in scaled units [mm]
            (a joint angle counts ``joint_scale_mm`` mm per rad).
        normal_weight_mm: weight ``w_n`` of the normal rows [mm].
        joint_scale_mm: scale of joint angles [mm per rad] in the damped step.
        active_set: freeze unknowns at a bound that the step would push out and
            recompute the step (joint limits respected *during* the iterations; without
            it the step is only clipped).
        polish: run Gauss-Newton polishing on every local solution.
        polish_iterations: most polishing iterations.
        polish_tol_mm: polishing target for contact distances and weighted normals [mm].
        approximate: return a configuration that meets only :attr:`acceptance` (status
            ``"approximate"``) when no strict one is found; off by default, so that the
            local solver answers ``"solved"`` or ``"gave_up"`` only.
        strict_retries: with ``approximate``: after a local solution that meets only the
            ``d_min`` tolerances, try this many more initial poses for one that meets the
            strict tolerances (the first ``d_min`` solution is returned if none does).
        psi_rule: ``"paper"``: the rotation about the anchor normal aligns the index ->
            ring direction (or the first -> last other contact); ``"procrustes"``: it
            best aligns every other contact seen from the anchor.
        initial: ``"sequence"`` (the off-line sequence) or ``"random"`` (random
            lambdas, the paper's comparison in Fig. 9).
        check_collisions: reject local solutions in self-collision (Check_Collisions).
        repair_iterations: beyond the paper: a local solution in self-collision is first
            *repaired* -- Gauss-Newton on the contacts plus one row per capsule pair
            closer than ``collision_margin_mm``, which pushes the pair apart within the
            contacts' null space -- for at most this many iterations (0: the paper's
            behaviour, go straight to the next initial pose).  30: on fig9's point
            problems (30 deg caps) successful repairs take 3-12 iterations and 10 would
            do, but penetration repairs on the built-in tasks need more: guitar-holding
            was solved for 5 of 12 seeds with 10, and one batch test's seed needs 30.
        collision_margin_mm: clearance the repair aims at [mm].
        tolerances: acceptance tolerances when the strict ones are not met
            (default: derived from ``d_min_mm``, see :attr:`acceptance`).
        cap_margin_rad: sphere-cap parameters are kept this far inside the cone.
        time_limit_s: stop after this long [s] (``None``: no limit): no new initial pose
            is started and no more random poses are drawn once it has passed; the
            problems not solved by then get ``"gave_up"`` with a message that says so.
            One call's limit, shared by every problem of a batch.
    """

    i_max: int = 64
    k_max: int = 40
    d_min_mm: float = 1.5
    s_min_mm: float = 1.0
    n_stall: int = 5
    alpha: float = 1.0
    damping_mm: float = 0.02
    max_step_mm: float = 60.0
    normal_weight_mm: float = 25.0
    joint_scale_mm: float = 40.0
    active_set: bool = True
    polish: bool = True
    polish_iterations: int = 10
    polish_tol_mm: float = 1e-9
    approximate: bool = False
    strict_retries: int = 2
    psi_rule: str = "procrustes"
    initial: str = "sequence"
    check_collisions: bool = True
    repair_iterations: int = 30
    collision_margin_mm: float = 0.5
    tolerances: Tolerances | None = field(default=None)
    cap_margin_rad: float = 1e-9
    time_limit_s: float | None = None

    def __post_init__(self):
        def need(cond, msg):
            if not cond:
                raise PrehensionError(f"LocalOptions: {msg}")

        need(isinstance(self.i_max, (int, np.integer)) and self.i_max >= 1, f"i_max must be an integer >= 1, got {self.i_max!r}")
        need(isinstance(self.k_max, (int, np.integer)) and self.k_max >= 0, f"k_max must be an integer >= 0, got {self.k_max!r}")
        need(isinstance(self.n_stall, (int, np.integer)) and self.n_stall >= 1, f"n_stall must be an integer >= 1, got {self.n_stall!r}")
        need(
            isinstance(self.polish_iterations, (int, np.integer)) and self.polish_iterations >= 0,
            f"polish_iterations must be an integer >= 0, got {self.polish_iterations!r}",
        )
        need(
            isinstance(self.repair_iterations, (int, np.integer)) and self.repair_iterations >= 0,
            f"repair_iterations must be an integer >= 0, got {self.repair_iterations!r}",
        )
        need(
            isinstance(self.strict_retries, (int, np.integer)) and self.strict_retries >= 0,
            f"strict_retries must be an integer >= 0, got {self.strict_retries!r}",
        )
        for name in ("d_min_mm", "alpha", "max_step_mm", "normal_weight_mm", "joint_scale_mm", "polish_tol_mm"):
            v = getattr(self, name)
            need(np.isfinite(v) and v > 0, f"{name} must be a positive number, got {v!r}")
        for name in ("s_min_mm", "damping_mm", "cap_margin_rad", "collision_margin_mm"):
            v = getattr(self, name)
            need(np.isfinite(v) and v >= 0, f"{name} must be a number >= 0, got {v!r}")
        need(self.psi_rule in ("paper", "procrustes"), f"psi_rule must be 'paper' or 'procrustes', got {self.psi_rule!r}")
        need(self.initial in ("sequence", "random"), f"initial must be 'sequence' or 'random', got {self.initial!r}")
        for name in ("approximate", "polish", "active_set", "check_collisions"):
            v = getattr(self, name)
            need(isinstance(v, (bool, np.bool_)), f"{name} must be True or False, got {v!r}")
        need(self.tolerances is None or isinstance(self.tolerances, Tolerances), "tolerances must be a Tolerances or None")
        limit = self.time_limit_s
        need(limit is None or (isinstance(limit, (int, float, np.number)) and not isinstance(limit, bool) and limit > 0
                               and math.isfinite(limit)), f"time_limit_s must be a number of seconds > 0 or None, got {limit!r}")

    @property
    def normal_tolerance_deg(self) -> float:
        """The normal misalignment that ``w_n |n_h + n_o| < d_min`` allows [deg]."""
        ratio = min(1.0, self.d_min_mm / (2.0 * self.normal_weight_mm))
        return math.degrees(2.0 * math.asin(ratio))

    @property
    def acceptance(self) -> Tolerances:
        """Tolerances of a local solution that polishing did not make strict."""
        if self.tolerances is not None:
            return self.tolerances
        return Tolerances(contact_mm=self.d_min_mm, normal_deg=self.normal_tolerance_deg)

    def kernel_options(self) -> K.Options:
        """The options as the kernel takes them (:class:`._kernel.Options`)."""
        return K.Options(
            alpha=float(self.alpha), damping_sq=float(self.damping_mm) ** 2, d_min=float(self.d_min_mm),
            w_n=float(self.normal_weight_mm), s_min=float(self.s_min_mm), n_stall=int(self.n_stall),
            k_max=int(self.k_max), max_step=float(self.max_step_mm),
            n_polish=int(self.polish_iterations) if self.polish else 0, polish_tol=float(self.polish_tol_mm),
            active_set=bool(self.active_set), procrustes=self.psi_rule == "procrustes",
            cap_margin=float(self.cap_margin_rad), n_repair=int(self.repair_iterations),
            collision_margin=float(self.collision_margin_mm), check_collisions=bool(self.check_collisions),
        )  # fmt: skip
