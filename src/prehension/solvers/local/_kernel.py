"""The numeric core of the local solver, compiled with numba (plain Python without it).

One call of :func:`run_states` runs Algorithm 1's inner loop (Claret & Suárez, sec. 3.1)
for ``S`` *states*, each a (problem, initial pose) pair, one after the other: initial
configuration, Jacobian iterations until the contacts are within ``d_min`` or the
ending conditions stop them, then Gauss-Newton polishing.  Self-collision and the final
verification are done by the caller with the foundation's functions.

Everything here works on flat arrays (the layout is built in :mod:`._group`):

* the hand as a tree of joints (parent, child, kind, dof offset, centres, axes, ``R0``);
* the unknowns ``x = (q_free, twist(6), per contact: hand params, object params)``; the
  twist entries are always 0 in ``x``: the object pose lives in ``(R, t)`` and a step's
  twist ``(w, v)`` moves it as ``R <- Rot(w) R`` about the problem's pivot, then by ``v``;
* per contact the residual ``f_c = (p_h - p_o, w_n (n_h + n_o))`` (6 rows, mm): hand
  point minus object point, and the sum of the two outward normals scaled by ``w_n``
  (the paper's fingertip centre ``r = p - rho n`` gives the same rows with ``w_n = rho``);
* regions by kind code: 0 point with normal, 1 sphere cap (``(alpha, gamma)``), 2 Bézier
  patch (``(u, v)``), with their data in the problem's row of ``pdata``.

The step is damped least squares on column-scaled unknowns,

.. math::

    \\Delta x = -\\alpha\\, D^{-1} \\tilde J^T (\\tilde J \\tilde J^T + \\mu^2 I)^{-1} f,
    \\qquad \\tilde J = J D^{-1},

with an active set: unknowns at a bound that the step would push out are frozen and the
step is recomputed.  ``J J^T`` is built block by block from the columns two contacts
share (the object twist and common joints), so its cost grows with the contacts, not
with the square of the unknowns.
"""

from __future__ import annotations

import math

import numpy as np

try:  # numba is optional: without it the same code runs as (slow) Python.
    from numba import njit

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is missing
    HAVE_NUMBA = False

    def njit(*args, **kwargs):
        if len(args) == 1 and callable(args[0]) and not kwargs:
            return args[0]
        return lambda f: f


# status codes of a state
FAILED_KMAX = 0
SOLVED_STRICT = 1
SOLVED_DMIN = 2
FAILED_STALL = 3
FAILED_COLLISION = 4

# option slots in the float array ``opt``
O_ALPHA, O_MU, O_DMIN, O_WN, O_SMIN, O_NSTALL, O_KMAX, O_MAXSTEP = 0, 1, 2, 3, 4, 5, 6, 7
O_NPOLISH, O_POLISH_P, O_POLISH_N, O_ACTIVE, O_PSI_MODE, O_CAP_MARGIN = 8, 9, 10, 11, 12, 13
O_NREPAIR, O_COL_MARGIN = 14, 15
N_OPT = 16

# columns of the per-contact int table ``cint``
C_LINK, C_HK, C_HOFF, C_HM, C_HN, C_OK, C_OOFF, C_OM, C_ON, C_XH, C_KH, C_XO, C_KO = range(13)
N_CINT = 13

K_POINT, K_CAP, K_BEZIER = 0, 1, 2
# sizes of region data (bezier: 3 (m+1)(n+1))
POINT_SIZE = 6  # point (3), normal (3)
CAP_SIZE = 16  # centre (3), radius, e1 (3), e2 (3), m (3), cos_half, half, unused
MAX_DEGREE = 15


# -- small linear algebra ---------------------------------------------------------------
@njit(cache=True)
def _rot(u0, u1, u2, th, out):
    """Rodrigues: ``out = Rot(u, th)`` for a unit axis ``u``."""
    c = math.cos(th)
    s = math.sin(th)
    v = 1.0 - c
    out[0, 0] = c + u0 * u0 * v
    out[0, 1] = u0 * u1 * v - u2 * s
    out[0, 2] = u0 * u2 * v + u1 * s
    out[1, 0] = u1 * u0 * v + u2 * s
    out[1, 1] = c + u1 * u1 * v
    out[1, 2] = u1 * u2 * v - u0 * s
    out[2, 0] = u2 * u0 * v - u1 * s
    out[2, 1] = u2 * u1 * v + u0 * s
    out[2, 2] = c + u2 * u2 * v


@njit(cache=True)
def _mm(A, B, out):
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(cache=True)
def _mv(A, x, out):
    for i in range(3):
        out[i] = A[i, 0] * x[0] + A[i, 1] * x[1] + A[i, 2] * x[2]


@njit(cache=True)
def _cross(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(cache=True)
def _cholesky_solve(A, b, n, L, y):
    """Solve ``A y = b`` (``A`` symmetric positive definite, n x n) by Cholesky; False if it fails."""
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not (s > 0.0):
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    for i in range(n):  # forward
        s = b[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):  # backward
        s = y[i]
        for k in range(i + 1, n):
            s -= L[k, i] * y[k]
        y[i] = s / L[i, i]
    return True


# -- forward kinematics -----------------------------------------------------------------
@njit(cache=True)
def _fk(q, jp, jc, jkind, joff, jP, jQ, ju, jR0, jv, Rl, rl, ax, org, tmp1, tmp2, vec):
    """Every link's pose (``Rl``, ``rl``) and every dof's axis and centre, palm frame."""
    for i in range(3):
        for j in range(3):
            Rl[0, i, j] = 1.0 if i == j else 0.0
        rl[0, i] = 0.0
    for k in range(jp.shape[0]):
        p = jp[k]
        c = jc[k]
        off = joff[k]
        Rp = Rl[p]
        _mv(Rp, jP[k], vec)
        for i in range(3):
            org[off, i] = vec[i] + rl[p, i]
        _mv(Rp, ju[k], vec)
        for i in range(3):
            ax[off, i] = vec[i]
        _rot(ju[k, 0], ju[k, 1], ju[k, 2], q[off], tmp1)
        _mm(Rp, tmp1, tmp2)
        _mm(tmp2, jR0[k], Rl[c])
        if jkind[k] == 1:
            _mv(Rl[c], jv[k], vec)
            for i in range(3):
                ax[off + 1, i] = vec[i]
                org[off + 1, i] = org[off, i]
            _rot(jv[k, 0], jv[k, 1], jv[k, 2], q[off + 1], tmp1)
            for i in range(3):
                for j in range(3):
                    tmp2[i, j] = Rl[c, i, j]
            _mm(tmp2, tmp1, Rl[c])
        _mv(Rl[c], jQ[k], vec)
        for i in range(3):
            rl[c, i] = org[off, i] - vec[i]


@njit(cache=True)
def _q_from_free(x, dof_free, dof_ratio, dof_offset, q_fixed, q):
    for d in range(q.shape[0]):
        j = dof_free[d]
        if j < 0:
            q[d] = q_fixed[d]
        else:
            q[d] = dof_ratio[d] * x[j] + dof_offset[d]


# -- regions ----------------------------------------------------------------------------
@njit(cache=True)
def _bernstein(m, t, B, dB, d2B, work):
    """Bernstein basis of degree ``m`` at ``t`` with first and second derivatives."""
    # work rows: basis of degree m-2, m-1, m (work[0..2])
    for r in range(3):
        for i in range(m + 1):
            work[r, i] = 0.0
    cur = np.zeros(MAX_DEGREE + 1)
    cur[0] = 1.0
    for deg in range(1, m + 1):
        for i in range(deg, -1, -1):
            left = cur[i - 1] if i >= 1 else 0.0
            right = cur[i] if i < deg else 0.0
            cur[i] = (1.0 - t) * right + t * left
        if deg == m - 2:
            for i in range(deg + 1):
                work[0, i] = cur[i]
        if deg == m - 1:
            for i in range(deg + 1):
                work[1, i] = cur[i]
    if m == 0:
        B[0] = 1.0
        dB[0] = 0.0
        d2B[0] = 0.0
        return
    if m - 1 == 0:
        work[1, 0] = 1.0
    if m - 2 == 0:
        work[0, 0] = 1.0
    for i in range(m + 1):
        B[i] = cur[i]
        a = work[1, i - 1] if i >= 1 else 0.0
        b = work[1, i] if i <= m - 1 else 0.0
        dB[i] = m * (a - b)
        if m >= 2:
            a2 = work[0, i - 2] if i >= 2 else 0.0
            b2 = work[0, i - 1] if (i >= 1 and i - 1 <= m - 2) else 0.0
            c2 = work[0, i] if i <= m - 2 else 0.0
            d2B[i] = m * (m - 1) * (a2 - 2.0 * b2 + c2)
        else:
            d2B[i] = 0.0


@njit(cache=True)
def _region(kind, off, m, n, data, prm, pt, nr, dpt, dnr, want_jac):
    """Point, outward normal and their derivatives (3 x k) of one region, its own frame."""
    if kind == K_POINT:
        for i in range(3):
            pt[i] = data[off + i]
            nr[i] = data[off + 3 + i]
        return
    if kind == K_CAP:
        a = prm[0]
        g = prm[1]
        ca = math.cos(a)
        sa = math.sin(a)
        cg = math.cos(g)
        sg = math.sin(g)
        rho = data[off + 3]
        for i in range(3):
            e1 = data[off + 4 + i]
            e2 = data[off + 7 + i]
            mm = data[off + 10 + i]
            nr[i] = cg * ca * mm - cg * sa * e2 + sg * e1
            pt[i] = data[off + i] + rho * nr[i]
            if want_jac:
                da = -cg * sa * mm - cg * ca * e2
                dg = -sg * ca * mm + sg * sa * e2 + cg * e1
                dnr[i, 0] = da
                dnr[i, 1] = dg
                dpt[i, 0] = rho * da
                dpt[i, 1] = rho * dg
        return
    # Bézier patch, control points b_ij at data[off + 3 (i (n+1) + j) + k]
    Bu = np.empty(MAX_DEGREE + 1)
    dBu = np.empty(MAX_DEGREE + 1)
    d2Bu = np.empty(MAX_DEGREE + 1)
    Bv = np.empty(MAX_DEGREE + 1)
    dBv = np.empty(MAX_DEGREE + 1)
    d2Bv = np.empty(MAX_DEGREE + 1)
    work = np.empty((3, MAX_DEGREE + 1))
    _bernstein(m, prm[0], Bu, dBu, d2Bu, work)
    _bernstein(n, prm[1], Bv, dBv, d2Bv, work)
    p = np.zeros(3)
    pu = np.zeros(3)
    pv = np.zeros(3)
    puu = np.zeros(3)
    puv = np.zeros(3)
    pvv = np.zeros(3)
    for i in range(m + 1):
        for j in range(n + 1):
            base = off + 3 * (i * (n + 1) + j)
            w00 = Bu[i] * Bv[j]
            w10 = dBu[i] * Bv[j]
            w01 = Bu[i] * dBv[j]
            w20 = d2Bu[i] * Bv[j]
            w11 = dBu[i] * dBv[j]
            w02 = Bu[i] * d2Bv[j]
            for k in range(3):
                b = data[base + k]
                p[k] += w00 * b
                pu[k] += w10 * b
                pv[k] += w01 * b
                puu[k] += w20 * b
                puv[k] += w11 * b
                pvv[k] += w02 * b
    N = np.empty(3)
    _cross(pu, pv, N)
    norm = math.sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2])
    if norm < 1e-300:
        norm = 1e-300
    for k in range(3):
        pt[k] = p[k]
        nr[k] = N[k] / norm
    if want_jac:
        t1 = np.empty(3)
        t2 = np.empty(3)
        dNu = np.empty(3)
        dNv = np.empty(3)
        _cross(puu, pv, t1)
        _cross(pu, puv, t2)
        for k in range(3):
            dNu[k] = t1[k] + t2[k]
        _cross(puv, pv, t1)
        _cross(pu, pvv, t2)
        for k in range(3):
            dNv[k] = t1[k] + t2[k]
        su = nr[0] * dNu[0] + nr[1] * dNu[1] + nr[2] * dNu[2]
        sv = nr[0] * dNv[0] + nr[1] * dNv[1] + nr[2] * dNv[2]
        for k in range(3):
            dpt[k, 0] = pu[k]
            dpt[k, 1] = pv[k]
            dnr[k, 0] = (dNu[k] - nr[k] * su) / norm
            dnr[k, 1] = (dNv[k] - nr[k] * sv) / norm


@njit(cache=True)
def _project_params(kind, off, data, x, i0, lo, hi, margin):
    """Keep one region's parameters in its domain: patches in [0,1]^2, caps in their cone."""
    if kind == K_BEZIER:
        for k in range(2):
            if x[i0 + k] < lo[i0 + k]:
                x[i0 + k] = lo[i0 + k]
            elif x[i0 + k] > hi[i0 + k]:
                x[i0 + k] = hi[i0 + k]
    elif kind == K_CAP:
        half = data[off + 14]
        a = x[i0]
        # wrap alpha into (-pi, pi]
        if a > math.pi or a <= -math.pi:
            a = math.atan2(math.sin(a), math.cos(a))
        g = x[i0 + 1]
        if g > 0.5 * math.pi:  # keep gamma in [-pi/2, pi/2] (same normal, alpha + pi)
            g = math.pi - g
            a = math.atan2(math.sin(a + math.pi), math.cos(a + math.pi))
        elif g < -0.5 * math.pi:
            g = -math.pi - g
            a = math.atan2(math.sin(a + math.pi), math.cos(a + math.pi))
        if half < math.pi:
            lim = half - margin
            if lim < 0.0:
                lim = 0.0
            ca = math.cos(a)
            cg = math.cos(g)
            n_m = cg * ca
            if n_m < math.cos(lim):
                n_1 = math.sin(g)
                n_2 = -cg * math.sin(a)
                s = math.sqrt(n_1 * n_1 + n_2 * n_2)
                if s > 1e-300:
                    sl = math.sin(lim)
                    n_1 = sl * n_1 / s
                    n_2 = sl * n_2 / s
                    n_m = math.cos(lim)
                    g = math.asin(min(1.0, max(-1.0, n_1)))
                    a = math.atan2(-n_2, n_m)
                else:  # opposite to the axis: any direction on the cone's rim
                    g = lim if lim < 0.5 * math.pi else 0.5 * math.pi
                    a = 0.0
        x[i0] = a
        x[i0 + 1] = g


@njit(cache=True)
def _project(x, nf, cint, data, lo, hi, margin):
    for j in range(nf):
        if x[j] < lo[j]:
            x[j] = lo[j]
        elif x[j] > hi[j]:
            x[j] = hi[j]
    for c in range(cint.shape[0]):
        _project_params(cint[c, C_HK], cint[c, C_HOFF], data, x, cint[c, C_XH], lo, hi, margin)
        _project_params(cint[c, C_OK], cint[c, C_OOFF], data, x, cint[c, C_XO], lo, hi, margin)


# -- residual and Jacobian ----------------------------------------------------------------
@njit(cache=True)
def _residual(x, R, t, data, piv, cint, cdofs, cnd, dof_free, dof_ratio, wn, want_jac,
              Rl, rl, ax, org, f, J, ph, nh, po, no, nf):  # fmt: skip
    """Residual ``f`` (6C) and, if asked, Jacobian ``J`` (6C x nx) at ``x`` and pose ``(R, t)``."""
    C = cint.shape[0]
    pt = np.empty(3)
    nr = np.empty(3)
    dpt = np.zeros((3, 2))
    dnr = np.zeros((3, 2))
    prm = np.zeros(2)
    v1 = np.empty(3)
    v2 = np.empty(3)
    a = np.empty(3)
    cp = np.empty(3)  # pivot in the palm frame
    _mv(R, piv, cp)
    for i in range(3):
        cp[i] += t[i]
    if want_jac:
        J[:, :] = 0.0
    for c in range(C):
        li = cint[c, C_LINK]
        r0 = 6 * c
        # hand side
        kh = cint[c, C_KH]
        for k in range(kh):
            prm[k] = x[cint[c, C_XH] + k]
        _region(cint[c, C_HK], cint[c, C_HOFF], cint[c, C_HM], cint[c, C_HN], data, prm, pt, nr, dpt, dnr, want_jac)
        _mv(Rl[li], pt, v1)
        _mv(Rl[li], nr, v2)
        for i in range(3):
            ph[c, i] = v1[i] + rl[li, i]
            nh[c, i] = v2[i]
        if want_jac:
            for k in range(kh):
                col = cint[c, C_XH] + k
                for i in range(3):
                    J[r0 + i, col] = Rl[li, i, 0] * dpt[0, k] + Rl[li, i, 1] * dpt[1, k] + Rl[li, i, 2] * dpt[2, k]
                    J[r0 + 3 + i, col] = wn * (
                        Rl[li, i, 0] * dnr[0, k] + Rl[li, i, 1] * dnr[1, k] + Rl[li, i, 2] * dnr[2, k]
                    )
            for jd in range(cnd[c]):
                d = cdofs[c, jd]
                col = dof_free[d]
                if col < 0:
                    continue
                rr = dof_ratio[d]
                for i in range(3):
                    a[i] = ph[c, i] - org[d, i]
                _cross(ax[d], a, v1)
                _cross(ax[d], nh[c], v2)
                for i in range(3):
                    J[r0 + i, col] += rr * v1[i]
                    J[r0 + 3 + i, col] += rr * wn * v2[i]
        # object side
        ko = cint[c, C_KO]
        for k in range(ko):
            prm[k] = x[cint[c, C_XO] + k]
        _region(cint[c, C_OK], cint[c, C_OOFF], cint[c, C_OM], cint[c, C_ON], data, prm, pt, nr, dpt, dnr, want_jac)
        _mv(R, pt, v1)
        _mv(R, nr, v2)
        for i in range(3):
            po[c, i] = v1[i] + t[i]
            no[c, i] = v2[i]
            f[r0 + i] = ph[c, i] - po[c, i]
            f[r0 + 3 + i] = wn * (nh[c, i] + no[c, i])
        if want_jac:
            for k in range(ko):
                col = cint[c, C_XO] + k
                for i in range(3):
                    J[r0 + i, col] = -(R[i, 0] * dpt[0, k] + R[i, 1] * dpt[1, k] + R[i, 2] * dpt[2, k])
                    J[r0 + 3 + i, col] = wn * (R[i, 0] * dnr[0, k] + R[i, 1] * dnr[1, k] + R[i, 2] * dnr[2, k])
            # twist (w, v) about the pivot: d po = w x (po - cp) + v, d no = w x no
            for i in range(3):
                a[i] = po[c, i] - cp[i]
            # d f_p / d w = -(w x a) = [a]x w;  d f_n / d w = wn (w x no) = -wn [no]x w
            J[r0 + 0, nf + 1] = -a[2]
            J[r0 + 0, nf + 2] = a[1]
            J[r0 + 1, nf + 0] = a[2]
            J[r0 + 1, nf + 2] = -a[0]
            J[r0 + 2, nf + 0] = -a[1]
            J[r0 + 2, nf + 1] = a[0]
            J[r0 + 3 + 0, nf + 1] = wn * no[c, 2]
            J[r0 + 3 + 0, nf + 2] = -wn * no[c, 1]
            J[r0 + 3 + 1, nf + 0] = -wn * no[c, 2]
            J[r0 + 3 + 1, nf + 2] = wn * no[c, 0]
            J[r0 + 3 + 2, nf + 0] = wn * no[c, 1]
            J[r0 + 3 + 2, nf + 1] = -wn * no[c, 0]
            for i in range(3):
                J[r0 + i, nf + 3 + i] = -1.0


@njit(cache=True)
def _errors(f, C, perr, nerr):
    """Largest contact distance [mm] and largest weighted normal error ``w_n |n_h + n_o|`` [mm]."""
    pm = 0.0
    nm = 0.0
    for c in range(C):
        r0 = 6 * c
        dp = math.sqrt(f[r0] ** 2 + f[r0 + 1] ** 2 + f[r0 + 2] ** 2)
        dn = math.sqrt(f[r0 + 3] ** 2 + f[r0 + 4] ** 2 + f[r0 + 5] ** 2)
        if dp > pm:
            pm = dp
        if dn > nm:
            nm = dn
    perr[0] = pm
    nerr[0] = nm


@njit(cache=True)
def _scaled_back(Ms, y, n, nx, Dinv, frozen, dx):
    """``dx = -Dinv Ms^T y`` over the first ``n`` rows (frozen unknowns stay put)."""
    for k in range(nx):
        s = 0.0
        for r in range(n):
            s += Ms[r, k] * y[r]
        dx[k] = -s * (0.0 if frozen[k] else Dinv[k])


@njit(cache=True)
def _dls_step(J, f, C, nx, Dinv, frozen, pcols, pn, mu2, A, L, y, dx, Js):
    """``dx = -Dinv J~^T (J~ J~^T + mu2 I)^-1 f`` with ``J~ = J Dinv`` (frozen columns removed)."""
    n = 6 * C
    for k in range(nx):
        d = 0.0 if frozen[k] else Dinv[k]
        for r in range(n):
            Js[r, k] = J[r, k] * d
    for c1 in range(C):
        for c2 in range(c1, C):
            m = pn[c1, c2]
            for i in range(6):
                r1 = 6 * c1 + i
                j0 = i if c1 == c2 else 0
                for j in range(j0, 6):
                    r2 = 6 * c2 + j
                    s = 0.0
                    for kk in range(m):
                        k = pcols[c1, c2, kk]
                        s += Js[r1, k] * Js[r2, k]
                    A[r1, r2] = s
                    A[r2, r1] = s
    scale = 0.0
    for i in range(n):
        scale += A[i, i]
    scale = scale / n if n > 0 else 1.0
    for i in range(n):
        A[i, i] += mu2 + 1e-14 * scale
    ok = _cholesky_solve(A, f, n, L, y)
    if not ok:
        for k in range(nx):
            dx[k] = 0.0
        return False
    _scaled_back(Js, y, n, nx, Dinv, frozen, dx)
    return True


@njit(cache=True)
def _apply_twist(dx, nf, R, t, piv, Rn, tn, tmp):
    """Move the object pose by the twist ``(w, v) = dx[nf:nf+6]`` about the pivot."""
    w0 = dx[nf]
    w1 = dx[nf + 1]
    w2 = dx[nf + 2]
    th = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    cp = np.empty(3)
    _mv(R, piv, cp)
    for i in range(3):
        cp[i] += t[i]
    if th > 0.0:
        _rot(w0 / th, w1 / th, w2 / th, th, tmp)
        _mm(tmp, R, Rn)
    else:
        for i in range(3):
            for j in range(3):
                Rn[i, j] = R[i, j]
    v = np.empty(3)
    _mv(Rn, piv, v)
    for i in range(3):
        tn[i] = cp[i] + dx[nf + 3 + i] - v[i]


@njit(cache=True)
def _advance(dx, nf, nx, x, R, t, piv, Rn, tn, tmp, cint, data, lo, hi, margin):
    """Apply a step: the object pose by its twist, the other unknowns by ``dx``, then
    project the parameters back into their regions."""
    _apply_twist(dx, nf, R, t, piv, Rn, tn, tmp)
    for i in range(3):
        t[i] = tn[i]
        for j in range(3):
            R[i, j] = Rn[i, j]
    for j in range(nx):
        if j < nf or j >= nf + 6:
            x[j] += dx[j]
    _project(x, nf, cint, data, lo, hi, margin)


@njit(cache=True)
def _cap_on_rim(kind, off, data, x, i0, margin):
    """The gradient ``(g_a, g_g)`` of ``n . m`` if a cap's parameters lie on its cone's rim."""
    if kind != K_CAP:
        return False, 0.0, 0.0
    half = data[off + 14]
    if half >= math.pi:
        return False, 0.0, 0.0
    lim = max(half - margin, 0.0)
    a = x[i0]
    g = x[i0 + 1]
    if math.cos(g) * math.cos(a) > math.cos(lim) + 1e-12:
        return False, 0.0, 0.0
    ga = -math.cos(g) * math.sin(a)
    gg = -math.sin(g) * math.cos(a)
    nrm = math.sqrt(ga * ga + gg * gg)
    if nrm < 1e-12:
        return False, 0.0, 0.0
    return True, ga / nrm, gg / nrm


@njit(cache=True)
def _rotate_columns(J, r0, i0, ca, cb):
    """Columns ``(i0, i0+1)`` of rows ``r0 .. r0+5`` -> ``(radial, tangent)`` combinations."""
    for r in range(r0, r0 + 6):
        u = J[r, i0]
        v = J[r, i0 + 1]
        J[r, i0] = ca * u + cb * v
        J[r, i0 + 1] = -cb * u + ca * v


@njit(cache=True)
def _solve_step(J, f, C, nx, nf, x, Dinv, lo, hi, boxed, pcols, pn, mu2, active, A, L, y, dx, frozen,
                cint, data, margin, Js, rims):  # fmt: skip
    """One damped step with an active set, warm-started from the previous step's.

    ``frozen`` comes in holding the previous step's frozen unknowns (kept while they
    are still at their bound).  After a solve, an unknown at a bound that the step
    pushes out is frozen, and a frozen one whose unconstrained step points inside is
    released; a sphere cap whose normal lies on its cone's rim and that the step pushes
    out of the cone moves only along the rim (its two columns are turned into radial and
    tangent combinations and the radial one is frozen).  The step is then computed once
    more if anything changed.
    """
    n = 6 * C
    for k in range(nx):
        if frozen[k] and not (boxed[k] and (x[k] <= lo[k] or x[k] >= hi[k])):
            frozen[k] = False
        if not active:
            frozen[k] = False
    ok = _dls_step(J, f, C, nx, Dinv, frozen, pcols, pn, mu2, A, L, y, dx, Js)
    if not ok or not active:
        return ok
    again = False
    for k in range(nx):
        if not boxed[k]:
            continue
        if frozen[k]:
            s = 0.0
            for r in range(n):
                s += J[r, k] * y[r]
            d = -s  # sign of the unconstrained step
            if (x[k] <= lo[k] and d > 0.0) or (x[k] >= hi[k] and d < 0.0):
                frozen[k] = False
                again = True
        elif (x[k] <= lo[k] and dx[k] < 0.0) or (x[k] >= hi[k] and dx[k] > 0.0):
            frozen[k] = True
            again = True
    # caps on their rim pushed outwards (at most 2 per contact)
    nr = 0
    for c in range(C):
        for side in range(2):
            kind = cint[c, C_HK] if side == 0 else cint[c, C_OK]
            off = cint[c, C_HOFF] if side == 0 else cint[c, C_OOFF]
            i0 = cint[c, C_XH] if side == 0 else cint[c, C_XO]
            on, ga, gg = _cap_on_rim(kind, off, data, x, i0, margin)
            if on and ga * dx[i0] + gg * dx[i0 + 1] < 0.0:
                _rotate_columns(J, 6 * c, i0, ga, gg)
                frozen[i0] = True
                rims[nr, 0] = i0
                rims[nr, 1] = ga
                rims[nr, 2] = gg
                nr += 1
                again = True
    if again:
        ok = _dls_step(J, f, C, nx, Dinv, frozen, pcols, pn, mu2, A, L, y, dx, Js)
        for k in range(nr):  # back to (alpha, gamma); the radial part is 0
            i0 = int(rims[k, 0])
            ga = rims[k, 1]
            gg = rims[k, 2]
            dt = dx[i0 + 1]
            dx[i0] = -gg * dt
            dx[i0 + 1] = ga * dt
            frozen[i0] = False
    return ok


# -- self-collision (repair of colliding local solutions) -----------------------------------
@njit(cache=True)
def _clamp01(x):
    return 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)


@njit(cache=True)
def _closest_points(p0, p1, q0, q1, pa, pb):
    """Closest points of segments p0-p1 and q0-q1 (Ericson, sec. 5.1.9); their distance."""
    tiny = 1e-12
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]
    e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]
    f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2]
    if a <= tiny and e <= tiny:
        s = 0.0
        t = 0.0
    elif a <= tiny:
        s = 0.0
        t = _clamp01(f / e)
    else:
        c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2]
        if e <= tiny:
            t = 0.0
            s = _clamp01(-c / a)
        else:
            b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]
            denom = a * e - b * b
            s = _clamp01((b * f - c * e) / denom) if denom > tiny * a * e else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = _clamp01(-c / a)
            elif t > 1.0:
                t = 1.0
                s = _clamp01((b - c) / a)
    for i in range(3):
        pa[i] = p0[i] + d1[i] * s
        pb[i] = q0[i] + d2[i] * t
    return math.sqrt((pa[0] - pb[0]) ** 2 + (pa[1] - pb[1]) ** 2 + (pa[2] - pb[2]) ** 2)


@njit(cache=True)
def _collision_rows(Rl, rl, ax, org, moves, dof_free, dof_ratio, cap_link, cap_a, cap_b, cap_r,
                    pair_i, pair_j, margin, nx, M, g, row0, max_rows):  # fmt: skip
    """Rows ``clearance - margin`` (and their Jacobians) of capsule pairs closer than ``margin``.

    Returns ``(rows written, smallest clearance)``.  The gradient of a clearance is
    ``n . (d pa/dq - d pb/dq)`` at the closest points ``pa``, ``pb`` (``n`` from ``pb``
    to ``pa``).
    """
    p0 = np.empty(3)
    p1 = np.empty(3)
    q0 = np.empty(3)
    q1 = np.empty(3)
    pa = np.empty(3)
    pb = np.empty(3)
    v = np.empty(3)
    w = np.empty(3)
    nrows = 0
    cmin = 1e300
    for k in range(pair_i.shape[0]):
        sa = pair_i[k]
        sb = pair_j[k]
        la = cap_link[sa]
        lb = cap_link[sb]
        _mv(Rl[la], cap_a[sa], p0)
        _mv(Rl[la], cap_b[sa], p1)
        _mv(Rl[lb], cap_a[sb], q0)
        _mv(Rl[lb], cap_b[sb], q1)
        for i in range(3):
            p0[i] += rl[la, i]
            p1[i] += rl[la, i]
            q0[i] += rl[lb, i]
            q1[i] += rl[lb, i]
        dist = _closest_points(p0, p1, q0, q1, pa, pb)
        clear = dist - cap_r[sa] - cap_r[sb]
        if clear < cmin:
            cmin = clear
        if clear >= margin or nrows >= max_rows or M.shape[0] == 0:
            continue
        if dist < 1e-9:
            continue
        n = np.empty(3)
        for i in range(3):
            n[i] = (pa[i] - pb[i]) / dist
        r = row0 + nrows
        for j in range(nx):
            M[r, j] = 0.0
        for d in range(dof_free.shape[0]):
            col = dof_free[d]
            if col < 0:
                continue
            ma = moves[la, d]
            mb = moves[lb, d]
            if ma == mb:  # moves both or neither: no relative motion
                continue
            if ma:
                for i in range(3):
                    w[i] = pa[i] - org[d, i]
            else:
                for i in range(3):
                    w[i] = pb[i] - org[d, i]
            _cross(ax[d], w, v)
            dv = n[0] * v[0] + n[1] * v[1] + n[2] * v[2]
            M[r, col] += dof_ratio[d] * (dv if ma else -dv)
        g[r] = clear - margin
        nrows += 1
    return nrows, cmin


@njit(cache=True)
def _dense_step(M, g, n, nx, Dinv, frozen, mu2, A, L, y, dx, Ms):
    """``dx = -Dinv M~^T (M~ M~^T + mu2 I)^-1 g`` for the first ``n`` rows (dense)."""
    for r in range(n):
        for k in range(nx):
            Ms[r, k] = 0.0 if frozen[k] else M[r, k] * Dinv[k]
    for i in range(n):
        for j in range(i, n):
            s = 0.0
            for k in range(nx):
                s += Ms[i, k] * Ms[j, k]
            A[i, j] = s
            A[j, i] = s
    for i in range(n):
        A[i, i] += mu2 + 1e-12
    if not _cholesky_solve(A, g, n, L, y):
        return False
    _scaled_back(Ms, y, n, nx, Dinv, frozen, dx)
    return True


# -- initial configuration ---------------------------------------------------------------
@njit(cache=True)
def _frame_of(z, F):
    """Columns (x, y, z): a right-handed orthonormal frame whose third axis is ``z``."""
    az = np.abs(z)
    k = 0
    if az[1] < az[k]:
        k = 1
    if az[2] < az[k]:
        k = 2
    e = np.zeros(3)
    e[k] = 1.0
    d = e[0] * z[0] + e[1] * z[1] + e[2] * z[2]
    xx = np.empty(3)
    for i in range(3):
        xx[i] = e[i] - d * z[i]
    nx = math.sqrt(xx[0] ** 2 + xx[1] ** 2 + xx[2] ** 2)
    for i in range(3):
        xx[i] /= nx
    yy = np.empty(3)
    _cross(z, xx, yy)
    for i in range(3):
        F[i, 0] = xx[i]
        F[i, 1] = yy[i]
        F[i, 2] = z[i]


@njit(cache=True)
def _default_params(kind, x, i0):
    if kind == K_BEZIER:
        x[i0] = 0.5
        x[i0 + 1] = 0.5
    elif kind == K_CAP:
        x[i0] = 0.0
        x[i0 + 1] = 0.0


@njit(cache=True)
def _initial_pose(x, data, piv, cint, anchor, i1, i2, psi_mode, Rl, rl, R, t, lo, hi, wn, margin):
    """Obtain_Initial_Conf: place the object so that the anchor contact holds exactly.

    The joint angles and hand parameters are those of ``x``; the object parameters start
    at the centre of their domain for the anchor and at the best of a small grid for the
    others.  The rotation ``psi`` about the anchor normal aligns the object's contact
    points with the hand's: the direction from contact ``i1`` to ``i2`` (the paper's
    index -> ring, ``psi_mode`` 0) or all contacts from the anchor (2-D Procrustes,
    ``psi_mode`` 1).
    """
    C = cint.shape[0]
    pt = np.empty(3)
    nr = np.empty(3)
    dpt = np.zeros((3, 2))
    dnr = np.zeros((3, 2))
    prm = np.zeros(2)
    ph = np.empty((C, 3))
    nh = np.empty((C, 3))
    poo = np.empty((C, 3))  # object points in the object frame (centre params)
    no_a = np.zeros(3)
    for c in range(C):
        _default_params(cint[c, C_OK], x, cint[c, C_XO])
        li = cint[c, C_LINK]
        for k in range(cint[c, C_KH]):
            prm[k] = x[cint[c, C_XH] + k]
        _region(cint[c, C_HK], cint[c, C_HOFF], cint[c, C_HM], cint[c, C_HN], data, prm, pt, nr, dpt, dnr, False)
        v = np.empty(3)
        _mv(Rl[li], pt, v)
        for i in range(3):
            ph[c, i] = v[i] + rl[li, i]
        _mv(Rl[li], nr, v)
        for i in range(3):
            nh[c, i] = v[i]
        for k in range(cint[c, C_KO]):
            prm[k] = x[cint[c, C_XO] + k]
        _region(cint[c, C_OK], cint[c, C_OOFF], cint[c, C_OM], cint[c, C_ON], data, prm, pt, nr, dpt, dnr, False)
        for i in range(3):
            poo[c, i] = pt[i]
        if c == anchor:
            for i in range(3):
                no_a[i] = nr[i]
    # R0 maps the anchor's object normal onto minus its hand normal
    A = np.empty((3, 3))
    B = np.empty((3, 3))
    _frame_of(no_a, A)
    mnh = np.empty(3)
    for i in range(3):
        mnh[i] = -nh[anchor, i]
    _frame_of(mnh, B)
    R0 = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            R0[i, j] = B[i, 0] * A[j, 0] + B[i, 1] * A[j, 1] + B[i, 2] * A[j, 2]
    # psi about u = n_h(anchor)
    u = nh[anchor]
    sc = 0.0  # sum of u . (a x b)
    sd = 0.0  # sum of a . b
    av = np.empty(3)
    bv = np.empty(3)
    ab = np.empty(3)
    pair_mode = psi_mode == 0 and i1 >= 0 and i2 >= 0
    npairs = 1 if pair_mode else C
    for c in range(npairs):
        if pair_mode:
            ca_ = i1
            cb_ = i2
        else:
            if c == anchor:
                continue
            ca_ = anchor
            cb_ = c
        d = np.empty(3)
        for i in range(3):
            d[i] = poo[cb_, i] - poo[ca_, i]
        _mv(R0, d, av)
        for i in range(3):
            bv[i] = ph[cb_, i] - ph[ca_, i]
        da = av[0] * u[0] + av[1] * u[1] + av[2] * u[2]
        db = bv[0] * u[0] + bv[1] * u[1] + bv[2] * u[2]
        for i in range(3):
            av[i] -= da * u[i]
            bv[i] -= db * u[i]
        _cross(av, bv, ab)
        sc += u[0] * ab[0] + u[1] * ab[1] + u[2] * ab[2]
        sd += av[0] * bv[0] + av[1] * bv[1] + av[2] * bv[2]
    psi = math.atan2(sc, sd) if (sc != 0.0 or sd != 0.0) else 0.0
    Rp = np.empty((3, 3))
    _rot(u[0], u[1], u[2], psi, Rp)
    _mm(Rp, R0, R)
    _mv(R, poo[anchor], pt)
    for i in range(3):
        t[i] = ph[anchor, i] - pt[i]
    # the other contacts' object parameters: best of a 5 x 5 grid (point and normal)
    G = 5
    for c in range(C):
        if c == anchor:
            continue
        kind = cint[c, C_OK]
        if kind == K_POINT:
            continue
        i0 = cint[c, C_XO]
        best = 1e300
        ba = x[i0]
        bb = x[i0 + 1]
        for ga in range(G):
            for gb in range(G):
                x[i0] = lo[i0] + (hi[i0] - lo[i0]) * (ga + 0.5) / G
                x[i0 + 1] = lo[i0 + 1] + (hi[i0 + 1] - lo[i0 + 1]) * (gb + 0.5) / G
                _project_params(kind, cint[c, C_OOFF], data, x, i0, lo, hi, margin)
                prm[0] = x[i0]
                prm[1] = x[i0 + 1]
                _region(kind, cint[c, C_OOFF], cint[c, C_OM], cint[c, C_ON], data, prm, pt, nr, dpt, dnr, False)
                cost = 0.0
                v = np.empty(3)
                w = np.empty(3)
                _mv(R, pt, v)
                _mv(R, nr, w)
                for i in range(3):
                    cost += (v[i] + t[i] - ph[c, i]) ** 2 + (wn * (w[i] + nh[c, i])) ** 2
                if cost < best:
                    best = cost
                    ba = x[i0]
                    bb = x[i0 + 1]
        x[i0] = ba
        x[i0 + 1] = bb


# -- the inner loop of Algorithm 1 ---------------------------------------------------------
@njit(cache=True)
def run_states(
    sprob, x0, pdata, piv_off,
    jp, jc, jkind, joff, jP, jQ, ju, jR0, jv, n_links,
    dof_free, dof_ratio, dof_offset, q_fixed,
    cint, cdofs, cnd, pcols, pn, anchor, i1, i2,
    lo, hi, boxed, Dinv_p, nf,
    moves, cap_link, cap_a, cap_b, cap_r, pair_i, pair_j, opt,
    status, iters, piters, xout, Rout, tout, eout,
):  # fmt: skip
    """Run Algorithm 1's inner loop for every state; see the module docstring.

    Outputs (one row per state): ``status`` (SOLVED_STRICT, SOLVED_DMIN, FAILED_KMAX,
    FAILED_STALL), ``iters`` (Jacobian iterations), ``piters`` (polishing iterations),
    ``xout`` (final unknowns), ``Rout``/``tout`` (final object pose), ``eout`` (largest
    contact distance [mm] and largest weighted normal error [mm]).
    """
    S = sprob.shape[0]
    C = cint.shape[0]
    nx = x0.shape[1]
    ndof = dof_free.shape[0]
    alpha = opt[O_ALPHA]
    mu2 = opt[O_MU] ** 2
    dmin = opt[O_DMIN]
    wn = opt[O_WN]
    smin = opt[O_SMIN]
    nstall = int(opt[O_NSTALL])
    kmax = int(opt[O_KMAX])
    maxstep = opt[O_MAXSTEP]
    npolish = int(opt[O_NPOLISH])
    tol_p = opt[O_POLISH_P]
    tol_n = opt[O_POLISH_N]
    active = opt[O_ACTIVE] > 0.5
    psi_mode = int(opt[O_PSI_MODE])
    margin = opt[O_CAP_MARGIN]
    nrepair = int(opt[O_NREPAIR])
    col_margin = opt[O_COL_MARGIN]
    max_rows = 12
    nM = 6 * C + max_rows
    M = np.zeros((nM, nx))
    Ms = np.zeros((nM, nx))
    g = np.zeros(nM)
    A2 = np.zeros((nM, nM))
    L2 = np.zeros((nM, nM))
    y2 = np.zeros(nM)
    M0 = np.zeros((0, nx))

    Rl = np.zeros((n_links, 3, 3))
    rl = np.zeros((n_links, 3))
    ax = np.zeros((ndof, 3))
    org = np.zeros((ndof, 3))
    tmp1 = np.zeros((3, 3))
    tmp2 = np.zeros((3, 3))
    vec = np.zeros(3)
    q = np.zeros(ndof)
    f = np.zeros(6 * C)
    fprev = np.zeros(6 * C)
    J = np.zeros((6 * C, nx))
    ph = np.zeros((C, 3))
    nh = np.zeros((C, 3))
    po = np.zeros((C, 3))
    no = np.zeros((C, 3))
    A = np.zeros((6 * C, 6 * C))
    L = np.zeros((6 * C, 6 * C))
    Js = np.zeros((6 * C, nx))
    rims = np.zeros((2 * C, 3))
    y = np.zeros(6 * C)
    dx = np.zeros(nx)
    frozen = np.zeros(nx, dtype=np.bool_)
    R = np.zeros((3, 3))
    t = np.zeros(3)
    Rn = np.zeros((3, 3))
    tn = np.zeros(3)
    perr = np.zeros(1)
    nerr = np.zeros(1)
    xbest = np.zeros(nx)
    Rbest = np.zeros((3, 3))
    tbest = np.zeros(3)
    xrep = np.zeros(nx)
    Rrep = np.zeros((3, 3))
    trep = np.zeros(3)
    prep = 0.0
    nrep = 0.0

    for s in range(S):
        prob = sprob[s]
        data = pdata[prob]
        Dinv = Dinv_p[prob]  # the problem's own scales
        piv = data[piv_off:piv_off + 3]
        x = x0[s].copy()
        _project(x, nf, cint, data, lo, hi, margin)
        _q_from_free(x, dof_free, dof_ratio, dof_offset, q_fixed, q)
        _fk(q, jp, jc, jkind, joff, jP, jQ, ju, jR0, jv, Rl, rl, ax, org, tmp1, tmp2, vec)
        _initial_pose(x, data, piv, cint, anchor, i1, i2, psi_mode, Rl, rl, R, t, lo, hi, wn, margin)
        st = FAILED_KMAX
        k = 0
        stall = 0
        for j in range(nx):
            frozen[j] = False
        while True:
            _residual(x, R, t, data, piv, cint, cdofs, cnd, dof_free, dof_ratio, wn, True,
                      Rl, rl, ax, org, f, J, ph, nh, po, no, nf)  # fmt: skip
            _errors(f, C, perr, nerr)
            if perr[0] < dmin and nerr[0] < dmin:
                st = SOLVED_DMIN
                break
            if k > 0:
                move = 0.0
                for c in range(C):
                    r0 = 6 * c
                    move += math.sqrt((f[r0] - fprev[r0]) ** 2 + (f[r0 + 1] - fprev[r0 + 1]) ** 2
                                      + (f[r0 + 2] - fprev[r0 + 2]) ** 2)  # fmt: skip
                    move += math.sqrt((f[r0 + 3] - fprev[r0 + 3]) ** 2 + (f[r0 + 4] - fprev[r0 + 4]) ** 2
                                      + (f[r0 + 5] - fprev[r0 + 5]) ** 2)  # fmt: skip
                if move < smin:
                    stall += 1
                    if stall >= nstall:
                        st = FAILED_STALL
                        break
                else:
                    stall = 0
            if k >= kmax:
                st = FAILED_KMAX
                break
            for i in range(6 * C):
                fprev[i] = f[i]
            ok = _solve_step(J, f, C, nx, nf, x, Dinv, lo, hi, boxed, pcols, pn, mu2, active, A, L, y, dx, frozen,
                             cint, data, margin, Js, rims)
            k += 1
            if not ok:
                st = FAILED_STALL
                break
            # step size alpha, then at most maxstep [mm in scaled units] per unknown
            big = 0.0
            for j in range(nx):
                v = abs(dx[j]) / Dinv[j] if Dinv[j] > 0.0 else 0.0
                if v > big:
                    big = v
            fac = alpha
            if big * alpha > maxstep:
                fac = maxstep / big
            for j in range(nx):
                dx[j] *= fac
            _advance(dx, nf, nx, x, R, t, piv, Rn, tn, tmp1, cint, data, lo, hi, margin)
            _q_from_free(x, dof_free, dof_ratio, dof_offset, q_fixed, q)
            _fk(q, jp, jc, jkind, joff, jP, jQ, ju, jR0, jv, Rl, rl, ax, org, tmp1, tmp2, vec)
        pk = 0
        repaired = False
        for _pass in range(2):
            # polishing: Gauss-Newton (tiny damping), keeping the best point met
            if st == SOLVED_DMIN and npolish > 0:
                best_p = perr[0]
                best_n = nerr[0]
                xbest[:] = x
                Rbest[:, :] = R
                tbest[:] = t
                reached = best_p <= tol_p and best_n <= tol_n
                pp = 0
                while pp < npolish and not reached:
                    pp += 1
                    ok = _solve_step(J, f, C, nx, nf, x, Dinv, lo, hi, boxed, pcols, pn, 1e-18, True,
                                     A, L, y, dx, frozen, cint, data, margin, Js, rims)  # fmt: skip
                    pk += 1
                    if not ok:
                        break
                    _advance(dx, nf, nx, x, R, t, piv, Rn, tn, tmp1, cint, data, lo, hi, margin)
                    _q_from_free(x, dof_free, dof_ratio, dof_offset, q_fixed, q)
                    _fk(q, jp, jc, jkind, joff, jP, jQ, ju, jR0, jv, Rl, rl, ax, org, tmp1, tmp2, vec)
                    _residual(x, R, t, data, piv, cint, cdofs, cnd, dof_free, dof_ratio, wn, True,
                              Rl, rl, ax, org, f, J, ph, nh, po, no, nf)  # fmt: skip
                    _errors(f, C, perr, nerr)
                    cur = max(perr[0] / tol_p, nerr[0] / tol_n)
                    prev = max(best_p / tol_p, best_n / tol_n)
                    if cur < prev:
                        best_p = perr[0]
                        best_n = nerr[0]
                        xbest[:] = x
                        Rbest[:, :] = R
                        tbest[:] = t
                    elif cur > 100.0 * prev:  # diverging: give up polishing
                        break
                    reached = best_p <= tol_p and best_n <= tol_n
                x[:] = xbest
                R[:, :] = Rbest
                t[:] = tbest
                perr[0] = best_p
                nerr[0] = best_n
                if reached:
                    st = SOLVED_STRICT
            if _pass == 1:
                # polished after a repair: keep it only if it is still clear of collisions
                _q_from_free(x, dof_free, dof_ratio, dof_offset, q_fixed, q)
                _fk(q, jp, jc, jkind, joff, jP, jQ, ju, jR0, jv, Rl, rl, ax, org, tmp1, tmp2, vec)
                nrow, cmin = _collision_rows(Rl, rl, ax, org, moves, dof_free, dof_ratio, cap_link, cap_a, cap_b,
                                             cap_r, pair_i, pair_j, col_margin, nx, M0, g, 0, 0)  # fmt: skip
                if cmin < 0.0 or st != SOLVED_STRICT:
                    x[:] = xrep
                    R[:, :] = Rrep
                    t[:] = trep
                    perr[0] = prep
                    nerr[0] = nrep
                    st = SOLVED_DMIN
                break
            # Check_Collisions; a colliding local solution is repaired when asked: Gauss-Newton
            # on the contacts plus one row per capsule pair closer than col_margin
            if (st == SOLVED_STRICT or st == SOLVED_DMIN) and nrepair > 0:
                _q_from_free(x, dof_free, dof_ratio, dof_offset, q_fixed, q)
                _fk(q, jp, jc, jkind, joff, jP, jQ, ju, jR0, jv, Rl, rl, ax, org, tmp1, tmp2, vec)
                nrow, cmin = _collision_rows(Rl, rl, ax, org, moves, dof_free, dof_ratio, cap_link, cap_a, cap_b,
                                             cap_r, pair_i, pair_j, col_margin, nx, M0, g, 0, 0)  # fmt: skip
                if cmin < 0.0:
                    rk = 0
                    prev_err = 1e300
                    slow = 0
                    while True:
                        _residual(x, R, t, data, piv, cint, cdofs, cnd, dof_free, dof_ratio, wn, True,
                                  Rl, rl, ax, org, f, J, ph, nh, po, no, nf)  # fmt: skip
                        _errors(f, C, perr, nerr)
                        for r in range(6 * C):
                            g[r] = f[r]
                            for j in range(nx):
                                M[r, j] = J[r, j]
                        nrow, cmin = _collision_rows(Rl, rl, ax, org, moves, dof_free, dof_ratio, cap_link, cap_a,
                                                     cap_b, cap_r, pair_i, pair_j, col_margin, nx, M, g, 6 * C,
                                                     max_rows)  # fmt: skip
                        if cmin >= 0.0 and perr[0] <= tol_p and nerr[0] <= tol_n:
                            break
                        if rk >= nrepair:
                            break
                        err = max(perr[0] / tol_p, nerr[0] / tol_n)
                        if cmin < 0.0:  # judge convergence only once clear
                            prev_err = 1e300
                            slow = 0
                        elif err < 0.5 * prev_err:
                            prev_err = err
                            slow = 0
                        else:
                            slow += 1
                        if cmin >= 0.0 and perr[0] < dmin and nerr[0] < dmin and slow >= 5:
                            break  # clear, within d_min, and no longer converging
                        n_all = 6 * C + nrow
                        for j in range(nx):
                            frozen[j] = False
                        ok = _dense_step(M, g, n_all, nx, Dinv, frozen, 1e-6, A2, L2, y2, dx, Ms)
                        if ok:
                            again = False
                            for j in range(nx):
                                if boxed[j] and ((x[j] <= lo[j] and dx[j] < 0.0) or (x[j] >= hi[j] and dx[j] > 0.0)):
                                    frozen[j] = True
                                    again = True
                            if again:
                                ok = _dense_step(M, g, n_all, nx, Dinv, frozen, 1e-6, A2, L2, y2, dx, Ms)
                        rk += 1
                        if not ok:
                            break
                        big = 0.0
                        for j in range(nx):
                            v = abs(dx[j]) / Dinv[j] if Dinv[j] > 0.0 else 0.0
                            if v > big:
                                big = v
                        if big > maxstep:
                            for j in range(nx):
                                dx[j] *= maxstep / big
                        _advance(dx, nf, nx, x, R, t, piv, Rn, tn, tmp1, cint, data, lo, hi, margin)
                        _q_from_free(x, dof_free, dof_ratio, dof_offset, q_fixed, q)
                        _fk(q, jp, jc, jkind, joff, jP, jQ, ju, jR0, jv, Rl, rl, ax, org, tmp1, tmp2, vec)
                    pk += rk
                    if cmin >= 0.0 and perr[0] <= tol_p and nerr[0] <= tol_n:
                        st = SOLVED_STRICT
                    elif cmin >= 0.0 and perr[0] < dmin and nerr[0] < dmin:
                        st = SOLVED_DMIN
                    else:
                        st = FAILED_COLLISION
            if not (repaired and st == SOLVED_DMIN and npolish > 0):
                break
            # a repaired answer within d_min only: polish it once more (from its residual)
            xrep[:] = x
            Rrep[:, :] = R
            trep[:] = t
            prep = perr[0]
            nrep = nerr[0]
            _q_from_free(x, dof_free, dof_ratio, dof_offset, q_fixed, q)
            _fk(q, jp, jc, jkind, joff, jP, jQ, ju, jR0, jv, Rl, rl, ax, org, tmp1, tmp2, vec)
            _residual(x, R, t, data, piv, cint, cdofs, cnd, dof_free, dof_ratio, wn, True,
                      Rl, rl, ax, org, f, J, ph, nh, po, no, nf)  # fmt: skip
            _errors(f, C, perr, nerr)
        status[s] = st
        iters[s] = k
        piters[s] = pk
        xout[s] = x
        Rout[s] = R
        tout[s] = t
        eout[s, 0] = perr[0]
        eout[s, 1] = nerr[0]
