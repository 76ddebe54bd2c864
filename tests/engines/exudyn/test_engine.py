"""Exudyn engine: its model against the description, its integrators' observed orders, its
reactions and rolling-disc joint against the in-house reference, and its failure statuses."""

import numpy as np
import pytest

from harness.engines import get_engine, integrator_of
from harness.engines.base import RunSettings
from harness.engines.exudyn.integrators import IMPLICIT, METHODS, NODE_TYPE
from harness.engines.exudyn.model import build
from harness.measure import compare
from harness.model.scene import available_scenes
from harness.engines import load_scene
from harness.engines.as_written import as_written
from harness.engines.loaded_models import body_discrepancies, exudyn_bodies, exudyn_gravity

ENGINE = get_engine("exudyn")


@pytest.mark.parametrize("name", available_scenes())
def test_model_as_built_matches_the_description(name):
    """Mass, centre of mass, inertia, joint position, type and axis, and gravity, as Exudyn
    holds them, agree with the scene's description (node type of the scene's integrator)."""
    scene = load_scene(name)
    model = scene.multibody()
    system = build(model, NODE_TYPE[integrator_of(scene, "exudyn")])
    found = body_discrepancies(exudyn_bodies(system, model), model, rtol=1e-12)
    # Exudyn holds the inertia about the body's reference point (its frame origin): the inertia
    # about the centre of mass read back from it loses m |c|^2 / |I| of its digits (the
    # pendulum's 1 mm bob 1 m from its frame: 2.5e6), round-off and no more
    cancel = {b.name: 1.0 + b.mass * float(np.dot(b.p_BCm_B, b.p_BCm_B)) / float(np.abs(b.I_Cm_B).max())
              for b in model.bodies}
    bad = [d.message for d in found
           if not (d.value <= d.tolerance * (cancel.get(d.body, 1.0) if d.quantity == "inertia" else 1.0))]
    assert found and not bad, bad
    assert np.allclose(exudyn_gravity(system), model.gravity_W, rtol=0, atol=1e-15)


def test_model_check_sees_a_changed_parameter():
    """The readback is not the description echoed: a system built from other parameters
    disagrees with the defaults on the body it changes (mass, and a moved hinge point)."""
    scene = load_scene("double_pendulum")
    moved = load_scene("double_pendulum", {"m": 1.5, "L": 1.2}).multibody()
    found = body_discrepancies(exudyn_bodies(build(moved, "RotationRotationVector"), moved), scene.multibody())
    failing = {(d.body, d.quantity) for d in found if not d.passed}
    assert ("bar1", "mass") in failing and ("bar2", "joint_position") in failing


def test_validate_model_check_builds_exudyn():
    checked = as_written(load_scene("heavy_top"), "exudyn")
    assert checked.discrepancies and not checked.problems
    assert {d.quantity for d in checked.discrepancies} >= {"mass", "com", "inertia", "joint_type", "gravity"}


def _order(name, method, dts, t_end, overrides=None):
    """Observed order of convergence of ``method`` on scene ``name`` from runs at ``dts``
    (each halving the step) against the in-house DOP853 reference: log2 of successive
    error ratios of the final-time state (centre-of-mass velocity and angular velocity)."""
    scene = load_scene(name, overrides or {})
    save = t_end
    ref = get_engine("inhouse").simulate(scene, RunSettings(t_end, save, save, "DOP853", rtol=1e-13, atol=1e-13))
    errs = []
    for dt in dts:
        tr = ENGINE.simulate(scene, RunSettings(t_end, dt, save, method))
        assert tr.ok, tr.message
        errs.append(max(np.abs(tr.w_WB_W[-1] - ref.w_WB_W[-1]).max(), np.abs(tr.v_WCm_W[-1] - ref.v_WCm_W[-1]).max()))
    errs = np.array(errs)
    return np.log2(errs[:-1] / errs[1:]), errs


@pytest.mark.parametrize("method", IMPLICIT)
def test_implicit_methods_converge_at_order_two(method):
    """Generalized-alpha (index 3) and trapezoidal (index 2) on a jointed scene: order 2."""
    orders, errs = _order("plate_pendulum", method, [0.02, 0.01, 0.005], 1.0)
    assert np.all(np.abs(orders - METHODS[method].order) < 0.3), (orders, errs)


@pytest.mark.parametrize("method", ["RK44", "RK67"])
def test_explicit_methods_reach_their_order(method):
    """RK44 and RK67 on a free body: the observed order reaches the nominal one (4, 6),
    measured at steps large enough to stay above round-off."""
    dts = [0.2, 0.1, 0.05] if method == "RK44" else [0.4, 0.2, 0.1]
    orders, errs = _order("torque_free", method, dts, 4.0)
    assert np.all(orders > METHODS[method].order - 0.4), (orders, errs)


def test_explicit_method_on_a_jointed_scene_is_unsupported():
    tr = ENGINE.simulate(load_scene("heavy_top"), RunSettings(0.1, 0.001, 0.01, "RK44"))
    assert tr.status == "unsupported" and "no algebraic equations" in tr.message and len(tr.t) == 0


def test_solver_failure_is_a_status_not_an_exception():
    """A step far too large for Newton: the run stops with status failed and a message."""
    tr = ENGINE.simulate(load_scene("double_pendulum", {"theta0": 3.0, "dphi0": 40.0}), RunSettings(20.0, 0.5, 0.5, "GeneralizedAlpha"))
    assert tr.status in ("failed", "blowup") and tr.message


@pytest.mark.parametrize("name", ["heavy_top", "rotating_plate", "spring_pendulum", "cart_pendulum"])
def test_reactions_agree_with_the_reference(name):
    """Joint forces and moments from Exudyn's multipliers (ball: Force; hinge and slide:
    ForceLocal and the moments of their rotation conditions) against the in-house reference's
    multipliers, at the scene's step."""
    scene = load_scene(name)
    t_end = 0.5
    ref = get_engine("inhouse").simulate(scene, RunSettings(t_end, 0.01, 0.01, "DOP853", rtol=1e-12, atol=1e-12))
    tr = ENGINE.simulate(scene, RunSettings(t_end, scene.dt, 0.01, "GeneralizedAlpha"))
    assert tr.ok and set(tr.reactions) == set(ref.reactions)
    f_scale, m_scale = compare.reaction_scales(ref, scene.multibody())
    err = compare.reaction_error(tr, ref)
    # generalized-alpha's step error at the scene's step; largest on the fast top: 1.3e-4
    assert err["force_max"] / f_scale < 1e-3, err
    assert err["moment_max"] / m_scale < 1e-3, err


def test_rolling_disc_joint_rolls_the_rim_edge():
    """Exudyn's own rolling-disc joint, placed at the lower rim edge, follows the reference
    (which models the edge of a disk of half-thickness h) with second-order convergence
    (slip, contact height and the steady circle are judged by validate on every engine)."""
    scene = load_scene("rolling_disk")
    ref = get_engine("inhouse").simulate(scene, RunSettings(0.5, 0.01, 0.01, "DOP853", rtol=1e-12, atol=1e-12))
    errs = []
    for dt in (5e-4, 2.5e-4):
        tr = ENGINE.simulate(scene, RunSettings(0.5, dt, 0.01, "GeneralizedAlpha"))
        assert tr.ok, tr.message
        errs.append(compare.trajectory_error(tr, ref)["position_max"])
    assert 3.0 < errs[0] / errs[1] < 5.0, errs


def test_rolling_contact_force_needs_the_damped_method(monkeypatch):
    """The rolling-disc joint's force (its ``ForceLocal`` turned to world) converges to the
    reference's at spectral radius 0.9; undamped (1) it stays about 6 % off at every step,
    though the motion converges (the force that the motion implies, m a_cm - m g from
    Exudyn's own velocities, is right)."""
    from harness.engines.exudyn import engine as exudyn_engine
    from harness.measure import contact_metrics

    scene = load_scene("rolling_disk")
    model = scene.multibody()
    ref = get_engine("inhouse").simulate(scene, RunSettings(0.2, 0.01, 0.01, "DOP853", rtol=1e-12, atol=1e-12))
    other = contact_metrics._contacts_only(ref, ["contact"], True)
    scale = compare.reaction_scales(other, model)[0]
    err = {}
    for radius in (0.9, 1.0):
        monkeypatch.setattr(exudyn_engine, "SPECTRAL_RADIUS", radius)
        for dt in (2.5e-4, 1.25e-4):
            tr = ENGINE.simulate(scene, RunSettings(0.2, dt, 0.01, "GeneralizedAlpha"))
            own = contact_metrics._contacts_only(tr, ["contact"], True)
            err[radius, dt] = compare.reaction_error(own, other)["force_max"] / scale
            assert compare.trajectory_error(tr, ref)["position_max"] < 1e-5
    assert err[0.9, 1.25e-4] < err[0.9, 2.5e-4] / 4 and err[0.9, 1.25e-4] < 1e-3, err
    assert min(err[1.0, 2.5e-4], err[1.0, 1.25e-4]) > 0.03, err


def test_undamped_index3_multipliers_wander(monkeypatch):
    """Why generalized-alpha runs at spectral radius 0.9. Spring pendulum, joint-force error
    after 0.5 s against the reference: at 0.9 it falls at order 2 down to 2.5e-4 s (then the
    index-3 conditioning ~ 1/h^2 shows: 1.3e-3 N at 1e-4 s); at 1 (undamped) it grows over
    100-fold from 1e-3 s to 1e-4 s (0.13 N), while the motion converges at both."""
    from harness.engines.exudyn import engine as exudyn_engine

    scene = load_scene("spring_pendulum")
    ref = get_engine("inhouse").simulate(scene, RunSettings(0.5, 0.01, 0.01, "DOP853", rtol=1e-12, atol=1e-12))
    err = {}
    for radius in (0.9, 1.0):
        monkeypatch.setattr(exudyn_engine, "SPECTRAL_RADIUS", radius)
        for dt in (1e-3, 2.5e-4, 1e-4):
            tr = ENGINE.simulate(scene, RunSettings(0.5, dt, 0.01, "GeneralizedAlpha"))
            err[radius, dt] = compare.reaction_error(tr, ref)["force_max"]
            assert compare.trajectory_error(tr, ref)["position_max"] < 1e-4
    assert err[0.9, 2.5e-4] < err[0.9, 1e-3] / 10, err
    assert err[1.0, 1e-4] > 100 * err[1.0, 1e-3], err
    assert err[0.9, 1e-4] < err[1.0, 1e-4] / 50, err


def test_samples_are_given_on_the_save_grid_as_every_engine_gives_them():
    """Exudyn's stored times carry ~1e-17 s of round-off; the trajectory gives the grid
    k * save_every itself, to the bit, as the other engines do (the closed forms cache their
    solutions by the times, so the runs of one scene share them)."""
    scene = load_scene("four_bar")
    settings = RunSettings(t_end=0.3, dt=scene.dt, save_every=0.01, integrator=scene.integrators["exudyn"])
    traj = get_engine("exudyn").simulate(scene, settings)
    assert traj.ok, traj.message
    np.testing.assert_array_equal(traj.t, np.arange(31) * 0.01)
