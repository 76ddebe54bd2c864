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


# ---------------------------------------------------------------------------------------------
# Singular positions: four_bar_chain (IFToMM A02), N parallelogram windows through their flat
# position, where each window's in-plane rows lose rank.


def chain_state(n, theta, dtheta, **params):
    """(scene, model, nem, y) of four_bar_chain with n windows on its parallelogram branch at crank
    angle theta (rad from +x toward +z; 0 is flat) turning at dtheta (rad/s)."""
    from harness.engines.inhouse.model import state_at
    from harness.model.builders.four_bar_chain import coupler, crank

    scene = load_scene("four_bar_chain", {"N": n, **params})
    model = scene.multibody()
    nem = build(model)
    q = {crank(i, n): np.array([theta]) for i in range(n + 1)} | {coupler(i, n): np.array([-theta]) for i in range(n)}
    v = {crank(i, n): np.array([dtheta]) for i in range(n + 1)} | {coupler(i, n): np.array([-dtheta]) for i in range(n)}
    return scene, model, nem, state_at(model, q, v, nem)


def test_near_a_flat_position_the_windows_rows_are_kept_whatever_the_bars_radius():
    """Slender bars (r = 5 mm) make J M^-1 J^T's largest eigenvalue ~1e5 (spin about a bar's own
    axis); 2e-3 rad from flat the windows' in-plane rows are ~1e-5 of it... and below 1e-10 of it
    in the unscaled matrix. The rank is decided on the row-scaled matrix: the velocity projection
    then satisfies every row (it left the windows' rows unprojected before)."""
    from harness.engines.inhouse.constraints import pseudo_inverse

    _, _, nem, y = chain_state(2, 2e-3, -5.0)
    _, J, _ = rows(nem, y)
    A = J @ nem.Minv @ J.T
    w = np.linalg.eigvalsh(A)
    assert w[-1] > 1e4 and np.sum(w > RANK_RTOL * w[-1]) < np.linalg.matrix_rank(J, tol=1e-9)  # unscaled: rows lost
    u = np.random.default_rng(0).normal(size=J.shape[1])
    projected = u - pseudo_inverse(A)(J @ u) @ (J @ nem.Minv)
    assert np.max(np.abs(J @ projected)) < 1e-9 * np.max(np.abs(J @ u))


def test_a_loop_model_evaluates_each_stage_at_its_projection():
    """Off the manifold near a flat position, the plain right-hand side turns a stage's velocity
    error c into a folding acceleration ~c / theta^2; evaluated at the stage's projection it stays
    at the exact one. On the manifold both are the same."""
    from harness.engines.inhouse import Baumgarte, projected_stages
    from harness.engines.inhouse.model import split
    from harness.engines.inhouse.newton_euler import make_rhs

    _, _, nem, y = chain_state(2, 1e-4, -5.0)
    plain, staged = make_rhs(nem, Baumgarte(omega=0.0)), projected_stages(nem, Baumgarte(omega=0.0))
    exact = split(nem, plain(0.0, y))[2]
    assert np.max(np.abs(split(nem, staged(0.0, y))[2] - exact)) < 1e-9 * np.max(np.abs(exact))
    off = y.copy()
    off[7 * nem.nb :] += 1e-7 * np.random.default_rng(1).normal(size=6 * nem.nb)  # a stage's velocity error
    err_plain = np.max(np.abs(split(nem, plain(0.0, off))[2] - exact))
    err_staged = np.max(np.abs(split(nem, staged(0.0, off))[2] - exact))
    assert err_staged < 1e-4 * np.max(np.abs(exact)) and err_plain > 100.0 * err_staged


def test_two_windows_pass_the_flat_position_on_the_exact_motion():
    """N = 2 (A02's trap: a window may fold into an anti-parallelogram at the flat position,
    t = 0.715 s; the projection used to stall there): per-state rk4 at 1 ms through it."""
    from harness.references import four_bar_chain

    scene = load_scene("four_bar_chain", {"N": 2})
    traj = ENGINE.simulate(scene, RunSettings(t_end=1.0, dt=1e-3, save_every=0.05, integrator="rk4"))
    assert traj.ok, traj.message
    assert four_bar_chain.exact_error(scene, traj)[0] < 1e-9  # measured 4.5e-11 m


def test_a_large_model_solves_its_rows_sparse_as_the_dense_form_does():
    """From SPARSE_ROWS rows on (four_bar_chain N = 14: 215 rows) the rows are factored sparse
    (SuperLU, regularised, refined): the same accelerations as the dense pseudo-inverse; the
    compiled form leaves such a model to the per-state one."""
    from harness.engines.inhouse import fast_method
    from harness.engines.inhouse.model import SPARSE_ROWS
    from harness.engines.inhouse.newton_euler import make_rhs
    from harness.measure.trajectory import Failure

    scene, model, nem, y = chain_state(14, 0.7, -3.0)
    assert nem.nc >= SPARSE_ROWS and nem.Minv_sparse is not None and nem.J_fixed is not None
    dense = replace(nem, Minv_sparse=None, J_fixed=None)
    a_sparse, a_dense = make_rhs(nem)(0.0, y), make_rhs(dense)(0.0, y)
    assert np.max(np.abs(a_sparse - a_dense)) < 1e-10 * np.max(np.abs(a_dense))
    assert fast_method("rk4", model) == "rk4"
    run = ENGINE.simulate(scene, RunSettings(t_end=0.01, dt=1e-3, save_every=0.01, integrator="rk4_compiled"))
    assert run.reason is Failure.UNSUPPORTED and "constraint rows" in run.message


def chain_through_flat(windows: int, dt: float, offset: float):
    """four_bar_chain with ``windows`` windows started on its exact motion so that rk4's two
    middle stages of step 51 (at 50.5 dt) land ``offset`` rad past the first flat position."""
    from harness.references import four_bar_chain

    params = load_scene("four_bar_chain", {"N": windows}).params
    return load_scene("four_bar_chain", {"N": windows, **four_bar_chain.start_before_flat(params, 50.5 * dt, offset)})


@pytest.mark.parametrize("offset", [1e-7, 1e-6, 1e-5])
def test_a_stage_in_the_band_of_the_flat_position_takes_its_neighbours_mean(offset, monkeypatch):
    """A02 at N = 40 (605 rows, the sparse solve), rk4 at 1 ms over 0.1 s with a stage placed
    ``offset`` rad from flat, where the windows' rows are dropped: the stage takes the mean of its
    neighbours along its motion (``newton_euler.SINGULAR_RESIDUAL``), and every crank tip stays on
    the exact motion (measured 1.0e-9, 1.4e-10, 3.8e-11 m). With the stage's own solve the run
    stopped at step 51 ("position projection did not converge") at 1e-7 rad and left the exact
    motion by 7.5e-2 m at 1e-6 rad and 2.2e-5 m at 1e-5 rad."""
    from harness.engines.inhouse import newton_euler
    from harness.references import four_bar_chain

    scene = chain_through_flat(40, 1e-3, offset)
    settings = RunSettings(t_end=0.1, dt=1e-3, save_every=0.01, integrator="rk4")
    traj = ENGINE.simulate(scene, settings)
    assert traj.ok, traj.message
    assert np.max(four_bar_chain.exact_error_series(scene, traj)) < 1e-8
    if offset == 1e-6:  # the band's own solve, for the record that the mean is what passes
        monkeypatch.setattr(newton_euler, "SINGULAR_RESIDUAL", np.inf)
        own = ENGINE.simulate(scene, settings)
        assert not own.ok or np.max(four_bar_chain.exact_error_series(scene, own)) > 1e-6
