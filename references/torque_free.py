"""Exact torque-free rotation of a rigid body (Euler's equations without moment).

Textbook location
-----------------
Boström, *Rigid body dynamics*, §4.7 "Three-dimensional rotations", Eqs. (4.60)-(4.73)
(text lines ~2306-2385); Euler's equations are Eqs. (4.35)-(4.37) of §4.3 (line ~2078).

Frames and units
----------------
Body-fixed principal frame, body axes x, y, z carry the principal moments I1, I2, I3
(kg m^2) *in any order of size*; omega is the absolute angular velocity (rad/s) expressed in
that body frame; t in s.

Printed formulas (OCR text, approximately)
------------------------------------------
(4.60)-(4.62)  ``I_1 ω̇_x − (I_2 − I_3) ω_y ω_z = 0`` (and cyclic).
(4.64)-(4.65)  ``ω̈_x + β ω_3² ω_x = 0``,  ``β = (I_3 − I_1)(I_3 − I_2)/(I_1 I_2)``.
(4.66)-(4.69)  for I_1 = I_2: ``γ = (I_3 − I_1)/I_1``,
               ``ω_x = ω_12 cos(γ ω_3 t + α)``, ``ω_y = ω_12 sin(γ ω_3 t + α)``.
(4.70), (4.72) ``tan α_b = ω_12/ω_3``, ``tan α_3 = I_1 ω_12/(I_3 ω_3)``.
(4.73)         ``cos α_s = 2 T_rot/(ω L̄)``.

Verified formulas
-----------------
* Euler (4.60)-(4.62): I ω̇ = (I ω) × ω, i.e. I_i ω̇_i = ε_ijk (I_j − I_k) ω_j ω_k.  Correct.
* Symmetric body (4.66)-(4.69): with (i, j, k) a *cyclic* permutation of (x, y, z) and
  I_i = I_j = I, ω_k is constant and (ω_i, ω_j) rotates rigidly at the rate γ ω_k,
  γ = (I_k − I)/I:
      ω_i(t) = ω_i0 cos(γ ω_k t) − ω_j0 sin(γ ω_k t),
      ω_j(t) = ω_i0 sin(γ ω_k t) + ω_j0 cos(γ ω_k t).
  Status: correct (sign checked: ω̇_x = −γ ω_3 ω_y, ω̇_y = +γ ω_3 ω_x from (4.60)-(4.61)).
  The remark "if I_3 > I_1 then ω rotates in the positive direction around the z axis"
  holds for ω_3 > 0 only (the rate is γ ω_3, it changes sign with ω_3): incomplete remark.
* (4.70), (4.72), (4.73) correct.  Consequence: tan α_3 = (I_1/I_3) tan α_b; for a flat body
  (I_3 > I_1) L lies *between* the symmetry axis and ω, so α_s = α_b − α_3 < α_b: the space
  cone lies *inside* the body cone and the body cone rolls around (outside of) it.  The text's
  "the body cone rolls inside the space cone" for I_1 < I_3 is the wrong way round
  (status: wrong remark; evidence: ``tests/references/test_torque_free.py::
  test_torque_free_cone_geometry_oblate``).  For a slender body (I_1 > I_3) the text's
  "body cone rolls outside the space cone" is correct.
* General asymmetric body (not printed in the text; Landau & Lifshitz, Mechanics §37, derived
  and re-verified here).  Sort the axes I_a < I_b < I_c and let s = ε_abc be the parity of
  that permutation; with x = ω_a, y = s ω_b, z = ω_c Euler's equations take the cyclic form
      I_a ẋ = (I_b − I_c) y z,  I_b ẏ = (I_c − I_a) z x,  I_c ż = (I_a − I_b) x y.
  With 2E = Σ I ω², M² = Σ I² ω² and the (cancellation-free) non-negative combinations
      P = 2E I_c − M² = I_a (I_c − I_a) x² + I_b (I_c − I_b) y²,
      Q = M² − 2E I_a = I_b (I_b − I_a) y² + I_c (I_c − I_a) z²,
      D = M² − 2E I_b = I_c (I_c − I_b) z² − I_a (I_b − I_a) x²:
  - D > 0 (rotation about the major axis c):
      x = A cn τ, y = B sn τ, z = C dn τ,
      A² = P/(I_a(I_c − I_a)), B² = P/(I_b(I_c − I_b)), C² = Q/(I_c(I_c − I_a)),
      τ = λ t + τ0, λ² = (I_c − I_b) Q/(I_a I_b I_c), m = k² = (I_b − I_a) P/((I_c − I_b) Q),
      1 − m = (I_c − I_a) D/((I_c − I_b) Q).
  - D < 0 (rotation about the minor axis a):
      x = A dn τ, y = B sn τ, z = C cn τ,
      B² = Q/(I_b(I_b − I_a)), λ² = (I_b − I_a) P/(I_a I_b I_c),
      m = (I_c − I_b) Q/((I_b − I_a) P), 1 − m = (I_c − I_a)(−D)/((I_b − I_a) P).
  - D = 0 (separatrix, m = 1): x = A sech τ, y = B tanh τ, z = C sech τ (A, B, C, λ as for
    D > 0), written explicitly because cephes' ``ellipj`` is wrong for 1 − m < 1e-9 at
    large arguments (e.g. ``ellipj(50.3, 1 - 1e-12)`` returns cn ≈ −8.7e8).
  The solution families have fixed signs (dn > 0, sech > 0); general initial signs are reached
  through the symmetries (x, z) → (−x, −z) and (x, y) → (−x, −y) of the cyclic system.  The
  initial phase is τ0 = F(φ0 | m) with φ0 = atan2(y0/B, x0/A) (D > 0) or atan2(y0/B, z0/C)
  (D < 0), F computed with Carlson's R_F so that it stays accurate as m → 1.
  Stationary cases (ω an eigenvector of I: rotation exactly about a principal axis, about any
  axis in the plane of an equal pair, or any axis when all moments are equal) return the
  constant ω0.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy import special as scipy_special
from scipy.special import elliprf

from harness.model import rotations

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "omega_body",
    "invariants",
    "symmetric_precession_rate",
    "cone_angles",
    "ellipj",
    "ellipf",
    "EXACT_NEEDS_RUNS",
    "exact_error",
    "exact_error_series",
]


# ---------------------------------------------------------------------------------------------
# Jacobi elliptic functions, accurate up to and including m = 1
# ---------------------------------------------------------------------------------------------
def _sech(u):
    """sech u without overflow: 2 e^{−|u|}/(1 + e^{−2|u|})."""
    e = np.exp(-np.abs(u))
    return 2.0 * e / (1.0 + e * e)


SCIPY_ELLIPJ_MIN_M1 = 1e-5  # below this, scipy.special.ellipj loses accuracy (see ellipj)


def ellipj(u, m: float, m1: float | None = None):
    """Jacobi sn, cn, dn of argument ``u`` (array) and parameter ``m = k²`` in [0, 1].

    ``scipy.special.ellipj`` wherever it is accurate. Two regimes are handled here instead:
    ``m1 = 1 - m == 0`` (the separatrix: tanh/sech exactly) and ``0 < m1 < 1e-9``, where
    cephes' ``ellipj`` switches to a first-order expansion in ``m1`` that fails at large
    arguments (``scipy.special.ellipj(50.3, 1 - 1e-12)`` returns cn ≈ −8.7e8). Measured
    against the AGM below over 0 <= u <= 100, SciPy's result differs by 1e-12 for
    m1 >= 1e-4, 2e-10 at m1 = 1e-6 and 2e-8 at m1 = 1e-8, so for ``m1 < 1e-5`` the
    arithmetic-geometric mean with descending Landen recursion (Abramowitz & Stegun 16.4) is
    used instead. ``m1`` may be given separately (more accurate near the separatrix).
    """
    u = np.asarray(u, dtype=float)
    m = float(m)
    m1 = 1.0 - m if m1 is None else float(m1)
    if not (0.0 <= m <= 1.0) or not (0.0 <= m1 <= 1.0):
        raise ValueError(f"ellipj: need 0 <= m <= 1, got m={m}, m1={m1}")
    if m1 == 0.0:
        sech = 1.0 / np.cosh(u)
        return np.tanh(u), sech, sech
    if m1 >= SCIPY_ELLIPJ_MIN_M1:
        sn, cn, dn, _ = scipy_special.ellipj(u, m)
        return sn, cn, dn
    return _ellipj_agm(u, m, m1)


def _ellipj_agm(u, m: float, m1: float):
    """sn, cn, dn by the AGM and descending Landen recursion (A&S 16.4), used for 0 < m1 < 1e-5."""
    a = [1.0]
    c = [np.sqrt(m)]
    b = np.sqrt(m1)
    for _ in range(64):
        a_prev = a[-1]
        a_new = 0.5 * (a_prev + b)
        c_new = c[-1] ** 2 / (4.0 * a_new)  # = (a_prev - b)/2 without cancellation
        b = np.sqrt(a_prev * b)
        a.append(a_new)
        c.append(c_new)
        if c_new <= 1e-17 * a_new:
            break
    n = len(a) - 1
    phi = (2.0**n) * a[n] * u
    phi_next = phi
    for j in range(n, 0, -1):
        phi_next = phi
        phi = 0.5 * (phi + np.arcsin(c[j] * np.sin(phi) / a[j]))
    sn = np.sin(phi)
    cn = np.cos(phi)
    dn = np.ones_like(u) if n == 0 else cn / np.cos(phi_next - phi)
    return sn, cn, dn


def ellipf(phi, m: float, m1: float | None = None):
    """Incomplete elliptic integral of the first kind F(φ | m) for |φ| <= π (m < 1), via
    Carlson: F = sin φ · R_F(cos² φ, m1 + m cos² φ, 1), reflected through K for |φ| > π/2."""
    phi = np.asarray(phi, dtype=float)
    m = float(m)
    m1 = 1.0 - m if m1 is None else float(m1)

    def _f(p):
        s, c = np.sin(p), np.cos(p)
        return s * elliprf(c * c, m1 + m * c * c, 1.0)

    K = elliprf(0.0, m1, 1.0) if m1 > 0.0 else np.inf
    out = _f(phi)
    hi = phi > 0.5 * np.pi
    lo = phi < -0.5 * np.pi
    out = np.where(hi, 2.0 * K - _f(np.pi - phi), out)
    out = np.where(lo, _f(np.pi + phi) - 2.0 * K, out)
    return out


# ---------------------------------------------------------------------------------------------
# Invariants and textbook helpers
# ---------------------------------------------------------------------------------------------
def invariants(I, omega0) -> tuple[float, float]:
    """Rotational kinetic energy E = ½ Σ I_i ω_i² (J) and |L| = |I ω| (kg m²/s)."""
    I = np.asarray(I, dtype=float)
    w = np.asarray(omega0, dtype=float)
    return 0.5 * float(np.sum(I * w * w)), float(np.linalg.norm(I * w))


def symmetric_precession_rate(I1: float, I3: float, omega3: float) -> float:
    """Rate (rad/s) at which ω rotates about the body symmetry axis z for I1 = I2:
    γ ω3 with γ = (I3 − I1)/I1 (textbook Eq. 4.67-4.69).  Positive = counter-clockwise about
    +z_body, i.e. (ω_x, ω_y) = ω_12 (cos(γω3 t + α), sin(γω3 t + α))."""
    return (I3 - I1) / I1 * omega3


def cone_angles(I1: float, I3: float, omega12: float, omega3: float) -> tuple[float, float, float]:
    """Half-angles (rad) for a symmetric body (I1 = I2): α_b between ω and the symmetry axis
    (body cone, Eq. 4.70), α_3 between L and the symmetry axis (Eq. 4.72), α_s between ω and L
    (space cone, Eq. 4.73).  Angles measured from the +z body axis (ω3 > 0 assumed for α_b,
    α_3 in [0, π/2))."""
    alpha_b = float(np.arctan2(abs(omega12), omega3))
    alpha_3 = float(np.arctan2(I1 * abs(omega12), I3 * omega3))
    alpha_s = abs(alpha_b - alpha_3)
    return alpha_b, alpha_3, alpha_s


# ---------------------------------------------------------------------------------------------
# Exact solution
# ---------------------------------------------------------------------------------------------
_CYCLIC = {(0, 1, 2), (1, 2, 0), (2, 0, 1)}


def omega_body(t, I, omega0) -> np.ndarray:
    """Exact body-frame angular velocity ω(t) (rad/s), array of shape (len(t), 3).

    ``I`` = (I1, I2, I3) principal moments (kg m², any order, all > 0) about body x, y, z;
    ``omega0`` = ω(0) in the body frame (rad/s).  Solves I ω̇ = (I ω) × ω exactly (see module
    docstring for the case analysis).  ``t`` may be a scalar or an array (s), any sign.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
    I = np.asarray(I, dtype=float).reshape(3)
    w0 = np.asarray(omega0, dtype=float).reshape(3)
    if np.any(I <= 0.0) or not np.all(np.isfinite(I)):
        raise ValueError(f"principal moments must be positive and finite, got {I}")
    out = np.empty((t.size, 3))
    out[:] = w0

    # ---- symmetric bodies (at least two equal moments): exact textbook precession ----------
    if I[0] == I[1] == I[2]:
        return out
    for k in range(3):
        i, j = [(1, 2), (2, 0), (0, 1)][k]  # (i, j, k) cyclic
        if I[i] == I[j]:
            rate = symmetric_precession_rate(I[i], I[k], w0[k])
            c, s = np.cos(rate * t), np.sin(rate * t)
            out[:, i] = w0[i] * c - w0[j] * s
            out[:, j] = w0[i] * s + w0[j] * c
            return out

    # ---- asymmetric body: sort, cyclic form ---------------------------------------------
    a, b, c_ = (int(v) for v in np.argsort(I, kind="stable"))
    par = 1.0 if (a, b, c_) in _CYCLIC else -1.0
    Ia, Ib, Ic = I[a], I[b], I[c_]
    x0, y0, z0 = w0[a], par * w0[b], w0[c_]

    P = Ia * (Ic - Ia) * x0 * x0 + Ib * (Ic - Ib) * y0 * y0
    Q = Ib * (Ib - Ia) * y0 * y0 + Ic * (Ic - Ia) * z0 * z0
    D = Ic * (Ic - Ib) * z0 * z0 - Ia * (Ib - Ia) * x0 * x0
    if P == 0.0 or Q == 0.0 or (x0 == 0.0 and z0 == 0.0):
        return out  # ω0 along a principal axis: permanent rotation

    sig = np.ones(3)
    if D > 0.0:
        if z0 < 0.0:
            sig = np.array([-1.0, 1.0, -1.0])
        x0s, y0s = sig[0] * x0, sig[1] * y0
        A = np.sqrt(P / (Ia * (Ic - Ia)))
        B = np.sqrt(P / (Ib * (Ic - Ib)))
        C = np.sqrt(Q / (Ic * (Ic - Ia)))
        lam = np.sqrt((Ic - Ib) * Q / (Ia * Ib * Ic))
        m = (Ib - Ia) * P / ((Ic - Ib) * Q)
        m1 = (Ic - Ia) * D / ((Ic - Ib) * Q)
        m, m1 = min(max(m, 0.0), 1.0), min(max(m1, 0.0), 1.0)
        phi0 = np.arctan2(y0s / B, x0s / A)
        tau0 = float(ellipf(phi0, m, m1))
        sn, cn, dn = ellipj(lam * t + tau0, m, m1)
        x, y, z = A * cn, B * sn, C * dn
    elif D < 0.0:
        if x0 < 0.0:
            sig = np.array([-1.0, 1.0, -1.0])
        y0s, z0s = sig[1] * y0, sig[2] * z0
        A = np.sqrt(P / (Ia * (Ic - Ia)))
        B = np.sqrt(Q / (Ib * (Ib - Ia)))
        C = np.sqrt(Q / (Ic * (Ic - Ia)))
        lam = np.sqrt((Ib - Ia) * P / (Ia * Ib * Ic))
        m = (Ic - Ib) * Q / ((Ib - Ia) * P)
        m1 = (Ic - Ia) * (-D) / ((Ib - Ia) * P)
        m, m1 = min(max(m, 0.0), 1.0), min(max(m1, 0.0), 1.0)
        phi0 = np.arctan2(y0s / B, z0s / C)
        tau0 = float(ellipf(phi0, m, m1))
        sn, cn, dn = ellipj(lam * t + tau0, m, m1)
        x, y, z = A * dn, B * sn, C * cn
    else:
        # separatrix M² = 2 E I_b: both x0 and z0 are nonzero here
        if z0 < 0.0:
            sig = sig * np.array([-1.0, 1.0, -1.0])
        if sig[0] * x0 < 0.0:
            sig = sig * np.array([-1.0, -1.0, 1.0])
        x0s, y0s = sig[0] * x0, sig[1] * y0
        A = np.sqrt(P / (Ia * (Ic - Ia)))
        B = np.sqrt(P / (Ib * (Ic - Ib)))
        C = np.sqrt(Q / (Ic * (Ic - Ia)))
        lam = np.sqrt((Ic - Ib) * Q / (Ia * Ib * Ic))
        tau0 = np.arcsinh((y0s / B) / (x0s / A))  # sinh τ0 = tanh τ0 / sech τ0
        tau = lam * t + tau0
        sech = _sech(tau)
        x, y, z = A * sech, B * np.tanh(tau), C * sech

    out[:, a] = sig[0] * x
    out[:, b] = par * sig[1] * y
    out[:, c_] = sig[2] * z
    return out


# ---------------------------------------------------------------------------------------------
# Exact check of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs


def body_rate_deviation(scene: "Scene", traj: "Trajectory") -> tuple[np.ndarray, float]:
    """The run's body-frame angular velocity minus ``omega_body`` at every sample, shape (n, 3)
    (rad/s), and the scale |omega0| (1 rad/s when omega0 = 0). Scene parameters I1, I2, I3 and
    omega0 (body frame); the body is the run's first."""
    p = scene.params
    R = rotations.matrix(traj.quat_WB[:, 0])
    w_B = np.einsum("tji,tj->ti", R, traj.w_WB_W[:, 0])
    exact = omega_body(traj.t, (p["I1"], p["I2"], p["I3"]), p["omega0"])
    return w_B - exact, float(np.linalg.norm(p["omega0"])) or 1.0


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """|w_B(t) - w_B_exact(t)| / |w0|, the body-frame angular velocity against the Jacobi
    elliptic solution (Euclidean norm per sample).

    ``exact_error`` takes the largest component instead (max |w_B,i - w_B_exact,i| / |w0|), so it
    is not the maximum of this series; each keeps the measure its study has always reported."""
    dev, scale = body_rate_deviation(scene, traj)
    return np.linalg.norm(dev, axis=-1) / scale


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """Max over samples and components of |w_B(t) - w_B_exact(t)| / |omega0| (relative): the
    body-frame angular velocity against the Jacobi-elliptic solution of Euler's equations.
    ``settings`` and ``run`` are unused (no extra runs)."""
    dev, scale = body_rate_deviation(scene, traj)
    err = float(np.max(np.abs(dev)))
    return err / scale, "rel", f"body-frame angular velocity vs Jacobi elliptic solution: {err:.2e} rad/s over |omega0|"
