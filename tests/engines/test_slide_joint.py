"""The slide (prismatic) joint: kinematics, in-house constraint rows (Jacobian and bias by finite
differences), the constraint measure, model checks, and the in-house engine against an
independent integration of the cart pendulum."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.measure import compare
from harness.model import kinematics
from harness.model import rotations
from harness.engines.base import RunSettings
from harness.engines.inhouse import ENGINE, build, initial_state
from harness.engines.inhouse.constraints import rows
from harness.engines.inhouse.model import join, split
from harness.engines.pinocchio.model import load_urdf
from harness.model.errors import InputError
from harness.engines.loaded_models import compare_bodies, pinocchio_bodies
from harness.model.multibody import Body, Multibody
from harness.engines import load_scene
from harness.model.sanity import check_multibody


def rotating_slide_model() -> Multibody:
    """A hinge about a tilted axis carrying a slide along a skew axis, centres of mass off the
    joint points: every term of the slide rows is exercised."""
    a = Body("a", None, "hinge", np.array([0.1, 0.2, 0.3]), np.array([0.0, 0.6, 0.8]), 2.0,
             np.array([0.2, -0.1, 0.05]), np.diag([0.3, 0.4, 0.5]))
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    b = Body("b", "a", "slide", np.array([0.3, 0.0, -0.2]), axis, 0.7, np.array([0.05, 0.1, -0.3]),
             np.array([[0.2, 0.01, 0.0], [0.01, 0.25, 0.02], [0.0, 0.02, 0.3]]))
    return Multibody(bodies=(a, b), gravity_W=np.array([0.0, 0.0, -9.81]),
                     q0={"a": np.array([0.7]), "b": np.array([0.25])}, v0={"a": np.array([1.3]), "b": np.array([-0.8])})


def test_slide_kinematics():
    model = rotating_slide_model()
    q, v = model.q0, model.v0
    st = kinematics.forward(model, q, v)
    a, b = model.bodies
    R_a = rotations.matrix(rotations.from_axis_angle(a.axis_B, q["a"][0]))
    origin_b = a.p_PB_P + R_a @ (b.p_PB_P + b.axis_B * q["b"][0])
    assert np.allclose(st["b"].p_WCm_W, origin_b + R_a @ b.p_BCm_B, atol=1e-15)
    assert rotations.geodesic_angle(st["b"].quat_WB, st["a"].quat_WB) < 1e-15
    # velocity by central differences along the joint-space motion
    h = 1e-6
    plus = kinematics.forward(model, {k: q[k] + h * v[k] for k in q}, v)
    minus = kinematics.forward(model, {k: q[k] - h * v[k] for k in q}, v)
    fd = (plus["b"].p_WCm_W - minus["b"].p_WCm_W) / (2 * h)
    assert np.allclose(st["b"].v_WCm_W, fd, atol=1e-8)


def _advance(nem, y, h):
    """The state after time h moving with constant v_WCm_W and constant body-frame w_WB_B."""
    P, Q, V, W = split(nem, y)
    dq = np.stack([rotations.from_axis_angle(w / np.linalg.norm(w), np.linalg.norm(w) * h) for w in W])
    Qh = np.stack([rotations.multiply(qi, di) for qi, di in zip(Q, dq)])
    return join(P + V * h, Qh, V, W)


@pytest.mark.parametrize("seed", [0, 1])
def test_slide_rows_jacobian_and_bias_by_finite_differences(seed):
    """Off the constraint manifold and with arbitrary velocities: dC/dt = J u and, for constant
    u = [v_WCm_W, w_WB_B], d2C/dt2 = gamma (rows of the hinge and of the slide)."""
    model = rotating_slide_model()
    nem = build(model)
    rng = np.random.default_rng(seed)
    P, Q, V, W = split(nem, initial_state(model, nem))
    Q = Q + 0.05 * rng.normal(size=Q.shape)
    Q /= np.linalg.norm(Q, axis=1, keepdims=True)
    y = join(P + 0.02 * rng.normal(size=P.shape), Q, rng.normal(size=V.shape), rng.normal(size=W.shape))
    C0, J, gamma = rows(nem, y)
    assert J.shape == (nem.nc, 6 * nem.nb) and nem.nc == 5 + 5
    h = 1e-4
    Cp, Cm = rows(nem, _advance(nem, y, h))[0], rows(nem, _advance(nem, y, -h))[0]
    u = y[7 * nem.nb :]
    assert np.allclose((Cp - Cm) / (2 * h), J @ u, atol=1e-8)
    assert np.allclose((Cp - 2 * C0 + Cm) / h**2, gamma, atol=2e-5)


def test_slide_joint_constraint_measure():
    """The measure ignores the slide's own displacement and sees an offset or a rotation."""
    scene = load_scene("cart_pendulum")
    model = scene.multibody()
    tr = ENGINE.simulate_model(model, RunSettings(0.2, 1e-3, 0.1, "rk4"))
    assert abs(tr.p_WCm_W[-1, 0, 0]) > 1e-3  # the cart moved
    viol = compare.constraint_violation(tr, model)
    assert viol["position"] < 1e-12 and viol["axis"] < 1e-12
    off = replace(tr, p_WCm_W=tr.p_WCm_W + np.array([0.0, 0.0, 1e-4]))  # both bodies lifted off the rail
    assert compare.constraint_violation(off, model)["position"] == pytest.approx(1e-4, rel=1e-6)
    tilt = rotations.from_axis_angle(np.array([0.0, 0.0, 1.0]), 1e-3)
    quat = tr.quat_WB.copy()
    quat[:, 0] = np.stack([rotations.multiply(q, tilt) for q in quat[:, 0]])
    assert compare.constraint_violation(replace(tr, quat_WB=quat), model)["axis"] >= 1e-3 * (1 - 1e-6)


def test_slide_axis_checks():
    scene = load_scene("cart_pendulum")
    model = scene.multibody()
    pmodel, _ = load_urdf(scene.urdf, scene.urdf_root_joint, model)
    wrong = replace(model, bodies=(replace(model.bodies[0], axis_B=np.array([0.0, 1.0, 0.0])),) + model.bodies[1:])
    problems = compare_bodies(pinocchio_bodies(pmodel, wrong), wrong)
    assert problems == ["cart: slide axis [1.0, 0.0, 0.0], scene says [0.0, 1.0, 0.0]"]
    with pytest.raises(InputError, match="slide axis must be a unit vector"):
        check_multibody(replace(model, bodies=(replace(model.bodies[0], axis_B=np.array([2.0, 0.0, 0.0])),) + model.bodies[1:]), "x")


def test_inhouse_cart_pendulum_matches_free_body_integration():
    """The in-house engine (slide + hinge constraints, maximal coordinates) against Lagrange's
    equations in (X, theta) written here."""
    M, m, L, r, g = 1.5, 0.8, 0.6, 0.08, 9.81
    I_c = 0.4 * m * r * r
    scene = load_scene("cart_pendulum", {"M": M, "m": m, "L": L, "r": r, "theta0": 2.0, "dX0": 0.3, "dtheta0": -1.0})

    def rhs(t, y):
        X, th, dX, dth = y
        c, s = np.cos(th), np.sin(th)
        A = np.array([[M + m, m * L * c], [m * L * c, I_c + m * L * L]])
        b = np.array([m * L * dth**2 * s, -m * g * L * s])
        ddX, ddth = np.linalg.solve(A, b)
        return [dX, dth, ddX, ddth]

    tt = np.linspace(0.0, 2.0, 201)
    sol = solve_ivp(rhs, (0.0, 2.0), [0.0, 2.0, 0.3, -1.0], t_eval=tt, method="DOP853", rtol=1e-12, atol=1e-12)
    tr = ENGINE.simulate(scene, RunSettings(2.0, 0.01, 0.01, "DOP853", rtol=1e-12, atol=1e-12))
    assert tr.ok, tr.message
    X = tr.p_WCm_W[:, 0, 0]
    th = np.arctan2(tr.p_WCm_W[:, 1, 0] - X, -tr.p_WCm_W[:, 1, 2])
    assert np.abs(X - sol.y[0]).max() < 1e-10 and np.abs(th - sol.y[1]).max() < 1e-10
    assert np.abs(tr.v_WCm_W[:, 0, 0] - sol.y[2]).max() < 1e-9


@pytest.mark.parametrize("engine", ["inhouse", "mujoco", "pinocchio"])
@pytest.mark.parametrize("name, overrides", [("cart_pendulum", {"X0": 0.3, "dX0": -0.4, "theta0": 0.7, "dtheta0": 1.1}),
                                             ("spring_pendulum", {"dr0": 0.2, "dtheta0": -0.5})])
def test_first_sample_is_the_initial_state_with_slide_joints(engine, name, overrides):
    """Every engine's slide-joint conventions (q, v along the axis in the parent frame) agree
    with harness.model.kinematics at t = 0."""
    from harness.engines import get_engine

    scene = load_scene(name, overrides)
    model = scene.multibody()
    integ = {"inhouse": "rk4", "mujoco": "RK4", "pinocchio": "rkmk4"}[engine]
    tr = get_engine(engine).simulate(scene, RunSettings(0.01, 1e-3, 0.01, integ))
    assert tr.ok, tr.message
    init = kinematics.forward(model, model.q0, model.v0)
    for i, body in enumerate(tr.body_names):
        assert np.allclose(tr.p_WCm_W[0, i], init[body].p_WCm_W, atol=1e-12)
        assert rotations.geodesic_angle(tr.quat_WB[0, i], init[body].quat_WB) < 1e-12
        assert np.allclose(tr.v_WCm_W[0, i], init[body].v_WCm_W, atol=1e-12)
        assert np.allclose(tr.w_WB_W[0, i], init[body].w_WB_W, atol=1e-12)
