"""Pinocchio with closed kinematic loops (``harness.engines.pinocchio.loops``): the cut joints as
Pinocchio's ``RigidConstraintModel``s solved by ``constraintDynamics``, projection after each step.

Runs are 1 s at dt = 1e-3 (the scenes' step). Bounds are a few times what was measured
(closure ~5e-15 m and m/s, four_bar energy drift 1.5e-8 (in-house rk4 1.4e-8), slider_crank
energy balance 2.4e-8; against the in-house rk4 on the same step: 6e-9 m, 5e-8 rad, 2e-7 m/s,
5e-7 rad/s, the two RK4s' different truncation errors)."""

import dataclasses
import types

import numpy as np
import pytest

from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.engines.pinocchio.engine import ENGINE as PINOCCHIO
from harness.measure import compare
from harness.model.multibody import LoopJoint
from harness.engines import load_scene
from harness.references import four_bar as four_bar_reference

T_END, DT = 1.0, 1e-3
SAVE = 1e-3  # fine saves: the energy balance integrates the piston's power over the samples


def _stub(scene, model, checks=None):
    """A scene that runs ``model`` (built by hand) on ``scene``'s URDF."""
    return types.SimpleNamespace(name=f"{scene.name}_custom", urdf=scene.urdf, urdf_root_joint=scene.urdf_root_joint, not_run={},
                                 checks=checks or {}, multibody=lambda: model)


@pytest.fixture(scope="module", params=["four_bar", "slider_crank"])
def runs(request):
    scene = load_scene(request.param)
    model = scene.multibody()
    pin_run = PINOCCHIO.simulate(scene, RunSettings(T_END, DT, SAVE, "rkmk4"))
    # the in-house run with its reactions (the scenes have no [checks.reaction]: asked through a stub)
    inhouse = get_engine("inhouse").simulate(_stub(scene, model, {"reaction": {}}), RunSettings(T_END, DT, SAVE, "rk4"))
    return types.SimpleNamespace(name=request.param, model=model, tr=pin_run, ih=inhouse)


def test_runs_ok_and_names_its_formulation(runs):
    tr = runs.tr
    assert tr.ok, tr.message
    assert len(tr.t) == round(T_END / SAVE) + 1
    assert tr.stats["steps"] == round(T_END / DT)
    settings = tr.stats["settings"]
    assert "constraintDynamics" in settings and "RigidConstraintModel" in settings and "mu" in settings
    assert "projection" in settings
    assert tr.stats["prox_unconverged"] == 0


def test_loop_closure_at_round_off(runs):
    model, tr = runs.model, runs.tr
    cut = compare.loop_closure(tr, model)["cut"]
    assert cut["position"] < 1e-13, cut  # m
    assert cut["velocity"] < 1e-13, cut  # m/s
    assert cut["axis"] < 1e-13, cut  # rad
    assert cut["axis_rate"] < 1e-12, cut  # rad/s
    tree = compare.constraint_violation(tr, model)
    assert tree["position"] < 1e-12 and tree["axis"] < 1e-12, tree


def test_energy_comparable_to_inhouse_rk4(runs):
    model, tr, ih = runs.model, runs.tr, runs.ih
    if model.forces:  # slider_crank: the piston force works, E - E0 - W
        ours, quadrature = compare.energy_balance(tr, model)
        theirs, _ = compare.energy_balance(ih, model)
        assert quadrature < 1e-7
    else:
        ours, theirs = compare.energy_drift(tr, model), compare.energy_drift(ih, model)
    assert ours < 5e-8, ours
    assert ours < 3.0 * theirs + 1e-9, (ours, theirs)


def test_agrees_with_inhouse(runs):
    tr, ih = runs.tr, runs.ih
    assert ih.ok, ih.message
    err = compare.trajectory_error(tr, ih)
    assert err["samples"] == len(tr.t)
    assert err["position_max"] < 1e-7, err  # m
    assert err["orientation_max"] < 1e-6, err  # rad
    assert err["velocity_max"] < 2e-6, err  # m/s
    assert err["angular_velocity_max"] < 5e-6, err  # rad/s


def test_cut_reaction_matches_inhouse(runs):
    """The cut joint's force on body_a (world) is determined in the plane of motion and agrees
    with the in-house multipliers; the moment about the hinge axis (world -y) is zero. The
    out-of-plane moment is statically indeterminate (not compared)."""
    tr, ih = runs.tr, runs.ih
    f_pin, m_pin = tr.reactions["cut"]
    f_ih, _ = ih.reactions["cut"]
    assert f_pin.shape == m_pin.shape == (len(tr.t), 3)
    scale = np.abs(f_pin).max()
    assert scale > 1.0  # N: the loop carries load
    assert np.abs(f_pin[:, [0, 2]] - f_ih[:, [0, 2]]).max() < 1e-6 * scale
    assert np.abs(f_pin[:, 1]).max() < 1e-9 * scale
    assert np.abs(m_pin[:, 1]).max() < 1e-9 * scale


@pytest.mark.parametrize("name", ["four_bar", "slider_crank"])
def test_semi_implicit_euler_keeps_the_loop_closed(name):
    scene = load_scene(name)
    model = scene.multibody()
    tr = PINOCCHIO.simulate(scene, RunSettings(0.5, DT, 0.01, "euler"))
    assert tr.ok, tr.message
    cut = compare.loop_closure(tr, model)["cut"]
    assert cut["position"] < 1e-13 and cut["velocity"] < 1e-13, cut


def _four_bar_with(loop_kind_or_loop):
    scene = load_scene("four_bar")
    model = scene.multibody()
    hinge = model.loops[0]
    loop = loop_kind_or_loop if isinstance(loop_kind_or_loop, LoopJoint) else \
        LoopJoint(hinge.name, loop_kind_or_loop, hinge.body_a, hinge.body_b, hinge.p_A, hinge.p_B)
    return scene, dataclasses.replace(model, loops=(loop,))


def test_planar_four_bar_closed_by_a_ball():
    """A ball closing the planar four-bar (3 rows, 1 redundant) gives the same motion as the
    hinge (stated by its joint point alone, the tree being planar: ``turns_about_axis_only``) and
    the same in-plane force; a ball carries no moment."""
    scene, ball = _four_bar_with("ball")
    settings = RunSettings(T_END, DT, 0.01, "rkmk4")
    tb = PINOCCHIO.simulate(_stub(scene, ball), settings)
    assert tb.ok, tb.message
    cut = compare.loop_closure(tb, ball)["cut"]
    assert set(cut) == {"position", "velocity"}
    assert cut["position"] < 1e-13 and cut["velocity"] < 1e-13, cut
    th = PINOCCHIO.simulate(scene, settings)
    err = compare.trajectory_error(tb, th)
    assert err["position_max"] < 1e-11 and err["angular_velocity_max"] < 1e-9, err
    assert np.abs(tb.reactions["cut"][0] - th.reactions["cut"][0]).max() < 1e-9 * np.abs(th.reactions["cut"][0]).max()
    assert not np.any(tb.reactions["cut"][1])
    ih = get_engine("inhouse").simulate(_stub(scene, ball), RunSettings(T_END, DT, 0.01, "rk4"))
    err = compare.trajectory_error(tb, ih)
    assert err["position_max"] < 1e-7 and err["orientation_max"] < 1e-6, err


def test_a_loop_that_cannot_close_fails_without_raising():
    scene, model = _four_bar_with("ball")
    hinge = model.loops[0]
    far = LoopJoint("cut", "ball", hinge.body_a, hinge.body_b, hinge.p_A, hinge.p_B + np.array([5.0, 0.0, 0.0]))
    _, bad = _four_bar_with(far)
    tr = PINOCCHIO.simulate(_stub(scene, bad), RunSettings(0.1, DT, 0.01, "rkmk4"))
    assert tr.status == "failed"
    assert "projection did not converge" in tr.message
    assert len(tr.t) == 0


def test_near_singular_four_bar_stays_closed():
    """four_bar_near_singular passes 2.9 deg from the singular (collinear) position each crank turn:
    the Delassus matrix becomes ill-conditioned there, the closure must not suffer."""
    scene = load_scene("four_bar_near_singular")
    model = scene.multibody()
    tr = PINOCCHIO.simulate(scene, RunSettings(T_END, DT, 0.01, "rkmk4"))
    assert tr.ok, tr.message
    cut = compare.loop_closure(tr, model)["cut"]
    assert cut["position"] < 1e-13 and cut["velocity"] < 1e-13, cut
    value, unit, _ = four_bar_reference.exact_error(scene, tr)
    assert unit == "rad" and value < 4e-5, value  # measured 1.6e-5 rad at 1 ms (4 times the scene's step)

def test_planar_hinge_is_one_point_and_a_3d_hinge_two():
    """A cut hinge whose tree path turns only about its axis (four_bar_chain's windows) is one
    CONTACT_3D point, 3 rows; bricard's (3-D loop) keeps its two points, 6 rows."""
    import pinocchio as pin
    from harness.engines.pinocchio.loops import LoopConstraints, turns_about_axis_only
    from harness.engines.pinocchio.model import load_urdf
    for name, params, rows in (("four_bar_chain", {"N": 3}, 3), ("bricard", None, 6)):
        scene = load_scene(name, params) if params else load_scene(name)
        model = scene.multibody()
        pmodel, ids = load_urdf(scene.urdf, scene.urdf_root_joint, model)
        constraints = LoopConstraints(pmodel, ids, model)
        assert constraints.nc == rows * len(model.loops), name
        assert all(turns_about_axis_only(model, loop) == (rows == 3) for loop in model.loops), name
        assert isinstance(constraints.models, pin.StdVec_RigidConstraintModel)


@pytest.mark.parametrize("windows", [2, 3])
def test_four_bar_chain_through_the_flat_position(windows):
    """IFToMM A02 with N = 2 and 3 windows through the first flat position (t = 0.715 s): every
    crank's tip against the exact motion falls at RK4's order. The windows' in-plane Delassus
    eigenvalues fall as c theta^2 there (c = 1.5 /kg at N = 2); with the former mu = 1e-6 of the
    Delassus diagonal their forces went missing near the flat position (N = 3: 8.5e-11, 5.3e-12,
    4.1e-11 m at 2, 1, 0.5 ms: rising again), with 1e-8 it falls at order 4 (measured 8.5e-11,
    5.3e-12, 3.3e-13 m; N = 2: 8.8e-11, 5.5e-12, 3.5e-13 m)."""
    from harness.references import four_bar_chain as ref
    scene = dataclasses.replace(load_scene("four_bar_chain", {"N": windows}), not_run={})
    errors = []
    for dt in (2e-3, 1e-3, 5e-4):
        tr = PINOCCHIO.simulate(scene, RunSettings(1.0, dt, 0.01, "rkmk4"))
        assert tr.ok, tr.message
        errors.append(float(np.max(ref.exact_error_series(scene, tr))))
    assert errors[1] < 2e-11, errors  # m
    assert errors[0] / errors[1] > 8.0 and errors[1] / errors[2] > 8.0, errors  # order >= 3


@pytest.mark.parametrize("offset", [1e-6, 1e-5])
def test_a_stage_next_to_the_flat_position_is_evaluated_at_its_projection(offset):
    """A02 at N = 40, rkmk4 at 1 ms over 0.1 s with a Runge-Kutta stage placed ``offset`` rad
    from the first flat position (``four_bar_chain.start_before_flat``): every stage is evaluated
    at its projection onto the loops, so the stage's velocity error is not amplified by the
    windows' near-singular rows, and every crank tip stays on the exact motion (measured 8.9e-13
    and 6.7e-13 m; with the stages unprojected 2.0e-9 and 5.5e-9 m)."""
    from harness.references import four_bar_chain

    params = load_scene("four_bar_chain").params
    scene = load_scene("four_bar_chain", four_bar_chain.start_before_flat(params, 50.5e-3, offset))
    scene = dataclasses.replace(scene, not_run={})
    traj = PINOCCHIO.simulate(scene, RunSettings(0.1, 1e-3, 0.01, "rkmk4"))
    assert traj.ok, traj.message
    assert np.max(four_bar_chain.exact_error_series(scene, traj)) < 1e-10
