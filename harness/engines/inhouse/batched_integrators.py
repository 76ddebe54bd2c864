"""Integrators for batches of in-house states (``batched.BatchedModel``), batch last.

Every method advances all the columns of ``Z`` (ny x nbatch) together, with one step size for
the whole batch (adaptive methods control the largest error over the columns), and samples at
given save times. Methods (``METHODS``):

============== ======== =================================================================
name           order    what
============== ======== =================================================================
rk4_batched    4        classic RK4 (``integrators.RK4``), fixed step
euler_batched  1        explicit Euler, fixed step
rkmk4          4        Runge-Kutta-Munthe-Kaas RK4: each body's orientation moves on SO(3)
                        (``q0 (x) exp(Theta)``), positions and velocities in R^n; fixed step
dop853_fast    8        DOP853 (Hairer's coefficients, from SciPy's published tables), step
                        size control as SciPy's, 7th-order dense output at the save times
gbs_parallel   2k       Gragg-Bulirsch-Stoer extrapolation of the explicit midpoint rule with
                        sequences n = 2, 4, ..., 2k advanced side by side as one batch (one
                        right-hand-side call per micro-step for all of them), so a step costs
                        2k sequential calls for order 2k; k from 3 to 8 chosen per step as
                        ODEX does, counting sequential calls; steps end on save times
============== ======== =================================================================

Fixed-step methods take ``steps_per_save`` equal steps between save times; adaptive ones take
the tolerances ``rtol``/``atol``. With ``project=True`` (the default) every accepted step is
followed by ``BatchedModel.project`` (unit quaternions, joint constraints; as the per-state
engine's fixed-step methods do), and the right-hand side has no Baumgarte terms.

Counters: ``steps`` accepted steps, ``rejected`` rejected ones, ``rhs_calls`` sequential calls
of the batched right-hand side, ``rhs_evals`` right-hand-side evaluations per trajectory (an
extrapolation step evaluates k sequences per call). A numerical failure is returned, never
raised: ``status`` "failed" or "blowup" with ``message`` and the samples before it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop

from harness.model import rotations
from harness.engines.inhouse.batched import BatchedModel, _outer
from harness.engines.inhouse.constraints import DynamicsError

NOMINAL_ORDER = {"rk4_batched": 4, "euler_batched": 1, "rkmk4": 4, "dop853_fast": 8, "gbs_parallel": 16}
FIXED = ("rk4_batched", "euler_batched", "rkmk4")
ADAPTIVE = ("dop853_fast", "gbs_parallel")
METHODS = FIXED + ADAPTIVE
GBS_SEQUENCES = 8
MAX_ADAPTIVE_STEPS = 200_000  # accepted + rejected steps before an adaptive run is declared failed

_NUMERICAL = (ArithmeticError, np.linalg.LinAlgError, DynamicsError, FloatingPointError)

# Hamilton product as a bilinear map on outer products: (p (x) q) = _HM_T @ vec(p q^T).
_HM = np.zeros((16, 4))
for _a in range(4):
    for _b in range(4):
        _HM[_a * 4 + _b] = rotations.multiply(np.eye(4)[_a], np.eye(4)[_b])
_HM_T = np.ascontiguousarray(_HM.T)


@dataclass
class BatchResult:
    """Samples of one batched integration.

    Attributes:
        t: (n,) save times reached (s); n < len(t_save) after a failure.
        Y: (n, nbatch, ny) states at those times, one state per row.
        steps, rejected: accepted and rejected steps.
        rhs_calls: sequential calls of the batched right-hand side.
        rhs_evals: right-hand-side evaluations per trajectory.
        wall_s: wall time of the integration (s).
        status: "ok", "failed" or "blowup"; message: why, when not ok.
    """

    t: np.ndarray
    Y: np.ndarray
    steps: int
    rejected: int
    rhs_calls: int
    rhs_evals: int
    wall_s: float
    status: str = "ok"
    message: str = ""


class _Counter:
    """Wrap a batched RHS to count calls and per-trajectory evaluations."""

    def __init__(self, f, nbatch: int, time_dependent: bool = True) -> None:
        self.f, self.nbatch, self.calls, self.evals = f, nbatch, 0, 0
        self.time_dependent = time_dependent

    def __call__(self, t, Z):
        self.calls += 1
        self.evals += Z.shape[1] // self.nbatch
        return self.f(t, Z)


def integrate_batch(
    bm: BatchedModel,
    Y0: np.ndarray,
    t_save: np.ndarray,
    method: str,
    *,
    steps_per_save: int = 1,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    first_step: float | None = None,
    project: bool = True,
    proj_tol: float = 1e-13,
    fixed_step: float | None = None,
    sequences: int = GBS_SEQUENCES,
) -> BatchResult:
    """Integrate the states ``Y0`` (nbatch x ny, or one state (ny,)) of ``bm`` from
    ``t_save[0]``, sampling at ``t_save`` (s); see the module docstring for the methods.

    ``fixed_step`` (s) turns the step-size control of the adaptive methods off (every step is
    accepted; steps still end on save times): for measuring their order of convergence.
    ``sequences`` is k of ``gbs_parallel`` (order 2k)."""
    if method not in METHODS:
        raise ValueError(f"unknown batched integrator {method!r} (known: {', '.join(METHODS)})")
    Y0 = np.asarray(Y0, dtype=float)
    if Y0.ndim == 1:
        Y0 = Y0[None, :]
    nbatch = Y0.shape[0]
    t_save = np.asarray(t_save, dtype=float)
    f = _Counter(bm.rhs, nbatch, bool(bm.nem.forces))
    post = (lambda Z: bm.project(Z, proj_tol)) if project else None
    out = np.full((len(t_save), nbatch, bm.ny), np.nan)
    Z = np.ascontiguousarray(Y0.T)
    state = {"n": 0, "steps": 0, "rejected": 0, "status": "ok", "message": ""}
    start = time.perf_counter()
    try:
        with np.errstate(all="ignore"):
            if post is not None:
                Z = post(Z)
            if not _record(Z, 0, t_save[0], out, state):
                pass
            elif method in FIXED:
                _fixed(bm, f, Z, t_save, steps_per_save, method, post, out, state)
            elif method == "dop853_fast":
                _dop853(f, Z, t_save, rtol, atol, first_step, post, out, state, fixed_step)
            else:
                _gbs(f, Z, t_save, rtol, atol, first_step, post, out, state, sequences, fixed_step)
    except _NUMERICAL as err:
        state["status"], state["message"] = "failed", f"{type(err).__name__} after {state['steps']} steps: {err}"
    wall = time.perf_counter() - start
    n = state["n"]
    return BatchResult(t_save[:n].copy(), out[:n], state["steps"], state["rejected"], f.calls, f.evals, wall,
                       state["status"], state["message"])


def _record(Z: np.ndarray, k: int, t: float, out: np.ndarray, state: dict) -> bool:
    """Store sample k; False (and a blow-up status) when it is not finite."""
    if not np.all(np.isfinite(Z)):
        state["status"], state["message"] = "blowup", f"non-finite state at t = {t:.6g} s"
        return False
    out[k] = Z.T
    state["n"] = k + 1
    return True


def _check_budget(state: dict, t: float) -> None:
    """Stop an adaptive run whose steps collapse (a failure, not a hang)."""
    if state["steps"] + state["rejected"] > MAX_ADAPTIVE_STEPS:
        raise FloatingPointError(f"more than {MAX_ADAPTIVE_STEPS} steps (t = {t:.6g} s): step size collapsed")


# ---------------------------------------------------------------------------------------------
# Fixed-step methods


def _fixed(bm, f, Z, t_save, steps_per_save, method, post, out, state) -> None:
    step = {"rk4_batched": _rk4_step, "euler_batched": _euler_step, "rkmk4": _rkmk4_step}[method]
    nb = bm.nem.nb
    for k in range(1, len(t_save)):
        t0 = t_save[k - 1]
        h = (t_save[k] - t0) / steps_per_save
        for j in range(steps_per_save):
            Z = step(bm, f, t0 + j * h, Z, h, nb)
            if post is not None:
                Z = post(Z)
            state["steps"] += 1
        if not _record(Z, k, t_save[k], out, state):
            return


def _euler_step(bm, f, t, Z, h, nb):
    return Z + h * f(t, Z)


def _rk4_step(bm, f, t, Z, h, nb):
    k1 = f(t, Z)
    k2 = f(t + 0.5 * h, Z + (0.5 * h) * k1)
    k3 = f(t + 0.5 * h, Z + (0.5 * h) * k2)
    k4 = f(t + h, Z + h * k3)
    return Z + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


def quat_exp(theta: np.ndarray) -> np.ndarray:
    """Unit quaternions (n, 4, B) of rotation vectors ``theta`` (n, 3, B) (rad):
    ``exp(theta) = (cos(|theta|/2), sin(|theta|/2) theta/|theta|)``."""
    angle = np.sqrt(np.einsum("nib,nib->nb", theta, theta))
    half_sinc = 0.5 * np.sinc(angle / (2.0 * np.pi))  # sin(angle/2)/angle, 1/2 at 0
    return np.concatenate([np.cos(0.5 * angle)[:, None, :], theta * half_sinc[:, None, :]], axis=1)


def dexpinv(theta: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Right-trivialised inverse differential of exp on SO(3), to the order RKMK4 needs:
    ``theta' = w + theta x w / 2 + theta x (theta x w) / 12`` for ``R = R0 exp(theta)``,
    ``R' = R [w]x`` (w body frame); stacks (n, 3, B)."""
    from harness.engines.inhouse.batched import _cross

    tw = _cross(theta, w)
    return w + 0.5 * tw + _cross(theta, tw) / 12.0


_RK4_A = ((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))
_RK4_B = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)
_RK4_C = (0.0, 0.5, 0.5, 1.0)


def _rkmk4_step(bm, f, t, Z, h, nb):
    """RKMK4: quaternions q0 (x) exp(Theta_i), Theta_i = h sum a_ij dexpinv(Theta_j, w_j);
    p, v, w by RK4. ``f`` is only called for its accelerations (via ``bm.accelerations``)."""
    n3, n7 = 3 * nb, 7 * nb
    B = Z.shape[1]
    q0 = Z[n3:n7].reshape(nb, 4, B)
    lin0 = np.concatenate([Z[:n3], Z[n7:]])  # p, v, w (9nb, B)
    k_lin, k_rot = [], []
    for a_row, c in zip(_RK4_A, _RK4_C):
        theta = sum((a * k for a, k in zip(a_row, k_rot)), np.zeros((nb, 3, B))) * h
        lin = lin0 + h * sum((a * k for a, k in zip(a_row, k_lin)), np.zeros_like(lin0))
        Zi = np.empty_like(Z)
        Zi[:n3], Zi[n7:] = lin[:n3], lin[n3:]
        Zi[n3:n7] = (_HM_T @ _outer(q0, quat_exp(theta))).reshape(4 * nb, B)
        f.calls += 1
        f.evals += 1
        dv, dw = bm.accelerations(t + c * h, Zi)
        w_i = lin[2 * n3 :].reshape(nb, 3, B)
        k_rot.append(dexpinv(theta, w_i))
        k_lin.append(np.concatenate([lin[n3 : 2 * n3], np.broadcast_to(dv, (nb, 3, B)).reshape(n3, B), dw.reshape(n3, B)]))
    theta = h * sum(b * k for b, k in zip(_RK4_B, k_rot))
    lin = lin0 + h * sum(b * k for b, k in zip(_RK4_B, k_lin))
    out = np.empty_like(Z)
    out[:n3], out[n7:] = lin[:n3], lin[n3:]
    out[n3:n7] = (_HM_T @ _outer(q0, quat_exp(theta))).reshape(4 * nb, B)
    return out


# ---------------------------------------------------------------------------------------------
# DOP853

_N = _dop.N_STAGES
_A = _dop.A[:_N, :_N]
_B = _dop.B
_C = _dop.C[:_N]
_E3, _E5, _D = _dop.E3, _dop.E5, _dop.D
_A_EXTRA, _C_EXTRA = _dop.A[_N + 1 :], _dop.C[_N + 1 :]
_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0


def _combine(coef: np.ndarray, K: np.ndarray) -> np.ndarray:
    """sum_s coef[s] K[s] for K (s, ny, B)."""
    s = len(coef)
    return (coef @ K[:s].reshape(s, -1)).reshape(K.shape[1:])


def _initial_step(f, t0, Z, f0, t_end, order, rtol, atol) -> float:
    """SciPy's ``select_initial_step`` with norms maxed over the batch columns."""
    scale = atol + np.abs(Z) * rtol
    ny = Z.shape[0]
    d0 = float(np.max(np.sqrt(np.sum((Z / scale) ** 2, axis=0) / ny)))
    d1 = float(np.max(np.sqrt(np.sum((f0 / scale) ** 2, axis=0) / ny)))
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_end - t0)
    f1 = f(t0 + h0, Z + h0 * f0)
    d2 = float(np.max(np.sqrt(np.sum(((f1 - f0) / scale) ** 2, axis=0) / ny))) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100 * h0, h1)


def _dop853(f, Z, t_save, rtol, atol, first_step, post, out, state, fixed_step=None) -> None:
    t, t_end = float(t_save[0]), float(t_save[-1])
    ny, B = Z.shape
    K = np.empty((_dop.N_STAGES_EXTENDED, ny, B))
    f0 = f(t, Z)
    if fixed_step is not None:
        h_abs = fixed_step
    else:
        h_abs = first_step if first_step is not None else _initial_step(f, t, Z, f0, t_end, 7, rtol, atol)
    h_abs = min(h_abs, t_end - t)
    k_next = 1
    exponent = -1.0 / 8.0
    while t < t_end and k_next < len(t_save):
        rejected = False
        while True:
            h = min(h_abs, t_end - t)
            if h < 10 * np.spacing(t):
                raise FloatingPointError(f"DOP853 step size underflow at t = {t:.6g} s")
            K[0] = f0
            for s in range(1, _N):
                K[s] = f(t + _C[s] * h, Z + h * _combine(_A[s, :s], K))
            Z_new = Z + h * _combine(_B, K)
            K[_N] = f(t + h, Z_new)
            scale = atol + np.maximum(np.abs(Z), np.abs(Z_new)) * rtol
            err5 = _combine(_E5, K) / scale
            err3 = _combine(_E3, K) / scale
            e5 = np.sum(err5 * err5, axis=0)
            e3 = np.sum(err3 * err3, axis=0)
            denom = e5 + 0.01 * e3
            with np.errstate(invalid="ignore", divide="ignore"):
                norms = np.where(denom > 0, h * e5 / np.sqrt(denom * ny), 0.0)
            err = float(np.max(norms))
            if fixed_step is not None:
                h_abs = fixed_step
                break
            if not np.isfinite(err):
                raise FloatingPointError(f"non-finite DOP853 error estimate at t = {t:.6g} s")
            if err < 1.0:
                factor = _MAX_FACTOR if err == 0 else min(_MAX_FACTOR, _SAFETY * err**exponent)
                if rejected:
                    factor = min(1.0, factor)
                h_abs = h * factor
                break
            h_abs = h * max(_MIN_FACTOR, _SAFETY * err**exponent)
            rejected = True
            state["rejected"] += 1
            _check_budget(state, t)
        t_new = t + h
        tol_t = 1e-12 * max(1.0, abs(t_new))
        k_end = int(np.searchsorted(t_save, t_new + tol_t, side="right"))
        interior = [k for k in range(k_next, k_end) if t_save[k] < t_new - tol_t]
        if interior:  # dense output for the save times inside (t, t_new)
            for s, (a, c) in enumerate(zip(_A_EXTRA, _C_EXTRA), start=_N + 1):
                K[s] = f(t + c * h, Z + h * _combine(a[:s], K))
            dZ = Z_new - Z
            F = [dZ, h * K[0] - dZ, 2 * dZ - h * (K[_N] + K[0])] + list(h * np.tensordot(_D, K, axes=1))
            for k in interior:
                x = (t_save[k] - t) / h
                y = np.zeros_like(Z)
                for i, Fi in enumerate(reversed(F)):
                    y += Fi
                    y *= x if i % 2 == 0 else (1.0 - x)
                sample = Z + y
                if not _record(post(sample) if post is not None else sample, k, t_save[k], out, state):
                    return
        if post is not None:
            Z_new = post(Z_new)
        if k_end > k_next and k_end - 1 not in interior:  # the step ends on a save time
            if not _record(Z_new, k_end - 1, t_save[k_end - 1], out, state):
                return
        k_next = max(k_next, k_end)
        state["steps"] += 1
        _check_budget(state, t)
        t, Z = t_new, Z_new
        f0 = f(t, Z) if post is not None else K[_N].copy()


# ---------------------------------------------------------------------------------------------
# Gragg-Bulirsch-Stoer extrapolation, sequences side by side


def _gbs(f, Z, t_save, rtol, atol, first_step, post, out, state, k_max, fixed_step=None) -> None:
    """Extrapolated midpoint rule, the k sequences n = 2, 4, ..., 2k of a step advanced side by
    side (one call of ``f`` per micro-step for all of them). Order and step control as ODEX
    (Hairer, Norsett & Wanner, II.9), with the work of k sequences counted as the 2k *sequential*
    calls they take here: after each step the row j of the extrapolation tableau that minimises
    calls per unit step (2j / H_j, H_j the step its error estimate predicts, at most the save
    interval since steps end on save times) sets the next k (one more when the last row wins, one
    less at most), between 3 and ``k_max``. A fixed step uses k_max."""
    ny, B = Z.shape
    t = float(t_save[0])
    timed = getattr(f, "time_dependent", True)  # per-sequence times only matter with forces
    k = k_max if fixed_step is not None else max(3, min(k_max, 5))
    h_cap = float(np.max(np.diff(t_save))) if len(t_save) > 1 else np.inf
    if fixed_step is not None:
        h_abs = fixed_step
    elif first_step is not None:
        h_abs = first_step
    else:
        h_abs = _initial_step(f, t, Z, f(t, Z), float(t_save[-1]), 2 * k - 1, rtol, atol)
    for k_save in range(1, len(t_save)):
        target = float(t_save[k_save])
        while t < target - 1e-12 * max(1.0, abs(target)):
            H = min(h_abs, target - t)
            last = H >= target - t - 1e-12 * max(1.0, abs(target))
            n_seq = 2 * np.arange(k, 0, -1)  # longest first: the active sequences are a prefix
            f0 = f(t, Z)
            hs = H / n_seq
            prev = np.repeat(Z[:, None, :], k, axis=1)  # (ny, k, B)
            cur = prev + hs[None, :, None] * f0[:, None, :]
            two_h = (2.0 * hs)[None, :, None]
            for m in range(1, int(n_seq[0])):
                ka = k - (m // 2)  # sequences with n > m (n = 2k, ..., 2)
                tm = np.repeat(t + m * hs[:ka], B) if timed else t
                F = f(tm, cur[:, :ka].reshape(ny, ka * B)).reshape(ny, ka, B)
                new = prev[:, :ka] + two_h[:, :ka] * F
                prev[:, :ka] = cur[:, :ka]
                cur[:, :ka] = new
            # Aitken-Neville on the h^2 expansion, shortest sequence first; errs[j] estimates
            # the error of T_{j,j-1} (local order 2j + 1) from T_jj - T_{j,j-1}.
            n_asc = n_seq[::-1]
            row = [cur[:, k - 1]]
            errs = [np.inf]
            for j in range(1, k):
                new_row = [cur[:, k - 1 - j]]
                for l in range(1, j + 1):
                    r = (n_asc[j] / n_asc[j - l]) ** 2
                    new_row.append(new_row[l - 1] + (new_row[l - 1] - row[l - 1]) / (r - 1.0))
                row = new_row
                scale = atol + rtol * np.maximum(np.abs(Z), np.abs(row[-1]))
                errs.append(float(np.max(np.sqrt(np.mean(((row[-1] - row[-2]) / scale) ** 2, axis=0)))))
            Z_new, err = row[-1], errs[-1]
            if fixed_step is not None:
                err = 0.0
            elif not np.isfinite(err):
                raise FloatingPointError(f"non-finite extrapolation at t = {t:.6g} s")
            # predicted steps and sequential calls per unit step of each tableau row
            steps = [H * min(4.0, max(0.2, 0.94 * (0.65 / max(e, 1e-300)) ** (1.0 / (2 * j + 1))))
                     for j, e in enumerate(errs) if j > 0]
            # a step never spans a save time: a row predicting more than that gains nothing
            costs = [2 * (j + 2) / min(hj, h_cap) for j, hj in enumerate(steps)]
            j_best = max(k - 2, int(np.argmin(costs)) + 1)  # tableau row (j_best + 1 sequences); k down by 1 at most
            if err <= 1.0:
                Z = post(Z_new) if post is not None else Z_new
                t = target if last else t + H
                state["steps"] += 1
                if fixed_step is not None:
                    h_abs = fixed_step
                    continue
                k_new = min(k_max, j_best + 2) if j_best == k - 1 else max(3, j_best + 1)
                h_new = steps[j_best - 1]
                h_abs = max(h_abs, h_new) if last and h_new > H else h_new
                k = k_new
            else:
                h_abs = steps[j_best - 1] if j_best < k - 1 else min(steps[-1], H)
                k = max(3, min(k, j_best + 1))
                state["rejected"] += 1
            _check_budget(state, t)
        if not _record(Z, k_save, target, out, state):
            return
