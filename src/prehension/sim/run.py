"""Run the physics test of a grasp (the protocol of :class:`~prehension.sim.options.SimOptions`).

Each of the six pushes starts from the same state -- the hand at the solved angles, the
object at the solved pose (jittered by the seed when asked) -- and runs the squeeze, then
the push, stopping early once the object has left the tolerances.  MuJoCo is
deterministic: the same grasp, options and seed give the same numbers.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

import numpy as np

from ..errors import PrehensionError
from ..mujoco_log import import_mujoco
from ..geometry.rotations import rotation_about
from ..tasks.model import Task
from .options import PUSH_DIRECTIONS, SimOptions
from .scene import MM, SimScene, build_scene_xml
from .push import squeeze_for
from .start import hand_depth, posed, solver_distance, start_state

__all__ = ["PushOutcome", "PhysicsReport", "Closing", "simulate_grasp", "require_mujoco", "scene_for"]

_INSTALL = 'pip install "prehension[sim]"'
_BLOCKS = 10  # the push is checked this many times (early stop), as DexGraspBench does


def require_mujoco():
    """The ``mujoco`` module, or a :class:`PrehensionError` that says how to install it."""
    try:
        return import_mujoco()
    except ImportError:
        raise PrehensionError(f"the physics test needs MuJoCo; install it with: {_INSTALL}") from None


@dataclass(frozen=True)
class PushOutcome:
    """One push: ``direction`` (``"-x"``...), whether the grasp ``held``, how far the
    object's centre of mass moved [mm] and how far it turned [deg], and the deepest
    hand-object penetration at the start [mm].  ``unstable``: the simulation went
    unstable (MuJoCo found a NaN, infinite or huge position, velocity or acceleration and
    reset its state): the push counts as dropped, whatever the distances read after the
    reset."""

    direction: str
    held: bool
    shift_mm: float
    turn_deg: float
    initial_penetration_mm: float
    unstable: bool = False

    def describe(self) -> str:
        """``"-x (moved 3 mm, turned 2 deg)"``, or why the distances mean nothing."""
        if self.unstable:
            return f"{self.direction} (the simulation went unstable)"
        return f"{self.direction} (moved {self.shift_mm:.0f} mm, turned {self.turn_deg:.0f} deg)"


@dataclass(frozen=True)
class Closing:
    """The hand closing from the pre-grasp (``simulate --from-pregrasp``): the position
    targets move from the pre-grasp's angles to the grasp's over ``close_s``, then hold
    there for as long again.  The grasp is **reached** when the object then stands within
    ``REACH_MM`` and ``REACH_DEG`` of its solved pose and every joint within
    ``REACH_JOINT_DEG`` of its solved angle, and the simulation stayed stable
    (``unstable``: it did not)."""

    reached: bool
    shift_mm: float
    turn_deg: float
    joint_error_deg: float
    unstable: bool = False

    def describe(self) -> str:
        if self.unstable:
            return "closing from the pre-grasp does NOT reach the grasp (the simulation went unstable)"
        return (f"closing from the pre-grasp {'reaches' if self.reached else 'does NOT reach'} the grasp (object moved "
                f"{self.shift_mm:.1f} mm, turned {self.turn_deg:.1f} deg; joints within {self.joint_error_deg:.1f} deg)")


REACH_MM, REACH_DEG, REACH_JOINT_DEG = 5.0, 5.0, 3.0
CLOSE_S = 0.5  # [s] the closing ramp, then as long again to settle


@dataclass(frozen=True)
class PhysicsReport:
    """The physics test of one grasp.

    Attributes:
        success: held in all six directions (and not rejected).
        rejected: the grasp started with a penetration deeper than the limit (not simulated).
        initial_penetration_mm: deepest hand-object penetration MuJoCo sees at the start [mm].
        pushes: one outcome per direction (empty when rejected).
        seed: the seed of the jitter.
        options: the protocol's settings.
        hand_penetration_mm: how deep the hand's geoms reach into the solver's mesh at the
            start [mm], exactly (``None``: the object has no mesh); see :mod:`.start`.
        approximation_mm: how far the object's convex pieces stand out of the solver's mesh
            where the hand touches them at the start [mm] (the object's approximation error).
        object_pieces: how many convex pieces made the object (after refining near the hand).
        closing: the hand closing from the pre-grasp, when the test started there
            (``None``: it started at the grasp); success then also needs it reached, and
            each push starts from the state the closing ended in.
    """

    success: bool
    rejected: bool
    initial_penetration_mm: float
    pushes: tuple[PushOutcome, ...]
    seed: int
    options: SimOptions = field(default_factory=SimOptions)
    hand_penetration_mm: float | None = None
    approximation_mm: float = 0.0
    object_pieces: int = 0
    closing: Closing | None = None

    @property
    def held(self) -> int:
        return sum(p.held for p in self.pushes)

    def to_dict(self) -> dict:
        return {
            "success": self.success, "rejected": self.rejected, "initial_penetration_mm": self.initial_penetration_mm,
            "hand_penetration_mm": self.hand_penetration_mm, "approximation_mm": self.approximation_mm,
            "object_pieces": self.object_pieces, "held": self.held, "pushes": [asdict(p) for p in self.pushes],
            "seed": self.seed, "options": self.options.to_dict(),
            **({} if self.closing is None else {"closing": asdict(self.closing)}),
        }  # fmt: skip

    def describe(self) -> str:
        if self.rejected:
            return (f"rejected: starts with {self.initial_penetration_mm:.1f} mm of hand-object penetration "
                    f"(limit {self.options.max_penetration_mm:g} mm)")  # fmt: skip
        verdict = "holds" if self.success else "DROPS"
        closing = "" if self.closing is None else f"; {self.closing.describe()}"
        unstable = sum(p.unstable for p in self.pushes)
        unstable = f" (the simulation went unstable in {unstable} of them)" if unstable else ""
        return f"{verdict}: held against {self.held} of {len(self.pushes)} pushes{unstable}{closing}"


def _jittered(T: np.ndarray, centre_mm: np.ndarray, options: SimOptions, seed: int) -> np.ndarray:
    """``T`` moved by a seeded random translation and rotation about the object's centre."""
    if options.jitter_mm == 0 and options.jitter_deg == 0:
        return T.copy()
    rng = np.random.default_rng(seed)
    d = rng.normal(size=3)
    axis = rng.normal(size=3)
    R = rotation_about(axis / np.linalg.norm(axis), np.radians(options.jitter_deg))
    c = T[:3, :3] @ centre_mm + T[:3, 3]  # the centre, palm frame
    out = np.eye(4)
    out[:3, :3] = R @ T[:3, :3]
    out[:3, 3] = R @ (T[:3, 3] - c) + c + options.jitter_mm * d / np.linalg.norm(d)
    return out


def scene_for(task: Task, solution, options: SimOptions = SimOptions(), seed: int = 0) -> SimScene:
    """The MuJoCo scene of ``solution`` (see :mod:`.scene`), its object's pieces refined
    next to the hand (:mod:`.start`; the approximation error left there in the scene's
    ``approximation_mm``)."""
    from ..quality.solid import mass_properties, object_solid

    centre = mass_properties(object_solid(task.object)).centroid_mm
    T = _jittered(np.asarray(solution.T_palm_object, float), centre, options, seed)
    start = start_state(require_mujoco(), task, T, np.asarray(solution.q, float), options)
    return replace(build_scene_xml(task, T, start.pieces, options), approximation_mm=start.approximation_mm)


def simulate_grasp(task: Task, solution, options: SimOptions = SimOptions(), seed: int = 0, pregrasp_q=None,
                   q_squeeze=None) -> PhysicsReport:  # fmt: skip
    """The physics test of ``solution`` (a grasp of ``task``; see the module docstring).

    ``pregrasp_q``: (n_dof,) angles to start from instead of the grasp's (its pre-grasp,
    :mod:`prehension.pregrasp`): the hand first closes onto the object (:class:`Closing`).
    ``q_squeeze``: the squeeze's targets when already computed (the first of
    :func:`~.push.squeeze_for`'s answer with the same ``options``), else computed here.
    """
    mujoco = require_mujoco()
    try:
        return _simulated(mujoco, task, solution, options, seed, pregrasp_q, q_squeeze)
    except mujoco.FatalError as exc:  # e.g. the arena overflows: a clear error, never a traceback
        raise PrehensionError(f"the physics test of task {task.name!r} stopped inside MuJoCo: {str(exc).splitlines()[0]}") from None


def _simulated(mujoco, task: Task, solution, options: SimOptions, seed: int, pregrasp_q, q_squeeze) -> PhysicsReport:
    """:func:`simulate_grasp` with MuJoCo at hand."""
    scene = scene_for(task, solution, options, seed)
    q = np.asarray(solution.q, dtype=float)
    model, data = posed(mujoco, scene.xml, scene.dof_names, q)
    if q_squeeze is None:
        q_squeeze = squeeze_for(task, q, solution.T_palm_object, solution.contacts, options)[0]
    sim = _Sim(mujoco, model, data, scene, q, q_squeeze, options)
    closing = None
    if pregrasp_q is not None:
        sim.q = np.asarray(pregrasp_q, dtype=float)
        depth = sim.reset()
        if depth <= options.max_penetration_mm:
            closing = sim.close(q)
    else:
        depth = sim.reset()
    start = dict(hand_penetration_mm=hand_depth(model, data, solver_distance(task), scene.T_palm_object),
                 approximation_mm=scene.approximation_mm, object_pieces=len(scene.object_pieces))  # fmt: skip
    if depth > options.max_penetration_mm:
        return PhysicsReport(False, True, depth, (), seed, options, **start)
    pushes = tuple(sim.push(name, np.asarray(d), depth) for name, d in PUSH_DIRECTIONS)
    success = all(p.held for p in pushes) and (closing is None or closing.reached)
    return PhysicsReport(success, False, depth, pushes, seed, options, **start, closing=closing)


class _Sim:
    """One model and its data, reset before each push."""

    def __init__(self, mujoco, model, data, scene: SimScene, q, q_squeeze, options: SimOptions):
        self.mj, self.model, self.data, self.options = mujoco, model, data, options
        self.qpos_adr = np.array([model.joint(f"dof:{d}").qposadr[0] for d in scene.dof_names])
        self.act = np.array([model.actuator(f"act:{d}").id for d in scene.dof_names])
        self.body = model.body("object").id
        self.q, self.q_squeeze = q, q_squeeze
        self.closed = None  # (qpos, qvel, ctrl) where the closing from the pre-grasp ended

    def reset(self) -> float:
        """Back to the start; the deepest hand-object penetration there [mm]."""
        mj, m, d = self.mj, self.model, self.data
        mj.mj_resetData(m, d)
        if self.closed is not None:
            d.qpos[:], d.qvel[:], d.ctrl[:] = self.closed
        else:
            d.qpos[self.qpos_adr] = self.q
            d.ctrl[self.act] = self.q
        mj.mj_forward(m, d)
        dists = [d.contact[i].dist for i in range(d.ncon)]
        return max(0.0, -min(dists, default=0.0)) / MM

    def close(self, q_grasp) -> Closing:
        """Targets from the pre-grasp to ``q_grasp`` over ``CLOSE_S``, then held as long;
        later pushes start from where this ends (squeezing towards ``q_squeeze``)."""
        mj, m, d, o = self.mj, self.model, self.data, self.options
        com0, R0 = d.xipos[self.body].copy(), d.xmat[self.body].reshape(3, 3).copy()
        steps = max(int(round(CLOSE_S / o.timestep_s)), 1)
        start = self.q.copy()
        for k in range(1, 2 * steps + 1):
            d.ctrl[self.act] = start + (q_grasp - start) * min(k / steps, 1.0)
            mj.mj_step(m, d)
        shift, turn = self._moved(com0, R0)
        error = float(np.degrees(np.max(np.abs(d.qpos[self.qpos_adr] - q_grasp)))) if len(q_grasp) else 0.0
        unstable = self._unstable()
        self.closed = (d.qpos.copy(), d.qvel.copy(), d.ctrl.copy())
        self.q = np.asarray(q_grasp, dtype=float)  # the squeeze ramps from the grasp's targets
        reached = not unstable and shift < REACH_MM and turn < REACH_DEG and error < REACH_JOINT_DEG
        return Closing(bool(reached), shift, turn, error, unstable)

    def _unstable(self) -> bool:
        """MuJoCo found a NaN, infinite or huge position, velocity or acceleration since the
        last reset (and reset its state: the counters of ``mjData.warning`` survive that)."""
        W = self.mj.mjtWarning
        return any(self.data.warning[int(w)].number > 0 for w in (W.mjWARN_BADQPOS, W.mjWARN_BADQVEL, W.mjWARN_BADQACC))

    def _moved(self, com0, R0) -> tuple[float, float]:
        com, R = self.data.xipos[self.body], self.data.xmat[self.body].reshape(3, 3)
        turn = R @ R0.T
        angle = np.degrees(np.arccos(np.clip(0.5 * (np.trace(turn) - 1.0), -1.0, 1.0)))
        return float(np.linalg.norm(com - com0) / MM), float(angle)

    def push(self, name: str, direction: np.ndarray, depth: float) -> PushOutcome:
        mj, m, d, o = self.mj, self.model, self.data, self.options
        self.reset()
        com0, R0 = d.xipos[self.body].copy(), d.xmat[self.body].reshape(3, 3).copy()
        steps = max(int(round(o.squeeze_s / o.timestep_s)), 1)
        for k in range(1, steps + 1):  # the squeeze: targets ramp to the squeezed angles
            d.ctrl[self.act] = self.q + (self.q_squeeze - self.q) * (k / steps)
            mj.mj_step(m, d)
        d.xfrc_applied[self.body, :3] = o.push_accel * o.mass_kg * direction
        hold = max(int(round(o.hold_s / o.timestep_s)), 1)
        shift, turn = self._moved(com0, R0)
        for block in range(_BLOCKS):
            if self._unstable():
                break
            mj.mj_step(m, d, nstep=hold * (block + 1) // _BLOCKS - hold * block // _BLOCKS)
            shift, turn = self._moved(com0, R0)
            if not (shift < o.max_shift_mm and turn < o.max_turn_deg):
                break
        d.xfrc_applied[self.body] = 0.0
        unstable = self._unstable()
        held = bool(not unstable and shift < o.max_shift_mm and turn < o.max_turn_deg)
        return PushOutcome(name, held, shift, turn, depth, unstable)
