"""Where on its two regions a contact is best made, for a given configuration.

A configuration that carries no contact parameters is judged at the parameters that make
each contact's error smallest: the residual

.. math::

    e(p_h, p_o) = \\begin{pmatrix} h(p_h) - o(p_o) \\\\ w\\,(n_h(p_h) + n_o(p_o)) \\end{pmatrix},
    \\qquad w = 10\\ \\text{mm},

(hand point minus object point, and the sum of the two outward normals, which vanishes
when they are opposed) is minimised by bounded least squares from the best few seeds of a
small grid.  When the contact holds, the minimum is 0 and the parameters found witness it.
"""

from __future__ import annotations

import numpy as np

from ..hands.kinematics import HandPose

__all__ = ["locate_contact_params", "NORMAL_WEIGHT_MM"]

NORMAL_WEIGHT_MM = 10.0
_STARTS = 3


def _contact_functions(task, pose: HandPose, T_palm_object, contact):
    """Residual and Jacobian of one contact as functions of ``x = (p_h, p_o)``."""
    hreg, oreg = task.hand_region(contact), task.object_region(contact)
    li = task.hand.link_index(hreg.link)
    R_h, r_h = pose.R_palm_link[0, li], pose.r_palm_link[0, li]
    R_o, r_o = T_palm_object[:3, :3], T_palm_object[:3, 3]
    kh = hreg.region.n_params

    def residual(x):
        xb = np.atleast_2d(x)
        hp, hn = hreg.region.evaluate(xb[:, :kh])
        op, on = oreg.evaluate(xb[:, kh:])
        d = (hp @ R_h.T + r_h) - (op @ R_o.T + r_o)
        n = hn @ R_h.T + on @ R_o.T
        return np.concatenate([d, NORMAL_WEIGHT_MM * n], axis=1)  # (B, 6)

    def jacobian(x):
        x = np.atleast_2d(x)
        dhp, dhn = hreg.region.jacobian(x[:, :kh])
        dop, don = oreg.jacobian(x[:, kh:])
        top = np.concatenate([R_h @ dhp[0], -R_o @ dop[0]], axis=1)
        bottom = NORMAL_WEIGHT_MM * np.concatenate([R_h @ dhn[0], R_o @ don[0]], axis=1)
        return np.concatenate([top, bottom], axis=0)  # (6, k)

    return residual, jacobian, kh


def _seeds(hreg, oreg) -> np.ndarray:
    """All pairs of the two regions' seed grids, shape (S, k_h + k_o)."""
    hs, os_ = hreg.seed_params(), oreg.seed_params()
    return np.concatenate([np.repeat(hs, len(os_), axis=0), np.tile(os_, (len(hs), 1))], axis=1)


def _bounds(hreg, oreg):
    lo = np.concatenate([hreg.param_bounds()[0], oreg.param_bounds()[0]])
    hi = np.concatenate([hreg.param_bounds()[1], oreg.param_bounds()[1]])
    return lo, np.maximum(hi, lo + 1e-12)  # least_squares needs lo < hi


def locate_contact_params(task, pose: HandPose, T_palm_object) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """Best-fitting ``(hand_params, object_params)`` of every contact of ``task``.

    Args:
        task: the task.
        pose: forward kinematics of ONE configuration (batch size 1).
        T_palm_object: (4, 4) object pose.
    """
    T = np.asarray(T_palm_object, dtype=float)
    out = []
    for contact in task.contacts:
        hreg, oreg = task.hand_region(contact).region, task.object_region(contact)
        residual, jacobian, kh = _contact_functions(task, pose, T, contact)
        if kh + oreg.n_params == 0:
            out.append((np.zeros(0), np.zeros(0)))
            continue
        seeds = _seeds(hreg, oreg)
        cost = np.sum(residual(seeds) ** 2, axis=1)
        lo, hi = _bounds(hreg, oreg)
        best = None
        for x0 in seeds[np.argsort(cost)[:_STARTS]]:
            sol = _least_squares()(
                lambda x: residual(x)[0], np.clip(x0, lo, hi), jac=jacobian, bounds=(lo, hi),
                xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=200,
            )  # fmt: skip
            if best is None or sol.cost < best.cost:
                best = sol
        out.append((best.x[:kh].copy(), best.x[kh:].copy()))
    return tuple(out)


def _least_squares():
    """``scipy.optimize.least_squares``, imported on first use (scipy.optimize costs ~0.2 s to import)."""
    from scipy.optimize import least_squares

    return least_squares
