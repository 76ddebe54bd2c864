"""The stiff flyball governor (``references/flyball_governor.py``) against independent checks.

* the initial state: each spring exactly at its rest length, as the benchmark sets it;
* the reduced equations: the energy balance against the dampers' dissipation, an implicit
  integration (Radau) against the explicit reference (DOP853), the linearised modes;
* the published output: the library's reference s(t) as plotted (29 points over 3 s);
* the in-house engine (maximal coordinates, Newton-Euler with the joints as constraints: another
  formulation) on the scene, and a perturbed start that works the dampers;
* the exact check of a run.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.engines import get_engine, load_scene
from harness.engines.base import RunSettings
from harness.measure import invariants
from harness.references import flyball_governor as fg

SCENE = load_scene("flyball_governor")
P = fg.FlyballParams.from_mapping(SCENE.params)
T10 = np.linspace(0.0, 10.0, 1001)


def test_each_spring_starts_at_its_rest_length():
    L, dL_da, dL_ds = fg.spring_length(P, P.s0, P.alpha0)
    assert L == pytest.approx(P.l0, abs=1e-15)  # sqrt((0.5 cos 30)^2 + 0.25^2) = 0.5
    h = 1e-6
    assert dL_da == pytest.approx((fg.spring_length(P, P.s0, P.alpha0 + h)[0]
                                   - fg.spring_length(P, P.s0, P.alpha0 - h)[0]) / (2 * h), rel=1e-8)
    assert dL_ds == pytest.approx((fg.spring_length(P, P.s0 + h, P.alpha0)[0]
                                   - fg.spring_length(P, P.s0 - h, P.alpha0)[0]) / (2 * h), rel=1e-8)


@pytest.mark.parametrize("over", [{}, {"ds0": 0.3, "dalpha0": -0.5}])
def test_energy_balances_the_dampers_dissipation(over):
    """E(t) - E(0) = W(t), the dampers' work -integral of c L'^2 integrated with the motion (one
    more state), to 1e-11 of the energy over 0.5 s; the perturbed start works the dampers (the
    scene's start hardly does: 3.1e-3 J over 10 s, README)."""
    p = fg.FlyballParams.from_mapping({**SCENE.params, **over})
    f = fg.rhs(p)

    def augmented(t, y):
        return [*f(t, y[:7]), float(fg.energy(p, y[:7, None])[1][0])]

    t = np.linspace(0.0, 0.5, 51)
    sol = solve_ivp(augmented, (0.0, 0.5), [*fg._y0(p), 0.0], method="DOP853", t_eval=t, rtol=1e-12, atol=1e-12)
    assert sol.success
    E, _ = fg.energy(p, sol.y[:7])
    assert np.max(np.abs(E - E[0] - sol.y[7])) < 1e-11 * abs(E[0])
    assert sol.y[7, -1] < (-1e-2 if over else 0.0)  # dissipated, and plainly so when the dampers work


def test_implicit_and_explicit_integrations_agree():
    with warnings.catch_warnings():  # Radau's numerical Jacobian overflows on the cyclic angle's column (harmless)
        warnings.simplefilter("ignore", RuntimeWarning)
        radau = fg.reference_solution(P, T10, method="Radau")
    dop = fg.reference_solution(P, T10)
    assert np.max(np.abs(radau.s - dop.s)) < 1e-9
    assert np.max(np.abs(radau.alpha - dop.alpha)) < 1e-9
    assert np.max(np.abs(radau.phi - dop.phi)) < 1e-8
    assert dop.s[-1] == pytest.approx(0.619623, abs=5e-7)  # s(10 s), README
    assert np.allclose(dop.alpha[:, 0], dop.alpha[:, 1], rtol=0, atol=1e-12)  # symmetric start, symmetric motion
    assert np.max(np.abs(dop.omega * np.array([fg._inertia_about_axis(fg._constants(P), a) for a in dop.alpha])
                         - fg.angular_momentum(P))) < 1e-12


def test_the_modes_at_the_start():
    """The stiffness the README states: decay rates 8.1e3, 1.5e3, ~20, ~20 1/s and the nod at 7.35 rad/s."""
    lam = fg.eigenvalues(P)
    real = np.sort(-lam[np.abs(lam.imag) < 1e-6].real)
    assert real == pytest.approx([20.05, 20.30, 1450.3, 8117.2], rel=1e-3)
    nod = lam[np.abs(lam.imag) > 1e-6]
    assert np.abs(nod.imag) == pytest.approx([7.346, 7.346], rel=1e-3) and np.all(np.abs(nod.real) < 1e-3)


def test_reproduces_the_published_curve():
    """The library's reference s(t) as plotted (``PUBLISHED_CURVE``, read off the figure to ~0.3 mm)."""
    t, s = np.array(fg.PUBLISHED_CURVE).T
    ref = fg.reference_solution(P, np.concatenate([[0.0], t]))
    diff = s - ref.s[1:]
    assert np.max(np.abs(diff)) < fg.PUBLISHED_RESOLUTION
    assert np.max(np.abs(diff)) < 2.5e-4 and abs(np.mean(diff)) < 1e-4  # no bias: the same system


@pytest.mark.parametrize("over", [{}, {"ds0": 0.3, "dalpha0": -0.5, "omega0": 4.0}])
def test_in_house_engine_agrees(over):
    """Maximal coordinates, each spring-damper a pair of forces at its end points (compiled DOP853,
    rtol 1e-11) against the reduced equations: the slider's height, both rods' angles, the shaft's
    angle."""
    scene = load_scene("flyball_governor", over)
    traj = get_engine("inhouse").simulate(scene, RunSettings(2.0, 1e-3, 1e-3, "dop853_compiled", rtol=1e-11,
                                                             atol=1e-11))
    assert traj.ok, traj.message
    ref = fg.reference_solution(scene.params, traj.t)
    s, alpha, phi = fg.run_coordinates(traj)
    assert np.max(np.abs(s - ref.s)) < 1e-8
    assert np.max(np.abs(alpha - ref.alpha)) < 1e-8
    assert np.max(np.abs(np.angle(np.exp(1j * (phi - ref.phi))))) < 1e-8


def test_in_house_energy_balance_with_the_dampers_work():
    """``invariants.work_of_forces`` counts the dampers' power (-c L'^2, Simpson on the samples):
    E - E0 - W stays within 1e-8 of the energy (RK4 at 1e-4 s: 2e-9) on samples every step, as validate saves a
    run that does work; without the dampers' work it would be off by the energy they dissipate."""
    traj = get_engine("inhouse").simulate(SCENE, RunSettings(1.0, 1e-4, 1e-4, "rk4_compiled"))
    model = SCENE.multibody()
    E = invariants.energies(traj, model)["energy"]
    W = invariants.work_of_forces(traj, model)
    assert np.max(np.abs(E - E[0] - W)) < 1e-8 * abs(E[0])
    assert W[-1] < -1e-4 and np.max(np.abs(E - E[0] - W)) < 1e-2 * abs(W[-1])


def test_exact_check_of_a_run():
    traj = get_engine("inhouse").simulate(SCENE, RunSettings(1.0, 1e-4, 1e-2, "rk4_compiled"))
    value, unit, detail = fg.exact_error(SCENE, traj)
    assert unit == "m" and value < 1e-8 and "rod angles" in detail
    assert np.max(fg.exact_error_series(SCENE, traj)) == value
    bad = traj.__class__(**{**traj.__dict__, "p_WCm_W": traj.p_WCm_W + np.array([0.0, 0.0, 1e-3])})
    assert fg.exact_error(SCENE, bad)[0] == pytest.approx(1e-3, rel=1e-4)
