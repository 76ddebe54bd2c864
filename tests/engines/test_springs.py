"""Joint springs: the scene's spring reaches MuJoCo (stiffness, springref) and Pinocchio (tau),
the common energy includes it, and the three engines agree on a slide joint whose parent turns."""

from __future__ import annotations

import numpy as np
import pytest

from harness.measure import compare
from harness.measure import invariants
from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.engines.mujoco.model import load_mjcf, read_spec
from harness.engines.loaded_models import mujoco_spring_problems
from harness.engines import load_scene
from harness.io.trajectory_csv import to_frame

#: The engines compared here at one fixed tolerance, each at a method of order 2 or more. PyBullet
#: (semi-implicit Euler, order 1; joint forces from its sensors) is judged by how its error converges,
#: in validate (tests/engines/pybullet/), not at a fixed tolerance set for the others.
DEFAULT = {"inhouse": "rk4", "mujoco": "RK4", "pinocchio": "rkmk4", "exudyn": "GeneralizedAlpha", "drake": "RK5"}


def test_spring_reaches_mujoco_and_is_checked():
    scene = load_scene("spring_pendulum", {"k": 75.0, "L": 0.31})
    model = scene.multibody()
    m = load_mjcf(scene.mjcf, model)
    assert mujoco_spring_problems(m, model) == []
    as_written = read_spec(scene.mjcf).compile()
    problems = mujoco_spring_problems(as_written, model)
    assert len(problems) == 2 and "stiffness 160 N/m, scene says 75 N/m" in problems[0]
    assert mujoco_spring_problems(read_spec(load_scene("cart_pendulum").mjcf).compile(), load_scene("cart_pendulum").multibody()) == []


def test_elastic_energy_column_and_slide_coordinate():
    scene = load_scene("spring_pendulum")
    model = scene.multibody()
    tr = get_engine("mujoco").simulate(scene, RunSettings(0.2, 1e-3, 0.01, "RK4"))
    frame = to_frame(tr, model)
    assert "elastic" in frame.columns and "elastic" not in to_frame(
        get_engine("mujoco").simulate(load_scene("torque_free"), RunSettings(0.02, 1e-3, 0.01, "RK4")), load_scene("torque_free").multibody())
    p = scene.params
    r = invariants.slide_coordinate(tr, model, "bob")
    assert r[0] == pytest.approx(p["r0"], abs=1e-14)
    assert np.allclose(frame["elastic"], 0.5 * p["k"] * (r - p["L"]) ** 2, rtol=1e-14, atol=0)
    # MuJoCo's own energy includes its joint spring: it matches the harness's to rounding
    assert compare.engine_energy_mismatch(tr, model) < 1e-13


def test_engines_agree_with_a_spring_on_a_turning_slide():
    scene = load_scene("spring_pendulum", {"theta0": 0.8, "dtheta0": -2.0, "dr0": 0.3})
    model = scene.multibody()
    runs = {e: get_engine(e).simulate(scene, RunSettings(0.5, 5e-4, 0.01, DEFAULT[e])) for e in DEFAULT}
    assert all(r.ok for r in runs.values())
    for e in ("mujoco", "pinocchio"):
        err = compare.trajectory_error(runs[e], runs["inhouse"])
        assert err["position_max"] < 1e-9 and err["velocity_max"] < 1e-8, (e, err)
        assert compare.energy_drift(runs[e], model) < 1e-9
    # Exudyn (a LinearSpringDamper along its prismatic joint), order 2: measured 1.0e-6 m, 8.5e-6 m/s, drift 7.6e-7
    err = compare.trajectory_error(runs["exudyn"], runs["inhouse"])
    assert err["position_max"] < 1e-5 and err["velocity_max"] < 1e-4, err
    assert compare.energy_drift(runs["exudyn"], model) < 1e-5
    # Drake (a PrismaticSpring), RK5 at target accuracy 1e-10
    err = compare.trajectory_error(runs["drake"], runs["inhouse"])
    assert err["position_max"] < 1e-7 and err["velocity_max"] < 1e-6, err
    assert compare.energy_drift(runs["drake"], model) < 1e-7
