"""The PyBullet engine: first order on a tree scene, its loaded model against the description,
and the scenes it does not model said why."""

from __future__ import annotations

import numpy as np
import pytest

from harness.engines import get_engine
from harness.engines.as_written import as_written
from harness.engines.base import RunSettings
from harness.measure import exact
from harness.engines import load_scene

ENGINE = get_engine("pybullet")


def _exact_error(scene, dt: float, t_end: float = 2.0) -> float:
    settings = RunSettings(t_end, dt, 0.01, "semi_implicit_euler")
    traj = ENGINE.simulate(scene, settings)
    assert traj.status == "ok", traj.message
    value, _, _ = exact.exact_error(scene, traj, settings, run=ENGINE.simulate)
    return float(value)


@pytest.mark.parametrize("name", ["torque_free", "plate_pendulum"])
def test_error_against_the_exact_solution_falls_at_order_one(name):
    """Semi-implicit Euler: halving the step halves the error against the closed form."""
    scene = load_scene(name)
    coarse, fine = _exact_error(scene, 2e-3), _exact_error(scene, 1e-3)
    order = np.log2(coarse / fine)
    assert 0.8 < order < 1.2, (coarse, fine, order)


def test_the_first_sample_is_the_scenes_initial_state():
    scene = load_scene("plate_pendulum")
    traj = ENGINE.simulate(scene, RunSettings(0.01, 1e-3, 0.01, "semi_implicit_euler"))
    ref = get_engine("inhouse").simulate(scene, RunSettings(0.01, 1e-3, 0.01, "rk4"))
    for a in ("p_WCm_W", "quat_WB", "v_WCm_W", "w_WB_W"):
        assert np.allclose(getattr(traj, a)[0], getattr(ref, a)[0], atol=1e-12), a


@pytest.mark.parametrize("name", ["plate_pendulum", "rotating_plate", "torque_free", "three_link_chain", "heavy_top",
                                  "spring_pendulum"])
def test_the_loaded_model_matches_the_description(name):
    loaded = as_written(load_scene(name), "pybullet")
    assert loaded.discrepancies and loaded.problems == []


def test_a_wrong_file_fails_and_the_inertia_trap_is_real(tmp_path):
    """A mass changed in the URDF shows in the read-back; without URDF_USE_INERTIA_FROM_FILE
    PyBullet does not hold the file's inertia (the flag ``read_urdf`` always sets)."""
    import shutil

    import pybullet as p

    from harness.engines.pybullet.model import Server, pybullet_bodies

    scene = load_scene("double_pendulum")
    model = scene.multibody()
    folder = tmp_path / "double_pendulum"
    shutil.copytree(scene.directory, folder)
    urdf = folder / "double_pendulum.urdf"
    urdf.write_text(urdf.read_text().replace('<mass value="1"/>', '<mass value="1.5"/>', 1))
    wrong = as_written(load_scene("double_pendulum", models_dir=tmp_path), "pybullet", model)
    assert any("bar1: mass 1.5" in m for m in wrong.problems), wrong.problems
    with Server() as client:
        body = p.loadURDF(str(scene.urdf), useFixedBase=True, physicsClientId=client)
        trap = pybullet_bodies(body, client, model)
    assert abs(trap[0].I_Cm_B[0, 0] - model.bodies[0].I_Cm_B[0, 0]) > 0.5 * model.bodies[0].I_Cm_B[0, 0]


@pytest.mark.parametrize("name, why", [("four_bar", "loop"), ("rolling_disk", "rolling")])
def test_a_scene_it_does_not_model_is_unsupported_with_the_reason(name, why):
    scene = load_scene(name)
    assert "pybullet" in scene.not_run
    traj = ENGINE.simulate(scene, RunSettings(0.01, 1e-3, 0.01, "semi_implicit_euler"))
    assert traj.status == "unsupported" and why in traj.message, traj.message


@pytest.mark.parametrize("name, params", [
    ("cart_pendulum", {"theta0": 0.7, "dX0": 1.5, "dtheta0": -2.0}),   # hinge on a moving (sliding) parent
    ("three_link_chain", {"dq1": 3.0}),                                  # a chain of hinges with skew axes
    ("spring_pendulum", {"dr0": 0.5, "dtheta0": 3.0}),                  # slide on a turning hub, a joint spring
    ("heavy_top", {}),                                                   # ball joint, spinning top
])
def test_the_first_reaction_is_the_ideal_one(name, params):
    """At the first sample the sensor's reading less what Bullet's constraint-solver pass adds
    (``harness.engines.pybullet.reactions``) is the articulated-body solve at the initial state:
    the ideal reaction to round-off, on moving parents and ball joints too (the uncorrected reading
    was off by a velocity-squared wrench: 0.1-0.3 of the force scale on these scenes' runs)."""
    from harness.measure import compare

    scene = load_scene(name, params)
    traj = ENGINE.simulate(scene, RunSettings(0.01, 1e-3, 0.01, "semi_implicit_euler"))
    ref = get_engine("pinocchio").simulate(scene, RunSettings(0.01, 1e-3, 0.01, "rkmk4"))
    f_scale, m_scale = compare.reaction_scales(ref, scene.multibody())
    for body, (f, m) in ref.reactions.items():
        assert np.linalg.norm(traj.reactions[body][0][0] - f[0]) < 1e-12 * f_scale, body
        assert np.linalg.norm(traj.reactions[body][1][0] - m[0]) < 1e-12 * m_scale, body


def test_importing_pybullet_prints_no_banner():
    """PyBullet's C code prints "pybullet build time: ..." (on file descriptor 2, measured with
    3.2.7) at import: ``pybullet_module`` keeps it off both outputs, so a validate run's progress
    and a CI log carry none."""
    import subprocess
    import sys

    code = "from harness.engines.pybullet.model import pybullet_module; pybullet_module()"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "build time" not in out.stdout + out.stderr, (out.stdout, out.stderr)
