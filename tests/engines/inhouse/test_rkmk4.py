"""The in-house engine's Lie-group integrator ``rkmk4`` (``harness.engines.inhouse.lie_group``):
its maps on SO(3), exactness for constant-rate rotation, its order, and its runs on jointed,
looped and rolling scenes."""

from __future__ import annotations

import numpy as np

from harness.judging.error_model import JUDGING_RESOLUTION
import pytest
from scipy.spatial.transform import Rotation

from harness.engines.base import RunSettings
from harness.engines.inhouse import ENGINE, algebra, lie_group
from harness.engines.inhouse.integrators import FIXED_STEP, LIE_GROUP, METHODS, RK4, integrate
from harness.engines.inhouse.lie_group import dexpinv, exp_right, rkmk_step
from harness.measure import exact
from harness.model import rotations
from harness.engines import load_scene


def random_unit_quaternions(rng, n):
    return algebra.normalized(rng.standard_normal((n, 4)))


def test_exp_right_is_the_hamilton_product_with_scipys_exponential():
    rng = np.random.default_rng(7)
    scales = np.repeat([1e-9, 0.01, 1.0, 3.0, 10.0], 4)[:, None]  # tiny to several turns (rad)
    for q, theta in zip(random_unit_quaternions(rng, 20), rng.standard_normal((20, 3)) * scales):
        expected = rotations.multiply(q, Rotation.from_rotvec(theta).as_quat(scalar_first=True))
        got = np.array(exp_right(q, theta))
        np.testing.assert_allclose(got * np.sign(got @ expected), expected, rtol=0, atol=1e-15)  # q and -q: one rotation
    assert exp_right((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0)) == (1.0, 0.0, 0.0, 0.0)
    # R exp(hat(Theta)): the increment is in the body frame (right multiplication)
    R = rotations.matrix(np.array(exp_right(rotations.from_axis_angle([1, 0, 0], 0.4), (0.0, 0.0, 0.3))))
    np.testing.assert_allclose(R, Rotation.from_rotvec([0.4, 0, 0]).as_matrix() @ Rotation.from_rotvec([0, 0, 0.3]).as_matrix(),
                               atol=1e-15)


def body_rate(q, theta, k, eps=1e-6):
    """The body angular velocity of ``q (x) exp_q(theta + s k)`` at s = 0 (central differences)."""
    qp, qm = np.array(exp_right(q, theta + eps * k)), np.array(exp_right(q, theta - eps * k))
    qt = np.array(exp_right(q, theta))
    dq = (qp - qm) / (2 * eps)
    return 2.0 * rotations.multiply(qt * [1, -1, -1, -1], dq)[1:]


def test_dexpinv_maps_the_body_rate_to_the_rate_of_theta():
    # R(s) = R0 exp(hat(Theta + s dexpinv(Theta, w))) turns at body rate w, up to the truncated
    # series' remainder O(|Theta|^4 |w|) (order 4: terms to ad^2; ad^3 has no term).
    rng = np.random.default_rng(3)
    q, theta, w = random_unit_quaternions(rng, 1)[0], 0.01 * rng.standard_normal(3), rng.standard_normal(3)
    np.testing.assert_allclose(body_rate(q, theta, np.array(dexpinv(theta, w, 4))), w, atol=1e-9)
    np.testing.assert_allclose(body_rate(q, theta, np.array(dexpinv(theta, w, 6))), w, atol=1e-9)
    # the spatial-frame sign (w - 1/2 [Theta, w]) or no correction misses by O(|Theta| |w|)
    assert np.max(np.abs(body_rate(q, theta, w - 0.5 * np.cross(theta, w)) - w)) > 1e-3 * np.linalg.norm(theta)
    assert np.max(np.abs(body_rate(q, theta, w) - w)) > 1e-3 * np.linalg.norm(theta)
    assert dexpinv(theta, w, 1) == tuple(w)  # order 1: the identity
    with pytest.raises(ValueError, match="series"):
        dexpinv(theta, w, 12)


def test_rkmk4_is_registered_as_a_fixed_step_fourth_order_method():
    record = METHODS["rkmk4"]
    assert (record.kind, record.order, record.stages) == ("fixed", 4, 4)
    assert FIXED_STEP["rkmk4"] is RK4 and "rkmk4" in LIE_GROUP
    with pytest.raises(ValueError, match="13 entries per body"):
        integrate(lambda t, y: -y, np.ones(12), np.linspace(0.0, 1.0, 3), "rkmk4")
    with pytest.raises(ValueError, match="13 entries per body"):
        integrate(lambda t, y: -y, np.ones(26), np.linspace(0.0, 1.0, 3), "rkmk4", bodies=1)


def free_spin(omega0, I=(1.0, 2.0, 3.0), **extra):
    return load_scene("torque_free", {"omega0": omega0, "I1": I[0], "I2": I[1], "I3": I[2], **extra})


@pytest.mark.parametrize("omega0, inertia", [((0.0, 0.0, 5.0), (1.0, 2.0, 3.0)),     # a principal axis
                                             ((2.0, -1.0, 3.0), (2.0, 2.0, 2.0))])   # any axis, spherical inertia
def test_constant_rate_rotation_is_integrated_exactly(omega0, inertia):
    scene = free_spin(omega0, inertia)
    w = np.array(omega0)
    errors = {}
    for method in ("rkmk4", "rk4"):
        traj = ENGINE.simulate(scene, RunSettings(t_end=10.0, dt=0.01, save_every=0.5, integrator=method))
        assert traj.ok and traj.stats["steps"] == 1000
        q0 = traj.quat_WB[0, 0]
        exact_q = np.array([rotations.multiply(q0, Rotation.from_rotvec(w * t).as_quat(scalar_first=True)) for t in traj.t])
        errors[method] = float(np.max(rotations.geodesic_angle(traj.quat_WB[:, 0], exact_q)))
    assert errors["rkmk4"] < 1e-12, errors
    assert errors["rk4"] > 1e-9, errors  # the quaternion RK4 of the same step has a measurable error


def test_rkmk4_keeps_quaternions_unit_without_renormalising():
    scene = free_spin((1.0, 0.3, 0.6))
    from harness.engines.inhouse import build, initial_state, make_rhs
    from harness.engines.inhouse.newton_euler import Baumgarte

    model = scene.multibody()
    nem = build(model)
    rhs = make_rhs(nem, Baumgarte(0.0, 1.0))
    t_save = np.linspace(0.0, 20.0, 11)
    norms = {}
    for method in ("rkmk4", "rk4"):
        res = integrate(rhs, initial_state(model, nem), t_save, method, steps_per_save=50)  # dt = 0.04 s, no post_step
        assert res.status == "ok" and res.rhs_evals == 4 * res.steps
        norms[method] = float(np.max(np.abs(np.linalg.norm(res.y[:, 3:7], axis=1) - 1.0)))
    assert norms["rkmk4"] < 1e-14 and norms["rk4"] > 1e-9, norms


def test_the_rotating_plate_on_its_hinge_is_exact():
    # Ex. 4.6.1: uniform rotation about a fixed axis, the scene where a hinge-angle integrator beat
    # the quaternion RK4; at a 5x coarser step than the scene's both stay on the hinge.
    scene = load_scene("rotating_plate")
    settings = {m: RunSettings(t_end=1.0, dt=0.005, save_every=0.05, integrator=m) for m in ("rkmk4", "rk4")}
    err = {}
    for method, s in settings.items():
        traj = ENGINE.simulate(scene, s)
        assert traj.ok, traj.message
        err[method] = exact.exact_error(scene, traj, s)[0]
    assert err["rkmk4"] < 1e-13 and err["rk4"] > 1e-9, err


def state_error(traj, ref):
    return max(np.max(np.abs(traj.p_WCm_W - ref.p_WCm_W)), np.max(np.abs(traj.v_WCm_W - ref.v_WCm_W)),
               np.max(np.abs(traj.w_WB_W - ref.w_WB_W)),
               np.max(np.abs(algebra.quat_matrix(traj.quat_WB) - algebra.quat_matrix(ref.quat_WB))))


@pytest.mark.parametrize("scene_name, t_end, dts", [("torque_free", 2.0, (0.05, 0.025)), ("heavy_top", 1.0, (0.01, 0.005))])
def test_measured_order_is_four(scene_name, t_end, dts):
    scene = load_scene(scene_name)
    ref = ENGINE.simulate(scene, RunSettings(t_end=t_end, dt=1e-3, save_every=0.1, integrator="DOP853", rtol=1e-13, atol=1e-14))
    errors = [state_error(ENGINE.simulate(scene, RunSettings(t_end=t_end, dt=dt, save_every=0.1, integrator="rkmk4")), ref)
              for dt in dts]
    order = np.log2(errors[0] / errors[1])
    assert abs(order - 4.0) < 0.3, (errors, order)


def test_the_dexpinv_correction_is_what_makes_it_fourth_order(monkeypatch):
    # without the second-order term of dexp^-1 the method drops to third order, without both to second
    scene = load_scene("torque_free")
    ref = ENGINE.simulate(scene, RunSettings(t_end=2.0, dt=1e-3, save_every=0.1, integrator="DOP853", rtol=1e-13, atol=1e-14))
    for series, expected in (((1.0, 0.5, 0.0), 3.0), ((1.0, 0.0, 0.0), 2.0)):
        monkeypatch.setattr(lie_group, "DEXPINV_SERIES", series)
        e = [state_error(ENGINE.simulate(scene, RunSettings(t_end=2.0, dt=dt, save_every=0.1, integrator="rkmk4")), ref)
             for dt in (0.1, 0.05)]
        assert abs(np.log2(e[0] / e[1]) - expected) < 0.3, (series, e)


@pytest.mark.parametrize("scene_name", ["heavy_top", "double_pendulum", "slider_crank", "rolling_disk"])
def test_rkmk4_agrees_with_rk4_on_jointed_looped_and_rolling_scenes(scene_name):
    # Ball and hinge joints, a closed loop, a rolling contact: both fourth-order methods converge
    # to the same motion: their difference is their truncation errors, so it falls at about the
    # fourth order when the step halves, or sits below what the harness resolves
    # (``JUDGING_RESOLUTION``: slider_crank's projections leave 1.6e-12 rad).
    scene = load_scene(scene_name)
    t_end = 0.1
    diffs = []
    for dt in (2 * scene.dt, scene.dt):
        runs = {m: ENGINE.simulate(scene, RunSettings(t_end=t_end, dt=dt, save_every=2 * scene.dt * round(0.01 / scene.dt),
                                                      integrator=m)) for m in ("rkmk4", "rk4")}
        assert all(r.ok for r in runs.values()), {m: r.message for m, r in runs.items()}
        a, b = runs["rkmk4"], runs["rk4"]
        diffs.append((np.max(np.abs(a.p_WCm_W - b.p_WCm_W)), np.max(rotations.geodesic_angle(a.quat_WB, b.quat_WB))))
        np.testing.assert_allclose(np.linalg.norm(a.quat_WB, axis=-1), 1.0, atol=1e-15)
        assert "rkmk4" in a.stats["settings"] and "projection" in a.stats["settings"]
    length = max(float(np.max(np.abs(b.p_WCm_W))), 1.0)
    for coarse, fine, scale in zip(diffs[0], diffs[1], (length, 1.0)):
        assert fine <= JUDGING_RESOLUTION * scale or coarse / fine > 2 ** 3.5, (scene_name, diffs)


def test_rkmk_step_of_a_vector_only_rhs_is_the_rk4_step_on_the_vectors():
    # with w = 0 throughout, the orientation does not move and the vector part is RK4's
    rng = np.random.default_rng(1)
    y0 = np.concatenate([rng.standard_normal(3), random_unit_quaternions(rng, 1)[0], rng.standard_normal(3), np.zeros(3)])
    vector = np.concatenate([np.ones(3), np.zeros(4), np.ones(3), np.zeros(3)])
    lam = vector * rng.standard_normal(13)

    def f(t, y):
        return lam * y + t * vector

    from harness.engines.inhouse.integrators import rk_step

    out = rkmk_step(f, 0.3, y0, 0.1, RK4, 1)
    ref = rk_step(f, 0.3, y0, 0.1, RK4)
    np.testing.assert_allclose(out[:3], ref[:3], rtol=1e-15)
    np.testing.assert_allclose(out[7:], ref[7:], rtol=1e-15)
    np.testing.assert_array_equal(out[3:7], y0[3:7])
