"""Drake engine: its URDF as read against the description, the scene's parameters reaching it
through Drake's context, its integrators' orders and error control, its reactions, and what it
does not run."""

import subprocess
import sys

import numpy as np
import pytest

from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.engines.drake.integrators import METHODS
from harness.engines.drake.model import drake_bodies, parse
from harness.measure import compare
from harness.model.scene import available_scenes
from harness.engines import load_scene
from harness.engines.as_written import as_written
from harness.engines.loaded_models import body_discrepancies

ENGINE = get_engine("drake")


def _reference(scene, t_end, save):
    return get_engine("inhouse").simulate(scene, RunSettings(t_end, save, save, "DOP853", rtol=1e-13, atol=1e-13))


@pytest.mark.parametrize("name", available_scenes())
def test_urdf_as_drake_reads_it_matches_the_description(name):
    """Mass, centre of mass, inertia, joint position, type and axis of every body, as Drake's
    own URDF parser reads the file, agree with the scene's description at its defaults."""
    scene = load_scene(name)
    model = scene.multibody()
    plant, _, joints = parse(scene.urdf, scene.urdf_root_joint, model, springs=False)
    found = body_discrepancies(drake_bodies(plant, joints, model), model, rtol=1e-9)
    assert found and all(d.passed for d in found), [d.message for d in found if not d.passed]


def test_a_moved_centre_of_mass_in_the_urdf_fails_the_model_check(tmp_path):
    """The readback is the file's, not the description echoed: bar1's inertial moved 2 cm in a
    copied URDF is a failing ``com`` discrepancy for Drake."""
    import shutil

    from harness.model.scene import MODELS_DIR

    shutil.copytree(MODELS_DIR / "double_pendulum", tmp_path / "double_pendulum")
    urdf = tmp_path / "double_pendulum" / "double_pendulum.urdf"
    text = urdf.read_text()
    assert '<origin xyz="0 0 -0.5"' in text
    urdf.write_text(text.replace('<origin xyz="0 0 -0.5"', '<origin xyz="0 0 -0.52"', 1))
    checked = as_written(load_scene("double_pendulum", models_dir=tmp_path), "drake")
    assert any("bar1: centre of mass" in p for p in checked.problems), checked.problems


def test_parameters_reach_drake_through_its_context():
    """A run with other masses and lengths (--set) agrees with the in-house reference of the same
    parameters: the scene's physics, not the file's, is what Drake integrates."""
    scene = load_scene("double_pendulum", {"m": 1.7, "L": 0.8, "theta0": 1.0})
    ref = _reference(scene, 1.0, 0.01)
    tr = ENGINE.simulate(scene, RunSettings(1.0, 1e-3, 0.01, "RK5", rtol=1e-11))
    assert tr.ok, tr.message
    assert compare.trajectory_error(tr, ref)["position_max"] < 1e-7


@pytest.mark.parametrize("method,dts", [("RK2", [0.02, 0.01, 0.005]), ("RK3_fixed", [0.04, 0.02, 0.01])])
def test_fixed_step_methods_reach_their_order(method, dts):
    """Observed order of the fixed-step methods on the plate pendulum (final-time velocities
    against DOP853 at 1e-13): within 0.3 of the nominal order."""
    scene = load_scene("plate_pendulum")
    ref = _reference(scene, 1.0, 1.0)
    errs = []
    for dt in dts:
        tr = ENGINE.simulate(scene, RunSettings(1.0, dt, 1.0, method))
        assert tr.ok, tr.message
        errs.append(np.abs(tr.w_WB_W[-1] - ref.w_WB_W[-1]).max())
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - METHODS[method].order) < 0.3), (orders, errs)


@pytest.mark.parametrize("method", ["RK3", "RK5", "Radau3"])
def test_error_controlled_methods_follow_the_target_accuracy(method):
    """Tightening Drake's target accuracy 1e-4 -> 1e-8 lowers the state error against the
    reference at least 100-fold, and costs more steps (at a maximum step, the run's dt, of the
    whole save interval, which the error control then decides below)."""
    scene = load_scene("heavy_top")
    ref = _reference(scene, 1.0, 0.05)
    err, steps = {}, {}
    for acc in (1e-4, 1e-8):
        tr = ENGINE.simulate(scene, RunSettings(1.0, 0.05, 0.05, method, rtol=acc))
        assert tr.ok, tr.message
        err[acc] = compare.trajectory_error(tr, ref)["orientation_max"]
        steps[acc] = tr.stats["steps"]
    assert err[1e-8] < err[1e-4] / 100 and steps[1e-8] > steps[1e-4], (err, steps)


def test_a_large_first_step_hint_does_not_hang():
    """Drake 1.51's error control never returns from ``AdvanceTo`` when asked for an initial
    step of 0.1 s on the heavy top; the engine leaves the first step to Drake, so a run whose
    dt (its maximum step, never passed as a first-step hint) is 0.2 s finishes (in a subprocess, so that a regression fails instead of
    hanging the suite)."""
    code = ("from harness.engines import get_engine, load_scene; "
            "from harness.engines.base import RunSettings; "
            "tr = get_engine('drake').simulate(load_scene('heavy_top'), RunSettings(2.0, 0.2, 0.2, 'RK5', rtol=1e-8)); "
            "print(tr.status)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "ok", out.stderr[-500:]


@pytest.mark.parametrize("name", ["heavy_top", "rotating_plate", "spring_pendulum", "cart_pendulum"])
def test_reactions_agree_with_the_reference(name):
    """Drake's reaction output port (rotated from the joint's child frame to world, without a
    spring's force along the slide) against the in-house multipliers."""
    scene = load_scene(name)
    ref = get_engine("inhouse").simulate(scene, RunSettings(0.5, 0.01, 0.01, "DOP853", rtol=1e-12, atol=1e-12))
    tr = ENGINE.simulate(scene, RunSettings(0.5, scene.dt, 0.01, "RK5"))
    assert tr.ok and set(tr.reactions) == set(ref.reactions)
    f_scale, m_scale = compare.reaction_scales(ref, scene.multibody())
    err = compare.reaction_error(tr, ref)
    assert err["force_max"] / f_scale < 1e-6 and err["moment_max"] / m_scale < 1e-6, err


def test_drakes_own_energy_is_the_harness_energy():
    scene = load_scene("spring_pendulum")
    tr = ENGINE.simulate(scene, RunSettings(0.5, scene.dt, 0.01, "RK5"))
    assert compare.engine_energy_mismatch(tr, scene.multibody()) < 1e-12


def test_the_rolling_disk_is_not_run_and_says_why():
    scene = load_scene("rolling_disk")
    assert "drake" in scene.not_run and "rolling constraint" in scene.not_run["drake"]
    tr = ENGINE.simulate(scene, RunSettings(0.1, scene.dt, scene.save_every, "RK5"))
    assert tr.unsupported and "rolling" in tr.message and len(tr.t) == 0


def test_preload_imports_every_pydrake_module_a_run_imports():
    """``preload`` (called by the parents of validate, stress and sweep before they fork) leaves
    a run nothing of pydrake to import: in a fresh interpreter, a run after it imports no
    further pydrake module."""
    code = (
        "import sys\n"
        "from harness.engines import get_engine, preload\n"
        "from harness.engines.base import RunSettings\n"
        "from harness.engines import load_scene\n"
        "preload(['drake'])\n"
        "before = {m for m in sys.modules if m.startswith('pydrake')}\n"
        "scenes = [load_scene(n) for n in ('heavy_top', 'spring_pendulum', 'cart_pendulum', 'torque_free')]\n"
        "scenes.append(load_scene('double_pendulum').with_params(F0=2.0, omega_f=3.0))  # a prescribed force\n"
        "for scene in scenes:\n"
        "    tr = get_engine('drake').simulate(scene, RunSettings(0.01, 0.001, 0.01, 'RK5'))\n"
        "    assert tr.ok, tr.message\n"
        "print(sorted({m for m in sys.modules if m.startswith('pydrake')} - before))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", out.stdout


def test_the_maximum_step_is_the_runs_step_never_the_save_interval():
    """Drake's error-controlled RK5 takes the run's dt as its maximum step: saved once over the
    horizon (a save interval of the whole horizon, which as a maximum step made heavy_top's run
    never return) it takes at least t_end / dt steps and ends ok."""
    scene = load_scene("heavy_top")
    t_end = 0.1
    tr = get_engine("drake").simulate(scene, RunSettings(t_end, scene.dt, t_end, "RK5"))
    assert tr.ok, tr.message
    assert tr.stats["steps"] >= round(t_end / scene.dt)
    assert f"max step {scene.dt:g} s" in tr.stats["settings"]


def test_a_state_that_turns_non_finite_ends_the_run_as_a_blowup():
    """A fixed-step RK3 far beyond its stability on a stiff spring (k/m = 1e6 1/s^2): the state
    overflows to NaN between two samples; the run ends as a blow-up (``Failure.NON_FINITE``) with
    the samples before it, never with the orientation's SVD error of reading a NaN pose (the
    stress study recorded it as an error of the worker)."""
    from harness.measure.trajectory import Failure

    scene = load_scene("spring_pendulum", {"k": 1e6, "r0": 0.18327677127551056, "theta0": 0.3})
    tr = get_engine("drake").simulate(scene, RunSettings(1.0, 0.00625, 0.025, "RK3_fixed"))
    assert tr.reason is Failure.NON_FINITE and tr.status == "blowup" and len(tr.t) >= 1, tr.message
