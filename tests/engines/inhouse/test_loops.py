"""The in-house engine on closed loops: cut joints as rows of the KKT system, redundant rows
solved by the pseudo-inverse, the loop closed to round-off by the projection, and the motion
equal to the exact four-bar reference."""

from dataclasses import replace

import numpy as np
import pytest

from harness.engines.base import RunSettings
from harness.engines.inhouse import InhouseEngine, build
from harness.engines.inhouse.constraints import RANK_RTOL, DynamicsError, rows, solve_rows, spd_solve
from harness.engines.inhouse.model import initial_state
from harness.measure import compare
from harness.model.builders.four_bar import AXIS
from harness.model.multibody import LoopJoint
from harness.engines import load_scene
from harness.references import four_bar as reference

ENGINE = InhouseEngine()


def settings(integrator="rk4", t_end=1.0, dt=1e-3):
    return RunSettings(t_end=t_end, dt=dt, save_every=0.01, integrator=integrator, rtol=1e-11, atol=1e-11)


def test_a_planar_loop_has_redundant_rows_and_the_pseudo_inverse_solves_them():
    model = load_scene("four_bar").multibody()
    nem = build(model)
    assert nem.redundant and nem.nc == 3 * 5 + 5  # three tree hinges and the cut hinge
    _, J, _ = rows(nem, initial_state(model, nem))
    A = J @ nem.Minv @ J.T
    w = np.linalg.eigvalsh(A)
    # 3 translational dof of the plane + the tree's 3 angles - 1 dof of the linkage: rank nc - 3
    assert int(np.sum(w > RANK_RTOL * w[-1])) == nem.nc - 3
    b = J @ np.linspace(-1.0, 1.0, J.shape[1])  # a right-hand side in the range of J
    x = solve_rows(A, b, True)
    assert np.allclose(A @ x, b, atol=1e-9 * np.abs(b).max())
    with pytest.raises(DynamicsError):
        spd_solve(A, b)  # Cholesky refuses the singular matrix: the tree scenes' solve could not do this


def test_the_fixed_step_run_closes_the_loop_to_round_off_and_follows_the_exact_motion():
    scene = load_scene("four_bar")
    model = scene.multibody()
    traj = ENGINE.simulate(scene, settings())
    assert traj.ok, traj.message
    closure = compare.loop_closure(traj, model)["cut"]
    assert closure["position"] < 1e-12 and closure["axis"] < 1e-12
    assert closure["velocity"] < 1e-8  # the velocity projection uses the step's starting Jacobian
    assert compare.energy_drift(traj, model) < 5e-8  # RK4 at 1 ms: 1.3e-8
    value, unit, _ = reference.exact_error(scene, traj)
    assert unit == "rad" and value < 2e-7


def test_the_adaptive_reference_uses_the_loop_baumgarte_gain_and_stays_in_the_plane():
    scene = load_scene("four_bar")
    model = scene.multibody()
    stiff = ENGINE.simulate(scene, settings("DOP853", t_end=2.0))
    weak = InhouseEngine(loop_baumgarte_ratio=0.2).simulate(scene, settings("DOP853", t_end=2.0))
    assert stiff.ok and weak.ok
    assert "Baumgarte" in stiff.stats["settings"]
    # the loop gain holds the out-of-plane drift that the tree scenes' gain lets grow
    assert compare.constraint_violation(stiff, model)["axis"] < 1e-10
    assert compare.constraint_violation(weak, model)["axis"] > 10 * compare.constraint_violation(stiff, model)["axis"]
    # the exact motion to the run's error bound: the larger of its accuracy (rtol per step) and the
    # round-off of the pseudo-inverse's solves (kappa eps per step, kappa the condition number of
    # J M^-1 J^T's kept spectrum, 1.8e5 here), summed over its steps. Measured across OpenBLAS
    # kernels: 1.3e-9 to 1.02e-8 rad, against a bound of 1.2e-8 rad
    nem = build(model)
    _, J, _ = rows(nem, initial_state(model, nem))
    w = np.linalg.eigvalsh(J @ nem.Minv @ J.T)
    kappa = w[-1] / w[w > RANK_RTOL * w[-1]][0]
    bound = stiff.stats["steps"] * max(settings().rtol, kappa * np.finfo(float).eps)
    assert reference.exact_error(scene, stiff)[0] < bound


def test_a_loop_closed_by_a_ball_moves_like_the_one_closed_by_a_hinge():
    scene = load_scene("four_bar")
    model = scene.multibody()
    cut = model.loops[0]
    ball = replace(model, loops=(replace(cut, kind="ball"),))
    a = ENGINE.simulate_model(model, settings(t_end=0.5))
    b = ENGINE.simulate_model(ball, settings(t_end=0.5))
    assert a.ok and b.ok
    assert compare.trajectory_error(a, b)["position_max"] < 1e-12


def test_cut_reactions_are_reported_and_in_plane_for_a_planar_loop():
    scene = load_scene("four_bar")
    model = scene.multibody()
    nem = build(model)
    from harness.engines.inhouse import reactions

    out = reactions(nem, 0.0, initial_state(model, nem))
    force, moment = out["cut"]
    assert abs(force[1]) < 1e-9 * np.linalg.norm(force) and np.linalg.norm(force) > 0.1  # in the x-z plane, N
    assert np.linalg.norm(moment) < 1e-9  # no couple is needed in a planar loop: the minimum-norm one is zero


def test_a_loop_to_the_world_closes_a_pendulum():
    """A double pendulum whose tip is pinned to the world by a cut ball joint is a rigid triangle
    when it closes: it must not move (its only motion left is none)."""
    from harness.model.builders.double_pendulum import build as pendulum

    base = pendulum({"m": 1.0, "L": 1.0, "r": 0.01, "g": 9.81, "theta0": 0.6, "phi0": -0.4, "dtheta0": 0.0,
                     "dphi0": 0.0, "F0": 0.0, "omega_f": 0.0})
    from harness.model import kinematics

    states = kinematics.forward(base, base.q0, base.v0)
    from harness.model import rotations

    st = states["bar2"]
    tip = st.p_WCm_W + rotations.matrix(st.quat_WB).reshape(3, 3) @ np.array([0.0, 0.0, -0.5])
    pinned = replace(base, loops=(LoopJoint("pin", "ball", "bar2", None, np.array([0.0, 0.0, -1.0]), tip, AXIS, AXIS),))
    traj = ENGINE.simulate_model(pinned, settings(t_end=0.5))
    assert traj.ok, traj.message
    assert np.max(np.abs(traj.p_WCm_W - traj.p_WCm_W[0])) < 1e-12
