"""Exact results for a cart on a frictionless horizontal rail carrying a pendulum.

Textbook location
-----------------
Boström, *Rigid body dynamics*: Ex. 1.2.2 (coordinates, velocity and acceleration, text line
~231), Ex. 1.3.1 (equations of motion, line ~289), Ex. 1.5.1 (linearisation and angular
frequency, line ~560), Ex. 1.6.1 (speed of the cart when the pendulum passes the vertical after
release from the horizontal, line ~755).

The system
----------
A cart of mass M (kg) slides without friction along a horizontal rail (world x); a pendulum
hangs from a pivot on the cart. The textbook's pendulum is a particle m on a massless rod of
length L; here it is any rigid body of mass m whose centre of mass lies at distance l from the
pivot, with moment of inertia I_c (kg m²) about its centre of mass for the swing axis
(I_O = I_c + m l² about the pivot; the textbook is I_c = 0, l = L). Gravity −g ẑ.

Frames, conventions, units (SI)
-------------------------------
X: cart displacement along +x (m); θ: angle of the pendulum from the downward vertical, positive
when the centre of mass swings toward +x (rad). Pendulum centre of mass at
(X + l sin θ, −l cos θ) relative to the rail's pivot height. S = M + m.

Printed formulas (OCR text) and status
--------------------------------------
Ex. 1.2.2  x = X + L sin θ, y = −L cos θ; ẋ = Ẋ + Lθ̇ cos θ, ẏ = Lθ̇ sin θ;
           ẍ = Ẍ + Lθ̈ cos θ − Lθ̇² sin θ, ÿ = Lθ̈ sin θ + Lθ̇² cos θ  — correct.
Ex. 1.3.1  (M + m)Ẍ + m(Lθ̈ cos θ − Lθ̇² sin θ) = 0,  mẌ cos θ + mLθ̈ + mg sin θ = 0  — correct.
Ex. 1.5.1  linearised (M + m)Ẍ + mLθ̈ = 0, mẌ + mLθ̈ + mgθ = 0;
           ω = √((M + m) g / (M L))  — correct.
Ex. 1.6.1  energy ½MẊ² + ½m(Ẋ − Lθ̇)² − mgL = 0, momentum MẊ + m(Ẋ − Lθ̇) = 0;
           Ẋ = √(2 m² g L / (M (M + m)))  — correct. (The text writes the pendulum's velocity
           at the vertical as Ẋ − Lθ̇ with θ̇ taken as a speed: with the angle convention of
           Ex. 1.2.2 it is Ẋ + Lθ̇, θ̇ < 0 on the way down from θ = +π/2. A sign convention, not
           an error: the printed speed is right.)

Verified formulas (general I_c, l)
----------------------------------
T = ½ S Ẋ² + m l cos θ Ẋ θ̇ + ½ I_O θ̇²,  V = −m g l cos θ.
Horizontal momentum P = S Ẋ + m l θ̇ cos θ is conserved (no horizontal external force), so the
centre of mass drifts at P/S; in that frame (w = Ẋ − P/S, E_rel = E − P²/(2S)):
    θ̇ = −S w / (m l cos θ),   J(θ) θ̇² = 2 (E_rel + m g l cos θ),   J(θ) = I_O − m² l² cos² θ / S,
    w² = 2 (E_rel + m g l cos θ) m² l² cos² θ / (S (S I_O − m² l² cos² θ)).
At the vertical from rest at θ0: Ẋ² = 2 m² l² g l (1 − cos θ0) / (S ((M + m) I_c + M m l²)),
which for θ0 = π/2, I_c = 0, l = L is Ex. 1.6.1.
Linearised: θ̈ J(0) + m g l θ = 0, ω² = m g l S / (S I_c + M m l²) (= (M + m) g/(M L) for the
particle). Period of the libration with amplitude θ_m (E_rel + m g l cos θ_m = 0), with
sin(θ/2) = k sin ψ, k = sin(θ_m/2) (smooth integrand, Gauss-Legendre):
    T = 4 ∫_0^{π/2} √(J(θ(ψ)) / (m g l)) / √(1 − k² sin² ψ) dψ.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from harness.measure.exact import extra_run
from harness.measure.signals import frequency_from_hermite_crossings

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "pivot_inertia",
    "small_oscillation_frequency",
    "textbook_frequency",
    "momentum",
    "relative_energy",
    "relative_speed_squared",
    "cart_velocity",
    "cart_speed_at_vertical",
    "textbook_cart_speed",
    "amplitude",
    "period",
    "EXACT_NEEDS_RUNS",
    "exact_error",
]


def pivot_inertia(m: float, l: float, I_c: float) -> float:
    """I_O = I_c + m l² (kg m²)."""
    return I_c + m * l * l


def small_oscillation_frequency(M: float, m: float, l: float, I_c: float, g: float) -> float:
    """ω = √(m g l S / (S I_c + M m l²)) (rad/s), S = M + m."""
    S = M + m
    return float(np.sqrt(m * g * l * S / (S * I_c + M * m * l * l)))


def textbook_frequency(M: float, m: float, L: float, g: float) -> float:
    """Ex. 1.5.1 as printed: ω = √((M + m) g / (M L)) (rad/s)."""
    return float(np.sqrt((M + m) * g / (M * L)))


def momentum(M: float, m: float, l: float, theta: float, dX: float, dtheta: float) -> float:
    """Horizontal momentum P = S Ẋ + m l θ̇ cos θ (kg m/s)."""
    return (M + m) * dX + m * l * dtheta * np.cos(theta)


def relative_energy(M, m, l, I_c, g, theta, dX, dtheta) -> float:
    """E_rel = T + V − P²/(2S) (J): the energy in the frame of the horizontal centre-of-mass
    drift, with V = −m g l cos θ."""
    S = M + m
    T = 0.5 * S * dX * dX + m * l * np.cos(theta) * dX * dtheta + 0.5 * pivot_inertia(m, l, I_c) * dtheta * dtheta
    P = momentum(M, m, l, theta, dX, dtheta)
    return float(T - m * g * l * np.cos(theta) - P * P / (2.0 * S))


def relative_speed_squared(theta, M, m, l, I_c, g, E_rel: float) -> np.ndarray:
    """w² = (Ẋ − P/S)² (m²/s²) at pendulum angle(s) θ, from energy and momentum (module
    docstring). Well conditioned everywhere, unlike w itself near a turning point (w → 0),
    where a rounding error ε in w² becomes √ε in w."""
    S = M + m
    c = np.cos(np.asarray(theta, dtype=float))
    mlc2 = (m * l * c) ** 2
    return 2.0 * (E_rel + m * g * l * c) * mlc2 / (S * (S * pivot_inertia(m, l, I_c) - mlc2))


def cart_velocity(theta, dtheta_sign, M, m, l, I_c, g, P: float, E_rel: float) -> np.ndarray:
    """Exact cart velocity Ẋ (m/s) at pendulum angle(s) θ from the two conservation laws, with
    momentum P and relative energy E_rel; ``dtheta_sign`` (the sign of θ̇ cos θ) picks the root:
    w = Ẋ − P/S has the sign of −θ̇ cos θ. Near a turning point see ``relative_speed_squared``."""
    w2 = relative_speed_squared(theta, M, m, l, I_c, g, E_rel)
    return P / (M + m) - np.sign(dtheta_sign) * np.sqrt(np.maximum(w2, 0.0))


def cart_speed_at_vertical(M, m, l, I_c, g, theta0: float, dX0: float = 0.0, dtheta0: float = 0.0) -> float:
    """|Ẋ − P/S| (m/s) when the pendulum passes the vertical (θ = 0), from any initial state
    that reaches it; from rest at θ0 = π/2 with I_c = 0 this is Ex. 1.6.1."""
    E = relative_energy(M, m, l, I_c, g, theta0, dX0, dtheta0)
    S = M + m
    return float(np.sqrt(2.0 * (E + m * g * l) * (m * l) ** 2 / (S * (S * pivot_inertia(m, l, I_c) - (m * l) ** 2))))


def textbook_cart_speed(M: float, m: float, L: float, g: float) -> float:
    """Ex. 1.6.1 as printed: Ẋ = √(2 m² g L / (M (M + m))) (m/s)."""
    return float(np.sqrt(2.0 * m * m * g * L / (M * (M + m))))


def amplitude(M, m, l, I_c, g, theta0: float, dX0: float = 0.0, dtheta0: float = 0.0) -> float:
    """Amplitude θ_m (rad) of the libration: cos θ_m = −E_rel/(m g l). Raises when the
    pendulum goes over the top."""
    E = relative_energy(M, m, l, I_c, g, theta0, dX0, dtheta0)
    c = -E / (m * g * l)
    if not -1.0 < c <= 1.0:
        raise ValueError("the pendulum does not librate (it goes over the top)")
    return float(np.arccos(c))


def period(M, m, l, I_c, g, theta0: float, dX0: float = 0.0, dtheta0: float = 0.0, n: int = 64) -> float:
    """Exact period (s) of the pendulum's libration (module docstring; Gauss-Legendre with
    ``n`` nodes on a smooth periodic-like integrand: converged to rounding for n = 64 at
    amplitudes up to ~170 degrees)."""
    th_m = amplitude(M, m, l, I_c, g, theta0, dX0, dtheta0)
    k = np.sin(0.5 * th_m)
    x, w = np.polynomial.legendre.leggauss(n)
    psi = 0.25 * np.pi * (x + 1.0)
    theta = 2.0 * np.arcsin(k * np.sin(psi))
    S = M + m
    J = pivot_inertia(m, l, I_c) - (m * l * np.cos(theta)) ** 2 / S
    f = np.sqrt(J / (m * g * l)) / np.sqrt(1.0 - (k * np.sin(psi)) ** 2)
    return float(4.0 * 0.25 * np.pi * np.sum(w * f))


# ---------------------------------------------------------------------------------------------
# Exact check of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = True  # a small-oscillation run of the check's own
MODAL_AMPLITUDE = 1e-3   # rad, the small-oscillation run's release angle


def run_angles(traj: "Trajectory") -> tuple[np.ndarray, np.ndarray]:
    """Pendulum angle from the downward vertical (toward +x) and its rate, from maximal
    coordinates: the pivot is the cart's frame origin (its centre of mass); the rate is the
    pendulum's angular velocity about the hinge axis -y."""
    cart, bob = traj.p_WCm_W[:, 0], traj.p_WCm_W[:, 1]
    theta = np.unwrap(np.arctan2(bob[:, 0] - cart[:, 0], cart[:, 2] - bob[:, 2]))
    return theta, -traj.w_WB_W[:, 1, 1]


def exact_error(scene: "Scene", traj: "Trajectory", settings, run) -> tuple[float, str, str]:
    """The largest of three relative errors: (1) the square of the cart velocity relative to the
    centre-of-mass drift, (Xdot - P/S)^2, at every sample against its exact value at the run's
    own pendulum angle from the conservation of energy and horizontal momentum
    (``relative_speed_squared``; at the vertical this is Ex. 1.6.1), over the squared velocity
    scale (squared because the speed is ill-conditioned where it vanishes); (2) the period of
    the run's pendulum (Hermite zero crossings of theta) against the exact period (``period``,
    Gauss-Legendre quadrature), where the run's horizon holds it (``_period_error``); (3) the
    small-oscillation frequency (Ex. 1.5.1), measured on a run by ``run`` of 2 periods from rest at theta = MODAL_AMPLITUDE with the step, integrator and
    tolerances of ``settings`` (the exact period at that amplitude is the reference, so no
    amplitude bias enters). The bob is a uniform sphere of radius r: I_c = 0.4 m r^2."""
    p = scene.params
    M, m, L, g = p["M"], p["m"], p["L"], p["g"]
    I_c = 0.4 * m * p["r"] ** 2
    theta, dtheta = run_angles(traj)
    P = momentum(M, m, L, p["theta0"], p["dX0"], p["dtheta0"])
    E = relative_energy(M, m, L, I_c, g, p["theta0"], p["dX0"], p["dtheta0"])
    w = traj.v_WCm_W[:, 0, 0] - P / (M + m)  # cart velocity relative to the centre-of-mass drift
    v_scale = max(float(np.max(np.abs(traj.v_WCm_W))), 1e-300)
    # compared squared: w itself is ill-conditioned at the turning points (w -> 0)
    err_speed = float(np.max(np.abs(w * w - relative_speed_squared(theta, M, m, L, I_c, g, E)))) / v_scale**2
    err_period, period_text = _period_error(traj, theta, dtheta, p, I_c)
    # small oscillations: a second run from rest at MODAL_AMPLITUDE
    T_small = period(M, m, L, I_c, g, MODAL_AMPLITUDE)
    modal = scene.with_params(theta0=MODAL_AMPLITUDE, dtheta0=0.0, dX0=0.0)
    save = settings.dt * max(1, int(round(0.02 * T_small / settings.dt)))
    n_saves = int(np.ceil(2 * T_small / save))  # 2 periods from a turning point: 4 zero crossings
    small = extra_run(run, modal, settings, n_saves, save, "small-oscillation run")
    w_small = frequency_from_hermite_crossings(small.t, *run_angles(small))
    err_small = abs(w_small * T_small / (2.0 * np.pi) - 1.0)
    w_lin = small_oscillation_frequency(M, m, L, I_c, g)
    at_vertical = cart_speed_at_vertical(M, m, L, I_c, g, p["theta0"], p["dX0"], p["dtheta0"])
    detail = (f"(cart velocity)^2 vs energy+momentum closed form {err_speed:.1e} (|Xdot - P/S| at the vertical "
              f"{at_vertical:.6f} m/s, Ex. 1.6.1); {period_text}; "
              f"small-oscillation omega {w_small:.6f} rad/s vs exact {2 * np.pi / T_small:.6f} ({err_small:.1e}; "
              f"linearised {w_lin:.6f}, Ex. 1.5.1)")
    return max(err_speed, err_period, err_small), "rel", detail


def _period_error(traj: "Trajectory", theta, dtheta, p, I_c: float) -> tuple[float, str]:
    """The run's libration period (Hermite zero crossings of its angle theta and rate dtheta)
    against the exact one (``period`` of the scene's parameters ``p`` and the bob's moment I_c,
    kg m^2): (relative error, detail). Judged only where the exact motion guarantees the
    three crossings it needs within the run: a libration whose horizon holds 1.5 exact periods
    and two save intervals (the first crossing comes within half a period, the third one period
    later). Otherwise 0 with the reason in the detail: the pendulum goes over the top (no
    libration, no period of theta), or the horizon is too short for this amplitude; the cart
    velocity against the conservation laws still judges every sample."""
    try:
        T = period(p["M"], p["m"], p["L"], I_c, p["g"], p["theta0"], p["dX0"], p["dtheta0"])
    except ValueError:
        return 0.0, "period not judged: the pendulum goes over the top (no libration)"
    horizon = float(traj.t[-1] - traj.t[0])
    save = float(traj.t[1] - traj.t[0]) if len(traj.t) > 1 else horizon
    if horizon < 1.5 * T + 2.0 * save:
        return 0.0, (f"period not judged: exact period {T:.6f} s, a horizon of {horizon:g} s holds fewer than "
                     "1.5 periods (three zero crossings are not guaranteed)")
    w_run = frequency_from_hermite_crossings(traj.t, theta, dtheta)
    err = abs(w_run * T / (2.0 * np.pi) - 1.0)
    return err, f"period {2 * np.pi / w_run:.6f} s vs exact {T:.6f} s ({err:.1e})"
