"""The in-house Newton-Euler engine against the laws of motion and independent solutions.

Independent references are written here from the textbook equations, not from an engine:
the closed-form spin of a symmetric free body, the Lagrange top in Euler angles and the double
pendulum's Lagrange equations in absolute angles, each integrated by SciPy at rtol 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from harness.measure import invariants
from harness.model import rotations
from harness.engines.base import RunSettings
from harness.engines.inhouse import (
    ENGINE,
    InhouseEngine,
    algebra,
    build,
    from_trajectory,
    initial_state,
    project,
    reactions,
    violation,
)
from harness.engines.inhouse.constraints import rows
from harness.engines.inhouse.model import join, split
from harness.engines.inhouse.newton_euler import make_dynamics
from harness.model.multibody import Body, Multibody
from harness.engines import load_scene
from harness.model.sanity import check_multibody

TIGHT = dict(rtol=1e-12, atol=1e-12)


def run(scene, integrator="DOP853", t_end=None, save_every=None, **kw):
    settings = RunSettings(
        t_end=t_end or scene.t_end,
        dt=scene.dt,
        save_every=save_every or scene.save_every,
        integrator=integrator,
        **({**TIGHT, **kw} if integrator != "rk4" else kw),
    )
    traj = ENGINE.simulate(scene, settings)
    assert traj.status == "ok", traj.message
    return traj


def body_omega(traj, i=0):
    """Body-frame angular velocity (n, 3) of body i from the trajectory's world-frame one."""
    R = algebra.quat_matrix(traj.quat_WB[:, i])
    return np.einsum("tji,tj->ti", R, traj.w_WB_W[:, i])


def max_violation(model, traj):
    """Largest position- and velocity-level constraint error over the saved samples."""
    nem = build(model)
    return np.max(np.array([violation(nem, y) for y in from_trajectory(nem, traj)]), axis=0)


def mixed_model() -> Multibody:
    """Hinge to world (offset pivot, skew axis) -> ball child, plus a free body; full inertias."""
    rng = np.random.default_rng(7)

    def inertia(d, seed_angle):
        S = Rotation.from_rotvec(seed_angle).as_matrix()
        return S @ np.diag(d) @ S.T

    a = Body("a", None, "hinge", np.array([0.1, 0.2, 0.3]), np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0), 2.0,
             np.array([0.05, -0.1, -0.3]), inertia([0.03, 0.04, 0.05], [0.3, -0.2, 0.5]))
    b = Body("b", "a", "ball", np.array([0.0, 0.05, -0.5]), np.zeros(3), 1.5,
             np.array([0.1, 0.0, -0.2]), inertia([0.02, 0.025, 0.03], [-0.4, 0.1, 0.2]))
    c = Body("c", None, "free", np.zeros(3), np.zeros(3), 0.7, np.zeros(3), inertia([0.01, 0.012, 0.015], [0.2, 0.2, -0.3]))
    q0 = {
        "a": np.array([0.4]),
        "b": rotations.from_axis_angle(np.array([0.2, 1.0, -0.3]), 0.7),
        "c": np.concatenate([[1.0, 0.0, 0.5], rotations.from_axis_angle(np.array([1.0, 0.0, 1.0]), 0.3)]),
    }
    v0 = {"a": np.array([1.2]), "b": rng.normal(size=3), "c": rng.normal(size=6)}
    model = Multibody(bodies=(a, b, c), gravity_W=np.array([0.0, 0.0, -9.81]), q0=q0, v0=v0)
    check_multibody(model, source="mixed_model")
    return model


# ---------------------------------------------------------------------------------------------
# Constraint kinematics: J and gamma are the derivatives of C (central differences).


def random_state(nem, rng):
    nb = nem.nb
    q = rng.normal(size=(nb, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return join(rng.normal(size=(nb, 3)), q, rng.normal(size=(nb, 3)), rng.normal(size=(nb, 3)))


def drift(nem, y, t):
    """State after time t of free motion with constant v_W and w_B (exact: R(t) = R exp(t[w_B]x))."""
    P, Q, V, W = split(nem, y)
    angle = np.linalg.norm(W, axis=1, keepdims=True) * t
    axis = W / np.linalg.norm(W, axis=1, keepdims=True)
    dq = np.concatenate([np.cos(angle / 2), np.sin(angle / 2) * axis], axis=1)
    return join(P + V * t, rotations.multiply(Q, dq), V, W)


@pytest.mark.parametrize("scene", ["heavy_top", "double_pendulum", "mixed"])
def test_jacobian_and_bias_are_derivatives_of_the_constraints(scene):
    model = mixed_model() if scene == "mixed" else load_scene(scene).multibody()
    nem = build(model)
    rng = np.random.default_rng(1)
    h = 1e-4
    for _ in range(3):
        y = random_state(nem, rng)  # off the constraint manifold on purpose: the identities hold anywhere
        C0, J, gamma = rows(nem, y)
        Cp, _, _ = rows(nem, drift(nem, y, h))
        Cm, _, _ = rows(nem, drift(nem, y, -h))
        u = y[7 * nem.nb :]
        np.testing.assert_allclose((Cp - Cm) / (2 * h), J @ u, atol=1e-6 * (1 + np.abs(J @ u).max()))
        np.testing.assert_allclose((Cp - 2 * C0 + Cm) / h**2, gamma, atol=2e-5 * (1 + np.abs(gamma).max()))


def test_projection_restores_the_constraints():
    model = mixed_model()
    nem = build(model)
    y = initial_state(model, nem)
    assert max(violation(nem, y)) < 1e-13
    rng = np.random.default_rng(3)
    y_bad = y + 1e-4 * rng.normal(size=y.size)
    assert max(violation(nem, y_bad)) > 1e-6
    y_fixed = project(nem, y_bad)
    pos, vel = violation(nem, y_fixed)
    assert pos < 1e-12 and vel < 1e-12
    Q = split(nem, y_fixed)[1]
    np.testing.assert_allclose(np.linalg.norm(Q, axis=1), 1.0, atol=1e-15)


# ---------------------------------------------------------------------------------------------
# Torque-free body.


def test_torque_free_conserves_energy_and_angular_momentum():
    scene = load_scene("torque_free")
    model = scene.multibody()
    traj = run(scene)
    E = invariants.energies(traj, model)["energy"]
    L = invariants.angular_momentum(traj, model)
    p = invariants.linear_momentum(traj, model)
    assert np.max(np.abs(E - E[0])) / abs(E[0]) < 1e-12
    assert np.max(np.abs(L - L[0])) / np.linalg.norm(L[0]) < 1e-12
    assert np.max(np.abs(p)) < 1e-14
    assert traj.stats["steps"] > 0 and traj.stats["rhs_evals"] > traj.stats["steps"] and traj.stats["wall_s"] > 0


@pytest.mark.parametrize("integrator, tol", [("DOP853", 1e-10), ("rk4", 1e-9)])
def test_symmetric_body_spins_at_the_closed_form_rate(integrator, tol):
    # I1 = I2: w3 is constant and (w1, w2) turns about the body symmetry axis at rate
    # Omega = gamma w3, gamma = (I3 - I1) / I1 (Euler's equations with no moment):
    # w1 = w1(0) cos(Omega t) - w2(0) sin(Omega t), w2 = w1(0) sin(Omega t) + w2(0) cos(Omega t).
    I1, I3 = 1.5, 2.5
    w0 = np.array([0.4, -0.3, 1.7])
    scene = load_scene("torque_free", {"I1": I1, "I2": I1, "I3": I3, "omega0": w0})
    traj = run(scene, integrator, t_end=5.0)
    t = traj.t
    Omega = (I3 - I1) / I1 * w0[2]
    exact = np.stack(
        [w0[0] * np.cos(Omega * t) - w0[1] * np.sin(Omega * t), w0[0] * np.sin(Omega * t) + w0[1] * np.cos(Omega * t), np.full_like(t, w0[2])],
        axis=1,
    )
    assert np.max(np.abs(body_omega(traj) - exact)) < tol


def test_full_inertia_tensor_matches_the_principal_axes_body():
    # The same body described in a frame B' rotated by S from its principal frame B:
    # I' = S I S^T, w' = S w, R_WB' = R_WB S^T. World-frame motion must be identical.
    I = np.diag([1.0, 2.0, 2.5])
    w0 = np.array([0.7, -0.4, 0.9])
    S = Rotation.from_rotvec([0.4, -0.7, 0.2]).as_matrix()

    def model(I_B, quat, w_B):
        body = Body("body", None, "free", np.zeros(3), np.zeros(3), 1.0, np.zeros(3), I_B)
        q0 = np.concatenate([np.zeros(3), quat])
        return Multibody((body,), np.zeros(3), {"body": q0}, {"body": np.concatenate([np.zeros(3), w_B])})

    principal = model(I, np.array([1.0, 0.0, 0.0, 0.0]), w0)
    rotated = model(S @ I @ S.T, rotations.from_matrix(S.T), S @ w0)
    settings = RunSettings(t_end=4.0, dt=1e-3, save_every=0.02, integrator="DOP853", **TIGHT)
    a = ENGINE.simulate_model(principal, settings)
    b = ENGINE.simulate_model(rotated, settings)
    assert a.ok and b.ok
    np.testing.assert_allclose(b.w_WB_W, a.w_WB_W, atol=1e-10)
    E = invariants.energies(b, rotated)["energy"]
    assert np.max(np.abs(E - E[0])) / E[0] < 1e-12


# ---------------------------------------------------------------------------------------------
# Heavy top (Lagrange top).


def test_heavy_top_conserves_energy_Lz_and_axial_momentum_with_the_tip_fixed():
    scene = load_scene("heavy_top")
    model = scene.multibody()
    I3 = scene.params["I3"]
    for integrator, t_end in (("DOP853", scene.t_end), ("rk4", 1.0)):
        traj = run(scene, integrator, t_end=t_end)
        E = invariants.energies(traj, model)["energy"]
        Lz = invariants.angular_momentum(traj, model)[:, 2]
        L3 = I3 * body_omega(traj)[:, 2]
        E_scale = np.max(invariants.energies(traj, model)["kinetic"])
        assert np.max(np.abs(E - E[0])) / E_scale < 1e-10, integrator
        assert np.max(np.abs(Lz - Lz[0])) / abs(L3[0]) < 1e-10, integrator
        assert np.max(np.abs(L3 - L3[0])) / abs(L3[0]) < 1e-12, integrator
        pos, vel = max_violation(model, traj)
        assert pos < 1e-9 and vel < 1e-9, (integrator, pos, vel)


def test_heavy_top_axis_matches_the_lagrange_top_in_euler_angles():
    # Euler angles z-y-z (precession phi, nutation theta, spin psi), R = Rz(phi) Ry(theta) Rz(psi),
    # I1' = I1 + m l^2 about the tip. Cyclic momenta p_psi = I3 (psi' + phi' cos theta) = I3 w3,
    # p_phi = I1' phi' sin^2 theta + p_psi cos theta; the nutation equation
    # I1' theta'' = I1' phi'^2 sin theta cos theta - p_psi phi' sin theta + m g l sin theta.
    # At psi = 0 the body rates are w1 = -phi' sin theta, w2 = theta'. Symmetry axis in world:
    # (sin theta cos phi, sin theta sin phi, cos theta).
    scene = load_scene("heavy_top", {"theta0": 0.6, "omega0": (0.5, -1.0, 30.0)})
    p = scene.params
    m, l, I1, I3, g, th0 = p["mass"], p["l"], p["I1"], p["I3"], p["g"], p["theta0"]
    w1, w2, w3 = p["omega0"]
    I1p = I1 + m * l * l
    p_psi = I3 * w3
    phid0 = -w1 / np.sin(th0)
    p_phi = I1p * phid0 * np.sin(th0) ** 2 + p_psi * np.cos(th0)

    def lagrange(t, z):
        phi, th, thd = z
        s, c = np.sin(th), np.cos(th)
        phid = (p_phi - p_psi * c) / (I1p * s * s)
        return [phid, thd, (I1p * phid**2 * s * c - p_psi * phid * s + m * g * l * s) / I1p]

    traj = run(scene, t_end=2.0)
    ref = solve_ivp(lagrange, (0.0, 2.0), [0.0, th0, w2], method="DOP853", t_eval=traj.t, **TIGHT)
    phi, th = ref.y[0], ref.y[1]
    assert np.ptp(th) > 0.5  # a real nutation, away from theta = 0
    axis_ref = np.stack([np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi), np.cos(th)], axis=1)
    axis = algebra.quat_matrix(traj.quat_WB[:, 0])[:, :, 2]
    assert np.max(np.abs(axis - axis_ref)) < 1e-10


def test_heavy_top_reaction_is_the_force_that_moves_the_centre_of_mass():
    scene = load_scene("heavy_top", {"omega0": (1.0, 2.0, 20.0)})
    model = scene.multibody()
    nem = build(model)
    y = initial_state(model, nem)
    ydot, _ = make_dynamics(nem)(0.0, y)
    force, moment = reactions(nem, 0.0, y)["top"]
    a_cm = ydot[7:10]
    np.testing.assert_allclose(force, model.bodies[0].mass * (a_cm - model.gravity_W), atol=1e-12)
    np.testing.assert_array_equal(moment, np.zeros(3))


# ---------------------------------------------------------------------------------------------
# Double pendulum.


def double_pendulum_reference(scene, t):
    """Lagrange equations in absolute angles theta (upper bar), phi (lower bar) from the downward
    vertical, positive toward +x. Bars of mass m, length L, inertia I = m (3 r^2 + L^2) / 12
    about their centres:
        M = [[m L^2/4 + I + m L^2, (m L^2 / 2) cos(theta - phi)],
             [(m L^2 / 2) cos(theta - phi), m L^2/4 + I]]
        M [theta'', phi''] = [-(m L^2/2) sin(theta - phi) phi'^2 - 3/2 m g L sin theta + F_x L cos theta,
                              (m L^2/2) sin(theta - phi) theta'^2 - 1/2 m g L sin phi]
    with F_x = F0 cos(omega_f t) at the pin (x_pin = L sin theta). A fifth state integrates the
    work of the force, F_x L cos(theta) theta'."""
    p = scene.params
    m, L, r, g, F0, wf = p["m"], p["L"], p["r"], p["g"], p["F0"], p["omega_f"]
    I = m * (3 * r * r + L * L) / 12
    a = m * L * L / 2

    def f(time, z):
        th, ph, thd, phd, _ = z
        c, s = np.cos(th - ph), np.sin(th - ph)
        M = np.array([[m * L * L / 4 + I + m * L * L, a * c], [a * c, m * L * L / 4 + I]])
        Fx = F0 * np.cos(wf * time)
        rhs = [-a * s * phd**2 - 1.5 * m * g * L * np.sin(th) + Fx * L * np.cos(th), a * s * thd**2 - 0.5 * m * g * L * np.sin(ph)]
        thdd, phdd = np.linalg.solve(M, rhs)
        return [thd, phd, thdd, phdd, Fx * L * np.cos(th) * thd]

    z0 = [p["theta0"], p["phi0"], p["dtheta0"], p["dphi0"], 0.0]
    return solve_ivp(f, (t[0], t[-1]), z0, method="DOP853", t_eval=t, **TIGHT).y


@pytest.mark.parametrize("F0", [0.0, 2.0])
def test_double_pendulum_matches_its_lagrange_equations(F0):
    scene = load_scene("double_pendulum", {"F0": F0, "omega_f": 3.0, "dtheta0": 0.5})
    L = scene.params["L"]
    traj = run(scene, t_end=3.0)
    th, ph, thd, phd, _ = double_pendulum_reference(scene, traj.t)
    zero = np.zeros_like(th)
    p1 = np.stack([L / 2 * np.sin(th), zero, -L / 2 * np.cos(th)], axis=1)
    p2 = np.stack([L * np.sin(th) + L / 2 * np.sin(ph), zero, -L * np.cos(th) - L / 2 * np.cos(ph)], axis=1)
    assert np.max(np.abs(traj.p_WCm_W[:, 0] - p1)) < 1e-10
    assert np.max(np.abs(traj.p_WCm_W[:, 1] - p2)) < 1e-10
    # Hinge axis -y: the world angular velocities are (0, -theta', 0) and (0, -phi', 0).
    assert np.max(np.abs(traj.w_WB_W[:, 0] - np.stack([zero, -thd, zero], axis=1))) < 1e-9
    assert np.max(np.abs(traj.w_WB_W[:, 1] - np.stack([zero, -phd, zero], axis=1))) < 1e-9


def test_double_pendulum_energy_and_constraints():
    scene = load_scene("double_pendulum")
    model = scene.multibody()
    for integrator, t_end in (("DOP853", scene.t_end), ("rk4", 2.0)):
        traj = run(scene, integrator, t_end=t_end)
        E = invariants.energies(traj, model)
        E_scale = np.max(np.abs(E["potential"] - E["potential"].min())) + np.max(E["kinetic"])
        assert np.max(np.abs(E["energy"] - E["energy"][0])) / E_scale < 1e-10, integrator
        pos, vel = max_violation(model, traj)
        assert pos < 1e-9 and vel < 1e-9, (integrator, pos, vel)


def test_forced_double_pendulum_energy_balance():
    # E(t) - E(0) = W(t) = integral of F . v_pin dt: W integrated along the independent Lagrange
    # solution, and W from the power on the engine's own samples (Simpson, h = 5 ms, whose
    # quadrature error is ~1e-8 J here).
    scene = load_scene("double_pendulum", {"F0": 3.0, "omega_f": 4.0})
    model = scene.multibody()
    traj = run(scene, t_end=3.0, save_every=0.005)
    E = invariants.energies(traj, model)["energy"]
    work = double_pendulum_reference(scene, traj.t)[4]
    assert np.max(np.abs(work)) > 0.1  # the force does real work
    assert np.max(np.abs(E - E[0] - work)) < 1e-10
    assert np.max(np.abs(E - E[0] - invariants.work_of_forces(traj, model))) < 1e-6


def test_hinge_reactions_transmit_no_moment_about_the_axis():
    scene = load_scene("double_pendulum", {"dtheta0": 1.0, "dphi0": -2.0, "F0": 1.0, "omega_f": 2.0})
    model = scene.multibody()
    nem = build(model)
    y = initial_state(model, nem)
    ydot, _ = make_dynamics(nem)(0.3, y)
    out = reactions(nem, 0.3, y)
    assert set(out) == {"bar1", "bar2"}
    for name, (force, moment) in out.items():
        assert abs(moment[1]) < 1e-12  # couple perpendicular to the (world y) hinge axis
    # bar2 feels only gravity and the pin reaction: m a = m g + F_pin.
    m = model.body("bar2").mass
    a_cm = split(nem, ydot)[2][1]  # d/dt v_WCm_W of bar2
    np.testing.assert_allclose(out["bar2"][0], m * (a_cm - model.gravity_W), atol=1e-12)


# ---------------------------------------------------------------------------------------------
# A mixed tree (hinge with offset pivot and skew axis, ball child, free body, full inertias).


def test_mixed_tree_conserves_energy_and_keeps_its_joints():
    model = mixed_model()
    settings = RunSettings(t_end=2.0, dt=1e-3, save_every=0.01, integrator="DOP853", **TIGHT)
    traj = ENGINE.simulate_model(model, settings)
    assert traj.ok, traj.message
    E = invariants.energies(traj, model)
    assert np.max(np.abs(E["energy"] - E["energy"][0])) / np.max(E["kinetic"]) < 1e-10
    pos, vel = max_violation(model, traj)
    assert pos < 1e-10 and vel < 1e-10
    rk4 = InhouseEngine().simulate_model(model, RunSettings(2.0, 1e-3, 0.01, "rk4"))
    assert rk4.ok
    assert np.max(np.abs(rk4.p_WCm_W - traj.p_WCm_W)) < 1e-8
    assert max(max_violation(model, rk4)) < 1e-12
