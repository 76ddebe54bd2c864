"""harness.references.rolling_cone: the closed forms of Ex. 3.4.1 and Ex. 4.7.1, verified.

Three independent routes to the normal force at the base rim: the simplified closed form, the
moment equation about the apex before simplification, and a numerical one that differentiates
the angular momentum about the apex along the exact rotation (no Omega x L algebra). The
closed forms are then checked against runs of two engines of different formulations (in-house
maximal coordinates with the apex and rim rows in one KKT system; Pinocchio reduced coordinates
with a spherical joint and the rim rows), and the printed result is shown wrong against them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import tplquad

from harness.engines import get_engine
from harness.model.builders import rolling_cone as builder
from harness.model import rotations
from harness.model.errors import InputError
from harness.engines import load_scene
from harness.references import rolling_cone as rc
from harness.validate.run import default_settings, reference_settings

CASES = [  # (m, L, beta, g, v, phi0)
    (1.0, 0.2, 0.3, 9.81, 0.5, 0.0),
    (2.0, 0.35, 0.9, 9.81, -1.2, 1.0),
    (0.4, 0.1, 0.15, 3.7, 0.25, -2.0),
    (1.0, 0.2, 0.6, 0.0, 1.0, 0.3),
]


@pytest.mark.parametrize("case", CASES)
def test_normal_force_closed_form_equals_the_moment_equation(case):
    p = rc.ConeParams(*case)
    assert rc.normal_force(p) == pytest.approx(rc.normal_force_from_moments(p), rel=1e-13, abs=1e-13)


def test_apex_moments_by_quadrature():
    """I_a = 3 m R^2 / 10 and I_t = 3 m L^2 / 5 + 3 m R^2 / 20 about the apex, by integrating over
    the solid cone (z from the apex along the axis, radius r <= z tan(beta)); the printed
    I_x'x' = 3 m L^2 / 10 is not the axial moment."""
    m, L, beta = 1.3, 0.25, 0.4
    R = L * np.tan(beta)
    rho = m / (np.pi * R * R * L / 3.0)

    def integral(f):  # over z in [0, L], r in [0, z tan(beta)], theta in [0, 2 pi], volume element r dr dtheta dz
        return rho * tplquad(lambda th, r, z: f(r, th, z) * r, 0.0, L, 0.0, lambda z: z * np.tan(beta),
                             0.0, 2.0 * np.pi, epsabs=1e-14, epsrel=1e-12)[0]

    I_axial = integral(lambda r, th, z: r * r)
    I_trans = integral(lambda r, th, z: (r * np.sin(th)) ** 2 + z * z)
    I_a, I_t = rc.apex_moments(rc.ConeParams(m, L, beta, 9.81, 0.0))
    assert I_axial == pytest.approx(I_a, rel=1e-9)
    assert I_trans == pytest.approx(I_t, rel=1e-9)
    assert abs(I_axial - 0.3 * m * L * L) > 0.5 * I_axial  # the printed axial moment
    # the builder's inertia about the centre of mass, shifted to the apex (Steiner), is the same
    I_cm = builder.cone_inertia(m, L, beta)
    assert I_cm[2, 2] == pytest.approx(I_a, rel=1e-12)
    assert I_cm[0, 0] + m * (0.75 * L) ** 2 == pytest.approx(I_t, rel=1e-12)


@pytest.mark.parametrize("case", CASES)
def test_normal_force_from_the_numerical_rate_of_angular_momentum(case):
    """dL_O/dt by central differences of L_O(t) = R I_O R^T w along the exact rotation
    (``orientation``), w from central differences of R; then the e_y moment balance about the
    apex with gravity at the centre of mass and N at the rim's contact point gives N."""
    p = rc.ConeParams(*case)
    I_a, I_t = rc.apex_moments(p)
    I_O = np.diag([I_t, I_t, I_a])
    h = 1e-4 / max(abs(rc.precession_rate(p)) / np.sin(p.beta), 1.0)

    def L_O(t):
        R = rc.orientation(p, np.array([t - h, t, t + h]))
        dR = (R[2] - R[0]) / (2.0 * h)
        W = dR @ R[1].T
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        return R[1] @ I_O @ R[1].T @ w

    t = 0.37
    dL = (L_O(t - h) - 8.0 * L_O(t - h / 2.0) + 8.0 * L_O(t + h / 2.0) - L_O(t + h)) / (6.0 * h)
    phi = p.phi0 + rc.precession_rate(p) * t
    e_x = np.array([np.cos(phi), np.sin(phi), 0.0])
    e_y = np.array([-np.sin(phi), np.cos(phi), 0.0])
    r_G = 0.75 * p.L * (np.cos(p.beta) * e_x + np.array([0.0, 0.0, np.sin(p.beta)]))
    r_C = p.L / np.cos(p.beta) * e_x
    # dL . e_y = (r_G x (-m g e_z)) . e_y + (r_C x N e_z) . e_y
    M_gravity = np.cross(r_G, [0.0, 0.0, -p.m * p.g]) @ e_y
    N = (M_gravity - dL @ e_y) / -(np.cross(r_C, [0.0, 0.0, 1.0]) @ e_y)
    assert N == pytest.approx(rc.normal_force(p), rel=1e-6, abs=1e-6 * rc.force_scale(p))


def _runs(overrides, t_end=0.4):
    scene = load_scene("rolling_cone", overrides)
    ref = get_engine("inhouse").simulate(scene, replace(reference_settings(scene), t_end=t_end))
    pin = get_engine("pinocchio").simulate(scene, replace(default_settings(scene, "pinocchio"), t_end=t_end))
    return scene, ref, pin


@pytest.mark.parametrize("overrides", [{}, {"beta": 0.9, "v": -1.2, "mass": 2.0, "L": 0.35, "phi0": 1.0}])
def test_runs_of_two_formulations_hold_the_closed_forms(overrides):
    scene, ref, pin = _runs(overrides)
    p = rc.ConeParams.of_scene(scene.params)
    for traj in (ref, pin):
        assert traj.ok, traj.message
        N = traj.reactions["contact"][0][:, 2]
        assert np.max(np.abs(N - rc.normal_force(p))) < 1e-9 * rc.force_scale(p)
        value, _, detail = rc.exact_error(scene, traj)
        assert value < 1e-7, detail


def test_printed_normal_force_is_wrong_and_the_cone_never_lifts_off():
    """Ex. 4.7.1 prints a normal force that falls with the speed and turns negative ("the cone
    loses contact"); the runs show it rising: at v = 1.5 m/s the printed value is -5.75 N (lift-off
    predicted) where both engines hold 9.7548 N on the rim."""
    scene, ref, pin = _runs({"v": 1.5})
    p = rc.ConeParams.of_scene(scene.params)
    assert rc.textbook_normal_force(p) < 0.0 < rc.normal_force(p)
    for traj in (ref, pin):
        N = traj.reactions["contact"][0][1:, 2]
        assert np.all(N > 0.9 * rc.normal_force(p))
        assert np.max(np.abs(N - rc.textbook_normal_force(p))) > 10.0
    # the normal force grows with the speed (step 4), the printed one falls
    slow, fast = rc.ConeParams(1.0, 0.2, 0.3, 9.81, 0.5), rc.ConeParams(1.0, 0.2, 0.3, 9.81, 1.0)
    assert rc.normal_force(fast) > rc.normal_force(slow)
    assert rc.textbook_normal_force(fast) < rc.textbook_normal_force(slow)


@pytest.mark.parametrize("beta", [0.0, -0.1, np.pi / 2, 2.0, float("nan")])
def test_builder_refuses_a_half_apex_angle_out_of_range(beta):
    params = {"mass": 1.0, "L": 0.2, "beta": beta, "h": 0.001, "g": 9.81, "v": 0.5, "phi0": 0.0}
    with pytest.raises(InputError, match="beta"):
        builder.build(params)


def test_initial_state_rolls_without_slip():
    """The builder's initial angular velocity is along the contact generator: the apex and the
    rim's contact point are at rest (Ex. 3.4.1)."""
    model = builder.build({"mass": 1.0, "L": 0.2, "beta": 0.5, "h": 0.001, "g": 9.81, "v": 0.8, "phi0": 0.7})
    R = rotations.matrix(model.q0["cone"])
    w_W = R @ model.v0["cone"]
    r_C = 0.2 / np.cos(0.5) * np.array([np.cos(0.7), np.sin(0.7), 0.0])
    assert np.allclose(np.cross(w_W, r_C), 0.0, atol=1e-14)
    assert (R @ [0.0, 0.0, 1.0])[2] == pytest.approx(np.sin(0.5), rel=1e-14)
    assert np.linalg.norm(np.cross(w_W, 0.2 * R @ [0.0, 0.0, 1.0])) == pytest.approx(0.8, rel=1e-14)
