"""The solution set of a task near one grasp: local coordinates, constraints, projection.

A grasp of ``C`` contacts is a point of the set

.. math::

    \\mathcal{M} = \\{(z, T) : F(z, T) = 0,\\; z_{lo} \\le z \\le z_{hi}\\}, \\qquad
    F = \\big(p_h(q, u_h) - p_o(T, u_o),\\; w_n\\,(n_h(q, u_h) + n_o(T, u_o))\\big)_{c=1..C} \\in \\mathbb{R}^{6C},

with ``z = (q_free, u_h, u_o)``: the joint angles the task moves (a coupled angle follows
its source), the hand regions' and the object regions' parameters, and ``T`` the object
pose (palm frame).  ``p``, ``n`` are the contact points [mm] and outward normals of
eqs. 15-16 -- the rows of the local solver (Claret & Suárez), computed by the one residual
function's batch core :func:`~prehension.verification.residuals.contact_residuals`; ``w_n`` [mm]
weighs the normals like the points.

The object moves by a twist ``tau = (omega, v)`` about the contacts' centroid ``c``:
``R <- Rot(omega) R``, ``t <- Rot(omega)(t - c) + c + v``.  Every unknown is scaled to
millimetres (:attr:`GraspChart.scale`): an angle by ``JOINT_SCALE_MM``, a region
parameter by how far a unit of it moves the region's point, ``omega`` by the object's
radius; steps and null spaces are taken in these units.

:meth:`GraspChart.jacobian` differentiates ``F`` by forward differences in one batched
call (``1 + n`` configurations: forward kinematics of a few dozen configurations costs
~50 us); :meth:`GraspChart.tangent` projects an ascent direction onto the null space of
``J``; :meth:`GraspChart.project` returns onto ``F = 0`` by Levenberg-Marquardt steps

.. math::

    (J^\\top J + \\lambda^2 I)\\, \\delta z = -J^\\top F \\quad (\\text{scaled units}),

the unknowns kept in their bounds and the contacts on fingertip caps in their cones.
Whatever it reaches is judged by :func:`~prehension.results.make_solution` alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.rotations import axis_angle_to_matrix
from ..hands.kinematics import forward_kinematics
from ..tasks.model import Configuration, Task
from ..verification.residuals import contact_residuals

__all__ = ["GraspChart", "JOINT_SCALE_MM", "NORMAL_WEIGHT_MM"]

JOINT_SCALE_MM = 40.0  # a radian of joint angle counts as this many mm (the local solver's joint_scale_mm)
NORMAL_WEIGHT_MM = 40.0  # w_n: the normal rows' weight [mm]
_FD_STEP_MM = 1e-6  # forward-difference step, scaled units [mm]
_CONVERGED_MM = 1e-9  # |F|_inf [mm] at which the projection stops (the strict tolerances: 1e-6 mm, 1e-6 deg ~ 7e-7 mm here)
_MAX_STEP_MM = 10.0  # longest projection step, scaled units [mm]
_DAMPING = 0.05  # Levenberg-Marquardt damping of a projection step (scaled units; J's entries are O(1))
_CONE_WEIGHT_MM = 1e3  # weight of a cap-cone row in a projection step (honoured exactly when consistent)
_CONE_MARGIN = 1e-9  # a step that meets a cone aims this far inside it (cos units)
_NEWTON_ITERATIONS = 15  # Levenberg-Marquardt steps of a projection at most
_AT_BOUND_MM = 1e-9  # an unknown this close to its bound (scaled mm along a step) is at it
_NEAR_BOUND = 0.1  # an unknown that a step would carry to its bound within this fraction of it is held


@dataclass(frozen=True, eq=False)
class GraspChart:
    """Local coordinates of a task's solution set around a grasp (module docstring).

    Attributes:
        task: the task.
        q_base: (n_dof,) the joint angles the chart starts from [rad] (idle fingers keep theirs).
        free: (nq,) indices of the dofs ``z`` moves (active, not a coupling's target).
        spans: per contact ``((hand start, k_h), (object start, k_o))`` in ``z``.
        lo, hi: (nz,) bounds of ``z`` (joint limits [rad], region parameter boxes).
        scale: (nz + 6,) mm per unit of each unknown, the twist's last.
        pivot: (3,) the point the object turns about (palm frame) [mm].
        cones: per region whose normals must stay within a cone (a sphere cap), ``(index
            of its first parameter in z, region)``: the parameter box only bounds it, the
            region's :meth:`~prehension.geometry.regions.Region.cone_margin` (``cos(g)
            cos(a) - cos(half angle)`` for a cap) must stay >= 0.
    """

    task: Task
    q_base: np.ndarray
    free: np.ndarray
    spans: tuple
    lo: np.ndarray
    hi: np.ndarray
    scale: np.ndarray
    pivot: np.ndarray
    cones: tuple = ()

    @classmethod
    def at(cls, task: Task, config: Configuration, object_radius_mm: float) -> tuple["GraspChart", np.ndarray]:
        """The chart around ``config`` (its ``contact_params`` given) and its ``z`` there."""
        hand = task.hand
        targets = {hand.dof_index(c.dof) for c in hand.couplings}
        free = np.array([d for d in np.flatnonzero(task.active_mask) if d not in targets], dtype=np.intp)
        lo, hi, z, spans, scale = [hand.lower[free]], [hand.upper[free]], [config.joint_angles[free]], [], [np.full(free.size, JOINT_SCALE_MM)]
        at, cones = free.size, []
        for contact, params in zip(task.contacts, config.contact_params):
            span = []
            for region, u in zip((task.hand_region(contact).region, task.object_region(contact)), params):
                u = np.asarray(u, dtype=float)
                a, b = region.param_bounds()
                lo.append(a), hi.append(b), z.append(u)
                scale.append(_param_scale(region, u))
                if region.cone_margin(u) is not None:
                    cones.append((at, region))
                span.append((at, u.size))
                at += u.size
            spans.append(tuple(span))
        pivot = np.mean([config.T_palm_object[:3, :3] @ task.object_region(c).evaluate(np.asarray(op, float)[None])[0][0]
                         for c, (_, op) in zip(task.contacts, config.contact_params)], axis=0) + config.T_palm_object[:3, 3]  # fmt: skip
        scale.append(np.r_[np.full(3, max(object_radius_mm, 1.0)), np.ones(3)])
        chart = cls(task, np.asarray(config.joint_angles, float).copy(), free, tuple(spans), np.concatenate(lo),
                    np.concatenate(hi), np.concatenate(scale), pivot, tuple(cones))  # fmt: skip
        return chart, np.concatenate(z)

    @property
    def nz(self) -> int:
        return self.lo.size

    def object_slices(self) -> list[slice]:
        """Where each contact's object parameters lie in ``z``."""
        return [slice(o0, o0 + ok) for _, (o0, ok) in self.spans]

    def angles(self, Z: np.ndarray) -> np.ndarray:
        """Every joint angle ``(B, n_dof)`` [rad] of unknowns ``Z (B, nz)`` (couplings exact)."""
        hand = self.task.hand
        q = np.repeat(self.q_base[None], Z.shape[0], axis=0)
        q[:, self.free] = Z[:, : self.free.size]
        for _ in range(2):  # a coupling's source may itself be coupled
            for c in hand.couplings:
                d, s = hand.dof_index(c.dof), hand.dof_index(c.source)
                if self.task.active_mask[d]:
                    q[:, d] = c.ratio * q[:, s] + c.offset
        return q

    def moved(self, T: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Object poses ``(B, 4, 4)``: ``T (4, 4)`` moved by twists ``tau (B, 6)`` (rad, mm)."""
        w = tau[:, :3]
        angle = np.linalg.norm(w, axis=1)
        axis = np.where(angle[:, None] > 0, w / np.maximum(angle, 1e-300)[:, None], [0.0, 0.0, 1.0])
        R = axis_angle_to_matrix(axis, angle)  # (B, 3, 3)
        out = np.repeat(T[None], tau.shape[0], axis=0)
        out[:, :3, :3] = R @ T[:3, :3]
        out[:, :3, 3] = np.einsum("bij,j->bi", R, T[:3, 3] - self.pivot) + self.pivot + tau[:, 3:]  # (B, 3)
        return out

    def residuals(self, Z: np.ndarray, T: np.ndarray) -> np.ndarray:
        """``F (B, 6C)`` [mm] of unknowns ``Z (B, nz)`` and object poses ``T (B, 4, 4)``."""
        pose = forward_kinematics(self.task.hand, self.angles(Z))
        params = [(Z[:, h0 : h0 + hk], Z[:, o0 : o0 + ok]) for (h0, hk), (o0, ok) in self.spans]
        res = contact_residuals(self.task, pose, T, params)
        gap = res["hand_point"] - res["object_point"]  # (B, C, 3)
        normals = NORMAL_WEIGHT_MM * (res["hand_normal"] + res["object_normal"])  # (B, C, 3)
        return np.concatenate([gap, normals], axis=2).reshape(Z.shape[0], -1)

    def jacobian(self, z: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(F (6C,), dF/d(z, tau) (6C, nz + 6))`` at ``(z, T)``, by forward differences."""
        n = self.nz + 6
        h = _FD_STEP_MM / self.scale  # (n,)
        Z = np.repeat(z[None], n + 1, axis=0)
        Z[1 : self.nz + 1, : self.nz] += np.diag(h[: self.nz])
        tau = np.zeros((n + 1, 6))
        tau[self.nz + 1 :] = np.diag(h[self.nz :])
        F = self.residuals(Z, self.moved(T, tau))
        return F[0], ((F[1:] - F[0]) / h[:, None]).T

    def step(self, z: np.ndarray, T: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(z + d[:nz]`` clipped to the bounds``, T`` moved by the twist ``d[nz:])``."""
        return np.clip(z + d[: self.nz], self.lo, self.hi), self.moved(T, d[None, self.nz :])[0]

    def project(self, z: np.ndarray, T: np.ndarray, J: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, bool]:
        """Levenberg-Marquardt steps onto ``F = 0`` from ``(z, T)``: ``(z, T, converged)``.

        Each step is the damped least-squares solution (scaled units, fixed damping
        ``_DAMPING``) of ``J dz = -F`` over the unknowns free in it: an unknown the step
        would carry through a bound is held where it is for that step (decided afresh at
        every step), a contact it would carry out of its cap's cone is kept on the cone
        (``_CONE_MARGIN`` inside), and a step longer than ``_MAX_STEP_MM`` is shortened to it.  ``J``: a Jacobian from nearby (the ascent's
        base point) to start with (chord steps, one residual each, while ``|F|`` falls
        at least by half a step); the Jacobian is recomputed whenever it does not.
        """
        F = self.residuals(z[None], T[None])[0]
        for _ in range(_NEWTON_ITERATIONS):
            if np.max(np.abs(F)) <= _CONVERGED_MM:
                return z, T, True
            if J is None:
                F, J = self.jacobian(z, T)
            z1, T1 = self.step(z, T, self._newton_step(z, F, J / self.scale))
            F1 = self.residuals(z1[None], T1[None])[0]
            if np.max(np.abs(F1)) > 0.5 * np.max(np.abs(F)):
                J = None  # slow or no progress: a fresh Jacobian at the next step
            z, T, F = z1, T1, F1
        return z, T, bool(np.max(np.abs(F)) <= _CONVERGED_MM)

    def _newton_step(self, z: np.ndarray, F: np.ndarray, Js: np.ndarray) -> np.ndarray:
        """A damped least-squares step (unscaled, (nz + 6,)) of ``Js ds = -F``, bounds held and the
        cones kept (see :meth:`project`)."""
        held, active = np.zeros(self.nz + 6, dtype=bool), np.zeros(len(self.cones), dtype=bool)
        value, rows = self._cone_rows(z)
        for _ in range(self.nz + 1):
            A = np.vstack([Js, _CONE_WEIGHT_MM * rows[active]])[:, ~held]
            b = np.r_[-F, _CONE_WEIGHT_MM * (_CONE_MARGIN - value[active])]
            damped = np.vstack([A, _DAMPING * np.eye(A.shape[1])])  # Levenberg-Marquardt: nearly singular directions barely move
            ds = np.zeros(self.nz + 6)
            ds[~held] = np.linalg.lstsq(damped, np.r_[b, np.zeros(A.shape[1])], rcond=None)[0]
            out, cut = self._leaves(z, ds / self.scale)
            if not np.any(out & ~held) and not np.any(cut & ~active):
                break
            held, active = held | out, active | cut
        size = float(np.linalg.norm(ds))
        if size > _MAX_STEP_MM:
            ds *= _MAX_STEP_MM / size
        return ds / self.scale

    def tangent(self, z: np.ndarray, J: np.ndarray, gradient: np.ndarray, radius_mm: float) -> np.ndarray:
        """The ascent step, at most ``radius_mm`` long (scaled units): ``gradient`` (nz + 6,)
        of an objective, in scaled units, projected onto the null space of ``J`` (the
        Jacobian at ``z``: first-order moves along the set) with every unknown that the
        direction would carry to its bound within a tenth of the step held where it is
        (``_NEAR_BOUND``: a step is not spent on a sliver) and every cap cone it would
        leave within a tenth of the step kept at its value (decided again until none is;
        a contact near its cone's edge would otherwise cut every step short to the
        sliver left before it); then shortened so that no unknown
        passes its bound and no contact leaves its cap's cone.  Unscaled, (nz + 6,); zero
        when no move raises the objective to first order."""
        g, Js = gradient / self.scale, J / self.scale  # per mm of scaled unknown
        held, active = np.zeros(self.nz + 6, dtype=bool), np.zeros(len(self.cones), dtype=bool)
        value, rows = self._cone_rows(z)
        for _ in range(self.nz + len(self.cones) + 1):
            u = np.zeros(self.nz + 6)
            u[~held] = _null_projection(np.vstack([Js, rows[active]])[:, ~held], g[~held])
            size = float(np.linalg.norm(u))
            if size <= 1e-12 * max(float(np.linalg.norm(g)), 1e-300):
                return np.zeros(self.nz + 6)
            u /= size  # unit step, scaled units
            reach = self._reach(z, u[: self.nz] / self.scale[: self.nz])  # mm along u until each unknown meets its bound
            blocked = np.r_[reach <= _NEAR_BOUND * radius_mm, np.zeros(6, dtype=bool)]
            toward = rows @ u  # per mm along u: < 0 toward the cone's boundary
            leaving = (toward < 0) & (value <= _NEAR_BOUND * radius_mm * -toward)  # met within a tenth of the step: kept
            if not np.any(blocked & ~held) and not np.any(leaving & ~active):
                break
            held, active = held | blocked, active | leaving
        length = min(radius_mm, float(np.min(reach, initial=np.inf)))
        while length > _AT_BOUND_MM and np.any(self._cone_rows(z + length * u[: self.nz] / self.scale[: self.nz])[0] < 0):
            length *= 0.5  # a cone met on the way: stop short of it
        return length * u / self.scale

    def _reach(self, z: np.ndarray, dz: np.ndarray) -> np.ndarray:
        """Per unknown, how far [mm along the step] ``z + l dz`` stays within its bounds (inf when it never leaves)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(dz > 0, (self.hi - z) / dz, np.where(dz < 0, (self.lo - z) / dz, np.inf))
        return np.maximum(np.nan_to_num(room, nan=np.inf), 0.0)

    def _leaves(self, z: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which unknowns ``z + d`` carries through a bound ((nz + 6,), the twist never) and
        which cap cones it leaves ((n_cones,))."""
        target = z + d[: self.nz]
        out = np.r_[(target < self.lo) | (target > self.hi), np.zeros(6, dtype=bool)]
        return out, self._cone_rows(target)[0] < 0.0

    def _cone_rows(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per cone (:attr:`cones`): how far inside it the contact lies (the region's
        ``cone_margin``, >= 0 inside), and its gradient per scaled
        unknown ((n_cones, nz + 6))."""
        value, rows = np.zeros(len(self.cones)), np.zeros((len(self.cones), self.nz + 6))
        for i, (k, region) in enumerate(self.cones):
            value[i], rows[i, k : k + 2] = region.cone_margin(z[k : k + 2])
        return value, rows / self.scale

    def configuration(self, z: np.ndarray, T: np.ndarray) -> Configuration:
        """The configuration at ``(z, T)``."""
        params = tuple((z[h0 : h0 + hk].copy(), z[o0 : o0 + ok].copy()) for (h0, hk), (o0, ok) in self.spans)
        return Configuration(self.angles(z[None])[0], T.copy(), params)


def _param_scale(region, u: np.ndarray) -> np.ndarray:
    """mm per unit of each parameter of ``region`` at ``u``: the length of ``d point / d u``
    (at least 1 mm, so a degenerate point of a patch does not blow the step up)."""
    if u.size == 0:
        return np.zeros(0)
    dp, _ = region.jacobian(u[None])  # (1, 3, k)
    return np.maximum(np.linalg.norm(dp[0], axis=0), 1.0)


def _null_projection(A: np.ndarray, g: np.ndarray) -> np.ndarray:
    """``N N^T g``: ``g`` projected onto the null space of ``A`` (``N`` an orthonormal basis of it)."""
    _, s, Vt = np.linalg.svd(A, full_matrices=True)
    rank = int(np.sum(s > 1e-9 * max(float(s[0]), 1e-300))) if s.size else 0
    N = Vt[rank:].T
    return N @ (N.T @ g)
