"""Exact nutation of the heavy symmetric (Lagrange) top with a fixed tip.

Textbook location
-----------------
Boström, *Rigid body dynamics*: the closed-form Lagrange top is **not** worked in the book.
The ingredients are: Ex. 2.2.1 (angular velocity of a top in the non-spinning frame,
``ω = −φ̇ sin θ e_x + θ̇ e_y + (ψ̇ + φ̇ cos θ) e_z``, text line ~1117-1140), the 3-2-3 Euler
angles precession φ / nutation θ / spin ψ of §3.2 (line ~1521-1534), Euler's equations about a
fixed point (4.35)-(4.37), and cyclic coordinates / first integrals (5.24) of §5.2.
Status of the printed pieces: Ex. 2.2.1's ω and angular acceleration re-derived and correct.
Everything below is derived here (standard result, e.g. Goldstein §5.7, Landau §35) and
verified against a tight integration of Euler's equations about the tip plus rotation-matrix
kinematics (``tests/references/test_heavy_top.py``).

Frames, conventions, units (SI)
-------------------------------
World frame: z up, gravity −g ẑ; the tip is fixed at the world origin.  Body frame: origin at
the tip, body z = symmetry axis, centre of mass at l·e3 (l > 0 means the centre of mass is
above the tip when the axis is up).  ``R0`` is the body→world rotation matrix, ``omega0`` the
body-frame angular velocity.  θ = angle between e3 = R ẑ_body and world ẑ, u = cos θ = e3·ẑ.
``I1`` is the transverse moment about the centre of mass, ``I3`` the axial one; the transverse
moment about the tip is A = I1 + m l².

Verified formulas
-----------------
Conserved quantities (exact):
    E   = ½ ωᵀ diag(A, A, I3) ω + m g l u              (potential m g z_cm)
    L_z = ẑ · R (A ω1, A ω2, I3 ω3)                      (vertical angular momentum about tip)
    L_3 = I3 ω3                                         (axial angular momentum)
With α = (2E − I3 ω3²)/A, β = 2 m g l/A, a = L_3/A, b = L_z/A:
    u̇² = f(u) = (1 − u²)(α − β u) − (b − a u)².
Evaluated at the initial state this is a Lagrange identity: with g_b = R0ᵀ ẑ,
α − β u0 = ω1² + ω2², b − a u0 = g_b1 ω1 + g_b2 ω2, 1 − u0² = g_b1² + g_b2², so
f(u0) = (g_b1 ω2 − g_b2 ω1)² = u̇0²  and  u̇0 = (g_b × ω)_3 = ((R0 ω) × e3)·ẑ.
The cubic is built in the shifted variable x = u − u0 (no cancellation):
    f = q² + c1 x + c2 x² + β x³,  q = u̇0,
    c1 = −(1 − u0²) β − 2 u0 (ω1² + ω2²) + 2 a (b − a u0),  c2 = 2 u0 β − (ω1² + ω2²) − a².
Its roots are real, u1 ≤ u0 ≤ u2 ≤ 1 ≤ u3 (f(±1) = −(b ∓ a)² ≤ 0).  The largest root x3 is
found first (numpy.roots + Newton polish), the other two from the deflated quadratic
β x² + (c2 + β x3) x − q²/x3 whose constant term is ≤ 0, so they are real with opposite signs.
For β > 0:
    u(t) = u1 + (u2 − u1) sn²(λ t + w0, k),  k² = (u2 − u1)/(u3 − u1),
    λ = sqrt(β (u3 − u1)/4) = sqrt(m g l (u3 − u1)/(2 A)),
    w0 = sgn(u̇0) F(arcsin s0 | k²),  s0² = (u0 − u1)/(u2 − u1)
(on [0, K] sn² increases, so u̇0 ≥ 0 takes w0 ≥ 0 and u̇0 < 0 takes w0 < 0; u̇0 = 0 is a turning
point: w0 = 0 at u1, w0 = K at u2).  Derivation: with u = u1 + (u2−u1) sn², u − u1 =
(u2−u1) sn², u − u2 = −(u2−u1) cn², u − u3 = −(u3−u1) dn², so f = β(u−u1)(u−u2)(u−u3) =
β (u2−u1)²(u3−u1) sn² cn² dn² while u̇² = 4 (u2−u1)² λ² sn² cn² dn².
For β < 0 (centre of mass below the tip, l < 0) the mirror v = −u gives the same form with
β → −β, a → −a (and v̇0 = −u̇0), so the formulas apply to v; then u3 <= −1.
For β = 0 (g = 0 or l = 0) the cubic degenerates to the quadratic c2 x² + c1 x + q² and u is
exactly harmonic: ü = f'(u)/2 is linear, u(t) = u0 + x_e (1 − cos Ω t) + (q/Ω) sin Ω t with
Ω² = −c2 = ω1² + ω2² + a², x_e = −c1/(2 c2); u3 = +inf (the β → 0 limit of the sn² form).
Azimuth (precession) rate: φ̇ = (L_z − L_3 u)/(A (1 − u²)) (undefined at u = ±1).
Tip (support) force: F = m a_cm + m g ẑ with a_cm = d²(l e3)/dt², in cylindrical components
from u, u̇, ü = ½ f'(u), φ̇ and φ̈ (``tip_force``); the tip exerts no couple (ball joint).
Steady precession at fixed θ: A cos θ φ̇² − L_3 φ̇ + m g l = 0 (θ̈ = 0 in the Lagrangian θ
equation A θ̈ = A φ̇² sin θ cos θ − L_3 φ̇ sin θ + m g l sin θ).

Degenerate initial states (documented behaviour)
-----------------------------------------------
* Axis exactly vertical (u0 = ±1) with ω1 = ω2 = 0 ("sleeping" top, or hanging top): this is
  an equilibrium of the exact equations, u ≡ u0 and the nutation bounds are (θ0, θ0), whether
  or not the sleeping top is stable (stable iff L_3² > 4 A m g l for u0 = 1); any perturbation
  of an unstable sleeping top leaves the vertical.  φ̇ is undefined there (returns nan).
* Steady precession (u̇0 = 0 and u0 a double root): u2 − u1 is at rounding level, u ≡ u0 is
  returned when u2 − u1 <= 1e-14.
* ω = 0 with g = 0: u ≡ u0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.special import elliprf

from harness.model import rotations
from harness.references.torque_free import ellipj

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "TopParams",
    "conserved",
    "nutation_roots",
    "nutation_bounds",
    "cos_theta",
    "cos_theta_rates",
    "tip_force",
    "u_dot0",
    "azimuth_rate",
    "azimuth_rate_from_u",
    "steady_precession_rates",
    "steady_precession_state",
    "tilt_about_y",
    "EXACT_NEEDS_RUNS",
    "exact_error",
    "exact_error_series",
    "exact_reaction",
]


@dataclass(frozen=True)
class TopParams:
    """Lagrange top: ``mass`` (kg), ``l`` tip→centre of mass (m), ``I1`` transverse moment
    about the centre of mass (kg m²), ``I3`` axial moment (kg m²), ``g`` (m/s²)."""

    mass: float = 1.0
    l: float = 0.1
    I1: float = 0.004
    I3: float = 0.006
    g: float = 9.81

    @property
    def I1_tip(self) -> float:
        """Transverse moment about the tip, A = I1 + m l² (kg m²)."""
        return self.I1 + self.mass * self.l**2

    @classmethod
    def coerce(cls, p) -> "TopParams":
        if isinstance(p, cls):
            return p
        return cls(**{k: float(p[k]) for k in ("mass", "l", "I1", "I3", "g")})


def tilt_about_y(theta0: float) -> np.ndarray:
    """Body→world rotation by ``theta0`` about world +y (tilts body z toward world +x)."""
    c, s = np.cos(theta0), np.sin(theta0)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _state(params, R0, omega0):
    p = TopParams.coerce(params)
    R0 = np.asarray(R0, dtype=float).reshape(3, 3)
    w = np.asarray(omega0, dtype=float).reshape(3)
    gb = R0[2, :]  # R0ᵀ ẑ: world vertical in body coordinates
    return p, R0, w, gb


def conserved(params, R0, omega0) -> tuple[float, float, float]:
    """(E, L_z, L_3): total energy (J, potential m g z_cm, zero at the tip height), vertical
    angular momentum about the tip (kg m²/s) and axial angular momentum I3 ω3 (kg m²/s)."""
    p, R0, w, gb = _state(params, R0, omega0)
    A = p.I1_tip
    Lb = np.array([A * w[0], A * w[1], p.I3 * w[2]])
    E = 0.5 * float(w @ Lb) + p.mass * p.g * p.l * float(gb[2])
    return E, float(gb @ Lb), float(p.I3 * w[2])


def u_dot0(R0, omega0) -> float:
    """u̇(0) = ((R0 ω0) × e3)·ẑ = (g_b × ω0)_3, e3 = R0 ẑ, g_b = R0ᵀ ẑ (1/s)."""
    R0 = np.asarray(R0, dtype=float).reshape(3, 3)
    w = np.asarray(omega0, dtype=float).reshape(3)
    gb = R0[2, :]
    return float(gb[0] * w[1] - gb[1] * w[0])


def _shifted_cubic(params, R0, omega0):
    """Coefficients (β, c2, c1, q) of f(u0 + x) = β x³ + c2 x² + c1 x + q², and u0."""
    p, R0, w, gb = _state(params, R0, omega0)
    A = p.I1_tip
    beta = 2.0 * p.mass * p.g * p.l / A
    a = p.I3 * w[2] / A
    u0 = float(gb[2])
    s2 = float(gb[0] ** 2 + gb[1] ** 2)  # 1 − u0²
    w2 = float(w[0] ** 2 + w[1] ** 2)  # α − β u0
    pp = float(gb[0] * w[0] + gb[1] * w[1])  # b − a u0
    q = float(gb[0] * w[1] - gb[1] * w[0])  # u̇0
    c1 = -s2 * beta - 2.0 * u0 * w2 + 2.0 * a * pp
    c2 = 2.0 * u0 * beta - w2 - a * a
    return beta, c2, c1, q, u0, w2


def _quad_roots(A2, A1, A0):
    """Real roots (lo, hi) of A2 x² + A1 x + A0 with A2 > 0, A0 <= 0 (stable formula)."""
    disc = max(A1 * A1 - 4.0 * A2 * A0, 0.0)
    if A1 == 0.0 and A0 == 0.0:
        return 0.0, 0.0
    qq = -0.5 * (A1 + np.copysign(np.sqrt(disc), A1))
    r1 = qq / A2
    r2 = A0 / qq if qq != 0.0 else 0.0
    return min(r1, r2), max(r1, r2)


def _roots_x(params, R0, omega0):
    """Roots of the shifted cubic in the (possibly mirrored) variable v = σ u, σ = sgn(β)
    (σ = +1 for β >= 0).  Mirroring u → −u maps f to the same form with β → −β, a → −a, so the
    analysis below always has β >= 0.  Returns (x1, x2, x3, v0, q, beta, c2, c1, rest, σ) with
    x1 <= 0 <= x2 <= x3 roots of f(σ(v0 + x)) (x3 = inf when β = 0), v̇0 = q."""
    beta, c2, c1, q, u0, w2 = _shifted_cubic(params, R0, omega0)
    sigma = 1.0
    if beta < 0.0:  # centre of mass below the tip (l < 0) or g < 0: mirror u → −u
        sigma, beta, c1, q, u0 = -1.0, -beta, -c1, -q, -u0
    sleeping = abs(u0) == 1.0 and w2 == 0.0
    if sleeping:
        return 0.0, 0.0, (np.inf if beta == 0.0 else 0.0), u0, q, beta, c2, c1, True, sigma
    if beta == 0.0:
        if c2 == 0.0:  # ω = 0 and no gravity: rest
            return 0.0, 0.0, np.inf, u0, q, beta, c2, c1, True, sigma
        # −c2 x² − c1 x − q² = 0 with −c2 > 0 and −q² <= 0
        x1, x2 = _quad_roots(-c2, -c1, -q * q)
        return x1, x2, np.inf, u0, q, beta, c2, c1, False, sigma
    coeffs = np.array([beta, c2, c1, q * q])
    dcoeffs = np.polyder(coeffs)
    x3 = float(np.max(np.roots(coeffs).real))
    x3 = max(x3, 1.0 - u0)  # u3 >= 1
    for _ in range(4):  # Newton polish of the (simple) largest root
        fx = np.polyval(coeffs, x3)
        dfx = np.polyval(dcoeffs, x3)
        if dfx <= 0.0:
            break
        x3n = x3 - fx / dfx
        if not np.isfinite(x3n) or abs(np.polyval(coeffs, x3n)) > abs(fx):
            break
        x3 = x3n
    if x3 > 0.0:
        x1, x2 = _quad_roots(beta, c2 + beta * x3, -q * q / x3)
    else:  # x3 = 0: u0 = u3 = 1, only possible with q = 0
        x1, x2 = _quad_roots(beta, c2, c1)
        x1, x2 = min(x1, 0.0), 0.0
    x1, x2 = min(x1, 0.0), max(x2, 0.0)
    return x1, x2, x3, u0, q, beta, c2, c1, False, sigma


def nutation_roots(params, R0, omega0) -> tuple[float, float, float]:
    """Roots (u1, u2, u3) of f(u), u1 <= u0 <= u2 the nutation range.  For m g l > 0:
    u2 <= 1 <= u3 (u3 = inf when g l = 0); for m g l < 0 (centre of mass below the tip) the
    third root lies below: u3 <= −1.  Sleeping top (axis vertical, no transverse ω): all three
    equal u0 (u3 = ±inf if g l = 0)."""
    x1, x2, x3, v0, *_, sigma = _roots_x(params, R0, omega0)
    if sigma > 0:
        return v0 + x1, v0 + x2, v0 + x3
    return -(v0 + x2), -(v0 + x1), -(v0 + x3)


def nutation_bounds(params, R0, omega0) -> tuple[float, float]:
    """(θ_min, θ_max) in rad, θ = arccos(u): θ_min = arccos(u2), θ_max = arccos(u1).
    Sleeping / steady precession: θ_min = θ_max = θ0 (to rounding)."""
    u1, u2, _ = nutation_roots(params, R0, omega0)
    return float(np.arccos(np.clip(u2, -1.0, 1.0))), float(np.arccos(np.clip(u1, -1.0, 1.0)))


def cos_theta(t, params, R0, omega0) -> np.ndarray:
    """Exact u(t) = cos θ(t) = e3(t)·ẑ for the Lagrange top (t in s, scalar or array)."""
    t = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
    x1, x2, x3, v0, q, beta, c2, c1, rest, sigma = _roots_x(params, R0, omega0)
    if rest:
        return np.full(t.shape, sigma * v0)
    if beta == 0.0:
        Om = np.sqrt(-c2)
        xe = -c1 / (2.0 * c2)
        return sigma * (v0 + xe * (1.0 - np.cos(Om * t)) + (q / Om) * np.sin(Om * t))
    span = x2 - x1
    if span <= 1e-14:
        return np.full(t.shape, sigma * v0)
    p = TopParams.coerce(params)
    d31 = x3 - x1  # u3 − u1
    k2 = span / d31
    k2c = (x3 - x2) / d31  # 1 − k²
    lam = np.sqrt(abs(p.mass * p.g * p.l) * d31 / (2.0 * p.I1_tip))
    s2 = min(max(-x1 / span, 0.0), 1.0)  # sn²(w0)
    c2_ = min(max(x2 / span, 0.0), 1.0)  # cn²(w0) = 1 − sn²
    d2 = x3 / d31  # dn²(w0) = 1 − k² sn² = (u3 − u0)/(u3 − u1)
    if k2c == 0.0 and c2_ == 0.0:
        raise ValueError("start exactly at an asymptotic (homoclinic) turning point u0 = u2 = u3")
    w0 = np.sqrt(s2) * float(elliprf(c2_, d2, 1.0))  # F(arcsin s0 | k²)
    if q < 0.0:
        w0 = -w0
    sn, _, _ = ellipj(lam * t + w0, k2, k2c)
    return sigma * (v0 + x1 + span * sn * sn)


def cos_theta_rates(t, params, R0, omega0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact (u, u̇, ü) at times t: u as ``cos_theta``, u̇ = 2 (u2 − u1) λ sn cn dn (mirrored by
    σ; harmonic when β = 0), ü = ½ f'(u) with
    f'(u) = −2 u (α − β u) − β (1 − u²) + 2 a (b − a u) (derivative of u̇² = f(u))."""
    t = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
    u = cos_theta(t, params, R0, omega0)
    x1, x2, x3, v0, q, beta_v, c2, c1, rest, sigma = _roots_x(params, R0, omega0)
    p = TopParams.coerce(params)
    if rest:
        udot = np.zeros(t.shape)
    elif beta_v == 0.0:
        Om = np.sqrt(-c2)
        xe = -c1 / (2.0 * c2)
        udot = sigma * (xe * Om * np.sin(Om * t) + q * np.cos(Om * t))
    elif x2 - x1 <= 1e-14:
        udot = np.zeros(t.shape)
    else:
        span, d31 = x2 - x1, x3 - x1
        k2, k2c = span / d31, (x3 - x2) / d31
        lam = np.sqrt(abs(p.mass * p.g * p.l) * d31 / (2.0 * p.I1_tip))
        w0 = np.sqrt(min(max(-x1 / span, 0.0), 1.0)) * float(elliprf(min(max(x2 / span, 0.0), 1.0), x3 / d31, 1.0))
        if q < 0.0:
            w0 = -w0
        sn, cn, dn = ellipj(lam * t + w0, k2, k2c)
        udot = sigma * 2.0 * span * lam * sn * cn * dn
    E, L_z, L_3 = conserved(params, R0, omega0)
    A = p.I1_tip
    alpha = (2.0 * E - L_3 * L_3 / p.I3) / A
    beta = 2.0 * p.mass * p.g * p.l / A
    a, b = L_3 / A, L_z / A
    uddot = 0.5 * (-2.0 * u * (alpha - beta * u) - beta * (1.0 - u * u) + 2.0 * a * (b - a * u))
    return u, udot, uddot


def tip_force(t, params, R0, omega0) -> np.ndarray:
    """Exact force (N) the fixed tip exerts on the top, F = m a_cm + m g ẑ, in cylindrical
    components (F_ρ, F_φ, F_z), shape (n, 3): e_ρ the horizontal direction of the symmetry
    axis e3, e_φ = ẑ × e_ρ. With ρ = l sin θ = l s, s = √(1 − u²), and φ the azimuth of e3:

        a_ρ = ρ̈ − ρ φ̇²,  a_φ = ρ φ̈ + 2 ρ̇ φ̇,  a_z = l ü,
        ρ̇ = −l u u̇ / s,  ρ̈ = −l ((u̇² + u ü)/s + u² u̇²/s³),
        φ̇ = (L_z − L_3 u)/(A s²),  φ̈ = u̇ (2 u (L_z − L_3 u) − L_3 s²)/(A s⁴).

    Undefined (nan horizontal components) where the axis is vertical (s = 0)."""
    p = TopParams.coerce(params)
    u, ud, udd = cos_theta_rates(t, params, R0, omega0)
    _, L_z, L_3 = conserved(params, R0, omega0)
    A, l = p.I1_tip, p.l
    s2 = 1.0 - u * u
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.sqrt(s2)
        rho, rhod = l * s, -l * u * ud / s
        rhodd = -l * ((ud * ud + u * udd) / s + u * u * ud * ud / (s * s2))
        phid = (L_z - L_3 * u) / (A * s2)
        phidd = ud * (2.0 * u * (L_z - L_3 * u) - L_3 * s2) / (A * s2 * s2)
        a_rho = rhodd - rho * phid * phid
        a_phi = rho * phidd + 2.0 * rhod * phid
    a_z = l * udd
    return p.mass * np.stack([a_rho, a_phi, a_z + p.g], axis=1)


def azimuth_rate_from_u(u, params, L_z: float, L_3: float) -> np.ndarray:
    """φ̇ = (L_z − L_3 u)/(A (1 − u²)) (rad/s); nan where u = ±1."""
    p = TopParams.coerce(params)
    u = np.asarray(u, dtype=float)
    den = p.I1_tip * (1.0 - u * u)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den != 0.0, (L_z - L_3 * u) / den, np.nan)


def azimuth_rate(t, params, R0, omega0) -> np.ndarray:
    """Exact precession rate φ̇(t) (rad/s) of the symmetry axis about world ẑ."""
    _, L_z, L_3 = conserved(params, R0, omega0)
    return azimuth_rate_from_u(cos_theta(t, params, R0, omega0), params, L_z, L_3)


def steady_precession_rates(params, theta: float, omega3: float) -> tuple[float, float]:
    """(slow, fast) steady precession rates φ̇ (rad/s) at constant tilt θ (0 < θ < π) and axial
    spin ω3: roots of A cos θ φ̇² − I3 ω3 φ̇ + m g l = 0 (slow = the root → m g l/(I3 ω3) for a
    fast top).  For cos θ = 0 the single root m g l/(I3 ω3) is returned twice.  Raises if
    the discriminant is negative (no steady precession at that θ, ω3)."""
    p = TopParams.coerce(params)
    A, L3, mgl = p.I1_tip, p.I3 * omega3, p.mass * p.g * p.l
    c = np.cos(theta)
    if c == 0.0:
        r = mgl / L3
        return r, r
    disc = L3 * L3 - 4.0 * A * c * mgl
    if disc < 0.0:
        raise ValueError("no steady precession: L3² < 4 A m g l cos θ")
    qq = 0.5 * (L3 + np.copysign(np.sqrt(disc), L3))
    r1 = mgl / qq  # small root (stable formula)
    r2 = qq / (A * c)
    return (r1, r2) if abs(r1) <= abs(r2) else (r2, r1)


def steady_precession_state(params, theta0: float, omega3: float, branch: str = "slow"):
    """(R0, omega0) for steady precession at tilt θ0 about world +y (``tilt_about_y``) with
    axial spin ω3: ω_world = φ̇ ẑ + ψ̇ e3, i.e. ω_body = φ̇ R0ᵀ ẑ + (ω3 − φ̇ cos θ0) ẑ_body."""
    slow, fast = steady_precession_rates(params, theta0, omega3)
    rate = slow if branch == "slow" else fast
    R0 = tilt_about_y(theta0)
    w = rate * R0[2, :]
    w[2] = omega3
    return R0, w


# ---------------------------------------------------------------------------------------------
# Exact checks of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs


def _scene_top(scene: "Scene") -> tuple[dict, np.ndarray]:
    """The scene's top parameters (mass, l, I1, I3, g) and its initial orientation R0 (the
    scene's own, from its multibody)."""
    p = scene.params
    R0 = rotations.matrix(scene.multibody().q0["top"])
    return {k: p[k] for k in ("mass", "l", "I1", "I3", "g")}, R0


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """|cos theta(t) - u_exact(t)|, the nutation (cos theta = e3 . z, the vertical component of
    the symmetry axis) against the Jacobi elliptic solution (dimensionless)."""
    params, R0 = _scene_top(scene)
    R = rotations.matrix(traj.quat_WB[:, 0])
    return np.abs(R[:, 2, 2] - cos_theta(traj.t, params, R0, np.asarray(scene.params["omega0"], float)))


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """Max over samples of |cos theta(t) - u_exact(t)| (dimensionless; ``exact_error_series``),
    with the nutation bounds in the detail. ``settings`` and ``run`` are unused (no extra runs)."""
    params, R0 = _scene_top(scene)
    lo, hi = nutation_bounds(params, R0, scene.params["omega0"])
    return (float(np.max(exact_error_series(scene, traj))), "",
            f"cos(theta) vs elliptic solution; nutation between {np.degrees(lo):.3f} and {np.degrees(hi):.3f} deg")


def exact_reaction(scene: "Scene", traj: "Trajectory") -> tuple[float, str]:
    """Max over samples of |F(t) - F_exact(t)| (N): the tip's reaction force on the top against
    ``tip_force`` (m a_cm + m g z of the elliptic solution), its cylindrical components taken
    about the run's own symmetry axis (horizontal components only where the axis is off the
    vertical)."""
    params, R0 = _scene_top(scene)
    exact = tip_force(traj.t, params, R0, scene.params["omega0"])
    e3 = rotations.matrix(traj.quat_WB[:, 0])[:, :, 2]
    h = np.hypot(e3[:, 0], e3[:, 1])
    e_rho = np.stack([e3[:, 0] / h, e3[:, 1] / h, np.zeros_like(h)], axis=1)
    e_phi = np.stack([-e_rho[:, 1], e_rho[:, 0], np.zeros_like(h)], axis=1)
    exact_W = exact[:, :1] * e_rho + exact[:, 1:2] * e_phi + exact[:, 2:3] * np.array([0.0, 0.0, 1.0])
    force = traj.reactions["top"][0]
    ok = h > 1e-6  # the horizontal components need the axis off the vertical
    err_h = float(np.max(np.linalg.norm(force[ok] - exact_W[ok], axis=-1), initial=0.0))
    err_z = float(np.max(np.abs(force[:, 2] - exact[:, 2])))
    return max(err_h, err_z), "tip force vs m a_cm + m g from the elliptic u(t) (cylindrical components about the run's own axis)"
