"""Exudyn and loop (cut) joints: the planar linkages (four_bar, slider_crank) with their redundant
rows left out, a spatial ball loop, a hinge loop's reaction, and the full-pivot fallback for rows
that are dependent at the initial state only (``harness.engines.exudyn.model.loop_rows``)."""

from dataclasses import replace

import numpy as np
import pytest

from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.engines.exudyn.model import loop_rows
from harness.measure import compare
from harness.model import rotations
from harness.model.builders.four_bar import bar_inertia
from harness.model.multibody import Body, LoopJoint, Multibody
from harness.model.sanity import check_loops
from harness.engines import load_scene

ENGINE = get_engine("exudyn")
INHOUSE = get_engine("inhouse")


def _x_onto(d) -> np.ndarray:
    """Quaternion (wxyz) turning body x onto the direction ``d``."""
    d = np.asarray(d, float) / np.linalg.norm(d)
    axis = np.cross([1.0, 0.0, 0.0], d)
    return rotations.from_axis_angle(axis / np.linalg.norm(axis), float(np.arctan2(np.linalg.norm(axis), d[0])))


def ball_triangle(omega: float = 3.0, spin: float = 1.0) -> Multibody:
    """Two bars on ball joints to the world at A = 0 and D = (0.6, 0, 0), their tips joined at
    T = (0.25, 0, 0.3) by a cut ball: the triangle ADT swings about the x axis under gravity (rate
    ``omega``), the left bar also spins about itself (``spin``). Three independent loop rows."""
    T, D = np.array([0.25, 0.0, 0.3]), np.array([0.6, 0.0, 0.0])
    L1, L2 = float(np.linalg.norm(T)), float(np.linalg.norm(T - D))
    q1, q2 = _x_onto(T), _x_onto(T - D)
    bodies = (
        Body("left", None, "ball", np.zeros(3), np.zeros(3), 1.0, np.array([L1 / 2, 0, 0]), bar_inertia(1.0, L1, 0.02)),
        Body("right", None, "ball", D, np.zeros(3), 1.5, np.array([L2 / 2, 0, 0]), bar_inertia(1.5, L2, 0.02)),
    )
    w = np.array([omega, 0.0, 0.0])
    v0 = {"left": rotations.matrix(q1).T @ w + np.array([spin, 0.0, 0.0]), "right": rotations.matrix(q2).T @ w}
    loop = LoopJoint("tip", "ball", "left", "right", np.array([L1, 0.0, 0.0]), np.array([L2, 0.0, 0.0]))
    model = Multibody(bodies=bodies, gravity_W=np.array([0.0, 0.0, -9.81]), q0={"left": q1, "right": q2}, v0=v0,
                      loops=(loop,))
    check_loops(model, "ball_triangle")
    return model


def collinear_bars(spin: float = 2.0) -> Multibody:
    """Two collinear bars along x on ball joints to the world at 0 and (0.7, 0, 0), their tips
    joined by a cut ball at (0.4, 0, 0), no gravity, the left bar spinning about itself: the loop's
    row along the bars is dependent at this state only (not structurally)."""
    bodies = (
        Body("left", None, "ball", np.zeros(3), np.zeros(3), 1.0, np.array([0.2, 0, 0]), bar_inertia(1.0, 0.4, 0.02)),
        Body("right", None, "ball", np.array([0.7, 0, 0]), np.zeros(3), 1.5, np.array([0.15, 0, 0]),
             bar_inertia(1.5, 0.3, 0.02)),
    )
    loop = LoopJoint("tip", "ball", "left", "right", np.array([0.4, 0.0, 0.0]), np.array([0.3, 0.0, 0.0]))
    model = Multibody(bodies=bodies, gravity_W=np.zeros(3),
                      q0={"left": np.array([1.0, 0, 0, 0]), "right": rotations.from_axis_angle(np.array([0, 0, 1.0]), np.pi)},
                      v0={"left": np.array([spin, 0.0, 0.0]), "right": np.zeros(3)}, loops=(loop,))
    check_loops(model, "collinear_bars")
    return model


def plate_on_a_loop_hinge() -> tuple[Multibody, Multibody]:
    """rotating_plate as a tree (its hinge) and as a free plate held by a cut hinge to the world at
    the same point and axis: the same motion, the bearing couple perpendicular to the axis."""
    tree = load_scene("rotating_plate").multibody()
    (plate,) = tree.bodies
    loop = LoopJoint("bearing", "hinge", "plate", None, np.zeros(3), np.zeros(3), plate.axis_B, plate.axis_B)
    omega = float(tree.v0["plate"][0])
    model = Multibody(bodies=(replace(plate, joint="free"),), gravity_W=tree.gravity_W,
                      q0={"plate": np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])},
                      v0={"plate": np.concatenate([np.zeros(3), omega * plate.axis_B])}, loops=(loop,))
    check_loops(model, "plate_on_a_loop_hinge")
    return tree, model


@pytest.mark.parametrize("name", ["four_bar", "slider_crank"])
def test_planar_linkage_closes_and_converges_at_order_two(name):
    """A planar loop closed by a hinge: Exudyn states the in-plane translations (tx, ty) and
    leaves out the 3 rows the tree's parallel hinges imply. Index 3 closes the loop's positions
    to round-off (measured 2.5e-15 m); the velocities are not constrained (the relative velocity
    at the cut point, measured 1.6e-4 / 6.4e-5 m/s at 1e-3 s, falls 4x per halved step, as at the
    tree's own joints). Against the in-house rk4 (its own error ~1e-7 m) the difference falls at
    order 2 (measured at 1e-3 s: four_bar 8.3e-5 m, 6.5e-4 rad; slider_crank 4.9e-5 m, 7.3e-4
    rad), and so does the loop's reaction on body_a (from 0.2 s, past the multipliers' start-up
    transient: 6.5e-4 and 5.8e-4 of the force scale)."""
    scene = load_scene(name)
    model = scene.multibody()
    rows = loop_rows(model)
    assert rows.rows == {"cut": ("tx", "ty")} and rows.dropped == {"cut": ("tz", "rx", "ry")} and not rows.singular
    ref = INHOUSE.simulate_model(model, RunSettings(1.0, 1e-3, 0.01, "rk4"), reactions=True)
    f_scale = compare.reaction_scales(ref, model)[0]
    errs, speeds, forces = [], [], []
    for dt in (1e-3, 5e-4):
        tr = ENGINE.simulate_model(model, RunSettings(1.0, dt, 0.01, scene.integrators["exudyn"]), reactions=True)
        assert tr.ok, tr.message
        assert "tz rx ry redundant" in tr.stats["settings"]
        closure = compare.loop_closure(tr, model)["cut"]
        assert closure["position"] < 1e-12 and closure["axis"] < 1e-12 and closure["axis_rate"] < 1e-10, closure
        assert max(compare.constraint_violation(tr, model).values()) < 1e-12
        err = compare.trajectory_error(tr, ref)
        errs.append((err["position_max"], err["orientation_max"]))
        speeds.append(closure["velocity"])
        forces.append(np.max(np.linalg.norm(tr.reactions["cut"][0][20:] - ref.reactions["cut"][0][20:], axis=-1)) / f_scale)
    assert errs[0][0] < 2e-4 and errs[0][1] < 2e-3, errs
    ratios = np.array(errs[0]) / np.array(errs[1])
    assert np.all((3.0 < ratios) & (ratios < 5.0)), (errs, ratios)
    assert speeds[0] < 4e-4 and 3.0 < speeds[0] / speeds[1] < 5.0, speeds
    assert forces[0] < 2e-3 and 3.0 < forces[0] / forces[1] < 5.0, forces


@pytest.mark.parametrize("name", ["four_bar", "slider_crank"])
def test_planar_linkage_runs_with_the_index2_method(name):
    """TrapezoidalIndex2 (velocity-level rows, Euler-parameter nodes): the loop's gap drifts at
    O(h^2) (measured 4.8e-6 and 2.1e-6 m after 1 s at 1e-3 s)."""
    scene = load_scene(name)
    tr = ENGINE.simulate(scene, RunSettings(1.0, 1e-3, 0.01, "TrapezoidalIndex2"))
    assert tr.ok, tr.message
    assert compare.loop_closure(tr, scene.multibody())["cut"]["position"] < 2e-5


def test_a_ball_loop_on_a_planar_linkage_leaves_out_the_normal_row():
    """four_bar closed by a ball instead of a hinge: the out-of-plane translation is left out, and
    the motion is the hinge-closed one (the same stated rows)."""
    model = load_scene("four_bar").multibody()
    ball = replace(model, loops=(replace(model.loops[0], kind="ball"),))
    rows = loop_rows(ball)
    assert rows.rows == {"cut": ("tx", "ty")} and rows.dropped == {"cut": ("tz",)}
    settings = RunSettings(0.5, 1e-3, 0.01, "GeneralizedAlpha")
    a, b = ENGINE.simulate_model(model, settings), ENGINE.simulate_model(ball, settings)
    assert a.ok and b.ok, b.message
    assert compare.trajectory_error(a, b)["orientation_max"] < 1e-12


def test_spatial_ball_loop_runs_and_agrees_with_inhouse():
    """A spatial loop closed by a ball (three independent rows, all stated): the gap stays at
    round-off, the motion converges to the in-house rk4's at order 2 (measured 8.0e-6 m at
    1e-3 s), and the loop's reaction (force on body_a) agrees with the in-house multipliers once
    the start-up transient of the index-3 multipliers has decayed (measured 1.3e-5 of the force
    scale from 0.2 s at 1e-3 s; 1.3e-2 at t = 0, where Exudyn's initial accelerations leave out
    the centripetal terms of joint points off the nodes)."""
    model = ball_triangle()
    rows = loop_rows(model)
    assert rows.rows == {"tip": ("tx", "ty", "tz")} and not rows.singular
    ref = INHOUSE.simulate_model(model, RunSettings(1.0, 1e-3, 0.01, "rk4"), reactions=True)
    assert ref.ok and "tip" in ref.reactions
    errs = []
    for dt in (1e-3, 5e-4):
        tr = ENGINE.simulate_model(model, RunSettings(1.0, dt, 0.01, "GeneralizedAlpha"), reactions=True)
        assert tr.ok, tr.message
        assert compare.loop_closure(tr, model)["tip"]["position"] < 1e-12
        errs.append(compare.trajectory_error(tr, ref)["position_max"])
        if dt == 1e-3:
            scale = compare.reaction_scales(ref, model)[0]
            force = np.linalg.norm(tr.reactions["tip"][0][20:] - ref.reactions["tip"][0][20:], axis=-1)
            assert np.max(force) / scale < 1e-4, np.max(force) / scale
            assert np.all(tr.reactions["tip"][1] == 0.0)  # a ball states no rotation row
    assert errs[0] < 3e-5 and 3.0 < errs[0] / errs[1] < 5.0, errs


def test_hinge_loop_reaction_is_the_tree_hinges():
    """A free plate held by a cut hinge moves as the hinged plate does, and the loop's reaction
    (on body_a: force, and the bearing couple from the multipliers of its rotation rows) is the
    tree hinge's reaction on the plate, and the in-house one."""
    tree, model = plate_on_a_loop_hinge()
    assert loop_rows(model).rows == {"bearing": ("tx", "ty", "tz", "rx", "ry")}
    settings = RunSettings(0.5, 1e-3, 0.01, "GeneralizedAlpha")
    a = ENGINE.simulate_model(tree, settings, reactions=True)
    b = ENGINE.simulate_model(model, settings, reactions=True)
    ref = INHOUSE.simulate_model(tree, RunSettings(0.5, 1e-3, 0.01, "DOP853", rtol=1e-12, atol=1e-12), reactions=True)
    assert a.ok and b.ok, b.message
    assert compare.trajectory_error(a, b)["orientation_max"] < 1e-10
    f_scale, m_scale = compare.reaction_scales(ref, tree)
    for other in (a.reactions["plate"], ref.reactions["plate"]):
        assert np.max(np.abs(b.reactions["bearing"][0] - other[0])) < 1e-6 * f_scale
        assert np.max(np.abs(b.reactions["bearing"][1] - other[1])) < 1e-6 * m_scale
    assert np.max(np.linalg.norm(b.reactions["bearing"][1], axis=-1)) > 0.1  # the couple is there


def test_rows_dependent_at_the_initial_state_only_keep_every_row():
    """Collinear bars: the loop's row along them is dependent at the initial state but not at
    random configurations, so no row is left out and the run uses the full-pivot LU (the default
    solver stops at the first step on the singular matrix)."""
    model = collinear_bars()
    rows = loop_rows(model)
    assert rows.singular and rows.rows == {"tip": ("tx", "ty", "tz")} and rows.dropped == {"tip": ()}
    tr = ENGINE.simulate_model(model, RunSettings(0.5, 1e-3, 0.01, "GeneralizedAlpha"))
    assert tr.ok, tr.message
    assert "full-pivot LU" in tr.stats["settings"]
    assert compare.loop_closure(tr, model)["tip"]["position"] < 1e-12
    ref = INHOUSE.simulate_model(model, RunSettings(0.5, 1e-3, 0.01, "rk4"))
    assert compare.trajectory_error(tr, ref)["orientation_max"] < 1e-9


def test_explicit_method_with_a_loop_joint_is_unsupported():
    """A loop joint on free bodies only (no tree joint) still needs algebraic equations."""
    _, model = plate_on_a_loop_hinge()
    tr = ENGINE.simulate_model(model, RunSettings(0.1, 1e-3, 0.01, "RK44"))
    assert tr.status == "unsupported" and "no algebraic equations" in tr.message
