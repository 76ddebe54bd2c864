"""Bricard's 6R linkage (``references/bricard.py``) against independent checks.

* the closure relation sin θ − sin φ − sin θ sin φ = 0 against the harness's own forward
  kinematics of the builder's tree (``harness.model.kinematics``, ``loop_closure``) over the whole
  closed curve, and the symmetry q = (θ, φ, θ, −φ, −θ) against a general solve of the cut's
  closure in the four other hinge angles;
* M(θ), ½ M'(θ), V'(θ) against the builder's bodies and finite differences;
* the reference: energy, convergence, the θ equation against the DAE in (θ, φ), the period
  from the energy quadrature;
* the reference against in-house engine runs (its compiled DOP853, rtol 1e-11), released from rest, with
  dq0 ≠ 0 and other L, s, m, g, and through a fold of the branch (the DAE);
* the exact check's plumbing.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.measure.trajectory import Trajectory
from harness.model import kinematics, loop_closure, rotations
from harness.model.builders import bricard as builder
from harness.engines import load_scene
from harness.references import bricard as br

SCENE = load_scene("bricard")
OTHER = dict(L=0.5, s=0.02, m=2.5, g=3.7, dq0=1.3)          # stays on the branch (fold speed 2.98 rad/s)
THROUGH_FOLD = dict(L=0.8, s=0.05, m=0.7, g=9.81, dq0=-5.0)  # fold speed 3.83 rad/s: passes the folds
CASES = [("scene", {}), ("dq0", dict(dq0=2.0)), ("other", OTHER), ("fold", dict(dq0=5.0)), ("fold_other", THROUGH_FOLD),
         ("no_gravity", dict(g=0.0, dq0=1.0))]
T2 = np.linspace(0.0, 2.0, 201)


def _params(over: dict) -> br.BricardParams:
    return br.BricardParams.from_mapping({**SCENE.params, **over})


def _closed_curve(n: int = 721) -> tuple[np.ndarray, np.ndarray]:
    """(θ, φ) along the whole curve c = 0: the branch through 0 and the other arcsin branch."""
    th = np.linspace(br.THETA_FOLDS[0], br.THETA_FOLDS[1], n)
    phi = br.closure_phi(th)
    return np.concatenate([th, th]), np.concatenate([phi, -np.pi - phi])


def _tree_state(p: br.BricardParams, theta: float, phi: float, dtheta: float = 0.0, dphi: float = 0.0):
    model = builder.build({"L": p.L, "s": p.s, "m": p.m, "g": p.g, "dq0": 0.0})
    names = [b.name for b in model.bodies]
    q = dict(zip(names, (np.array([x]) for x in br.joint_angles(theta, phi))))
    v = dict(zip(names, (np.array([x]) for x in br.joint_angles(dtheta, dphi))))
    return model, kinematics.forward(model, q, v)


def _cut_residuals(model, states) -> dict[str, float]:
    loop = model.loops[0]
    st = states[loop.body_a]
    R = rotations.matrix(st.quat_WB)
    a = loop_closure.end(st.p_WCm_W, R, st.v_WCm_W, st.w_WB_W, model.body(loop.body_a).p_BCm_B, loop.p_A, loop.axis_A)
    b = loop_closure.world_end(loop.p_B, loop.axis_B, ())
    return {k: float(v) for k, v in loop_closure.residuals(loop, a, b).items()}


# ---------------------------------------------------------------------------------------------
# Closure
# ---------------------------------------------------------------------------------------------
def test_geometry_matches_the_builder():
    for L in (1.0, 0.37):
        for i, (name, point, axis, along) in enumerate(builder.geometry(L)):
            assert name == br.BODIES[i]
            assert np.allclose(point, L * br._HINGES[i], atol=1e-15) and np.allclose(along, br._ALONG[i])
            assert np.allclose(axis, np.eye(3)[br._AXES[i]])
    p = br.BricardParams(L=0.8, s=0.07, m=1.7)
    for i, I in enumerate(br._body_inertia(p)):
        assert np.allclose(I, builder.rod_inertia(p.m, p.L, p.s, br._ALONG[i]), rtol=1e-15, atol=0)
    # the builder's velocity mode is the derivative of the closure at q = 0: (1, φ'(0), 1, −φ'(0), −1)
    assert np.allclose(builder.velocity_mode(0.8), br.joint_angles(1.0, br.dphi_dtheta(0.0)), atol=1e-12)


@pytest.mark.parametrize("L", [1.0, 0.3, 2.5])
def test_closure_relation_closes_the_tree(L):
    """Along the whole closed curve c(θ, φ) = 0 (both arcsin branches, through both folds) the
    builder's tree at q = (θ, φ, θ, −φ, −θ) returns link5's tip to F = (0, −L, 0), link5's
    orientation is Rot(x, φ) (a rotation about world x only, as the cut hinge allows), and at the
    rates (1, φ', 1, −φ', −1) θ̇ the cut point stands still and link5 turns about x only."""
    p = br.BricardParams(L=L)
    th, phi = _closed_curve()
    assert np.max(np.abs(br.closure_residual(th, phi))) < 1e-15
    worst = 0.0
    for k in range(0, len(th), 6):
        model, states = _tree_state(p, th[k], phi[k])
        r = _cut_residuals(model, states)
        R5 = rotations.matrix(states["link5"].quat_WB)
        worst = max(worst, r["position"] / L, r["axis"], np.max(np.abs(R5 - br._rot(0, phi[k]))))
        assert br.cut_residual(L, th[k], phi[k])[0] < 2e-15 * L
    assert worst < 3e-15
    # velocities on the branch (φ' finite away from the folds)
    for t in np.linspace(-0.4, 3.5, 14):
        model, states = _tree_state(p, t, br.closure_phi(t), 1.7, 1.7 * br.dphi_dtheta(t))
        r = _cut_residuals(model, states)
        assert r["velocity"] < 1e-14 * L and r["axis_rate"] < 1e-14
        w5 = states["link5"].w_WB_W
        assert np.allclose(w5[1:], 0.0, atol=1e-14) and w5[0] == pytest.approx(1.7 * br.dphi_dtheta(t), rel=1e-13)


def test_no_bifurcation_along_the_curve():
    """The cut hinge's five rows (link5's angular velocity without its x part, the velocity of
    its point at F) in the five tree rates keep rank 4 along the whole closed curve: one velocity
    mode everywhere (fourth singular value >= 1.12 with L = 1 m, the fifth 0)."""
    L = 1.0
    th, phi = _closed_curve(721)
    fourth, fifth = np.inf, 0.0
    for t, f in zip(th, phi):
        Rs, O, tip = br.forward_kinematics(L, br.joint_angles(t, f))
        U = [np.eye(3)[br._AXES[0]]] + [Rs[j - 1][:, br._AXES[j]] for j in range(1, 5)]
        G = np.array([np.concatenate([u, np.cross(u, tip - o)]) for u, o in zip(U, O)]).T[1:]
        sv = np.linalg.svd(G, compute_uv=False)
        fourth, fifth = min(fourth, sv[3]), max(fifth, sv[4])
    assert fourth > 1.12 and fifth < 1e-14


def test_the_motion_keeps_the_symmetry():
    """Solving the cut's six closure equations for (q2, q3, q4, q5, ψ) at a given q1 = θ, from a
    generic start, gives the symmetric configuration q = (θ, φ(θ), θ, −φ, −θ), ψ = φ: the
    symmetry is found, not assumed."""
    L = 1.0

    def residual(x, theta):
        Rs, _, tip = br.forward_kinematics(L, np.r_[theta, x[:4]])
        return np.concatenate([tip - np.array([0.0, -L, 0.0]), (Rs[4] - br._rot(0, x[4])).ravel()])

    x = np.zeros(5)
    for theta in np.linspace(0.05, np.pi - 0.05, 25):  # continuation along the branch
        guess = x + np.array([0.2, 0.1, -0.1, -0.1, 0.2]) * 0.05  # off the symmetric set
        sol = least_squares(residual, guess, args=(theta,), xtol=1e-15, ftol=1e-15, gtol=1e-15)
        x = sol.x
        assert np.max(np.abs(sol.fun)) < 1e-13
        phi = br.closure_phi(theta)
        assert np.allclose(np.r_[theta, x[:4]], br.joint_angles(theta, phi), atol=1e-10)
        assert x[4] == pytest.approx(phi, abs=1e-10)


def test_the_trace_of_the_120_degree_screw():
    """c(θ, φ) is the trace of Rot(z, θ) Rot(y, φ) R_S, with R_S the rotation by −120° about the
    cube's diagonal (1, −1, 1) through its centre that maps each hinge to the next but one (module docstring)."""
    RS = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    n = np.array([1.0, -1.0, 1.0]) / np.sqrt(3.0)
    assert np.allclose(RS, rotations.matrix(rotations.from_axis_angle(n, -2 * np.pi / 3)), atol=1e-15)
    centre = np.array([0.5, -0.5, -0.5])
    pts = np.vstack([br._HINGES, br._CUT])  # A, B, C, D, E, F
    axes = np.eye(3)[list(br._AXES) + [0]]
    for k in range(6):
        assert np.allclose(centre + RS @ (pts[k] - centre), pts[(k + 2) % 6], atol=1e-15)
        assert abs(abs(RS @ axes[k] @ axes[(k + 2) % 6]) - 1.0) < 1e-15
    rng = np.random.default_rng(3)
    for th, ph in rng.uniform(-np.pi, np.pi, (20, 2)):
        trace = np.trace(br._rot(2, th) @ br._rot(1, ph) @ RS)
        assert trace == pytest.approx(float(br.closure_residual(th, ph)), abs=1e-15)


def test_closure_derivatives():
    h = 1e-5
    for t in np.linspace(-0.4, 3.5, 17):
        d1 = (br.closure_phi(t + h) - br.closure_phi(t - h)) / (2 * h)
        d2 = (br.dphi_dtheta(t + h) - br.dphi_dtheta(t - h)) / (2 * h)
        assert br.dphi_dtheta(t) == pytest.approx(d1, rel=1e-8, abs=1e-9)
        assert br.d2phi_dtheta2(t) == pytest.approx(d2, rel=1e-8, abs=1e-9)
    assert br.closure_phi(np.pi / 2) == pytest.approx(np.pi / 6, abs=1e-15)
    assert br.closure_phi(np.pi) == pytest.approx(0.0, abs=1e-15) and br.dphi_dtheta(np.pi) == pytest.approx(-1.0)
    with pytest.raises(ValueError):
        br.closure_phi(-0.6)


# ---------------------------------------------------------------------------------------------
# Dynamics
# ---------------------------------------------------------------------------------------------
def _kinetic_energy_of_the_builder(p: br.BricardParams, theta: float, dtheta: float) -> float:
    """½ Σ m v² + ω·I ω from the harness's forward kinematics of the builder's bodies."""
    model, states = _tree_state(p, theta, br.closure_phi(theta), dtheta, br.dphi_dtheta(theta) * dtheta)
    T = 0.0
    for body in model.bodies:
        st = states[body.name]
        R = rotations.matrix(st.quat_WB)
        T += 0.5 * body.mass * st.v_WCm_W @ st.v_WCm_W + 0.5 * st.w_WB_W @ (R @ body.I_Cm_B @ R.T) @ st.w_WB_W
    return T


@pytest.mark.parametrize("over", [{}, dict(L=0.5, s=0.02, m=2.5, g=3.7)])
def test_mass_function(over):
    """M(θ) against the builder's bodies' kinetic energy, ½ M' and V' against finite differences,
    the hand-derived values at q = 0 and the mirror symmetry about θ = π/2."""
    p = _params(over)
    M0, _, dV0 = br.mass_function(p, 0.0)
    assert M0 == pytest.approx(p.m * (5 * p.L**2 + p.s**2), rel=1e-14)
    assert dV0 == pytest.approx(-p.m * p.g * p.L, rel=1e-14)
    assert float(br.potential(p, 0.0, 0.0)) == pytest.approx(-3 * p.m * p.g * p.L, rel=1e-14)
    assert float(br.potential(p, np.pi / 2, np.pi / 6)) == pytest.approx(-2 * np.sqrt(3) * p.m * p.g * p.L, rel=1e-14)
    for fold in br.THETA_FOLDS:
        assert abs(float(br.potential(p, fold, -np.pi / 2))) < 1e-14 * p.m * p.g * p.L
    th, phi = _closed_curve(401)  # V ≤ 0 on the branch (its largest value at the folds), ≥ 0 beyond
    V = br.potential(p, th, phi) / (p.m * p.g * p.L)
    assert np.all(V[:401] < 1e-14) and np.all(V[401:] > -1e-14) and V[401:].max() == pytest.approx(2 * np.sqrt(3))
    h = 1e-5
    for t in np.linspace(-0.45, 3.55, 9):
        M, half_dM, dV = br.mass_function(p, t)
        assert 0.5 * M * 1.3**2 == pytest.approx(_kinetic_energy_of_the_builder(p, t, 1.3), rel=1e-13)
        dM = (br.mass_function(p, t + h)[0] - br.mass_function(p, t - h)[0]) / (2 * h)
        Vp = float(br.potential(p, t + h, br.closure_phi(t + h))
                   - br.potential(p, t - h, br.closure_phi(t - h))) / (2 * h)
        assert half_dM == pytest.approx(0.5 * dM, rel=1e-7, abs=1e-8 * M)
        assert dV == pytest.approx(Vp, rel=1e-7, abs=1e-8 * p.m * p.g * p.L)
        Mm, half_dMm, dVm = br.mass_function(p, np.pi - t)
        assert (Mm, half_dMm, dVm) == pytest.approx((M, -half_dM, -dV), rel=1e-12, abs=1e-12 * M)


# ---------------------------------------------------------------------------------------------
# The reference: energy, convergence, the two formulations, the period
# ---------------------------------------------------------------------------------------------
def _kinetic_scale(p, m) -> float:
    T = br.energy(p, m.theta, m.phi, m.dtheta, m.dphi) - br.potential(p, m.theta, m.phi)
    return max(float(np.max(T)), 3 * p.m * p.g * p.L, 1e-300)


@pytest.mark.parametrize("name, over", CASES, ids=[c[0] for c in CASES])
def test_reference_conserves_energy(name, over):
    """Measured 1e-13 to 2e-12 relative to the energy scale (max of T and 3 m g L) over 2 s."""
    p = _params(over)
    m = br.reference_solution(p, T2)
    assert m.method == ("theta" if abs(p.dq0) < br.fold_speed(p) and p.g > 0 else "dae")
    E = br.energy(p, m.theta, m.phi, m.dtheta, m.dphi)
    assert np.max(np.abs(E - E[0])) / _kinetic_scale(p, m) < 1e-10
    E0 = 0.5 * p.m * (5 * p.L**2 + p.s**2) * p.dq0**2 - 3 * p.m * p.g * p.L
    assert E[0] == pytest.approx(E0, rel=1e-13, abs=1e-13)
    assert np.max(np.abs(br.closure_residual(m.theta, m.phi))) < 1e-10
    if m.method == "dae" and p.g > 0:  # the motion passes a fold onto the other branch (φ < −π/2)
        assert np.min(m.phi) < -np.pi / 2 - 0.1


@pytest.mark.parametrize("name, over", CASES, ids=[c[0] for c in CASES])
def test_reference_converges(name, over):
    """rtol 1e-12 against 1e-10 (measured 1e-11 to 1.2e-9 rad over 2 s); the default tolerances
    (θ equation 1e-13, DAE 1e-12) against 3e-14 and 1e-13 (measured < 2e-12 rad)."""
    p = _params(over)
    m12 = br.reference_solution(p, T2, rtol=1e-12, atol=1e-12)
    m10 = br.reference_solution(p, T2, rtol=1e-10, atol=1e-10)
    assert np.max(np.abs(m12.angles - m10.angles)) < 3e-9
    m = br.reference_solution(p, T2)
    fine = 3e-14 if m.method == "theta" else 1e-13  # (DOP853 takes no rtol below 2.2e-14)
    mf = br.reference_solution(p, T2, rtol=fine, atol=fine)
    assert np.max(np.abs(m.angles - mf.angles)) < 5e-12


@pytest.mark.parametrize("name, over", CASES[:3], ids=[c[0] for c in CASES[:3]])
def test_theta_equation_matches_the_dae(name, over):
    """M(θ) θ̈ + ½ M' θ̇² + V' = 0 against the DAE in (θ, φ) with a multiplier (measured 8e-13
    to 2.7e-12 rad over 2 s)."""
    p = _params(over)
    a = br.reference_solution(p, T2, method="theta")
    b = br.reference_solution(p, T2, method="dae")
    assert np.max(np.abs(a.angles - b.angles)) < 1e-10
    assert np.max(np.abs(a.dphi - b.dphi)) < 1e-9


def test_period_from_the_energy_quadrature():
    """Released from rest: θ swings between 0 and π; the quadrature's period (4.99171 s with the
    defaults) puts θ = π/2 at T/4 and the turning point θ = π (θ̇ = 0) at T/2."""
    for over in ({}, dict(L=0.5, s=0.02, m=2.5, g=3.7)):
        p = _params({**over, "dq0": 0.0})
        T = br.period(p)
        if not over:
            assert T == pytest.approx(4.991711513688, abs=1e-9)
        m = br.reference_solution(p, np.array([0.0, T / 4, T / 2, 3 * T / 4, T]))
        assert np.allclose(m.theta, [0.0, np.pi / 2, np.pi, np.pi / 2, 0.0], atol=1e-9)
        assert abs(m.dtheta[2]) < 1e-9 and abs(m.dtheta[4]) < 1e-9
        t = np.linspace(0.0, T, 401)
        m = br.reference_solution(p, t)
        assert -1e-12 < m.theta.min() and m.theta.max() < np.pi + 1e-12


def test_fold_speed():
    """Below the fold speed the motion stays on the branch: the θ equation (up to turning points a
    few 1e-3 rad from a fold, where φ' grows without bound: at 95 % of the fold speed, 2e-3 rad,
    it agrees with the DAE to < 1e-10 rad); just above it the motion passes a fold (the DAE)."""
    p = _params({})
    v = br.fold_speed(p)
    assert v == pytest.approx(3.4276089325, rel=1e-9)
    t = np.linspace(0.0, 2.5, 251)
    a = br.reference_solution(_params({"dq0": 0.95 * v}), t)
    b = br.reference_solution(_params({"dq0": 0.95 * v}), t, method="dae")
    assert a.method == "theta" and np.max(np.abs(a.angles - b.angles)) < 1e-9
    assert br.THETA_FOLDS[1] - a.theta.max() < 3e-3  # the turning point, 2e-3 rad from the fold
    assert br.reference_solution(_params({"dq0": -0.95 * v}), t).method == "theta"
    m = br.reference_solution(_params({"dq0": 1.02 * v}), np.linspace(0.0, 3.0, 301))
    assert m.method == "dae" and m.theta.max() == pytest.approx(br.THETA_FOLDS[1], abs=1e-3)
    assert m.phi.min() < -np.pi / 2 - 0.03  # past the fold, on the other arcsin branch


# ---------------------------------------------------------------------------------------------
# Against the in-house engine, and the exact check's plumbing
# ---------------------------------------------------------------------------------------------
def _inhouse(over: dict):
    scene = SCENE.with_params(**over) if over else SCENE
    traj = get_engine("inhouse").simulate_model(builder.build(scene.params), RunSettings(
        t_end=2.0, dt=1e-3, save_every=0.01, integrator="dop853_compiled", rtol=1e-11, atol=1e-11))
    assert traj.ok, traj.message
    return scene, traj


@pytest.mark.parametrize("name, over", [CASES[0], CASES[2], CASES[4]], ids=[CASES[i][0] for i in (0, 2, 4)])
def test_reference_matches_inhouse(name, over):
    """Over 2 s: measured 8e-13 rad released from rest, 3.8e-12 with OTHER (dq0 = 1.3 rad/s,
    other L, s, m, g), 4.5e-12 through the folds (the DAE); the runs' symmetry residual < 2e-12."""
    scene, traj = _inhouse(over)
    value, unit, detail = br.exact_error(scene, traj, None, None)
    assert unit == "rad" and value < 1e-8, detail
    series = br.exact_error_series(scene, traj)
    assert series.shape == traj.t.shape and series.max() == pytest.approx(value, rel=1e-12)
    assert np.max(br.symmetry_residual(br.hinge_angles(traj), br.cut_angle(traj))) < 1e-9


def _synthetic_run(p: br.BricardParams, m: br.Motion, offset: np.ndarray | None = None) -> Trajectory:
    """A trajectory in maximal coordinates from the tree at the reference's hinge angles."""
    n = len(m.t)
    q = m.angles + (0.0 if offset is None else offset)
    quat, pos = np.empty((n, 5, 4)), np.empty((n, 5, 3))
    for k in range(n):
        Rs, os, _ = br.forward_kinematics(p.L, q[k])
        quat[k] = rotations.from_matrix(Rs)
        pos[k] = os + np.einsum("kij,kj->ki", Rs, 0.5 * p.L * br._ALONG)
    zeros = np.zeros((n, 5, 3))
    return Trajectory("synthetic", "none", br.BODIES, m.t, pos, quat, zeros, zeros)


def test_exact_error_reads_the_hinge_angles():
    """The reference written as a run has zero error; 1e-6 rad added to q4 is measured as 1e-6 rad
    (and breaks the symmetry by as much)."""
    t = np.linspace(0.0, 2.5, 51)
    for over in ({}, dict(dq0=5.0)):
        scene = SCENE.with_params(**over) if over else SCENE
        p = _params(over)
        m = br.reference_solution(p, t)
        value, unit, detail = br.exact_error(scene, _synthetic_run(p, m))
        assert value < 1e-12 and unit == "rad" and "symmetry residual" in detail
        shifted = _synthetic_run(p, m, np.array([0.0, 0.0, 0.0, 1e-6, 0.0]))
        assert br.exact_error(scene, shifted)[0] == pytest.approx(1e-6, rel=1e-6)
        assert np.max(br.symmetry_residual(br.hinge_angles(shifted))) == pytest.approx(1e-6, rel=1e-6)
    assert br.EXACT_NEEDS_RUNS is False
