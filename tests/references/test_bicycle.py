"""harness.references.bicycle (the Whipple bicycle benchmark, Meijaard et al. 2007) against the
published numbers and against independent derivations written here.

The published numbers are the yardstick; the module computes them from Table 1's parameters
by Appendix A's formulas. Where each number was read and checked:

* Table 1 (the parameters): the paper; BicycleParameters' data file
  ``data/bicycles/Benchmark/Parameters/BenchmarkBenchmark.txt`` and test
  ``bicycleparameters/tests/test_models.py`` (github.com/moorepants/BicycleParameters).
* M, C1, K0, K2 (section 5, 14 decimals): BicycleParameters' ``benchmark_matrices`` (moorepants),
  and three other public transcriptions that agree digit for digit (the NLEVP "bicycle"
  problem, two simulators' parameter files).
* Table 2 (eigenvalues at 0-10 m/s, the bifurcation, weave and capsize speeds): transcribed
  "as written in that paper" in github.com/hazelnusse/OBD,
  ``whipple/tests/whipple-eigs-unittest.cpp`` (D. L. Peterson); at 0, 4, 5 and 10 m/s also a
  second, independent transcription. Where the OBD file pads a castering eigenvalue with a
  trailing 0 (3-6 m/s: -12.15861426576450, -14.07838969279820) the other gives
  -12.15861426576447, -14.07838969279822; the tolerance below (1e-13 relative) admits both.
* The state matrix at 0-5 m/s from an independent derivation: SymPy's Kane's-method model of
  the benchmark, ``sympy/physics/mechanics/tests/test_kane3.py`` (its precomputed ``Res``,
  15 significant digits).

Independent derivations here: M as the Hessian of the four bodies' kinetic energy at v = 0
(3-D rigid-body kinematics, the constraint-consistent velocities solved from the contacts), K0
as the Hessian of their potential energy with the pitch solved from the front contact (finite
differences), the capsize speed in closed form (det(g K0 + v^2 K2) = 0), the weave speed from
the Hurwitz determinant of the characteristic quartic (no eigenvalue solver), and the scaling
laws of the parameters.
"""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import pytest
from scipy.optimize import brentq

from harness.references import bicycle as bc

P = bc.BicycleParams()

# Table 1 (BicycleParameters' BenchmarkBenchmark.txt; lam = 0.314159265358979323846 there)
TABLE_1 = dict(w=1.02, c=0.08, lam=math.pi / 10, g=9.81, rR=0.3, mR=2.0, IRxx=0.0603, IRyy=0.12,
               xB=0.3, zB=-0.9, mB=85.0, IBxx=9.2, IBxz=2.4, IByy=11.0, IBzz=2.8,
               xH=0.9, zH=-0.7, mH=4.0, IHxx=0.05892, IHxz=-0.00756, IHyy=0.06, IHzz=0.00708,
               rF=0.35, mF=3.0, IFxx=0.1405, IFyy=0.28)

PUBLISHED = {  # section 5 of the paper, 14 decimals
    "M": [[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]],
    "C1": [[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]],
    "K0": [[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]],
    "K2": [[0.0, 76.59734589573222], [0.0, 2.65431523794604]],
}
WEAVE_SPEED = 4.29238253634111  # m/s, Table 2(a)
CAPSIZE_SPEED = 6.02426201538837  # m/s, Table 2(a)
WEAVE_FREQUENCY = 3.43503384866144  # rad/s, |Im| of the weave pair at the weave speed, Table 2(a)
BIFURCATION_SPEED = 0.68428307889246  # m/s, two real eigenvalues meet (Table 2(a))
BIFURCATION_EIGENVALUE = 3.78290405129320  # 1/s, the double eigenvalue there

# Table 2(b, c): the eigenvalues at v = 0, 1, ..., 10 m/s
TABLE_2 = {
    0: [-5.53094371765393, -3.13164324790656, 3.13164324790656, 5.53094371765393],
    1: [-7.11008014637442, -3.13423125066578, 3.52696170990070 - 0.80774027519930j, 3.52696170990070 + 0.80774027519930j],
    2: [-8.67387984831735, -3.07158645641514, 2.68234517512745 - 1.68066296590675j, 2.68234517512745 + 1.68066296590675j],
    3: [-10.35101467245920, -2.63366137253667, 1.70675605663975 - 2.31582447384325j, 1.70675605663975 + 2.31582447384325j],
    4: [-12.15861426576447, -1.42944427361326, 0.41325331521125 - 3.07910818603206j, 0.41325331521125 + 3.07910818603206j],
    5: [-14.07838969279822, -0.32286642900409, -0.77534188219585 - 4.46486771378823j, -0.77534188219585 + 4.46486771378823j],
    6: [-16.08537123098030, -0.00406690076970, -1.52644486584142 - 5.87673060598709j, -1.52644486584142 + 5.87673060598709j],
    7: [-18.15788466125262, 0.10268170574766, -2.13875644258362 - 7.19525913329805j, -2.13875644258362 + 7.19525913329805j],
    8: [-20.27940894394569, 0.14327879765713, -2.69348683581097 - 8.46037971396931j, -2.69348683581097 + 8.46037971396931j],
    9: [-22.43788559040858, 0.15790184030917, -3.21675402252485 - 9.69377351531791j, -3.21675402252485 + 9.69377351531791j],
    10: [-24.62459635017404, 0.16105338653172, -3.72016840437287 - 10.90681139476287j, -3.72016840437287 + 10.90681139476287j],
}


def _sympy_kane_state_matrix(v: float) -> np.ndarray:
    """SymPy's test_kane3.py ``Res``: the state matrix of (roll, steer, roll rate, steer rate)
    from its Kane's-method model of the benchmark (g = 9.81), 15 significant digits."""
    return np.array([[0, 0, 1.0, 0], [0, 0, 0, 1.0],
                     [9.48977444677355, -0.891197738059089 * v**2 - 0.571523173729245, -0.105522449805691 * v,
                      -0.330515398992311 * v],
                     [11.7194768719633, -1.97171508499972 * v**2 + 30.9087533932407, 3.67680523332152 * v,
                      -3.08486552743311 * v]])


def _random_bicycles(n: int, seed: int) -> list[bc.BicycleParams]:
    """Seeded bicycles: every parameter of the benchmark times a factor in [0.7, 1.3], the
    steer axis tilt in [0.05, 0.6] rad (the identities tested hold for any values)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        values = {f.name: getattr(P, f.name) * rng.uniform(0.7, 1.3) for f in fields(P)}
        values["lam"] = rng.uniform(0.05, 0.6)
        out.append(bc.BicycleParams(**values))
    return out


RANDOM = _random_bicycles(6, seed=2007)


def _self_stable(p: bc.BicycleParams) -> bool:
    try:
        bc.capsize_speed(p, v_max=20.0)
    except ValueError:
        return False
    return True


STABLE = [p for p in RANDOM if _self_stable(p)]  # 4 of the 6 have a self-stable range below 20 m/s


# ---------------------------------------------------------------------------------------------
# The published benchmark
# ---------------------------------------------------------------------------------------------
def test_the_defaults_are_table_1():
    assert {f.name: getattr(P, f.name) for f in fields(P)} == TABLE_1


def test_matrices_reproduce_every_printed_digit():
    """Each entry within half a unit of the 14th decimal printed (plus 4 ulp): 14-16
    significant digits; the zeros exactly."""
    for name, X in zip(("M", "C1", "K0", "K2"), bc.linearized(P)):
        want = np.array(PUBLISHED[name])
        assert X.shape == (2, 2)
        err = np.abs(X - want)
        assert np.all(err <= 0.5e-14 + 4 * np.spacing(np.abs(want))), f"{name}: {X.tolist()} vs {want.tolist()}"
        assert np.all(X[want == 0.0] == 0.0)


def test_state_matrix_matches_sympys_kane_derivation():
    """SymPy's Kane's-method model (an independent derivation): the state matrix at 0-5 m/s to
    1e-12 absolute (its own tolerance), and its three speed coefficients to 1e-13 relative."""
    for v in range(6):
        assert np.max(np.abs(bc.state_matrix(P, float(v)) - _sympy_kane_state_matrix(v))) < 1e-12
    M, C1, K0, K2 = bc.linearized(P)
    A0 = _sympy_kane_state_matrix(0.0)[2:]
    A1 = _sympy_kane_state_matrix(1.0)[2:] - A0  # v and v^2 terms at v = 1
    np.testing.assert_allclose(-np.linalg.solve(M, P.g * K0), A0[:, :2], rtol=1e-13)
    np.testing.assert_allclose(-np.linalg.solve(M, K2)[:, 1], A1[:, 1], rtol=1e-13)
    np.testing.assert_allclose(-np.linalg.solve(M, C1), A1[:, 2:], rtol=1e-13)


def _close_sets(got: np.ndarray, want, rtol: float) -> bool:
    """Every eigenvalue of ``want`` has one of ``got`` within rtol max(1, |lambda|), one to one."""
    got = list(got)
    for w in want:
        k = int(np.argmin([abs(g - w) for g in got]))
        if abs(got[k] - w) > rtol * max(1.0, abs(w)):
            return False
        got.pop(k)
    return True


@pytest.mark.parametrize("v", sorted(TABLE_2))
def test_eigenvalues_of_table_2(v):
    lam = bc.eigenvalues(P, float(v))
    assert lam.shape == (4,)
    assert _close_sets(lam, TABLE_2[v], 1e-13), f"v = {v}: {lam} vs {TABLE_2[v]}"
    assert np.all(np.diff(lam.real) >= 0.0)


def test_weave_and_capsize_speeds_are_table_2():
    v_w, v_c = bc.weave_speed(P), bc.capsize_speed(P)
    assert abs(v_w - WEAVE_SPEED) < 1e-13 and abs(v_c - CAPSIZE_SPEED) < 1e-13
    at_weave = bc.eigenvalues(P, v_w)
    pair = at_weave[np.abs(at_weave.imag) > 0]
    assert np.allclose(np.abs(pair.imag), WEAVE_FREQUENCY, rtol=1e-13, atol=0.0)
    assert np.max(np.abs(pair.real)) < 1e-13
    assert np.min(np.abs(bc.eigenvalues(P, v_c))) < 1e-13  # the capsize eigenvalue is 0 there


def test_the_bifurcation_of_table_2a():
    """At 0.68428307889246 m/s two real eigenvalues meet at 3.78290405129320 1/s; a double root
    moves as the square root of a perturbation, so the computed pair agrees to ~1e-7 only."""
    lam = bc.eigenvalues(P, BIFURCATION_SPEED)
    pair = lam[np.argsort(np.abs(lam - BIFURCATION_EIGENVALUE))[:2]]
    assert np.all(np.abs(pair - BIFURCATION_EIGENVALUE) < 1e-6)
    below, above = bc.eigenvalues(P, BIFURCATION_SPEED - 1e-3), bc.eigenvalues(P, BIFURCATION_SPEED + 1e-3)
    assert np.all(below.imag == 0.0) and np.sum(above.imag != 0.0) == 2


# ---------------------------------------------------------------------------------------------
# The speeds by independent routes, and the self-stable range
# ---------------------------------------------------------------------------------------------
def _capsize_closed_form(p: bc.BicycleParams) -> float:
    """det(g K0 + v^2 K2) = 0 (a zero eigenvalue), linear in v^2 since K2's first column is 0."""
    _, _, K0, K2 = bc.linearized(p)
    return math.sqrt(-p.g * np.linalg.det(K0) / (K0[0, 0] * K2[1, 1] - K0[1, 0] * K2[0, 1]))


def _quartic(p: bc.BicycleParams, v: float) -> np.ndarray:
    """(a4, a3, a2, a1, a0) of det(M s^2 + v C1 s + g K0 + v^2 K2), expanded by hand."""
    M, C1, K0, K2 = bc.linearized(p)
    C, K = v * C1, p.g * K0 + v * v * K2

    def mixed(X, Y):  # the s-free coefficient of det(X + Y) - det(X) - det(Y)
        return X[0, 0] * Y[1, 1] + Y[0, 0] * X[1, 1] - X[0, 1] * Y[1, 0] - Y[0, 1] * X[1, 0]

    return np.array([np.linalg.det(M), mixed(M, C), np.linalg.det(C) + mixed(M, K), mixed(C, K), np.linalg.det(K)])


def _hurwitz_3(p: bc.BicycleParams, v: float) -> float:
    """The third Hurwitz determinant a1 (a3 a2 - a4 a1) - a3^2 a0: zero where a complex pair
    crosses the imaginary axis (at s = +-i sqrt(a1/a3))."""
    a4, a3, a2, a1, a0 = _quartic(p, v)
    return a1 * (a3 * a2 - a4 * a1) - a3 * a3 * a0


def test_random_bicycles_include_self_stable_ones():
    assert len(STABLE) >= 3


@pytest.mark.parametrize("p", [P] + STABLE, ids=["benchmark"] + [f"stable{i}" for i in range(len(STABLE))])
def test_speeds_by_independent_routes(p):
    """Capsize: the closed form; weave: brentq on the Hurwitz determinant (no eigenvalues)."""
    v_w, v_c = bc.weave_speed(p, v_max=20.0), bc.capsize_speed(p, v_max=20.0)
    assert v_w < v_c
    assert abs(v_c - _capsize_closed_form(p)) < 1e-12
    hopf = brentq(lambda v: _hurwitz_3(p, v), v_w - 0.05, v_w + 0.05, xtol=1e-14)
    assert abs(v_w - hopf) < 1e-10
    a4, a3, a2, a1, a0 = _quartic(p, v_w)
    at_weave = bc.eigenvalues(p, v_w)
    assert np.max(np.abs(at_weave.imag)) == pytest.approx(math.sqrt(a1 / a3), rel=1e-12)
    if p is P:
        assert abs(math.sqrt(a1 / a3) - WEAVE_FREQUENCY) < 1e-13


def test_the_self_stable_range():
    v_w, v_c = bc.weave_speed(P), bc.capsize_speed(P)
    crossings = bc.stability_crossings(P)
    assert [(x.stabilising, x.oscillatory) for x in crossings] == [(True, True), (False, False)]
    assert [x.speed for x in crossings] == [v_w, v_c]
    inside = np.linspace(v_w + 1e-6, v_c - 1e-6, 200)
    assert all(bc.spectral_abscissa(P, v) < 0.0 for v in inside)
    assert bc.spectral_abscissa(P, v_w - 1e-6) > 0.0 and bc.spectral_abscissa(P, v_c + 1e-6) > 0.0
    assert all(bc.spectral_abscissa(P, v) > 0.0 for v in np.linspace(0.0, v_w - 1e-3, 50))
    assert all(bc.spectral_abscissa(P, v) > 0.0 for v in np.linspace(v_c + 1e-3, 10.0, 50))


def test_no_self_stable_range_is_refused():
    """Without trail and wheel spin inertia the bicycle is never self-stable (a bicycle needs
    neither for it, but this one has no weave crossing below 10 m/s)."""
    p = replace(P, c=0.0, IRyy=0.0, IFyy=0.0)
    assert all(bc.spectral_abscissa(p, v) > 0.0 for v in np.linspace(0.0, 10.0, 41))
    with pytest.raises(ValueError, match="no stabilising weave crossing"):
        bc.weave_speed(p)


# ---------------------------------------------------------------------------------------------
# The matrices as functions of the parameters
# ---------------------------------------------------------------------------------------------
E_X, E_Y, E_Z = np.eye(3)


def _inertia(p: bc.BicycleParams) -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """Per body: mass (kg), centre of mass (m) and inertia tensor about it (kg m^2), the paper's
    global frame (z down) at the upright configuration; the wheels' moments about a diameter
    serve as xx and zz."""
    return {
        "R": (p.mR, np.array([0.0, 0.0, -p.rR]), np.diag([p.IRxx, p.IRyy, p.IRxx])),
        "B": (p.mB, np.array([p.xB, 0.0, p.zB]), np.array([[p.IBxx, 0.0, p.IBxz], [0.0, p.IByy, 0.0], [p.IBxz, 0.0, p.IBzz]])),
        "H": (p.mH, np.array([p.xH, 0.0, p.zH]), np.array([[p.IHxx, 0.0, p.IHxz], [0.0, p.IHyy, 0.0], [p.IHxz, 0.0, p.IHzz]])),
        "F": (p.mF, np.array([p.w, 0.0, -p.rF]), np.diag([p.IFxx, p.IFyy, p.IFxx])),
    }


def _velocities(p: bc.BicycleParams, droll: float, dsteer: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per body (velocity of its centre of mass, angular velocity) at forward speed 0 with roll
    rate ``droll`` and steer rate ``dsteer``, upright: the rear frame's origin velocity u, yaw
    and pitch rates and the two wheel spins solved from rolling without slip at both contacts
    (material points at rest) and zero forward speed (rear wheel not spinning)."""
    lam_hat = np.array([math.sin(p.lam), 0.0, math.cos(p.lam)])  # steering axis, down
    S = np.array([p.w + p.c, 0.0, 0.0])  # where it meets the ground
    cR, cF, contact_F = np.array([0.0, 0.0, -p.rR]), np.array([p.w, 0.0, -p.rF]), np.array([p.w, 0.0, 0.0])

    def kinematics(z):  # z = (u (3), yaw rate, pitch rate, rear spin, front spin)
        u, dyaw, dpitch, sR, sF = z[:3], z[3], z[4], z[5], z[6]
        wB = droll * E_X + dpitch * E_Y + dyaw * E_Z
        wR, wH = wB + sR * E_Y, wB + dsteer * lam_hat
        wF = wH + sF * E_Y

        def rear(r):
            return u + np.cross(wB, r)

        def front(r):
            return u + np.cross(wB, r) + dsteer * np.cross(lam_hat, r - S)

        slip_R = rear(cR) + np.cross(wR, -cR)
        slip_F = front(cF) + np.cross(wF, contact_F - cF)
        return np.concatenate([slip_R, slip_F, [sR]]), (rear, front, wB, wR, wH, wF)

    z0 = np.zeros(7)
    r0, _ = kinematics(z0)
    Jz = np.stack([kinematics(e)[0] - r0 for e in np.eye(7)], axis=1)  # affine in z
    z = np.linalg.solve(Jz, -r0)
    assert np.max(np.abs(kinematics(z)[0])) < 1e-12
    _, (rear, front, wB, wR, wH, wF) = kinematics(z)
    body = _inertia(p)
    return {"R": (rear(body["R"][1]), wR), "B": (rear(body["B"][1]), wB),
            "H": (front(body["H"][1]), wH), "F": (front(body["F"][1]), wF)}


def _kinetic_energy_mass_matrix(p: bc.BicycleParams) -> np.ndarray:
    """M from T = 1/2 sum (m |v|^2 + w.I w) = 1/2 qd.M qd: T is quadratic in (roll rate, steer
    rate), so M = [[2 T(e1), T(e1+e2) - T(e1) - T(e2)], [., 2 T(e2)]]."""
    body = _inertia(p)

    def T(dr, ds):
        vel = _velocities(p, dr, ds)
        return 0.5 * sum(m * vel[k][0] @ vel[k][0] + vel[k][1] @ I @ vel[k][1] for k, (m, _, I) in body.items())

    t1, t2, t12 = T(1.0, 0.0), T(0.0, 1.0), T(1.0, 1.0)
    off = t12 - t1 - t2
    return np.array([[2 * t1, off], [off, 2 * t2]])


@pytest.mark.parametrize("p", [P] + RANDOM, ids=["benchmark"] + [f"random{i}" for i in range(len(RANDOM))])
def test_mass_matrix_is_the_kinetic_energy(p):
    M = bc.linearized(p)[0]
    np.testing.assert_allclose(M, _kinetic_energy_mass_matrix(p), rtol=1e-12, atol=1e-12 * abs(M[0, 0]))


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    a = axis / np.linalg.norm(axis)
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _potential(p: bc.BicycleParams, roll: float, steer: float) -> float:
    """V = -g sum m z (J; z down) at (roll, steer), the rear contact at the origin, the pitch of
    the rear frame solved (Newton) so that the front wheel touches the ground."""
    lam_hat = np.array([math.sin(p.lam), 0.0, math.cos(p.lam)])
    S0 = np.array([p.w + p.c, 0.0, 0.0])
    body = _inertia(p)
    cR0 = body["R"][1]

    def place(pitch):
        RB = _rotation(E_X, roll) @ _rotation(E_Y, pitch)
        nR = RB @ E_Y  # rear axle
        up = -E_Z + (E_Z @ nR) * nR
        cR = p.rR * up / np.linalg.norm(up)  # rear wheel centre above the contact at the origin
        RH = RB @ _rotation(lam_hat, steer)  # front frame (the steering axis is fixed in B)
        S = cR + RB @ (S0 - cR0)

        def in_B(r):
            return cR + RB @ (r - cR0)

        def in_H(r):
            return S + RH @ (r - S0)

        cF = in_H(body["F"][1])
        nF = RH @ E_Y
        down = E_Z - (E_Z @ nF) * nF
        contact_z = (cF + p.rF * down / np.linalg.norm(down))[2]
        return contact_z, {"R": cR, "B": in_B(body["B"][1]), "H": in_H(body["H"][1]), "F": cF}

    pitch = 0.0
    for _ in range(50):
        z, _ = place(pitch)
        dz = (place(pitch + 1e-7)[0] - place(pitch - 1e-7)[0]) / 2e-7
        step = z / dz
        pitch -= step
        if abs(step) < 1e-17:
            break
    z, centres = place(pitch)
    assert abs(z) < 1e-15
    return -p.g * sum(body[k][0] * centres[k][2] for k in body)


def _potential_hessian(p: bc.BicycleParams) -> np.ndarray:
    """Central second differences at h and h/2, Richardson-extrapolated (error ~ h^4)."""

    def hess(h):
        V = lambda a, b: _potential(p, a * h, b * h)  # noqa: E731
        V0 = V(0, 0)
        H = np.zeros((2, 2))
        H[0, 0] = (V(1, 0) - 2 * V0 + V(-1, 0)) / h**2
        H[1, 1] = (V(0, 1) - 2 * V0 + V(0, -1)) / h**2
        H[0, 1] = H[1, 0] = (V(1, 1) - V(1, -1) - V(-1, 1) + V(-1, -1)) / (4 * h * h)
        return H

    h = 2e-2
    return (4 * hess(h / 2) - hess(h)) / 3


@pytest.mark.parametrize("p", [P] + RANDOM[:3], ids=["benchmark"] + [f"random{i}" for i in range(3)])
def test_gravity_stiffness_is_the_potential_energy(p):
    """g K0 is the Hessian of the potential energy on the constraint surface (pitch from the
    front contact); the finite differences agree to ~1e-10 of the largest entry (measured
    2e-10 to 1.2e-9 on these bicycles)."""
    K0 = bc.linearized(p)[2]
    H = _potential_hessian(p)
    assert np.max(np.abs(p.g * K0 - H)) < 1e-8 * np.max(np.abs(p.g * K0))


def test_matrices_scale_with_mass_length_and_gravity():
    """Every mass and inertia times k: all four matrices times k, the eigenvalues and the two
    speeds unchanged. Lengths times L (inertias times L^2): M ~ L^2, C1 ~ L, K0 ~ L, K2 ~ L^0, so
    the eigenvalues at speed sqrt(L) v are those at v over sqrt(L) and the speeds scale as
    sqrt(L). Gravity times a: the speeds scale as sqrt(a)."""
    base = bc.linearized(P)
    heavy = bc.scaled(P, mass=3.7)
    for X, Y in zip(base, bc.linearized(heavy)):
        np.testing.assert_allclose(Y, 3.7 * X, rtol=1e-14, atol=0.0)
    np.testing.assert_allclose(bc.eigenvalues(heavy, 5.0), bc.eigenvalues(P, 5.0), rtol=1e-12)
    assert bc.weave_speed(heavy) == pytest.approx(WEAVE_SPEED, abs=1e-12)
    assert bc.capsize_speed(heavy) == pytest.approx(CAPSIZE_SPEED, abs=1e-12)

    L = 1.6
    big = bc.scaled(P, length=L)
    for X, Y, k in zip(base, bc.linearized(big), (2, 1, 1, 0)):
        np.testing.assert_allclose(Y, L**k * X, rtol=1e-13, atol=1e-13 * np.max(np.abs(X)))
    for v in (1.0, 5.0, 8.0):
        np.testing.assert_allclose(np.sort_complex(bc.eigenvalues(big, math.sqrt(L) * v)),
                                   np.sort_complex(bc.eigenvalues(P, v) / math.sqrt(L)), rtol=1e-12, atol=1e-12)
    assert bc.weave_speed(big, v_max=15.0) == pytest.approx(math.sqrt(L) * WEAVE_SPEED, abs=1e-11)
    assert bc.capsize_speed(big, v_max=15.0) == pytest.approx(math.sqrt(L) * CAPSIZE_SPEED, abs=1e-11)

    moon = bc.scaled(P, g=1.62)
    assert bc.weave_speed(moon) == pytest.approx(math.sqrt(1.62 / 9.81) * WEAVE_SPEED, abs=1e-11)
    assert bc.capsize_speed(moon) == pytest.approx(math.sqrt(1.62 / 9.81) * CAPSIZE_SPEED, abs=1e-11)
    for X, Y in zip(base, bc.linearized(moon)):
        assert np.array_equal(X, Y)  # g enters only the equations, not the matrices


def test_state_matrix_is_the_second_order_system():
    """A x = (qd, qdd) with M qdd = -(v C1 qd + (g K0 + v^2 K2) q), for a random state."""
    M, C1, K0, K2 = bc.linearized(P)
    x = np.array([0.01, -0.02, 0.3, -0.1])
    for v in (0.0, 3.0, 7.5):
        A = bc.state_matrix(P, v)
        qdd = A[2:] @ x
        np.testing.assert_allclose(M @ qdd, -(v * C1 @ x[2:] + (P.g * K0 + v * v * K2) @ x[:2]), rtol=1e-13, atol=1e-15)
        np.testing.assert_array_equal(A[:2] @ x, x[2:])


def test_blocks_are_the_benchmark_coefficients_and_from_blocks_their_inverse():
    """M^-1 K0, M^-1 C1, M^-1 K2 back from the state matrices at 0 and v; the state matrix at any
    speed from them."""
    M, C1, K0, K2 = bc.linearized(P)
    MK0, MC1, MK2 = bc.blocks(bc.state_matrix(P, 0.0), bc.state_matrix(P, 3.0), 3.0, P.g)
    for got, X in ((MK0, K0), (MC1, C1), (MK2, K2)):
        np.testing.assert_allclose(got, np.linalg.solve(M, X), rtol=1e-13, atol=1e-14)
    for v in (0.0, 4.0, 9.0):
        np.testing.assert_allclose(bc.from_blocks(MK0, MC1, MK2, v, P.g), bc.state_matrix(P, v), rtol=1e-13, atol=1e-13)
    with pytest.raises(ValueError, match="nonzero"):
        bc.blocks(bc.state_matrix(P, 0.0), bc.state_matrix(P, 0.0), 0.0, P.g)


def test_crossings_of_a_given_state_matrix():
    """``matrix`` replaces the benchmark's state matrix in the root finding (an engine's own
    linearisation, ``harness.engines.linearization``): with the benchmark's it finds the same speeds,
    on a narrow scan too; with another bicycle's, that bicycle's."""
    default = bc.stability_crossings(P)
    given = bc.stability_crossings(P, matrix=lambda v: bc.state_matrix(P, v))
    assert [x.speed for x in given] == [x.speed for x in default]
    narrow = bc.stability_crossings(P, v_max=7.0, v_min=3.0, n=9, matrix=lambda v: bc.state_matrix(P, v))
    assert bc.weave_speed(P, crossings=narrow) == pytest.approx(WEAVE_SPEED, abs=1e-12)
    assert bc.capsize_speed(P, crossings=narrow) == pytest.approx(CAPSIZE_SPEED, abs=1e-12)
    moon = bc.scaled(P, g=1.62)
    other = bc.stability_crossings(P, matrix=lambda v: bc.state_matrix(moon, v))
    assert bc.weave_speed(P, crossings=other) == pytest.approx(bc.weave_speed(moon), abs=1e-12)
