"""``rkmk4_compiled`` (the Runge-Kutta-Munthe-Kaas form of the compiled explicit Runge-Kutta
kernel) against the per-state ``rkmk4`` (the readable oracle). No wall-clock assertions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from harness.engines import integrator
from harness.engines.base import RunSettings
from harness.engines.inhouse import ENGINE, build, initial_state, projection_tolerance
from harness.engines.inhouse.compiled import solver as compiled
from harness.engines.inhouse.integrators import RK4
from harness.measure import exact
from harness.model import rotations
from harness.engines import load_scene


def max_difference(a, b):
    return max(np.max(np.abs(a.p_WCm_W - b.p_WCm_W)), np.max(np.abs(a.v_WCm_W - b.v_WCm_W)),
               np.max(np.abs(a.w_WB_W - b.w_WB_W)), np.max(rotations.geodesic_angle(a.quat_WB, b.quat_WB)))


def test_rkmk4_compiled_is_a_fixed_step_fourth_order_method():
    record = integrator("inhouse", "rkmk4_compiled")
    assert (record.kind, record.order, record.stages) == ("fixed", 4, 4)
    np.testing.assert_array_equal(compiled.dexpinv_series(RK4), [1.0, 0.5, 1.0 / 12.0])
    assert compiled.dexpinv_series(None).shape == (0,)


@pytest.mark.parametrize("name", ["torque_free", "heavy_top", "double_pendulum", "cart_pendulum", "spring_pendulum"])
def test_rkmk4_compiled_reproduces_the_per_state_rkmk4(name):
    scene = load_scene(name)
    dt = scene.dt * 5
    slow = ENGINE.simulate(scene, RunSettings(0.5, dt, 0.05, "rkmk4"))
    fast = ENGINE.simulate(scene, RunSettings(0.5, dt, 0.05, "rkmk4_compiled"))
    assert fast.ok and slow.ok, fast.message
    assert (fast.engine, fast.integrator) == ("inhouse", "rkmk4_compiled")
    assert max_difference(fast, slow) < 1e-11
    n = int(round(0.5 / dt))
    assert fast.stats["steps"] == n and fast.stats["rhs_evals"] == 4 * n
    assert "compiled (Numba)" in fast.stats["settings"] and "projection" in fast.stats["settings"]


def test_constant_rate_rotation_is_exact_in_the_compiled_form():
    scene = load_scene("torque_free", {"omega0": (0.0, 0.0, 5.0)})
    traj = ENGINE.simulate(scene, RunSettings(t_end=10.0, dt=0.01, save_every=0.5, integrator="rkmk4_compiled"))
    assert traj.ok
    q0 = traj.quat_WB[0, 0]
    want = np.array([rotations.multiply(q0, Rotation.from_rotvec([0.0, 0.0, 5.0 * t]).as_quat(scalar_first=True))
                     for t in traj.t])
    assert np.max(rotations.geodesic_angle(traj.quat_WB[:, 0], want)) < 1e-12
    plate = load_scene("rotating_plate")
    settings = RunSettings(t_end=2.0, dt=0.005, save_every=0.05, integrator="rkmk4_compiled")
    assert exact.exact_error(plate, ENGINE.simulate(plate, settings), settings)[0] < 1e-13


def test_a_lie_group_batch_is_the_scalar_trajectories():
    scene = load_scene("heavy_top")
    model = scene.multibody()
    nem = build(model)
    packed, tol = compiled.pack(nem), projection_tolerance(nem)
    rng = np.random.default_rng(4)
    y0 = initial_state(model, nem)
    Y = np.repeat(y0[None], 3, axis=0)
    Y[:, 10 * nem.nb:] += 0.5 * rng.standard_normal((3, 3 * nem.nb))  # other spins
    Yend, words = compiled.run_batch(packed, Y, 20, 1e-3, threads=2, proj_tol=tol, lie_group=True)
    assert list(words) == ["ok"] * 3
    for i, y in enumerate(Y):
        one = compiled.integrate_fixed(packed, y, np.array([0.0, 0.02]), steps_per_save=20, proj_tol=tol, lie_group=True)
        np.testing.assert_allclose(Yend[i], one.y[-1], rtol=0, atol=1e-12 * max(1.0, np.max(np.abs(y))))
        plain = compiled.integrate_fixed(packed, y, np.array([0.0, 0.02]), steps_per_save=20, proj_tol=tol)
        assert np.max(np.abs(plain.y[-1] - one.y[-1])) > 0.0
