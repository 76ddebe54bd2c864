"""The compiled in-house solver through the first flat position of four_bar_chain (IFToMM A02,
N = 2 parallelogram windows of slender rods, r = 5 mm): the rank of J M^-1 J^T decided on the
row-scaled matrix and every stage of the loop model evaluated at its projection onto the
constraints, as the per-state form does. Against the exact motion
(``references/four_bar_chain.exact_error_series``) and the per-state rk4 (the readable oracle).
The compiled form before 2026-11-27 (rank decided on J M^-1 J^T itself, stages not projected)
stopped at 0.715 s: "position projection did not converge". No wall-clock assertions."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from harness.engines import load_scene
from harness.engines.base import RunSettings
from harness.engines.inhouse import ENGINE, build, initial_state
from harness.engines.inhouse.compiled import kernels
from harness.engines.inhouse.compiled import solver as compiled
from harness.references import four_bar_chain as reference

# s: past the first flat position (0.715 s) of A02's motion
T_END = 1.0
DT = 1e-3


def chain(N: int = 2):
    """four_bar_chain with N windows, run by the in-house engine here whatever its [not_run] says."""
    scene = load_scene("four_bar_chain").with_params(N=N)
    return replace(scene, not_run={e: why for e, why in scene.not_run.items() if e != ENGINE.name})


def test_rk4_compiled_passes_the_first_flat_position_as_the_per_state_rk4():
    """Measured: 4.5e-11 m from the exact motion at 1 s for both forms, 1e-14 m apart (the two
    forms drift apart by round-off amplified at each later flat passage: 2e-9 m over 20 s, as a
    relative perturbation of 1e-15 of the initial state moves either form)."""
    scene = chain()
    settings = RunSettings(T_END, DT, 0.05, "rk4_compiled")
    fast = ENGINE.simulate(scene, settings)
    assert fast.ok, fast.message
    assert fast.t[-1] == pytest.approx(T_END)
    error = reference.exact_error_series(scene, fast)
    assert np.max(error) < 1e-8
    slow = ENGINE.simulate(scene, replace(settings, integrator="rk4"))
    assert slow.ok, slow.message
    np.testing.assert_allclose(fast.p_WCm_W, slow.p_WCm_W, rtol=0, atol=1e-9)
    assert np.max(np.abs(error - reference.exact_error_series(scene, slow))) < 1e-9


@pytest.mark.parametrize("method", ["dop853_compiled", "rkmk4_compiled"])
def test_the_other_compiled_methods_pass_the_first_flat_position(method):
    """Measured over 1 s: dop853_compiled (rtol 1e-13, 38 steps) 1.8e-12 m, rkmk4_compiled
    4.2e-11 m from the exact motion. Without the stage projection (the rank decided on the
    row-scaled matrix) dop853_compiled's step size underflowed at a later flat position (4.6 s)."""
    scene = chain()
    run = ENGINE.simulate(scene, RunSettings(T_END, DT, 0.05, method, rtol=1e-13, atol=1e-12))
    assert run.ok, run.message
    assert run.t[-1] == pytest.approx(T_END)
    assert np.max(reference.exact_error_series(scene, run)) < 1e-8


def test_a_loop_models_rhs_is_that_of_its_projected_stage_and_leaves_the_state_alone():
    """``rhs`` of a loop model projects a copy of its state (``stage_tol`` of the packed model):
    the caller's state is not changed (DOP853 evaluates its candidate solution there), and a
    state off the manifold has the derivative of its projection."""
    nem = build(chain().multibody())
    model = compiled.pack(nem)
    assert model[-1] > 0.0 and compiled.pack(build(load_scene("double_pendulum").multibody()))[-1] == 0.0
    ws = kernels.workspace(model)
    y = initial_state(chain().multibody(), nem)
    off = y + 1e-7 * np.random.default_rng(2).standard_normal(len(y))
    before = off.copy()
    dy_off, dy = np.empty_like(y), np.empty_like(y)
    assert kernels.rhs(0.0, off, dy_off, model, ws) == kernels.OK
    np.testing.assert_array_equal(off, before)
    projected = off.copy()
    assert kernels.project(projected, model, ws, model[-1]) == kernels.OK
    assert kernels.rhs(0.0, projected, dy, model, ws) == kernels.OK
    np.testing.assert_allclose(dy_off, dy, rtol=0, atol=1e-9 * np.max(np.abs(dy)))


@pytest.mark.parametrize("offset", [1e-7, 1e-6])
def test_rk4_compiled_takes_the_neighbours_mean_in_the_band_as_the_per_state_rk4(offset):
    """N = 12 (188 rows, the largest model the compiled form takes), rk4 at 1 ms over 0.1 s with
    a stage placed ``offset`` rad from the first flat position
    (``four_bar_chain.start_before_flat``): both forms replace the stage by its neighbours' mean
    and stay on the exact motion (measured: compiled 3.3e-11 m at both offsets; the per-state
    rk4 with the stage's own solve 2.3e-10 m). DOP853 is not affected (its own test)."""
    params = chain(12).params
    scene = chain(12).with_params(**reference.start_before_flat(params, 50.5 * DT, offset))
    settings = RunSettings(0.1, DT, 0.01, "rk4_compiled")
    fast = ENGINE.simulate(scene, settings)
    assert fast.ok, fast.message
    assert np.max(reference.exact_error_series(scene, fast)) < 1e-9
    slow = ENGINE.simulate(scene, replace(settings, integrator="rk4"))
    assert slow.ok, slow.message
    np.testing.assert_allclose(fast.p_WCm_W, slow.p_WCm_W, rtol=0, atol=1e-9)
