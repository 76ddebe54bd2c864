"""Compiled kernels of the in-house equations for L trajectories side by side ("lanes").

The physics, the model tuple and the status codes are those of ``compiled_kernels`` (read its
docstring first); here every quantity carries a last axis of L lanes, one independent
trajectory each, and every arithmetic statement is a loop over the lanes, which the compiler
turns into SIMD instructions. A rigid-body right-hand side is branch-free arithmetic on 3x3
blocks, so L trajectories cost little more than one: this is what ``compiled.run_batch`` uses
for many initial conditions (``mujoco.rollout``'s use case). Shapes: ``Y`` is ny x L.

Lanes never mix: a lane whose state stops being finite, or whose constraint matrix is not
positive definite, carries NaN (and a flag) to the end without disturbing the others. The
projection iterates until every lane has converged; a lane that has converged takes no more
Gauss-Newton steps (its update is masked), as ``compiled_kernels.project`` stops for it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from harness.engines.inhouse.compiled.kernels import _PROJECTION_ITERATIONS, _QUADRATIC, NO_PROJECTION, NONFINITE, OK, SINGULAR

_JIT = dict(cache=True, nogil=True, error_model="numpy", fastmath=False)


@njit(**_JIT)
def workspace(model, L):
    """Buffers for L lanes: (R, omega, s, J, A, B, u0, lam, bias, C, qn, vec, flags, err, JF, AF,
    BF); flags rows: singular, projection failed, active, need, done; JF, AF, BF keep J, the
    factor of J M^-1 J^T and M^-1 J^T of lanes whose projection finished early."""
    mass, nc = model[0], model[13]
    nb = mass.shape[0]
    m = max(nc, 1)
    R = np.zeros((nb + 1, 3, 3, L))
    for i in range(3):
        R[nb, i, i, :] = 1.0
    return (R, np.zeros((nb + 1, 3, L)), np.zeros((2, 3, L)), np.zeros((m, 6 * nb, L)), np.zeros((m, m, L)),
            np.zeros((6 * nb, m, L)), np.zeros((6 * nb, L)), np.zeros((m, L)), np.zeros((m, L)), np.zeros((m, L)),
            np.zeros((nb, 4, L)), np.zeros((16, 3, L)), np.zeros((5, L)), np.zeros(L),
            np.zeros((m, 6 * nb, L)), np.zeros((m, m, L)), np.zeros((6 * nb, m, L)))


@njit(**_JIT)
def _rotation(q, R):
    """R (3,3,L) of unit quaternions q (4,L), wxyz."""
    for l in range(q.shape[1]):
        q0, q1, q2, q3 = q[0, l], q[1, l], q[2, l], q[3, l]
        R[0, 0, l] = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
        R[0, 1, l] = 2.0 * (q1 * q2 - q0 * q3)
        R[0, 2, l] = 2.0 * (q1 * q3 + q0 * q2)
        R[1, 0, l] = 2.0 * (q1 * q2 + q0 * q3)
        R[1, 1, l] = 1.0 - 2.0 * (q1 * q1 + q3 * q3)
        R[1, 2, l] = 2.0 * (q2 * q3 - q0 * q1)
        R[2, 0, l] = 2.0 * (q1 * q3 - q0 * q2)
        R[2, 1, l] = 2.0 * (q2 * q3 + q0 * q1)
        R[2, 2, l] = 1.0 - 2.0 * (q1 * q1 + q2 * q2)


@njit(**_JIT)
def _cross(a, b, out):
    """out = a x b, all (3,L); out may not alias a or b."""
    for l in range(a.shape[1]):
        out[0, l] = a[1, l] * b[2, l] - a[2, l] * b[1, l]
        out[1, l] = a[2, l] * b[0, l] - a[0, l] * b[2, l]
        out[2, l] = a[0, l] * b[1, l] - a[1, l] * b[0, l]


@njit(**_JIT)
def _rotate(R, x, out):
    """out = R x for rotations R (3,3,L) and a constant vector x (3,)."""
    for l in range(out.shape[1]):
        for i in range(3):
            out[i, l] = R[i, 0, l] * x[0] + R[i, 1, l] * x[1] + R[i, 2, l] * x[2]


@njit(**_JIT)
def _rotate_lanes(R, x, out):
    """out = R x for rotations R (3,3,L) and vectors x (3,L)."""
    for l in range(x.shape[1]):
        for i in range(3):
            out[i, l] = R[i, 0, l] * x[0, l] + R[i, 1, l] * x[1, l] + R[i, 2, l] * x[2, l]


@njit(**_JIT)
def _unit_quaternions(Y, nb, Q):
    """Q (nb,4,L) = the quaternions of the lanes Y divided by their norms (Q may be Y's own
    quaternion rows: each norm is taken before its quaternion is written)."""
    for i in range(nb):
        k = 3 * nb + 4 * i
        for l in range(Y.shape[1]):
            n = np.sqrt(Y[k, l] ** 2 + Y[k + 1, l] ** 2 + Y[k + 2, l] ** 2 + Y[k + 3, l] ** 2)
            for m in range(4):
                Q[i, m, l] = Y[k + m, l] / n


@njit(**_JIT)
def _frames(model, Y, ws, with_velocity):
    """``compiled_kernels._frames`` per lane: unit quaternions, rotations and (when asked)
    world angular velocities of every body."""
    mass = model[0]
    nb = mass.shape[0]
    R, omega, qn = ws[0], ws[1], ws[10]
    _unit_quaternions(Y, nb, qn)
    for i in range(nb):
        _rotation(qn[i], R[i])
        if with_velocity:
            _rotate_lanes(R[i], Y[10 * nb + 3 * i: 10 * nb + 3 * i + 3], omega[i])


@njit(**_JIT)
def _constraints(model, Y, ws, with_bias, with_error):
    """J (nc, 6nb, L), and when asked the bias gamma and the error C (nc, L); after ``_frames``."""
    mass, jc, jp, rc, rp, hinge, axis, b1, b2, row = (model[0], model[4], model[5], model[6], model[7], model[8],
                                                      model[9], model[10], model[11], model[12])
    nb = mass.shape[0]
    R, omega, s, J, bias, C, vec = ws[0], ws[1], ws[2], ws[3], ws[8], ws[9], ws[11]
    L = Y.shape[1]
    J[:, :, :] = 0.0
    a, nk, ck, u, v = vec[0], vec[1], vec[2], vec[3], vec[4]
    for j in range(jc.shape[0]):
        c, p, r0 = jc[j], jp[j], row[j]
        _rotate(R[c], rc[j], s[0])
        _rotate(R[p], rp[j], s[1])
        for m in range(3):
            J[r0 + m, 3 * c + m, :] = 1.0
            if p < nb:
                J[r0 + m, 3 * p + m, :] = -1.0
        for m in range(3):
            m1, m2 = (m + 1) % 3, (m + 2) % 3
            for col in range(3):
                for l in range(L):
                    J[r0 + m, 3 * nb + 3 * c + col, l] = -(s[0, m1, l] * R[c, m2, col, l] - s[0, m2, l] * R[c, m1, col, l])
                if p < nb:
                    for l in range(L):
                        J[r0 + m, 3 * nb + 3 * p + col, l] = s[1, m1, l] * R[p, m2, col, l] - s[1, m2, l] * R[p, m1, col, l]
        if with_error:
            for m in range(3):
                for l in range(L):
                    C[r0 + m, l] = Y[3 * c + m, l] + s[0, m, l] - s[1, m, l]
                if p < nb:
                    for l in range(L):
                        C[r0 + m, l] -= Y[3 * p + m, l]
        if with_bias:
            _cross(omega[c], s[0], u)
            _cross(omega[c], u, v)
            for m in range(3):
                for l in range(L):
                    bias[r0 + m, l] = v[m, l]
            if p < nb:
                _cross(omega[p], s[1], u)
                _cross(omega[p], u, v)
                for m in range(3):
                    for l in range(L):
                        bias[r0 + m, l] -= v[m, l]
        if hinge[j]:
            _rotate(R[c], axis[j], a)
            for k in range(2):
                r = r0 + 3 + k
                _rotate(R[p], b1[j] if k == 0 else b2[j], nk)
                _cross(a, nk, ck)
                for col in range(3):
                    for l in range(L):
                        J[r, 3 * nb + 3 * c + col, l] = ck[0, l] * R[c, 0, col, l] + ck[1, l] * R[c, 1, col, l] + ck[2, l] * R[c, 2, col, l]
                    if p < nb:
                        for l in range(L):
                            J[r, 3 * nb + 3 * p + col, l] = -(ck[0, l] * R[p, 0, col, l] + ck[1, l] * R[p, 1, col, l]
                                                             + ck[2, l] * R[p, 2, col, l])
                if with_error:
                    for l in range(L):
                        C[r, l] = a[0, l] * nk[0, l] + a[1, l] * nk[1, l] + a[2, l] * nk[2, l]
                if with_bias:
                    _cross(omega[c], a, u)
                    _cross(u, nk, v)  # (omega_c x A) x N_k
                    _cross(omega[p], nk, u)
                    _cross(a, u, ck)  # A x (omega_p x N_k)
                    for l in range(L):
                        bias[r, l] = ((v[0, l] + ck[0, l]) * (omega[c, 0, l] - omega[p, 0, l])
                                      + (v[1, l] + ck[1, l]) * (omega[c, 1, l] - omega[p, 1, l])
                                      + (v[2, l] + ck[2, l]) * (omega[c, 2, l] - omega[p, 2, l]))
    _slides(model, Y, ws, with_bias, with_error)


@njit(**_JIT)
def _dot(a, b, l):
    """a . b of lane l (a, b (3,L))."""
    return a[0, l] * b[0, l] + a[1, l] * b[1, l] + a[2, l] * b[2, l]


@njit(**_JIT)
def _row_times_rotation(x, R, J, r, col0, sign):
    """J[r, col0:col0+3] = sign x^T R per lane (x (3,L), R (3,3,L))."""
    for col in range(3):
        for l in range(x.shape[1]):
            J[r, col0 + col, l] = sign * (x[0, l] * R[0, col, l] + x[1, l] * R[1, col, l] + x[2, l] * R[2, col, l])


@njit(**_JIT)
def _offsets(model, Y, ws, j, s_c, s_p, d):
    """World offsets s_c, s_p of slide j's joint points and d = x_c - x_p, per lane."""
    mass, sc, sp, src, srp = model[0], model[14], model[15], model[16], model[17]
    nb = mass.shape[0]
    R = ws[0]
    c, p = sc[j], sp[j]
    _rotate(R[c], src[j], s_c)
    _rotate(R[p], srp[j], s_p)
    for m in range(3):
        for l in range(Y.shape[1]):
            d[m, l] = Y[3 * c + m, l] + s_c[m, l] - s_p[m, l]
        if p < nb:
            for l in range(Y.shape[1]):
                d[m, l] -= Y[3 * p + m, l]


@njit(**_JIT)
def _slides(model, Y, ws, with_bias, with_error):
    """``compiled_kernels._slides`` per lane."""
    mass, sc, sp, sb1, sb2, srow = model[0], model[14], model[15], model[18], model[19], model[21]
    nb = mass.shape[0]
    L = Y.shape[1]
    R, omega, J, bias, C, vec = ws[0], ws[1], ws[3], ws[8], ws[9], ws[11]
    n, x, t1, t2, wn = vec[0], vec[1], vec[2], vec[3], vec[4]
    s_c, s_p, d, wsc, wsp, dd = vec[8], vec[9], vec[10], vec[11], vec[12], vec[13]
    for j in range(sc.shape[0]):
        c, p, r0 = sc[j], sp[j], srow[j]
        _offsets(model, Y, ws, j, s_c, s_p, d)
        if with_bias:
            _cross(omega[c], s_c, wsc)
            _cross(omega[p], s_p, wsp)
            for m in range(3):
                for l in range(L):
                    dd[m, l] = Y[7 * nb + 3 * c + m, l] + wsc[m, l] - wsp[m, l]
                if p < nb:
                    for l in range(L):
                        dd[m, l] -= Y[7 * nb + 3 * p + m, l]
        for k in range(2):
            r = r0 + k
            _rotate(R[p], sb1[j] if k == 0 else sb2[j], n)
            for m in range(3):
                J[r, 3 * c + m, :] = n[m]
                if p < nb:
                    for l in range(L):
                        J[r, 3 * p + m, l] = -n[m, l]
            _cross(s_c, n, x)
            _row_times_rotation(x, R[c], J, r, 3 * nb + 3 * c, 1.0)
            if p < nb:
                for m in range(3):
                    for l in range(L):
                        t1[m, l] = s_p[m, l] + d[m, l]
                _cross(n, t1, x)
                _row_times_rotation(x, R[p], J, r, 3 * nb + 3 * p, 1.0)
            if with_error:
                for l in range(L):
                    C[r, l] = _dot(d, n, l)
            if with_bias:
                _cross(omega[c], wsc, t1)
                _cross(omega[p], wsp, t2)
                _cross(omega[p], n, wn)
                for l in range(L):
                    bias[r, l] = ((t1[0, l] - t2[0, l]) * n[0, l] + (t1[1, l] - t2[1, l]) * n[1, l]
                                  + (t1[2, l] - t2[2, l]) * n[2, l] + 2.0 * _dot(dd, wn, l))
                _cross(omega[p], wn, t1)
                for l in range(L):
                    bias[r, l] += _dot(d, t1, l)
        a, nr = vec[5], vec[6]
        for k in range(3):
            r = r0 + 2 + k
            for m in range(3):  # columns e_(k+1) of R_c and e_(k+2) of R_p, copied contiguous
                for l in range(L):
                    a[m, l] = R[c, m, (k + 1) % 3, l]
                    nr[m, l] = R[p, m, (k + 2) % 3, l]
            _cross(a, nr, x)
            _row_times_rotation(x, R[c], J, r, 3 * nb + 3 * c, 1.0)
            if p < nb:
                _row_times_rotation(x, R[p], J, r, 3 * nb + 3 * p, -1.0)
            if with_error:
                for l in range(L):
                    C[r, l] = _dot(a, nr, l)
            if with_bias:
                _cross(omega[c], a, t1)
                _cross(t1, nr, t2)
                _cross(omega[p], nr, t1)
                _cross(a, t1, wn)
                for l in range(L):
                    bias[r, l] = ((t2[0, l] + wn[0, l]) * (omega[c, 0, l] - omega[p, 0, l])
                                  + (t2[1, l] + wn[1, l]) * (omega[c, 1, l] - omega[p, 1, l])
                                  + (t2[2, l] + wn[2, l]) * (omega[c, 2, l] - omega[p, 2, l]))


@njit(**_JIT)
def _springs(model, Y, ws, u0):
    """``compiled_kernels._springs`` per lane."""
    mass, Iinv, sc, sp, src, saxis, kslide, stiffness, qref = (model[0], model[2], model[14], model[15], model[16],
                                                              model[20], model[22], model[23], model[24])
    nb = mass.shape[0]
    L = Y.shape[1]
    R, vec = ws[0], ws[11]
    s_c, s_p, d, a, f, fB, arm, mom = vec[8], vec[9], vec[10], vec[11], vec[12], vec[13], vec[14], vec[15]
    for e in range(kslide.shape[0]):
        j = kslide[e]
        c, p = sc[j], sp[j]
        _offsets(model, Y, ws, j, s_c, s_p, d)
        _rotate(R[c], saxis[j], a)
        for l in range(L):
            magnitude = -stiffness[e] * (_dot(d, a, l) - qref[e])
            for m in range(3):
                f[m, l] = magnitude * a[m, l]
                u0[3 * c + m, l] += f[m, l] / mass[c]
            for m in range(3):
                fB[m, l] = R[c, 0, m, l] * f[0, l] + R[c, 1, m, l] * f[1, l] + R[c, 2, m, l] * f[2, l]
                arm[m, l] = src[j, m]
        _cross(arm, fB, mom)
        for m in range(3):
            for l in range(L):
                u0[3 * nb + 3 * c + m, l] += Iinv[c, m, 0] * mom[0, l] + Iinv[c, m, 1] * mom[1, l] + Iinv[c, m, 2] * mom[2, l]
        if p < nb:
            for m in range(3):
                for l in range(L):
                    u0[3 * p + m, l] -= f[m, l] / mass[p]
                    fB[m, l] = R[p, 0, m, l] * f[0, l] + R[p, 1, m, l] * f[1, l] + R[p, 2, m, l] * f[2, l]
                    arm[m, l] = (R[p, 0, m, l] * (s_p[0, l] + d[0, l]) + R[p, 1, m, l] * (s_p[1, l] + d[1, l])
                                 + R[p, 2, m, l] * (s_p[2, l] + d[2, l]))
            _cross(arm, fB, mom)
            for m in range(3):
                for l in range(L):
                    u0[3 * nb + 3 * p + m, l] -= (Iinv[p, m, 0] * mom[0, l] + Iinv[p, m, 1] * mom[1, l]
                                                  + Iinv[p, m, 2] * mom[2, l])


@njit(**_JIT)
def _minv_jt(model, ws, L):
    """B = M^-1 J^T (6nb, nc, L) and A = J B (nc, nc, L)."""
    mass, Iinv, nc = model[0], model[2], model[13]
    nb = mass.shape[0]
    J, A, B = ws[3], ws[4], ws[5]
    for r in range(nc):
        for i in range(nb):
            inv_m = 1.0 / mass[i]
            for m in range(3):
                for l in range(L):
                    B[3 * i + m, r, l] = J[r, 3 * i + m, l] * inv_m
                for l in range(L):
                    B[3 * nb + 3 * i + m, r, l] = (Iinv[i, m, 0] * J[r, 3 * nb + 3 * i, l] + Iinv[i, m, 1] * J[r, 3 * nb + 3 * i + 1, l]
                                                   + Iinv[i, m, 2] * J[r, 3 * nb + 3 * i + 2, l])
    for r in range(nc):
        for s in range(r + 1):
            for l in range(L):
                A[r, s, l] = 0.0
            for k in range(6 * nb):
                for l in range(L):
                    A[r, s, l] += J[r, k, l] * B[k, s, l]
            if s < r:
                for l in range(L):
                    A[s, r, l] = A[r, s, l]


@njit(**_JIT)
def _cholesky(A, n, bad):
    """A = L L^T per lane, in place (lower triangle); bad[l] = 1 where a pivot is <= 0 (not
    positive definite; that lane's factor then holds NaN). A NaN pivot (a lane that is no
    longer finite) is not flagged: it ends as a non-finite state."""
    Ln = A.shape[2]
    for k in range(n):
        for m in range(k):
            for l in range(Ln):
                A[k, k, l] -= A[k, m, l] * A[k, m, l]
        for l in range(Ln):
            d = A[k, k, l]
            bad[l] = 1.0 if d <= 0.0 else bad[l]
            A[k, k, l] = np.sqrt(d)
        for i in range(k + 1, n):
            for m in range(k):
                for l in range(Ln):
                    A[i, k, l] -= A[i, m, l] * A[k, m, l]
            for l in range(Ln):
                A[i, k, l] /= A[k, k, l]


@njit(**_JIT)
def _cholesky_solve(A, b, x, n):
    """x = (L L^T)^-1 b per lane with the factor of ``_cholesky``."""
    Ln = A.shape[2]
    for i in range(n):
        for l in range(Ln):
            x[i, l] = b[i, l]
        for m in range(i):
            for l in range(Ln):
                x[i, l] -= A[i, m, l] * x[m, l]
        for l in range(Ln):
            x[i, l] /= A[i, i, l]
    for i in range(n - 1, -1, -1):
        for m in range(i + 1, n):
            for l in range(Ln):
                x[i, l] -= A[m, i, l] * x[m, l]
        for l in range(Ln):
            x[i, l] /= A[i, i, l]


@njit(**_JIT)
def rhs(t, Y, dY, model, ws):
    """dY/dt (ny, L) of the lanes ``Y`` at time t (s). A lane with a singular constraint matrix
    gets NaN and ws flags[0] = 1."""
    mass, I_B, Iinv, grav, nc = model[0], model[1], model[2], model[3], model[13]
    nb = mass.shape[0]
    L = Y.shape[1]
    _frames(model, Y, ws, nc > 0)
    qn, u0, vec = ws[10], ws[6], ws[11]
    Iw, tau = vec[6], vec[7]
    for i in range(nb):
        w = Y[10 * nb + 3 * i: 10 * nb + 3 * i + 3]
        for m in range(3):
            for l in range(L):
                dY[3 * i + m, l] = Y[7 * nb + 3 * i + m, l]
                u0[3 * i + m, l] = grav[i, m]
        k = 3 * nb + 4 * i
        for l in range(L):
            q0, q1, q2, q3 = qn[i, 0, l], qn[i, 1, l], qn[i, 2, l], qn[i, 3, l]
            w0, w1, w2 = w[0, l], w[1, l], w[2, l]
            dY[k, l] = 0.5 * (-q1 * w0 - q2 * w1 - q3 * w2)
            dY[k + 1, l] = 0.5 * (q0 * w0 + q2 * w2 - q3 * w1)
            dY[k + 2, l] = 0.5 * (q0 * w1 + q3 * w0 - q1 * w2)
            dY[k + 3, l] = 0.5 * (q0 * w2 + q1 * w1 - q2 * w0)
            for m in range(3):
                Iw[m, l] = I_B[i, m, 0] * w0 + I_B[i, m, 1] * w1 + I_B[i, m, 2] * w2
        _cross(Iw, w, tau)  # -w x I w
        for m in range(3):
            for l in range(L):
                u0[3 * nb + 3 * i + m, l] = Iinv[i, m, 0] * tau[0, l] + Iinv[i, m, 1] * tau[1, l] + Iinv[i, m, 2] * tau[2, l]
    if model[22].shape[0] > 0:
        _springs(model, Y, ws, u0)
    if nc > 0:
        J, A, B, lam, bias = ws[3], ws[4], ws[5], ws[7], ws[8]
        _constraints(model, Y, ws, True, False)
        _minv_jt(model, ws, L)
        for r in range(nc):  # rhs = -gamma - J u0
            for l in range(L):
                bias[r, l] = -bias[r, l]
            for k in range(6 * nb):
                for l in range(L):
                    bias[r, l] -= J[r, k, l] * u0[k, l]
        _cholesky(A, nc, ws[12][0])
        _cholesky_solve(A, bias, lam, nc)
        for k in range(6 * nb):
            for r in range(nc):
                for l in range(L):
                    u0[k, l] += B[k, r, l] * lam[r, l]
    for k in range(6 * nb):
        for l in range(L):
            dY[7 * nb + k, l] = u0[k, l]


@njit(**_JIT)
def _freeze(ws, mask):
    """Keep J, the factor and M^-1 J^T of the lanes where ``mask`` is set (JF, AF, BF)."""
    for src, dst in ((ws[3], ws[14]), (ws[4], ws[15]), (ws[5], ws[16])):
        for i in range(src.shape[0]):
            for j in range(src.shape[1]):
                for l in range(src.shape[2]):
                    dst[i, j, l] = src[i, j, l] if mask[l] > 0.0 else dst[i, j, l]


@njit(**_JIT)
def _settle(ws, done, remaining, frozen):
    """Lanes ``done`` finished with the current evaluation. While others go on (``remaining``
    > 0), or when some finished earlier (``frozen``), keep their data with ``_freeze``; returns
    whether the velocity projection must read the kept data (JF, AF, BF)."""
    if remaining == 0.0 and not frozen:
        return False  # every lane finished now: the current buffers are each lane's own
    if np.any(done > 0.0):
        _freeze(ws, done)
        return True
    return frozen


@njit(**_JIT)
def project(Y, model, ws, tol):
    """In place, per lane, as ``compiled_kernels.project``: each lane takes Gauss-Newton steps
    until it converges, and its velocities are projected with the J and factor of its own last
    evaluation, whatever the other lanes do (their extra iterations do not touch it). Lanes that
    do not converge get ws flags[1] = 1; a singular constraint matrix sets flags[0]."""
    mass, nc = model[0], model[13]
    nb = mass.shape[0]
    L = Y.shape[1]
    _unit_quaternions(Y, nb, Y[3 * nb: 7 * nb].reshape(nb, 4, L))
    if nc == 0:
        return
    J, A, B, lam, C, flags, err = ws[3], ws[4], ws[5], ws[7], ws[9], ws[12], ws[13]
    active, need, done, dth = flags[2], flags[3], flags[4], ws[11][5]
    active[:] = 1.0
    frozen = False  # whether some lanes finished before the last iteration (their data in JF, AF, BF)
    for it in range(_PROJECTION_ITERATIONS + 1):
        _frames(model, Y, ws, False)
        _constraints(model, Y, ws, False, True)
        _minv_jt(model, ws, L)
        _cholesky(A, nc, flags[0])
        err[:] = 0.0
        for r in range(nc):
            for l in range(L):
                err[l] = max(err[l], abs(C[r, l]))
        last = it == _PROJECTION_ITERATIONS
        n_need = 0.0
        for l in range(L):
            need[l] = 1.0 if (active[l] > 0.0 and err[l] > tol) else 0.0
            flags[1, l] = 1.0 if (last and need[l] > 0.0) else flags[1, l]
            done[l] = active[l] if (last or need[l] == 0.0) else 0.0
            active[l] = 0.0 if last else need[l]
            n_need += active[l]
        frozen = _settle(ws, done, n_need, frozen)
        if n_need == 0.0:
            break
        _cholesky_solve(A, C, lam, nc)
        for i in range(nb):  # masked Gauss-Newton step: dx = -M^-1 J^T lam
            for m in range(3):
                for r in range(nc):
                    for l in range(L):
                        Y[3 * i + m, l] -= need[l] * B[3 * i + m, r, l] * lam[r, l]
            for m in range(3):
                for l in range(L):
                    dth[m, l] = 0.0
                for r in range(nc):
                    for l in range(L):
                        dth[m, l] -= need[l] * B[3 * nb + 3 * i + m, r, l] * lam[r, l]
            k = 3 * nb + 4 * i
            for l in range(L):
                if need[l] > 0.0:
                    q0, q1, q2, q3 = Y[k, l], Y[k + 1, l], Y[k + 2, l], Y[k + 3, l]
                    w0, w1, w2 = dth[0, l], dth[1, l], dth[2, l]
                    q0, q1, q2, q3 = (q0 + 0.5 * (-q1 * w0 - q2 * w1 - q3 * w2), q1 + 0.5 * (q0 * w0 + q2 * w2 - q3 * w1),
                                      q2 + 0.5 * (q0 * w1 + q3 * w0 - q1 * w2), q3 + 0.5 * (q0 * w2 + q1 * w1 - q2 * w0))
                    n = np.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
                    Y[k, l], Y[k + 1, l], Y[k + 2, l], Y[k + 3, l] = q0 / n, q1 / n, q2 / n, q3 / n
        n_active = 0.0
        for l in range(L):  # a step from a tiny error is final (its remainder is O(|C|^2))
            active[l] = 1.0 if (need[l] > 0.0 and err[l] > _QUADRATIC) else 0.0
            done[l] = need[l] - active[l]
            n_active += active[l]
        frozen = _settle(ws, done, n_active, frozen)
        if n_active == 0.0:
            break
    if frozen:
        J, A, B = ws[14], ws[15], ws[16]
    # velocities: u -= B (A^-1 J u), with each lane's J and factor of its last evaluation
    for r in range(nc):
        for l in range(L):
            C[r, l] = 0.0
        for k in range(6 * nb):
            for l in range(L):
                C[r, l] += J[r, k, l] * Y[7 * nb + k, l]
    _cholesky_solve(A, C, lam, nc)
    for k in range(6 * nb):
        for r in range(nc):
            for l in range(L):
                Y[7 * nb + k, l] -= B[k, r, l] * lam[r, l]


@njit(**_JIT)
def _rk4_step(t, Y, h, model, ws, k1, k2, k3, k4, tmp):
    """One classic RK4 step of h (s) from time t (s), all lanes, Y in place."""
    n, L = Y.shape
    rhs(t, Y, k1, model, ws)
    for i in range(n):
        for l in range(L):
            tmp[i, l] = Y[i, l] + 0.5 * h * k1[i, l]
    rhs(t + 0.5 * h, tmp, k2, model, ws)
    for i in range(n):
        for l in range(L):
            tmp[i, l] = Y[i, l] + 0.5 * h * k2[i, l]
    rhs(t + 0.5 * h, tmp, k3, model, ws)
    for i in range(n):
        for l in range(L):
            tmp[i, l] = Y[i, l] + h * k3[i, l]
    rhs(t + h, tmp, k4, model, ws)
    for i in range(n):
        for l in range(L):
            Y[i, l] += h / 6.0 * (k1[i, l] + 2.0 * (k2[i, l] + k3[i, l]) + k4[i, l])


@njit(**_JIT)
def rk4_batch(model, Y0, nstep, h, proj_tol, Yend, status, first, last, L):
    """RK4 over rows ``first..last-1`` of the batch ``Y0`` (nbatch x ny), L rows at a time as
    lanes: ``nstep`` steps of ``h`` s from t = 0, projection after each step; final states into
    ``Yend``, a status code per row into ``status`` (``compiled_kernels``' codes)."""
    n = Y0.shape[1]
    ws = workspace(model, L)
    Y = np.empty((n, L))
    k1, k2, k3, k4, tmp = np.empty((n, L)), np.empty((n, L)), np.empty((n, L)), np.empty((n, L)), np.empty((n, L))
    flags = ws[12]
    for b0 in range(first, last, L):
        lanes = min(L, last - b0)
        for l in range(L):  # a short last group repeats its first row in the spare lanes
            src = b0 + l if l < lanes else b0
            for i in range(n):
                Y[i, l] = Y0[src, i]
        flags[0, :] = 0.0
        flags[1, :] = 0.0
        project(Y, model, ws, proj_tol)
        for j in range(nstep):
            _rk4_step(j * h, Y, h, model, ws, k1, k2, k3, k4, tmp)
            project(Y, model, ws, proj_tol)
        for l in range(lanes):
            finite = True
            for i in range(n):
                Yend[b0 + l, i] = Y[i, l]
                finite = finite and np.isfinite(Y[i, l])
            if flags[0, l] > 0.0:
                status[b0 + l] = SINGULAR
            elif flags[1, l] > 0.0:
                status[b0 + l] = NO_PROJECTION
            elif not finite:
                status[b0 + l] = NONFINITE
            else:
                status[b0 + l] = OK
