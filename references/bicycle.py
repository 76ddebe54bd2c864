"""Whipple bicycle benchmark: the linearised roll and steer equations of upright straight running,
their eigenvalues, and the speeds that bound the self-stable range.

Source
------
J. P. Meijaard, J. M. Papadopoulos, A. Ruina and A. L. Schwab, "Linearized dynamics equations
for the balance and steer of a bicycle: a benchmark and review", Proc. R. Soc. A 463 (2007)
1955-1982, doi:10.1098/rspa.2007.1857: Table 1 (the benchmark's parameters), section 5 and
Appendix A (the coefficient matrices from the parameters), section 5 (the benchmark's matrices
printed to 14 decimals), Table 2 (eigenvalues at 0-10 m/s, the weave and capsize
speeds). This module is the yardstick the ``bicycle`` scene is judged by: each engine's
linearisation about upright straight running (an engine's ``linearization.linearize`` in the benchmark's
coordinates of ``harness/model/builders/bicycle.py``) against ``state_matrix``, its M^-1 K0,
M^-1 C1 and M^-1 K2 (``blocks``) against ``linearized``'s, and its own weave and capsize speeds
(``stability_crossings`` with ``matrix``) against Table 2 (``tests/engines/test_linearization.py``).

The system (SI units)
---------------------
The Whipple (Carvallo-Whipple) bicycle: four rigid bodies -- rear wheel R, rear frame with rider
B, front frame (handlebar and fork) H, front wheel F -- joined by three ideal hinges (rear axle,
steering axis, front axle); the wheels are axisymmetric knife edges rolling without slip on a
level plane; no friction, no rider control. Its configuration space has seven dimensions
(position and yaw of the rear contact, roll, pitch (fixed by the front contact), steer and the
two wheel angles) and its velocity space three (roll rate, steer rate, forward speed).

Frames and coordinates (the paper's): global frame at the rear wheel's contact point in the
upright reference configuration, x forward along the ground line, y to the right, z **down**;
every position below is in that frame at the upright configuration, every inertia about the
body's own centre of mass in that frame (m, kg m^2). Coordinates q = (phi, delta): roll phi of
the rear frame about the x axis (positive: leaning to the right) and steer angle delta of the
front frame relative to the rear frame about the steering axis (unit vector
(sin lambda, 0, cos lambda), pointing down; positive: steering to the right). The forward speed
v (m/s, of the rear contact) is a constant of the linearised motion. The equations are::

    M q'' + v C1 q' + (g K0 + v^2 K2) q = f,        f = (T_phi, T_delta) (N m; 0 here)

and in first-order form, for x = (phi, delta, phi', delta') (``state_matrix``)::

    x' = A x,   A = [[0, I], [-M^-1 (g K0 + v^2 K2), -v M^-1 C1]]            (1/s, 1/s^2)

Parameters (``BicycleParams``, Table 1): wheelbase w, trail c, steer axis tilt lambda (from the
vertical), gravity g; rear wheel radius rR, mass mR, moments (IRxx, IRyy) (IRzz = IRxx);
rear frame B: centre of mass (xB, zB), mass mB, inertia (IBxx, IBxz, IByy, IBzz);
front frame H: (xH, zH), mH, (IHxx, IHxz, IHyy, IHzz); front wheel F: rF, mF, (IFxx, IFyy)
(IFzz = IFxx). The wheel centres are at (0, -rR) and (w, -rF) in (x, z).

Appendix A, numbered (``derived``; every quantity a function of the parameters)
-------------------------------------------------------------------------------
1. Whole bicycle T: mT = mR + mB + mH + mF,
   xT = (xB mB + xH mH + w mF)/mT,  zT = (-rR mR + zB mB + zH mH - rF mF)/mT;
   about the rear contact: ITxx = IRxx + IBxx + IHxx + IFxx + mR rR^2 + mB zB^2 + mH zH^2 + mF rF^2,
   ITxz = IBxz + IHxz - mB xB zB - mH xH zH + mF w rF,
   ITzz = IRzz + IBzz + IHzz + IFzz + mB xB^2 + mH xH^2 + mF w^2.
2. Front assembly A = H + F: mA = mH + mF, xA = (xH mH + w mF)/mA, zA = (zH mH - rF mF)/mA;
   about its centre of mass: IAxx = IHxx + IFxx + mH (zH - zA)^2 + mF (rF + zA)^2,
   IAxz = IHxz - mH (xH - xA)(zH - zA) + mF (w - xA)(rF + zA),
   IAzz = IHzz + IFzz + mH (xH - xA)^2 + mF (w - xA)^2.
3. Steering axis: uA = (xA - w - c) cos(lambda) - zA sin(lambda), the distance of A's centre of
   mass ahead of the axis; A's moment about the axis and its products with the x and z axes
   through the rear contact:
   IAll = mA uA^2 + IAxx sin^2 + 2 IAxz sin cos + IAzz cos^2,
   IAlx = -mA uA zA + IAxx sin + IAxz cos,   IAlz = mA uA xA + IAxz sin + IAzz cos.
4. mu = (c/w) cos(lambda) (the yaw of the rear frame per steer angle at the front contact);
   gyrostatic coefficients SR = IRyy/rR, SF = IFyy/rF, ST = SR + SF; static moment
   SA = mA uA + mu mT xT.
5. M  = [[ITxx, IAlx + mu ITxz], [IAlx + mu ITxz, IAll + 2 mu IAlz + mu^2 ITzz]]          (kg m^2)
   K0 = [[mT zT, -SA], [-SA, -SA sin(lambda)]]                                              (kg m)
   K2 = [[0, (ST - mT zT) cos(lambda)/w], [0, (SA + SF sin(lambda)) cos(lambda)/w]]       (kg)
   C1 = [[0, mu ST + SF cos(lambda) + ITxz cos(lambda)/w - mu mT zT],
         [-(mu ST + SF cos(lambda)), IAlz cos(lambda)/w + mu (SA + ITzz cos(lambda)/w)]]  (kg m)

**Printed** (section 5, the benchmark): M = [[80.81722, 2.31941332208709], [2.31941332208709,
0.29784188199686]], C1 = [[0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]],
K0 = [[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]],
K2 = [[0, 76.59734589573222], [0, 2.65431523794604]]; Table 2: weave speed
v_w = 4.29238253634111 m/s, capsize speed v_c = 6.02426201538837 m/s, and the eigenvalues at
v = 0, 1, ..., 10 m/s. **Status:** correct -- the formulas above reproduce every printed
matrix entry to all its 14 printed decimals, the state matrix of SymPy's independent
Kane's-method derivation (``sympy/physics/mechanics/tests/test_kane3.py``) to 1e-13, the
eigenvalues of Table 2 to 1e-13 (relative) and the two speeds to 1e-14 m/s
(``tests/references/test_bicycle.py``). M is also checked there against the kinetic energy of
the four bodies from their 3-D velocities at v = 0, and g K0 against the Hessian of their
potential energy with the pitch solved from the front contact, for random parameter sets.

Stability (``weave_speed``, ``capsize_speed``)
----------------------------------------------
Above the bifurcation speed (0.684 m/s for the benchmark) the four eigenvalues are a complex
pair (weave) and two real ones (capsize, the smaller in magnitude; castering, large and
negative). The upright straight running is asymptotically stable where all real parts are
negative: v_w < v < v_c. The weave speed is where the weave pair crosses the imaginary axis
(a Hopf crossing, from unstable to stable on increasing speed), the capsize speed where the
capsize eigenvalue crosses zero (det(g K0 + v^2 K2) = 0, from stable to unstable). Both are
found by brentq on the largest real part of the eigenvalues (the spectral abscissa),
bracketed by a scan of the speed range, each crossing classified by whether the eigenvalue
that crosses is complex or real.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:  # pragma: no cover
    from harness.model.scene import Scene

import numpy as np
from scipy.optimize import brentq

__all__ = [
    "BicycleParams",
    "Derived",
    "derived",
    "linearized",
    "state_matrix",
    "eigenvalues",
    "spectral_abscissa",
    "blocks",
    "from_blocks",
    "Crossing",
    "stability_crossings",
    "weave_speed",
    "capsize_speed",
    "scaled",
]

SPEED_XTOL = 1e-13  # m/s, brentq's absolute tolerance on the weave and capsize speeds
SCAN_POINTS = 401  # speeds scanned for sign changes of the spectral abscissa


@dataclass(frozen=True)
class BicycleParams:
    """The benchmark's parameters (Table 1; defaults: the benchmark bicycle). SI units; the
    paper's global frame (x forward, y right, z down, origin at the rear contact, upright);
    inertias about each body's centre of mass in that frame. ``lam`` is the steer axis tilt
    lambda from the vertical (rad). The wheels' moments about their diameters serve as both xx
    and zz moments (IRzz = IRxx, IFzz = IFxx); IByy, IHyy do not enter the linearised equations."""

    w: float = 1.02  # m, wheelbase
    c: float = 0.08  # m, trail
    lam: float = math.pi / 10.0  # rad, steer axis tilt (pi/2 - head angle)
    g: float = 9.81  # m/s^2 (N/kg)
    # rear wheel R
    rR: float = 0.3  # m
    mR: float = 2.0  # kg
    IRxx: float = 0.0603  # kg m^2, about a diameter
    IRyy: float = 0.12  # kg m^2, about the axle
    # rear body and frame B (with the rider)
    xB: float = 0.3  # m
    zB: float = -0.9  # m (z down: 0.9 m above the ground)
    mB: float = 85.0  # kg
    IBxx: float = 9.2  # kg m^2
    IBxz: float = 2.4  # kg m^2
    IByy: float = 11.0  # kg m^2
    IBzz: float = 2.8  # kg m^2
    # front handlebar and fork assembly H
    xH: float = 0.9  # m
    zH: float = -0.7  # m
    mH: float = 4.0  # kg
    IHxx: float = 0.05892  # kg m^2
    IHxz: float = -0.00756  # kg m^2
    IHyy: float = 0.06  # kg m^2
    IHzz: float = 0.00708  # kg m^2
    # front wheel F
    rF: float = 0.35  # m
    mF: float = 3.0  # kg
    IFxx: float = 0.1405  # kg m^2, about a diameter
    IFyy: float = 0.28  # kg m^2, about the axle


@dataclass(frozen=True)
class Derived:
    """The intermediate quantities of Appendix A (module docstring, steps 1-4), SI units."""

    mT: float  # kg, whole bicycle
    xT: float  # m
    zT: float  # m
    ITxx: float  # kg m^2, about the rear contact
    ITxz: float
    ITzz: float
    mA: float  # kg, front assembly H + F
    xA: float  # m
    zA: float  # m
    IAxx: float  # kg m^2, about A's centre of mass
    IAxz: float
    IAzz: float
    uA: float  # m, A's centre of mass ahead of the steering axis
    IAll: float  # kg m^2, A about the steering axis
    IAlx: float  # kg m^2, A's lambda-x product (x axis through the rear contact)
    IAlz: float  # kg m^2, A's lambda-z product (z axis through the rear contact)
    mu: float  # 1, c cos(lambda)/w
    SR: float  # kg m, IRyy/rR
    SF: float  # kg m, IFyy/rF
    ST: float  # kg m
    SA: float  # kg m, mA uA + mu mT xT


def derived(p: BicycleParams) -> Derived:
    """Appendix A's intermediate quantities (module docstring, steps 1-4)."""
    sl, cl = math.sin(p.lam), math.cos(p.lam)
    IRzz, IFzz = p.IRxx, p.IFxx
    mT = p.mR + p.mB + p.mH + p.mF
    xT = (p.xB * p.mB + p.xH * p.mH + p.w * p.mF) / mT
    zT = (-p.rR * p.mR + p.zB * p.mB + p.zH * p.mH - p.rF * p.mF) / mT
    ITxx = (p.IRxx + p.IBxx + p.IHxx + p.IFxx + p.mR * p.rR**2 + p.mB * p.zB**2 + p.mH * p.zH**2
            + p.mF * p.rF**2)
    ITxz = p.IBxz + p.IHxz - p.mB * p.xB * p.zB - p.mH * p.xH * p.zH + p.mF * p.w * p.rF
    ITzz = IRzz + p.IBzz + p.IHzz + IFzz + p.mB * p.xB**2 + p.mH * p.xH**2 + p.mF * p.w**2
    mA = p.mH + p.mF
    xA = (p.xH * p.mH + p.w * p.mF) / mA
    zA = (p.zH * p.mH - p.rF * p.mF) / mA
    IAxx = p.IHxx + p.IFxx + p.mH * (p.zH - zA) ** 2 + p.mF * (p.rF + zA) ** 2
    IAxz = p.IHxz - p.mH * (p.xH - xA) * (p.zH - zA) + p.mF * (p.w - xA) * (p.rF + zA)
    IAzz = p.IHzz + IFzz + p.mH * (p.xH - xA) ** 2 + p.mF * (p.w - xA) ** 2
    uA = (xA - p.w - p.c) * cl - zA * sl
    IAll = mA * uA**2 + IAxx * sl**2 + 2.0 * IAxz * sl * cl + IAzz * cl**2
    IAlx = -mA * uA * zA + IAxx * sl + IAxz * cl
    IAlz = mA * uA * xA + IAxz * sl + IAzz * cl
    mu = p.c / p.w * cl
    SR = p.IRyy / p.rR
    SF = p.IFyy / p.rF
    ST = SR + SF
    SA = mA * uA + mu * mT * xT
    return Derived(mT, xT, zT, ITxx, ITxz, ITzz, mA, xA, zA, IAxx, IAxz, IAzz, uA, IAll, IAlx, IAlz,
                   mu, SR, SF, ST, SA)


def linearized(p: BicycleParams) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(M, C1, K0, K2)``, each 2x2 (rows and columns: roll phi, steer delta) of
    ``M q'' + v C1 q' + (g K0 + v^2 K2) q = 0`` (module docstring, step 5). Units: M kg m^2,
    C1 kg m (times v: N m s), K0 kg m (times g: N m), K2 kg (times v^2: N m)."""
    d = derived(p)
    sl, cl = math.sin(p.lam), math.cos(p.lam)
    mu = d.mu
    Mpd = d.IAlx + mu * d.ITxz
    M = np.array([[d.ITxx, Mpd], [Mpd, d.IAll + 2.0 * mu * d.IAlz + mu**2 * d.ITzz]])
    K0 = np.array([[d.mT * d.zT, -d.SA], [-d.SA, -d.SA * sl]])
    K2 = np.array([[0.0, (d.ST - d.mT * d.zT) / p.w * cl], [0.0, (d.SA + d.SF * sl) / p.w * cl]])
    C1 = np.array([[0.0, mu * d.ST + d.SF * cl + d.ITxz / p.w * cl - mu * d.mT * d.zT],
                   [-(mu * d.ST + d.SF * cl), d.IAlz / p.w * cl + mu * (d.SA + d.ITzz / p.w * cl)]])
    return M, C1, K0, K2


def state_matrix(p: BicycleParams, v: float) -> np.ndarray:
    """A (4x4) of ``d/dt (phi, delta, phi', delta') = A (phi, delta, phi', delta')`` at forward
    speed ``v`` (m/s): ``[[0, I], [-M^-1 (g K0 + v^2 K2), -v M^-1 C1]]``."""
    M, C1, K0, K2 = linearized(p)
    A = np.zeros((4, 4))
    A[:2, 2:] = np.eye(2)
    A[2:, :2] = -np.linalg.solve(M, p.g * K0 + v * v * K2)
    A[2:, 2:] = -np.linalg.solve(M, v * C1)
    return A


def eigenvalues(p: BicycleParams, v: float) -> np.ndarray:
    """The four eigenvalues (1/s, complex) of ``state_matrix(p, v)``, sorted by real part, then
    imaginary part (``np.sort_complex``)."""
    return np.sort_complex(np.linalg.eigvals(state_matrix(p, v)).astype(complex))


def spectral_abscissa(p: BicycleParams, v: float, matrix: Callable[[float], np.ndarray] | None = None) -> float:
    """The largest real part of the eigenvalues at speed ``v`` (1/s): negative iff upright
    straight running at ``v`` is asymptotically stable. ``matrix``: the state matrix as a
    function of the speed (default ``state_matrix(p, .)``; e.g. an engine's linearisation,
    ``linearization.linearize``)."""
    A = state_matrix(p, v) if matrix is None else np.asarray(matrix(v), dtype=float)
    return float(np.max(np.linalg.eigvals(A).real))


def blocks(A0: np.ndarray, Av: np.ndarray, v: float, g: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(M^-1 K0, M^-1 C1, M^-1 K2)`` (2x2 each; 1/m, 1/m, 1/m^2) from two state matrices of
    the benchmark form (module docstring): ``A0`` at speed 0 and ``Av`` at speed ``v`` != 0
    (m/s), gravity ``g`` (m/s^2)::

        M^-1 K0 = -A0[2:, :2] / g,   M^-1 K2 = -(Av[2:, :2] + g M^-1 K0) / v^2,
        M^-1 C1 = -Av[2:, 2:] / v

    The inverse of ``from_blocks``; what an engine's linearisations at two speeds give of the
    benchmark's coefficients (M itself needs a force: the linearisation sees only M^-1 times
    them)."""
    if v == 0.0 or g == 0.0:
        raise ValueError("blocks: the speed v and gravity g must be nonzero")
    MK0 = -np.asarray(A0, float)[2:, :2] / g
    MK2 = -(np.asarray(Av, float)[2:, :2] + g * MK0) / (v * v)
    MC1 = -np.asarray(Av, float)[2:, 2:] / v
    return MK0, MC1, MK2


def from_blocks(MK0: np.ndarray, MC1: np.ndarray, MK2: np.ndarray, v: float, g: float) -> np.ndarray:
    """The state matrix (4x4) at speed ``v`` (m/s) and gravity ``g`` (m/s^2) from
    ``(M^-1 K0, M^-1 C1, M^-1 K2)``: ``[[0, I], [-(g M^-1 K0 + v^2 M^-1 K2), -v M^-1 C1]]``."""
    A = np.zeros((4, 4))
    A[:2, 2:] = np.eye(2)
    A[2:, :2] = -(g * np.asarray(MK0, float) + v * v * np.asarray(MK2, float))
    A[2:, 2:] = -v * np.asarray(MC1, float)
    return A


@dataclass(frozen=True)
class Crossing:
    """A speed at which the spectral abscissa changes sign: ``speed`` (m/s), ``stabilising``
    (True: unstable below, stable above), ``oscillatory`` (True: a complex pair crosses -- a
    Hopf crossing, |Im| = ``frequency`` (rad/s); False: a real eigenvalue crosses zero)."""

    speed: float
    stabilising: bool
    oscillatory: bool
    frequency: float


def stability_crossings(p: BicycleParams, v_max: float = 10.0, v_min: float = 0.0,
                        n: int = SCAN_POINTS, matrix: Callable[[float], np.ndarray] | None = None) -> list[Crossing]:
    """Every sign change of the spectral abscissa on [v_min, v_max] (m/s), in increasing speed:
    a scan of ``n`` speeds brackets each, brentq (xtol 1e-13 m/s) finds it, and the
    eigenvalue of largest real part there classifies it (module docstring, Stability). A
    crossing between two scanned speeds that cross back before the next is missed; the
    benchmark's crossings are 1.7 m/s apart at the default scan (0.025 m/s). ``matrix``: the
    state matrix as a function of the speed (default ``state_matrix(p, .)``), e.g. an engine's
    linearisation: its own crossings."""
    def A(v):
        return state_matrix(p, v) if matrix is None else np.asarray(matrix(v), dtype=float)

    speeds = np.linspace(v_min, v_max, n)
    alpha = np.array([spectral_abscissa(p, v, matrix) for v in speeds])
    out = []
    for k in range(n - 1):
        a, b = alpha[k], alpha[k + 1]
        if a == 0.0 and k > 0:
            continue  # counted as the right end of the previous interval
        if a * b > 0.0 or (a == 0.0 and b == 0.0):
            continue
        if b == 0.0:
            v = float(speeds[k + 1])
        elif a == 0.0:
            v = float(speeds[k])
        else:
            v = brentq(lambda s: spectral_abscissa(p, s, matrix), speeds[k], speeds[k + 1], xtol=SPEED_XTOL,
                       rtol=4.0 * np.finfo(float).eps)
        lam = np.linalg.eigvals(A(v))
        top = lam[np.argmax(lam.real)]
        scale = max(1.0, float(np.max(np.abs(lam))))
        out.append(Crossing(float(v), bool(b < a), bool(abs(top.imag) > 1e-9 * scale), float(abs(top.imag))))
    return out


def weave_speed(p: BicycleParams, v_max: float = 10.0, *, crossings: list[Crossing] | None = None) -> float:
    """v_w (m/s): the lowest speed in (0, v_max] at which the weave pair's real parts turn
    negative on increasing speed (a stabilising Hopf crossing). ValueError when there is none.
    ``crossings``: those to read it from (default ``stability_crossings(p, v_max)``; pass an
    engine's, ``stability_crossings(..., matrix=...)``)."""
    for x in stability_crossings(p, v_max) if crossings is None else crossings:
        if x.oscillatory and x.stabilising:
            return x.speed
    raise ValueError(f"no stabilising weave crossing below {v_max:g} m/s")


def capsize_speed(p: BicycleParams, v_max: float = 10.0, *, crossings: list[Crossing] | None = None) -> float:
    """v_c (m/s): the lowest speed above the weave speed, up to v_max, at which a real
    eigenvalue (capsize) turns positive (a destabilising crossing through zero). ValueError when
    there is none. ``crossings`` as ``weave_speed``."""
    crossings = stability_crossings(p, v_max) if crossings is None else crossings
    v_w = weave_speed(p, v_max, crossings=crossings)
    for x in crossings:
        if x.speed > v_w and not x.oscillatory and not x.stabilising:
            return x.speed
    raise ValueError(f"no capsize crossing between the weave speed {v_w:.6g} and {v_max:g} m/s")


def scaled(p: BicycleParams, *, mass: float = 1.0, length: float = 1.0, g: float | None = None) -> BicycleParams:
    """The bicycle with every mass times ``mass``, every length times ``length`` and every
    moment of inertia times ``mass length^2`` (angles unchanged), and gravity ``g`` (m/s^2; None:
    unchanged)."""
    lengths = {"w", "c", "rR", "xB", "zB", "xH", "zH", "rF"}
    masses = {"mR", "mB", "mH", "mF"}
    out = {}
    for f in fields(p):
        value = getattr(p, f.name)
        if f.name in lengths:
            value = value * length
        elif f.name in masses:
            value = value * mass
        elif f.name.startswith("I"):
            value = value * mass * length**2
        out[f.name] = value
    if g is not None:
        out["g"] = g
    return replace(p, **out)


#: The scene as the benchmark report states it (``harness benchmark``): what is published and the
#: required accuracy of a run (a state error relative to the scene's scales). The benchmark's own
#: figures are its linearisation's: ``linearization_agreement`` judges an engine's against them.
BENCHMARK = {
    "problem": "Whipple bicycle",
    "title": "the benchmark bicycle of Meijaard, Papadopoulos, Ruina & Schwab 2007",
    "published": "M, C1, K0, K2 to 14 digits (Appendix A's formulas of Table 1's parameters), the eigenvalues "
                 "against speed (Table 2), the weave speed 4.29238253634111 m/s and the capsize speed "
                 "6.02426201538837 m/s; an engine's own linearisation about upright straight running is judged "
                 "against them",
    "required": 1e-3,
}

#: The speed (m/s) besides 0 at which an engine's linearisation gives its coefficients (``blocks``).
BLOCK_SPEED = 5.0


def params_of(params) -> BicycleParams:
    """The benchmark's parameters from a mapping that names them as ``BicycleParams`` does (a
    scene's parameter values; other keys ignored)."""
    from dataclasses import fields

    return BicycleParams(**{f.name: float(params[f.name]) for f in fields(BicycleParams)})


def linearization_agreement(scene: "Scene", matrix: Callable[[float], np.ndarray]) -> dict:
    """An engine's linearisation against the benchmark's at the scene's parameters
    (``params_of(scene.params)``): ``matrix(v)`` is its state matrix (4x4)
    about upright straight running at speed v (m/s). Returns ``error``, the largest relative error
    over the nonzero entries of M^-1 K0, M^-1 C1 and M^-1 K2 from its matrices at 0 and
    ``BLOCK_SPEED`` (``blocks``) against ``linearized(p)``'s, and ``digits`` = -log10(error);
    ``weave`` and ``capsize``, its own speeds (m/s, root finding on its spectral abscissa between
    3 and 7 m/s), and ``speed_error``, their largest distance from the benchmark's (m/s)."""
    p = params_of(scene.params)
    M, C1, K0, K2 = linearized(p)
    got = blocks(matrix(0.0), matrix(BLOCK_SPEED), BLOCK_SPEED, p.g)
    worst = 0.0
    for mine, ref in zip(got, (np.linalg.solve(M, K0), np.linalg.solve(M, C1), np.linalg.solve(M, K2))):
        nonzero = np.abs(ref) > 1e-12 * np.abs(ref).max()
        worst = max(worst, float(np.max(np.abs(mine[nonzero] - ref[nonzero]) / np.abs(ref[nonzero]))))
    crossings = stability_crossings(p, v_max=7.0, v_min=3.0, n=9, matrix=matrix)
    weave, capsize = weave_speed(p, crossings=crossings), capsize_speed(p, crossings=crossings)
    speed_error = max(abs(weave - weave_speed(p)), abs(capsize - capsize_speed(p)))
    return {"error": worst, "digits": float("inf") if worst == 0.0 else -float(np.log10(worst)),
            "weave": weave, "capsize": capsize, "speed_error": speed_error}


def published_eigenvalues(scene: "Scene", speeds) -> np.ndarray:
    """The benchmark's eigenvalues (1/s, complex, ``eigenvalues``) at each of ``speeds`` (m/s), at
    the scene's parameters: shape (len(speeds), 4), as Table 2 prints them for the benchmark's."""
    p = params_of(scene.params)
    return np.array([eigenvalues(p, float(v)) for v in speeds])
