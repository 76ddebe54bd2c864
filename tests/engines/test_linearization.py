"""``harness.engines.linearization``: Richardson's table, the linearisation of a pendulum against its
closed form on every engine that gives its accelerations, and the Whipple bicycle's
linearisation on the in-house engine and Pinocchio against the benchmark (Meijaard et al. 2007):
the state matrix and M^-1 K0, M^-1 C1, M^-1 K2 to 8 significant digits and more, the eigenvalues,
and the weave and capsize speeds found by root finding on each engine's own linearisation to
1e-6 m/s (measured: 1e-12 relative on the matrices, 2e-12 m/s on the speeds)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from harness.engines import accelerations, load_scene, with_accelerations
from harness.model import rotations
from harness.model.builders import bicycle as bb
from harness.model.multibody import Multibody
from harness.references import bicycle as bc
from harness.engines import linearization as lz

P = bc.BicycleParams()
WEAVE_SPEED = 4.29238253634111  # m/s, Table 2(a)
CAPSIZE_SPEED = 6.02426201538837  # m/s, Table 2(a)
LINEARIZING = ("inhouse", "pinocchio")


def test_the_engines_that_give_accelerations():
    assert with_accelerations() == LINEARIZING


def test_richardson_extrapolates_central_differences():
    f, x, exact = np.sin, 0.7, np.cos(0.7)
    diffs = [(f(x + h) - f(x - h)) / (2 * h) for h in (0.2, 0.1, 0.05)]
    best, error = lz.richardson(diffs)
    assert abs(diffs[-1] - exact) > 1e-4 and abs(best - exact) < 1e-9
    assert abs(best - exact) < error < 1e-5
    assert lz.richardson(diffs[:1]) == (diffs[0], 0.0)


@dataclass(frozen=True)
class HingeAngle:
    """The one coordinate of a pendulum on a hinge to the world: its angle and rate."""

    model: Multibody
    n: int = 1

    def joint_state(self, x):
        name = self.model.bodies[0].name
        return {name: np.array([x[0]])}, {name: np.array([x[1]])}

    def accelerations(self, states, a_WCm_W, alpha_WB_W):
        body = self.model.bodies[0]
        axis = rotations.matrix(states[body.name].quat_WB) @ body.axis_B
        return np.array([axis @ alpha_WB_W[body.name]])


@pytest.mark.parametrize("engine", LINEARIZING)
def test_pendulum_linearisation_is_its_closed_form(engine):
    """The plate pendulum, theta'' = -(m g d / I_O) sin(theta - theta_e): about a state off its
    equilibrium the lower row is (-(m g d / I_O) cos(theta - theta_e), 0) and the residual the
    acceleration there."""
    scene = load_scene("plate_pendulum")
    model = scene.multibody()
    body = model.bodies[0]
    m, r, g = body.mass, np.asarray(body.p_BCm_B), float(-model.gravity_W[2])
    axis = np.asarray(body.axis_B) / np.linalg.norm(body.axis_B)
    d = np.linalg.norm(np.cross(axis, r))
    I_O = axis @ body.I_Cm_B @ axis + m * d * d
    theta_e = -np.arctan2(r[0], -r[2])  # the centre of mass below the hinge (axis -y: theta > 0 swings toward +x)
    w2 = m * g * d / I_O
    x0 = np.array([0.3, 0.5])
    lin = lz.linearize(engine, scene, HingeAngle(model), x0)
    assert lin.A[0] == pytest.approx([0.0, 1.0], abs=0.0)
    assert lin.A[1] == pytest.approx([-w2 * np.cos(x0[0] - theta_e), 0.0], rel=1e-11, abs=1e-11)
    assert lin.residual == pytest.approx([-w2 * np.sin(x0[0] - theta_e)], rel=1e-12)


def test_an_engine_without_accelerations_is_refused():
    scene = load_scene("plate_pendulum")
    with pytest.raises(NotImplementedError, match="MuJoCo gives no accelerations"):
        lz.linearize("mujoco", scene, HingeAngle(scene.multibody()))
    with pytest.raises(ValueError, match="steps must be positive"):
        lz.linearize("inhouse", scene, HingeAngle(scene.multibody()), step=0.0)


@pytest.mark.parametrize("name", ["heavy_top", "rolling_disk", "bicycle"])
def test_the_engines_accelerations_agree(name):
    """The two hooks at each scene's initial state (a free-flyer's, a ball joint's, a rolling
    contact's, three hinges deep): the same bodies' accelerations to round-off."""
    scene = load_scene(name)
    model = scene.multibody()
    a1, al1 = accelerations("inhouse", scene, model, model.q0, model.v0)
    a2, al2 = accelerations("pinocchio", scene, model, model.q0, model.v0)
    scale = max(np.abs(np.concatenate([*a1.values(), *al1.values()])).max(), 1.0)
    for b in model.body_names:
        assert np.abs(a1[b] - a2[b]).max() < 1e-11 * scale and np.abs(al1[b] - al2[b]).max() < 1e-11 * scale, b


@pytest.fixture(scope="module")
def bicycle():
    scene = load_scene("bicycle")
    return scene, scene.multibody()


def _digits(A: np.ndarray, ref: np.ndarray) -> float:
    """The fewest significant digits over the nonzero entries of ``ref`` (zeros: to 1e-12 of the
    largest entry, counted as 12)."""
    scale = np.abs(ref).max()
    nonzero = np.abs(ref) > 1e-12 * scale
    assert np.all(np.abs(A[~nonzero]) < 1e-11 * scale), A
    return float(-np.log10(np.max(np.abs(A[nonzero] - ref[nonzero]) / np.abs(ref[nonzero]))))


@pytest.mark.parametrize("engine", LINEARIZING)
def test_bicycle_state_matrix_to_published_digits(bicycle, engine):
    """About upright straight running at 0, 4.6 and 10 m/s: the lower 2x4 block of the state
    matrix against the benchmark's, at least 8 significant digits in every entry (measured: 11.9),
    its residual zero (an equilibrium), its eigenvalues those of the benchmark (Table 2)."""
    scene, model = bicycle
    for v in (0.0, 4.6, 10.0):
        lin = lz.linearize(engine, scene, bb.Coordinates(model, v))
        ref = bc.state_matrix(P, v)
        assert _digits(lin.A[2:], ref[2:]) > 10.0, v
        assert np.abs(lin.residual).max() < 1e-12
        assert lin.eigenvalues == pytest.approx(bc.eigenvalues(P, v), rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("engine", LINEARIZING)
def test_bicycle_coefficients_to_published_digits(bicycle, engine):
    """M^-1 K0, M^-1 C1 and M^-1 K2 from the engine's linearisations at 0 and 5 m/s (the
    benchmark form: ``bc.blocks``) against the printed M, C1, K0, K2: 8 significant digits at
    least (measured: 12); the form itself holds at a third speed."""
    scene, model = bicycle
    A0, A5 = (lz.linearize(engine, scene, bb.Coordinates(model, v)).A for v in (0.0, 5.0))
    M, C1, K0, K2 = bc.linearized(P)
    for got, ref in zip(bc.blocks(A0, A5, 5.0, P.g), (np.linalg.solve(M, K0), np.linalg.solve(M, C1), np.linalg.solve(M, K2))):
        assert _digits(got, ref) > 10.0
    A8 = lz.linearize(engine, scene, bb.Coordinates(model, 8.0)).A
    assert np.abs(bc.from_blocks(*bc.blocks(A0, A5, 5.0, P.g), 8.0, P.g) - A8).max() < 1e-9


@pytest.mark.parametrize("engine", LINEARIZING)
def test_bicycle_weave_and_capsize_speeds_of_the_engine(bicycle, engine):
    """The speeds where the engine's own linearisation changes stability (brentq on its spectral
    abscissa, each evaluation a fresh linearisation at that speed): Table 2's to 1e-6 m/s
    (measured 2e-12 m/s); the weave crossing is a Hopf one, the capsize one real."""
    scene, model = bicycle
    crossings = bc.stability_crossings(P, v_max=7.0, v_min=3.0, n=9,
                                       matrix=lambda v: lz.linearize(engine, scene, bb.Coordinates(model, v)).A)
    assert abs(bc.weave_speed(P, crossings=crossings) - WEAVE_SPEED) < 1e-6
    assert abs(bc.capsize_speed(P, crossings=crossings) - CAPSIZE_SPEED) < 1e-6
    assert [(x.oscillatory, x.stabilising) for x in crossings] == [(True, True), (False, False)]
