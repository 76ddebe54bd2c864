"""Comparison measures on hand-made trajectories with known answers."""

import numpy as np

from harness.measure import compare
from harness.measure import invariants
from harness.model import rotations
from harness.engines import load_scene
from harness.measure.trajectory import Trajectory


def _single_body(t, p, q, v, w, name="body"):
    n = len(t)
    return Trajectory("test", "none", (name,), t, p.reshape(n, 1, 3), q.reshape(n, 1, 4), v.reshape(n, 1, 3), w.reshape(n, 1, 3))


def test_trajectory_error_measures_position_and_geodesic_angle():
    t = np.linspace(0, 1, 5)
    z3 = np.zeros((5, 3))
    q = np.tile([1.0, 0, 0, 0], (5, 1))
    a = _single_body(t, z3, q, z3, z3)
    q_b = np.array([rotations.from_axis_angle([0, 0, 1], 0.01 * k) for k in range(5)])
    b = _single_body(t, z3 + [0, 3e-3, 4e-3], -q_b, z3, z3)  # sign-flipped quaternions
    err = compare.trajectory_error(a, b)
    assert np.isclose(err["position_max"], 5e-3)
    assert np.isclose(err["orientation_max"], 0.04)


def test_energy_and_momentum_of_a_spinning_body():
    scene = load_scene("torque_free", {"mass": 2.0, "I1": 1.0, "I2": 2.0, "I3": 3.0})
    model = scene.multibody()
    t = np.array([0.0, 1.0])
    p = np.array([[1.0, 0, 0], [1.0, 0.5, 0]])
    v = np.array([[0, 0.5, 0], [0, 0.5, 0]])
    q = np.tile([1.0, 0, 0, 0], (2, 1))
    w = np.array([[0, 0, 2.0], [0, 0, 2.0]])
    tr = _single_body(t, p, q, v, w)
    e = invariants.energies(tr, model)
    assert np.allclose(e["kinetic"], 0.5 * 2.0 * 0.25 + 0.5 * 3.0 * 4.0)
    assert np.allclose(e["potential"], 0.0)
    L = invariants.angular_momentum(tr, model)
    # r x m v = (1,0,0) x (0,1,0) = (0,0,1) plus spin I3 w = 6
    assert np.allclose(L[:, 2], 7.0)
    assert compare.energy_drift(tr, model) == 0.0
    assert compare.momentum_drift(tr, model, ["px", "Lz", "L3"]) == {"px": 0.0, "Lz": 0.0, "L3": 0.0}


def test_constraint_violation_of_a_displaced_top():
    scene = load_scene("heavy_top")
    model = scene.multibody()
    l = scene.params["l"]
    t = np.array([0.0])
    q = rotations.from_axis_angle([0, 1, 0], 0.5).reshape(1, 4)
    com = rotations.matrix(q[0]) @ np.array([0, 0, l])
    tr = _single_body(t, (com + [0, 0, 1e-3]).reshape(1, 3), q, np.zeros((1, 3)), np.zeros((1, 3)), name="top")
    assert np.isclose(compare.constraint_violation(tr, model)["position"], 1e-3)


def test_energy_balance_of_a_force_doing_known_work():
    """A free body pushed by a constant force: E - E0 equals the work, balance ~ 0."""
    from dataclasses import replace

    from harness.model.multibody import PointForce

    scene = load_scene("torque_free", {"mass": 1.0})
    model = scene.multibody()
    model = replace(model, forces=(PointForce("body", np.zeros(3), lambda t: np.array([2.0, 0, 0])),))
    t = np.linspace(0, 1, 11)
    p = np.stack([t**2, 0 * t, 0 * t], axis=1)  # a = F/m = 2
    v = np.stack([2 * t, 0 * t, 0 * t], axis=1)
    tr = _single_body(t, p, np.tile([1.0, 0, 0, 0], (11, 1)), v, np.zeros((11, 3)))
    balance, quad = compare.energy_balance(tr, model)
    assert balance < 1e-12 and quad < 1e-12
