"""The in-house engine ends a run that blows up (a non-finite state, or a speed beyond
``BLOWUP_SPEED`` = 1e8 m/s or rad/s, the bound of MuJoCo and Pinocchio) with status "blowup",
a one-line message (time and what), and the finite samples before it; never "ok"."""

from __future__ import annotations

import numpy as np
import pytest

from harness.engines.base import RunSettings
from harness.engines.base import BLOWUP_SPEED
from harness.engines.inhouse import ENGINE
from harness.engines.inhouse.integrators import Result
from harness.engines import load_scene


def _sound(traj) -> None:
    """Every kept sample finite and below the speed bound (m/s, rad/s)."""
    for a in (traj.p_WCm_W, traj.quat_WB, traj.v_WCm_W, traj.w_WB_W):
        assert np.all(np.isfinite(a))
    assert np.max(np.linalg.norm(traj.v_WCm_W, axis=-1), initial=0.0) <= BLOWUP_SPEED
    assert np.max(np.linalg.norm(traj.w_WB_W, axis=-1), initial=0.0) <= BLOWUP_SPEED


def test_per_state_unstable_step_is_a_blowup_with_samples_before():
    # spring 1.6e7 N/m on a 1 kg bob: 4000 rad/s, RK4 at dt = 1 ms (h omega = 4 > 2.83) grows ~3.7x a step
    scene = load_scene("spring_pendulum", {"k": 1.6e7, "theta0": 0.0})
    traj = ENGINE.simulate(scene, RunSettings(0.1, 1e-3, 1e-3, "rk4"))
    assert traj.status == "blowup" and not traj.ok
    assert "beyond" in traj.message and "t = " in traj.message and "\n" not in traj.message
    assert 0 < len(traj.t) < 100
    _sound(traj)
    t_bad = float(traj.message.split("t = ")[1].split()[0])
    assert t_bad == pytest.approx(traj.t[-1] + 1e-3)


@pytest.mark.parametrize("method", ["rk4", "rk4_compiled"])
def test_initial_state_beyond_the_bound_is_a_blowup_at_t0(method):
    # cart_pendulum of the issue: bob speed L * dtheta0 = 1e105 m/s at t = 0 (energies overflow)
    scene = load_scene("cart_pendulum", {"m": 1e100, "L": 1e5, "dtheta0": 1e100})
    traj = ENGINE.simulate(scene, RunSettings(0.1, 1e-3, 1e-2, method))
    assert traj.status == "blowup"
    assert "at t = 0 s" in traj.message
    assert len(traj.t) == 0


def test_spin_beyond_the_bound_is_a_blowup():
    scene = load_scene("torque_free", {"omega0": (2e8, 0.0, 0.0)})
    traj = ENGINE.simulate(scene, RunSettings(1e-6, 1e-8, 1e-7, "rk4_compiled"))
    assert traj.status == "blowup" and "angular speed" in traj.message and "rad/s" in traj.message


@pytest.mark.parametrize("bad", ["nan", "speed"])
def test_compiled_path_cuts_at_the_first_bad_sample(monkeypatch, bad):
    """The compiled path applies the same guard to what its kernel returns: here a kernel result
    whose fourth sample is NaN (or too fast) while the kernel said "ok"."""
    from harness.engines.inhouse.compiled import solver as compiled

    real = compiled.integrate_fixed

    def spoiled(*args, **kwargs):
        res = real(*args, **kwargs)
        y = res.y.copy()
        nb = y.shape[1] // 13
        y[3, 7 * nb] = np.nan if bad == "nan" else 10 * BLOWUP_SPEED  # x-velocity of body 0
        return Result(res.t, y, res.steps, res.rhs_evals, res.wall_s, "ok", "")

    monkeypatch.setattr(compiled, "integrate_fixed", spoiled)
    traj = ENGINE.simulate(load_scene("double_pendulum"), RunSettings(0.1, 1e-3, 1e-2, "rk4_compiled"))
    assert traj.status == "blowup"
    assert len(traj.t) == 3
    assert "t = 0.03 s" in traj.message
    assert ("non-finite" in traj.message) == (bad == "nan")
    _sound(traj)


def test_sound_run_stays_ok():
    traj = ENGINE.simulate(load_scene("spring_pendulum"), RunSettings(0.1, 1e-3, 1e-2, "rk4"))
    assert traj.ok and len(traj.t) == 11
