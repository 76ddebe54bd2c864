"""Linearised double pendulum of two equal uniform bars: modes and exact linear response.

Textbook location
-----------------
Boström, *Rigid body dynamics*: Ex. 5.2.2 (nonlinear Lagrange equations, text line ~2797),
Ex. 5.3.2 (linearisation, line ~2976), Ex. 6.1.1 (eigenfrequencies and mode vectors,
line ~3221), §6.2 Eqs. (6.29)-(6.36) and Ex. 6.2.1 (modal analysis of the forced pendulum
from rest, line ~3309).

Frames, conventions, units (SI)
-------------------------------
Two equal bars, each of mass m (kg), length L (m), transverse moment of inertia about its
centre I_c (kg m²): the textbook's thin bar has I_c = m L²/12, the harness scene's solid
cylinder of radius r has I_c = m (3 r² + L²)/12.  Absolute angles θ (upper bar) and φ (lower
bar) from the downward vertical, positive so that the lower end swings toward +x; gravity g
(m/s²) downward.  A horizontal force F0 cos(ω_f t) (N) along +x acts at the middle pin.

Printed formulas (OCR text, approximately) and status
-----------------------------------------------------
Ex. 5.2.2  T = mL²[ (2/3) θ̇² + (1/6) φ̇² + (1/2) θ̇ φ̇ cos(φ − θ) ]  — correct (the intermediate
           line "m L²[θ̇² + ¼ φ̇² + θ̇ φ̇ cos(φ−θ)]" lacks the factor ½: typo, final line right).
           Q_θ = F0 cos ωt · L cos θ,  Q_φ = 0  — correct.
           Lagrange eq. for θ:  mL²[(4/3) θ̈ + ½ φ̈ cos(φ−θ) − ½ φ̇² sin(φ−θ)] + (3/2) m g L sin θ
           = F0 L cos θ cos ωt  — correct.
           Lagrange eq. for φ printed as  mL²[(1/3) φ̈ + ½ θ̈ cos(φ−θ) **−** ½ θ̇² sin(φ−θ)]
           + ½ m g L sin φ = 0  — **wrong sign**: d/dt ∂T/∂φ̇ − ∂T/∂φ = mL²[(1/3) φ̈
           + ½ θ̈ cos(φ−θ) − ½ θ̇ (φ̇ − θ̇) sin(φ−θ) + ½ θ̇ φ̇ sin(φ−θ)], i.e. **+** ½ θ̇² sin(φ−θ)
           (the printed sign does not conserve energy: test
           ``test_double_pendulum_ex522_printed_sign_breaks_energy``).
Ex. 5.3.2  (4/3) θ̈ + ½ φ̈ + (3g/2L) θ = F0 L cos ωt,  (1/3) φ̈ + ½ θ̈ + (g/2L) φ = 0
           — LHS correct (divided by m L²), RHS **dimensionally wrong**: after dividing by
           m L² it must be F0 cos(ωt)/(m L) (the printed F0 L is the undivided generalised
           force).  Ex. 6.2.1 then uses the undivided M and Q consistently.
Ex. 6.1.1  M = [[4/3, 1/2], [1/2, 1/3]] m L²,  K = [[3/2, 0], [0, 1/2]] m g L;
           ω² = (g/L)(3 ± 6/√7): ω1 = 0.86 √(g/L), ω2 = 2.30 √(g/L)  — correct
           (0.855695, 2.295166); u2/u1 = 1.43 and −2.10 — correct (1.43050, −2.09717);
           unit mode vectors (0.57, 0.82), (0.43, −0.90) — correct (0.57294, 0.81960),
           (0.43041, −0.90264).
Ex. 6.2.1  modal masses m1 = 1.12 m L², m2 = 0.13 m L²  — m2 correct (0.13008); **m1 is 1.13118
           m L², printed 1.12** (the value obtained by inserting the 2-digit rounded vector
           (0.57, 0.82); rounding error carried into a printed result, 1 % off).
           Y_k = L F0 u1^k (cos ωt − cos ω_k t)/(m_k (ω_k² − ω²))  — correct (from rest).

Verified formulas (general I_c)
-------------------------------
M = [[I_c + (5/4) m L², ½ m L²], [½ m L², I_c + ¼ m L²]],  K = diag((3/2) m g L, ½ m g L)
(K does not depend on I_c; I_c = m L²/12 recovers the textbook).  Nonlinear (for tests):
    M11 θ̈ + ½ m L² cos(φ−θ) φ̈ − ½ m L² φ̇² sin(φ−θ) + (3/2) m g L sin θ = F0 L cos θ cos ω_f t
    M22 φ̈ + ½ m L² cos(φ−θ) θ̈ + ½ m L² θ̇² sin(φ−θ) + ½ m g L sin φ = 0.
Linearised: M ξ̈ + K ξ = (F0 L, 0)ᵀ cos ω_f t, ξ = (θ, φ) (the neglected part of F0 L cos θ is
O(F0 θ²)).  With mass-normalised modes U (Uᵀ M U = 1, Uᵀ K U = diag ω_k²), ξ = U Y:
    Ÿ_k + ω_k² Y_k = f_k cos ω_f t,  f_k = F0 L U_0k,  Y_k(0) = (Uᵀ M ξ0)_k, Ẏ_k(0) = (Uᵀ M ξ̇0)_k,
    Y_k = Y_k(0) cos ω_k t + Ẏ_k(0) sin(ω_k t)/ω_k + f_k G_k(t),
    G_k(t) = (cos ω_f t − cos ω_k t)/(ω_k² − ω_f²)
           = (t/Σ) sin(Σ t/2) · sinc(δ t/2),  Σ = ω_k + ω_f, δ = ω_k − ω_f, sinc x = sin x / x,
which is regular at resonance: G_k → t sin(ω_k t)/(2 ω_k) for ω_f = ω_k (secular growth).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

from harness.measure.exact import extra_run
from harness.measure.signals import frequency_from_zero_crossings
from harness.model import rotations

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "thin_bar_inertia",
    "cylinder_inertia",
    "mass_matrix",
    "stiffness_matrix",
    "modes",
    "unit_modes",
    "linear_response",
    "EXACT_NEEDS_RUNS",
    "exact_error",
]


def thin_bar_inertia(m: float, L: float) -> float:
    """I_c = m L²/12 (kg m²), the textbook's thin bar."""
    return m * L * L / 12.0


def cylinder_inertia(m: float, L: float, r: float) -> float:
    """Transverse I_c = m (3 r² + L²)/12 of a solid cylinder about its centre (kg m²)."""
    return m * (3.0 * r * r + L * L) / 12.0


def mass_matrix(m: float, L: float, I_c: float) -> np.ndarray:
    """Linearised mass matrix for ξ = (θ, φ) (kg m²)."""
    mL2 = m * L * L
    return np.array([[I_c + 1.25 * mL2, 0.5 * mL2], [0.5 * mL2, I_c + 0.25 * mL2]])


def stiffness_matrix(m: float, L: float, g: float) -> np.ndarray:
    """Linearised (gravity) stiffness matrix for ξ = (θ, φ) (N m / rad)."""
    return np.array([[1.5 * m * g * L, 0.0], [0.0, 0.5 * m * g * L]])


def modes(m: float, L: float, I_c: float, g: float) -> tuple[np.ndarray, np.ndarray]:
    """Eigenfrequencies (ω1 < ω2, rad/s) and mass-normalised mode vectors (columns of U,
    Uᵀ M U = I, first (θ) component made positive) of K u = ω² M u."""
    M = mass_matrix(m, L, I_c)
    K = stiffness_matrix(m, L, g)
    w2, U = scipy.linalg.eigh(K, M)
    U = U * np.where(U[0, :] < 0.0, -1.0, 1.0)
    return np.sqrt(w2), U


def unit_modes(m: float, L: float, I_c: float, g: float):
    """Textbook normalisation (6.24): (ω, U_unit, modal masses) with uᵀu = 1 and
    m_k = u_kᵀ M u_k (Eq. 6.27, kg m²)."""
    om, U = modes(m, L, I_c, g)
    Uu = U / np.linalg.norm(U, axis=0)
    M = mass_matrix(m, L, I_c)
    return om, Uu, np.einsum("ik,ij,jk->k", Uu, M, Uu)


def linear_response(
    t,
    m: float,
    L: float,
    I_c: float,
    g: float,
    theta0: float,
    phi0: float,
    dtheta0: float,
    dphi0: float,
    F0: float = 0.0,
    omega_f: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Exact solution (θ(t), φ(t)) (rad) of M ξ̈ + K ξ = (F0 L, 0) cos(ω_f t) with
    ξ(0) = (θ0, φ0), ξ̇(0) = (θ̇0, φ̇0), by modal superposition; valid at resonance."""
    t = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
    om, U = modes(m, L, I_c, g)
    M = mass_matrix(m, L, I_c)
    Y0 = U.T @ M @ np.array([theta0, phi0], dtype=float)
    V0 = U.T @ M @ np.array([dtheta0, dphi0], dtype=float)
    f = F0 * L * U[0, :]
    wf = abs(float(omega_f))
    Y = np.empty((2, t.size))
    for k in range(2):
        wk = om[k]
        Y[k] = Y0[k] * np.cos(wk * t) + V0[k] * np.sin(wk * t) / wk
        if f[k] != 0.0:
            S, d = wk + wf, wk - wf
            G = (t / S) * np.sin(0.5 * S * t) * np.sinc(d * t / (2.0 * np.pi))
            Y[k] += f[k] * G
    xi = U @ Y
    return xi[0], xi[1]


# ---------------------------------------------------------------------------------------------
# Exact check of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = True  # modal runs (and a forced run) of the check's own
MODAL_AMPLITUDE = 1e-3   # rad
MODAL_PERIODS = 8        # periods of the slow mode measured
FORCED_AMPLITUDE = 1e-3  # rad, peak of the small-amplitude forced run

#: The floor of ``exact_error`` itself (``harness.measure.exact.declared_floor``): a small-oscillation
#: (linear) theory, measured from the zero crossings of saved samples. At MODAL_AMPLITUDE the
#: nonlinear frequency shift is about amplitude^2 / 16 = 6e-8, and the crossings are interpolated
#: linearly between samples 1/50 of the fast period apart; the reference run's error, 7.2e-7, is the
#: same at rtol 1e-12 and 1e-10 (it does not follow the run's accuracy). The bound is relative.
EXACT_FLOOR = (1e-5, "small-oscillation theory measured from zero crossings (amplitude 1e-3 rad)")


def _bar_inertia(scene: "Scene") -> float:
    """The scene's transverse moment of a bar about its centre (kg m²), from its builder."""
    from harness.model.builders.double_pendulum import bar_inertia

    p = scene.params
    return bar_inertia(p["m"], p["L"], p["r"])[0, 0]


def bar_angles(traj: "Trajectory") -> tuple[np.ndarray, np.ndarray]:
    """Absolute angles (theta, phi) of the two bars from the downward vertical, toward +x, from
    the bars' orientations (each bar hangs along its body -z)."""
    out = []
    for i in range(2):
        d = -rotations.matrix(traj.quat_WB[:, i])[:, :, 2]
        out.append(np.arctan2(d[:, 0], -d[:, 2]))
    return out[0], out[1]


def exact_error(scene: "Scene", traj: "Trajectory", settings, run) -> tuple[float, str, str]:
    """Max relative error of the two small-oscillation frequencies (``modes``). ``run`` makes a
    run from each mode shape at MODAL_AMPLITUDE rad (rest, no force) with the step, integrator and
    tolerances of ``settings``; the frequency is measured from the zero crossings of the upper
    bar's angle. With a force (F0 != 0) a third run from rest, with the force scaled to a
    FORCED_AMPLITUDE response at the scene's omega_f, is compared with the exact linear response
    (Ex. 6.2.1, ``linear_response``), relative to that peak. ``traj`` itself is not judged."""
    p = scene.params
    I_c = _bar_inertia(scene)
    omegas, vectors = modes(p["m"], p["L"], I_c, p["g"])
    errors, measured = [], []
    for k in range(2):
        u = vectors[:, k] / np.max(np.abs(vectors[:, k])) * MODAL_AMPLITUDE
        modal = scene.with_params(theta0=u[0], phi0=u[1], dtheta0=0.0, dphi0=0.0, F0=0.0)
        t_end = MODAL_PERIODS * 2 * np.pi / omegas[0]
        save = settings.dt * max(1, int(round(0.02 * (2 * np.pi / omegas[1]) / settings.dt)))
        out = extra_run(run, modal, settings, int(np.ceil(t_end / save)), save, f"modal run {k + 1}")
        # upper bar angle from the vertical, signed toward +x
        r = out.p_WCm_W[:, 0]
        theta = np.arctan2(r[:, 0], -r[:, 2])
        w = frequency_from_zero_crossings(out.t, theta)
        measured.append(w)
        errors.append(abs(w - omegas[k]) / omegas[k])
    detail = (f"omega = {measured[0]:.6f}, {measured[1]:.6f} rad/s measured; exact {omegas[0]:.6f}, {omegas[1]:.6f} "
              f"= {omegas[0] / np.sqrt(p['g'] / p['L']):.4f}, {omegas[1] / np.sqrt(p['g'] / p['L']):.4f} sqrt(g/L)")
    if p["F0"] != 0.0:
        err, note = _forced_error(scene, settings, run, I_c, omegas)
        errors.append(err)
        detail += "; " + note
    return float(max(errors)), "rel", detail


def _forced_error(scene: "Scene", settings, run, I_c: float, omegas: np.ndarray) -> tuple[float, str]:
    """Small-amplitude forced response (Ex. 6.2.1, from rest) against the exact linear response
    ``linear_response`` at the scene's forcing frequency: the force is scaled so that the exact
    response peaks at FORCED_AMPLITUDE rad over two slow periods; error = max |(theta, phi) -
    exact| over that peak (nonlinear terms ~ amplitude^2)."""
    p = scene.params
    t_end = 2.0 * 2.0 * np.pi / omegas[0]
    save = settings.dt * max(1, int(round(0.01 * (2 * np.pi / omegas[1]) / settings.dt)))
    n_saves = int(np.ceil(t_end / save))
    t = np.arange(n_saves + 1) * save
    unit = np.abs(np.array(linear_response(t, p["m"], p["L"], I_c, p["g"], 0.0, 0.0, 0.0, 0.0, 1.0, p["omega_f"]))).max()
    F_small = FORCED_AMPLITUDE / unit
    forced = scene.with_params(theta0=0.0, phi0=0.0, dtheta0=0.0, dphi0=0.0, F0=F_small)
    out = extra_run(run, forced, settings, n_saves, save, "forced run")
    theta, phi = bar_angles(out)
    ex_theta, ex_phi = linear_response(out.t, p["m"], p["L"], I_c, p["g"], 0.0, 0.0, 0.0, 0.0, F_small, p["omega_f"])
    err = float(max(np.max(np.abs(theta - ex_theta)), np.max(np.abs(phi - ex_phi)))) / FORCED_AMPLITUDE
    return err, (f"forced from rest at omega_f = {p['omega_f']:g} rad/s with F0 = {F_small:.3e} N (peak {FORCED_AMPLITUDE:g} rad) "
                 f"vs the exact linear response (Ex. 6.2.1): {err:.1e} of the peak")
