"""Four-bar linkage (``references/four_bar.py``) against independent checks.

* Freudenstein's relation and the closed-form assembly against the closure equations and the
  builder's own assembly;
* the reference (index-1 DAE in the absolute angles, DOP853 rtol 1e-12): energy, closure,
  convergence, and a second formulation written here -- 2-D Newton-Euler in maximal
  coordinates (x, z, angle of every bar's centre of mass, four pins as 8 constraints);
* the reference against the in-house engine (its compiled DOP853, rtol 1e-11) on the scene and on seeded
  random Grashof and non-Grashof linkages (the latter swing through toggle positions);
* the near-singular case recommended in the module docstring.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.measure.trajectory import Trajectory
from harness.model import rotations
from harness.model.builders import four_bar as builder
from harness.engines import load_scene
from harness.references import four_bar as fb

SCENE = load_scene("four_bar")
BASE = fb.FourBarParams.from_mapping(SCENE.params)
NEAR_SINGULAR = dict(a=0.2, b=0.4, c=0.251, d=0.45)  # b + c = a + d + 1e-3 (module docstring)
T2 = np.linspace(0.0, 2.0, 201)


def _e(x):
    return np.array([np.cos(x), np.sin(x)])


def _ep(x):
    return np.array([-np.sin(x), np.cos(x)])


def _random_sets(grashof_sign: float, n: int, seed: int) -> list[dict]:
    """Seeded random linkages that assemble at their theta0 (a margin of 0.02 m from a toggle)
    and are clearly (|p + q - s - l| >= 0.03 m) Grashof (+1) or non-Grashof (-1)."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        a, b, c, d = rng.uniform(0.1, 0.6, 4)
        th0, dth0 = rng.uniform(-np.pi, np.pi), rng.uniform(-10.0, 10.0)
        G = fb.grashof(a, b, c, d)
        rho = np.sqrt(a * a + d * d - 2 * a * d * np.cos(th0))
        if np.sign(G) != grashof_sign or abs(G) < 0.03 or not abs(b - c) + 0.02 < rho < b + c - 0.02:
            continue
        out.append(dict(a=a, b=b, c=c, d=d, theta0=th0, dtheta0=dth0, branch=float(rng.choice([-1.0, 1.0])),
                        m_crank=rng.uniform(0.2, 2.0), m_coupler=rng.uniform(0.2, 2.0), m_rocker=rng.uniform(0.2, 2.0)))
    return out


GRASHOF = _random_sets(+1.0, 3, seed=11)
NON_GRASHOF = _random_sets(-1.0, 3, seed=12)
# two drawn once from another seed (rounded), kept for what they do: a Grashof linkage whose crank
# is not the shortest link, swinging through 11 toggles in 2 s, and a non-Grashof one through 6
TOGGLING = [
    dict(a=0.3559, b=0.5752, c=0.1721, d=0.5743, theta0=-1.1823, dtheta0=6.5541, branch=1.0,
         m_crank=0.9366, m_coupler=1.1893, m_rocker=0.2496),
    dict(a=0.3008, b=0.2476, c=0.5235, d=0.1622, theta0=1.4677, dtheta0=-6.2435, branch=-1.0,
         m_crank=0.9065, m_coupler=0.6174, m_rocker=1.7142),
]
CASES = [("scene", {})] + [(f"grashof{i}", p) for i, p in enumerate(GRASHOF)] + \
        [(f"nongrashof{i}", p) for i, p in enumerate(NON_GRASHOF)] + \
        [("grashof_toggling", TOGGLING[0]), ("nongrashof_toggling", TOGGLING[1])] + [("near_singular", NEAR_SINGULAR)]


def _params(over: dict) -> fb.FourBarParams:
    return fb.FourBarParams.from_mapping({**SCENE.params, **over})


def _kinetic(p, m: fb.Motion) -> np.ndarray:
    return fb.energy(p, m.theta, m.beta, m.gamma, m.dtheta, m.dbeta, m.dgamma) - fb.potential(p, m.theta, m.beta, m.gamma)


# ---------------------------------------------------------------------------------------------
# Kinematics
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, over", CASES, ids=[c[0] for c in CASES])
def test_freudenstein_and_closed_form_assembly(name, over):
    """The closed-form (beta, gamma) close the loop (Phi = 0) and satisfy Freudenstein's relation;
    they agree with the builder's circle intersection on both branches."""
    p = _params(over)
    a, b, c, d = p.lengths
    th = np.linspace(-np.pi, np.pi, 2001)
    rho = np.sqrt(a * a + d * d - 2 * a * d * np.cos(th))
    th = th[(rho > abs(b - c) + 1e-3) & (rho < b + c - 1e-3)]
    for branch in (1.0, -1.0):
        beta, gamma = fb.assemble(a, b, c, d, th, branch)
        assert np.max(np.abs(fb.closure_residual(a, b, c, d, th, beta, gamma))) < 1e-14
        assert np.max(np.abs(fb.freudenstein_residual(a, b, c, d, th, gamma))) < 1e-13
        assert np.all(fb.branch_of(a, b, c, d, th, beta, gamma) == branch)
        for k in range(0, len(th), 97):
            bb, gg = builder.assemble(a, b, c, d, th[k], branch)
            assert abs(np.angle(np.exp(1j * (bb - beta[k])))) < 1e-12 and abs(np.angle(np.exp(1j * (gg - gamma[k])))) < 1e-12
    # Freudenstein's K's by brute force: cos(theta - gamma) is linear in (cos gamma, -cos theta, 1)
    _, gamma = fb.assemble(a, b, c, d, th, 1.0)
    K = np.linalg.lstsq(np.stack([np.cos(gamma), -np.cos(th), np.ones_like(th)], axis=1), np.cos(th - gamma), rcond=None)[0]
    assert np.allclose(K, fb.freudenstein_coefficients(a, b, c, d), rtol=1e-10, atol=1e-12)


def test_velocity_closure_is_the_derivative_of_the_assembly():
    """Problem 3.1's relations (beta', gamma' from theta') against the theta-derivative of the
    closed forms, and the builder's rates."""
    a, b, c, d = BASE.lengths
    h = 1e-6
    for th in np.linspace(-3.0, 3.0, 13):
        for branch in (1.0, -1.0):
            beta, gamma = fb.assemble(a, b, c, d, th, branch)
            bp, gp = fb.assemble(a, b, c, d, th + h, branch)
            bm, gm = fb.assemble(a, b, c, d, th - h, branch)
            dbeta, dgamma = fb.velocity_closure(a, b, c, th, beta, gamma, 1.0)
            assert dbeta == pytest.approx((bp - bm) / (2 * h), abs=1e-7)
            assert dgamma == pytest.approx((gp - gm) / (2 * h), abs=1e-7)
            assert np.allclose(builder.rates(a, b, c, th, float(beta), float(gamma), 2.5), (2.5 * dbeta, 2.5 * dgamma),
                               rtol=1e-12, atol=1e-12)


def test_inertia_matches_the_builders_bars():
    for L, m in ((BASE.a, BASE.m_crank), (BASE.b, BASE.m_coupler), (BASE.c, BASE.m_rocker)):
        I_c = builder.bar_inertia(m, L, BASE.r)[1, 1]
        assert m * (0.25 * BASE.r**2 + L**2 / 3.0) == pytest.approx(I_c + m * L**2 / 4, rel=1e-15)


# ---------------------------------------------------------------------------------------------
# The reference: energy, closure, convergence, a second formulation
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, over", CASES, ids=[c[0] for c in CASES])
def test_reference_conserves_energy_and_closure(name, over):
    p = _params(over)
    m = fb.reference_solution(p, T2)
    E = fb.energy(p, m.theta, m.beta, m.gamma, m.dtheta, m.dbeta, m.dgamma)
    scale = max(np.max(_kinetic(p, m)), abs(E[0]))
    assert np.max(np.abs(E - E[0])) / scale < 1e-10
    assert np.max(np.abs(fb.closure_residual(*p.lengths, m.theta, m.beta, m.gamma))) < 1e-10
    assert np.max(np.abs(fb.freudenstein_residual(*p.lengths, m.theta, m.gamma))) < 1e-9
    # the closed forms on each sample's own branch, away from toggles (where they are singular)
    sigma = fb.branch_of(*p.lengths, m.theta, m.beta, m.gamma)
    ok = np.abs(np.sin(m.beta - m.gamma)) > 0.05
    _, gamma = fb.assemble(*p.lengths, m.theta[ok & (sigma > 0)], 1.0)
    assert np.max(np.abs(np.angle(np.exp(1j * (gamma - m.gamma[ok & (sigma > 0)])))), initial=0.0) < 1e-8
    _, gamma = fb.assemble(*p.lengths, m.theta[ok & (sigma < 0)], -1.0)
    assert np.max(np.abs(np.angle(np.exp(1j * (gamma - m.gamma[ok & (sigma < 0)])))), initial=0.0) < 1e-8


@pytest.mark.parametrize("name, over", CASES, ids=[c[0] for c in CASES])
def test_reference_converges(name, over):
    p = _params(over)
    m12 = fb.reference_solution(p, T2)
    m10 = fb.reference_solution(p, T2, rtol=1e-10, atol=1e-10)
    m13 = fb.reference_solution(p, T2, rtol=1e-13, atol=1e-13)
    assert np.max(np.abs(m12.angles - m10.angles)) < 1e-7
    assert np.max(np.abs(m12.angles - m13.angles)) < 1e-9


def _maximal_newton_euler(p: fb.FourBarParams, t: np.ndarray, tol: float = 1e-12) -> np.ndarray:
    """Bar angles (3, n) from 2-D Newton-Euler in maximal coordinates: per bar the centre of mass
    (x, z) and the angle, M = diag(m, m, I_c); pins A (ground), B, D (ground), C as 8 constraints
    with multipliers (Baumgarte, critically damped at 30 /s); DOP853."""
    L = np.array(p.lengths[:3])
    m = np.array([p.m_crank, p.m_coupler, p.m_rocker])
    I = m * (3 * p.r**2 + L**2) / 12
    Minv = 1.0 / np.array([m[0], m[0], I[0], m[1], m[1], I[1], m[2], m[2], I[2]])
    # (body, offset from its centre along the bar, other body or None, its offset, ground point)
    pins = [(0, -L[0] / 2, None, 0.0, np.zeros(2)), (0, L[0] / 2, 1, -L[1] / 2, None),
            (2, -L[2] / 2, None, 0.0, np.array([p.d, 0.0])), (1, L[1] / 2, 2, L[2] / 2, None)]
    al = 30.0
    f = np.zeros(9)
    f[1::3] = -m * p.g

    def rhs(_t, y):
        q, v = y[:9], y[9:]
        G, gam, c = np.zeros((8, 9)), np.zeros(8), np.zeros(8)
        for k, (i, s, j, s2, ground) in enumerate(pins):
            r = slice(2 * k, 2 * k + 2)
            G[r, 3 * i:3 * i + 2] = np.eye(2)
            G[r, 3 * i + 2] = s * _ep(q[3 * i + 2])
            gam[r] = s * _e(q[3 * i + 2]) * v[3 * i + 2] ** 2
            c[r] = q[3 * i:3 * i + 2] + s * _e(q[3 * i + 2])
            if j is None:
                c[r] -= ground
            else:
                G[r, 3 * j:3 * j + 2] = -np.eye(2)
                G[r, 3 * j + 2] = -s2 * _ep(q[3 * j + 2])
                gam[r] -= s2 * _e(q[3 * j + 2]) * v[3 * j + 2] ** 2
                c[r] -= q[3 * j:3 * j + 2] + s2 * _e(q[3 * j + 2])
        gam -= 2 * al * G @ v + al * al * c
        lam = np.linalg.solve((G * Minv) @ G.T, gam - G @ (Minv * f))
        return np.concatenate([v, Minv * (f + G.T @ lam)])

    th, be, ga, dth, dbe, dga = fb.initial_state(p)
    B = p.a * _e(th)
    q0 = np.concatenate([p.a / 2 * _e(th), [th], B + p.b / 2 * _e(be), [be], np.array([p.d, 0.0]) + p.c / 2 * _e(ga), [ga]])
    v0 = np.concatenate([p.a / 2 * dth * _ep(th), [dth], p.a * dth * _ep(th) + p.b / 2 * dbe * _ep(be), [dbe],
                         p.c / 2 * dga * _ep(ga), [dga]])
    sol = solve_ivp(rhs, (0.0, t[-1]), np.concatenate([q0, v0]), method="DOP853", t_eval=t, rtol=tol, atol=tol)
    assert sol.success
    return sol.y[[2, 5, 8]]


@pytest.mark.parametrize("name, over", [CASES[0], CASES[4], CASES[-1]], ids=[CASES[i][0] for i in (0, 4, -1)])
def test_reference_matches_maximal_coordinate_newton_euler(name, over):
    """Lagrange in absolute angles vs Newton-Euler in maximal coordinates (measured 7.7e-12,
    3.6e-12 and 7.2e-12 rad over 2 s for the scene, a non-Grashof set through two toggles and
    the near-singular case)."""
    p = _params(over)
    ref = fb.reference_solution(p, T2)
    assert np.max(np.abs(_maximal_newton_euler(p, T2) - ref.angles.T)) < 1e-9


# ---------------------------------------------------------------------------------------------
# Against the in-house engine, and the exact check's plumbing
# ---------------------------------------------------------------------------------------------
def _inhouse(over: dict, t_end: float = 2.0) -> tuple:
    scene = SCENE.with_params(**over) if over else SCENE
    traj = get_engine("inhouse").simulate(scene, RunSettings(integrator="dop853_compiled", dt=1e-3, t_end=t_end, save_every=0.01,
                                                             rtol=1e-11, atol=1e-11))
    assert traj.ok, traj.message
    return scene, traj


def test_reference_matches_inhouse_on_the_scene():
    """Measured 5.5e-9 rad over 2 s (crank; coupler 2.2e-9, rocker 1.7e-9)."""
    scene, traj = _inhouse({})
    value, unit, detail = fb.exact_error(scene, traj, None, None)
    assert unit == "rad" and value < 2e-8, detail
    series = fb.exact_error_series(scene, traj)
    assert series.shape == traj.t.shape and series.max() == pytest.approx(value, rel=1e-12)


@pytest.mark.parametrize("name, over", CASES[1:-1], ids=[c[0] for c in CASES[1:-1]])
def test_reference_matches_inhouse_on_random_linkages(name, over):
    """Random Grashof and non-Grashof linkages: measured 2e-10 to 3.6e-8 rad over 2 s. The in-house
    DOP853 run's error does not follow its tolerance: through toggle positions it grows in steps
    of ~1e-9 (its energy jumps there by ~1e-9 relative, the reference's stays at 1e-12, and the
    maximal-coordinate integration above agrees with the reference to 1e-11); on other random
    sets it reached 1.5e-7 rad at rtol 1e-11 and 2e-8 at 1e-13. Hence the looser bound: it is
    the engine's error, not the reference's."""
    scene, traj = _inhouse(over)
    value, _, detail = fb.exact_error(scene, traj, None, None)
    assert value < 1e-6, detail
    if "nongrashof" in name or "toggling" in name:  # these swing between toggles: the branch flips
        ref = fb.reference_solution(scene.params, traj.t)
        sigma = fb.branch_of(*_params(over).lengths, ref.theta, ref.beta, ref.gamma)
        assert np.any(sigma[1:] != sigma[:-1])


def _synthetic_run(p: fb.FourBarParams, t: np.ndarray, angles: np.ndarray) -> Trajectory:
    """A trajectory in maximal coordinates made from bar angles (rotation about world -y)."""
    n = len(t)
    quat = np.stack([[rotations.from_axis_angle(np.array([0.0, -1.0, 0.0]), a) for a in row] for row in angles])
    com = fb.com_positions(p, angles[:, 0], angles[:, 1], angles[:, 2])
    p_W = np.zeros((n, 3, 3))
    p_W[:, :, 0], p_W[:, :, 2] = com[..., 0], com[..., 1]
    zeros = np.zeros((n, 3, 3))
    return Trajectory("synthetic", "none", fb.BODIES, t, p_W, quat, zeros, zeros)


def test_exact_error_reads_the_bar_angles():
    """The reference itself, written as a run, has zero error; a 1e-6 rad offset of the rocker
    is measured as 1e-6 rad."""
    t = np.linspace(0.0, 1.0, 51)
    ref = fb.reference_solution(BASE, t)
    traj = _synthetic_run(BASE, t, ref.angles)
    assert fb.exact_error(SCENE, traj)[0] < 1e-12
    shifted = ref.angles + np.array([0.0, 0.0, 1e-6])
    assert fb.exact_error(SCENE, _synthetic_run(BASE, t, shifted))[0] == pytest.approx(1e-6, rel=1e-6)
    assert fb.EXACT_NEEDS_RUNS is False


# ---------------------------------------------------------------------------------------------
# The near-singular case (module docstring)
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("c, closest, sv_min", [
    (0.251, 6.0865e-2, 2.427e-2),    # recommended: epsilon = 1e-3 m
    (0.2502, 2.7268e-2, 1.0946e-2),  # scene four_bar_near_singular as created: epsilon = 2e-4 m
])
def test_near_singular_case_closest_approach(c, closest, sv_min):
    """a = 0.2, b = 0.4, d = 0.45 m, b + c = a + d + epsilon: the crank turns fully, every turn
    passes near the change point (``singularity_angle`` down to ``closest`` rad, the smallest
    singular value of Phi_q down to ``sv_min`` m, against 0.199 m for four_bar), never at it,
    and the reference stays tight there."""
    p = _params(dict(NEAR_SINGULAR, c=c))
    eps = p.b + p.c - p.a - p.d
    assert fb.grashof(*p.lengths) == pytest.approx(eps, abs=1e-12)
    # the kinematic closest approach, on the branch over all crank angles (it lies near theta = pi)
    th = np.linspace(np.pi - 0.2, np.pi + 0.2, 40001)
    assert np.min(fb.singularity_angle(th, *fb.assemble(*p.lengths, th, 1.0))) == pytest.approx(closest, rel=1e-4)
    t = np.linspace(0.0, 5.0, 5001)
    m = fb.reference_solution(p, t)
    assert np.min(m.dtheta) > 6.0  # the crank keeps turning
    assert (m.theta[-1] - m.theta[0]) / (2 * np.pi) > 8.9
    assert np.all(fb.branch_of(*p.lengths, m.theta, m.beta, m.gamma) == 1.0)
    near = fb.singularity_angle(m.theta, m.beta, m.gamma)
    assert closest <= near.min() < 1.1 * closest  # sampled every 1 ms
    sv = [np.linalg.svd(fb.constraint_jacobian(p.a, p.b, p.c, *x), compute_uv=False)[-1]
          for x in zip(m.theta, m.beta, m.gamma)]
    assert sv_min * 0.999 < min(sv) < sv_min * 1.02
    E = fb.energy(p, m.theta, m.beta, m.gamma, m.dtheta, m.dbeta, m.dgamma)
    assert np.max(np.abs(E - E[0])) / abs(E[0]) < 1e-10
    assert np.max(np.abs(fb.closure_residual(*p.lengths, m.theta, m.beta, m.gamma))) < 1e-11
    m13 = fb.reference_solution(p, t, rtol=1e-13, atol=1e-13)
    assert np.max(np.abs(m.angles - m13.angles)) < 1e-9
