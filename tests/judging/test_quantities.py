"""One definition of each trajectory quantity (``harness.judging.quantities``): validate's
``trajectory.*`` checks, ``harness debug``, the stress study's bands and the work-precision
study's state error name and compute the same quantity the same way."""

from dataclasses import replace

import numpy as np
import pytest

from harness.engines import get_engine
from harness.judging import quantities
from harness.measure import compare
from harness.engines import load_scene
from harness.judging.checks import check_run
from harness.validate.run import default_settings, reference_settings


@pytest.fixture(scope="module")
def pair():
    """heavy_top over 0.5 s: MuJoCo at its defaults and validate's in-house DOP853 reference, saved
    at the same times."""
    scene = replace(load_scene("heavy_top"), t_end=0.5)
    ref = get_engine("inhouse").simulate(scene, reference_settings(scene))
    settings = default_settings(scene, "mujoco")
    run = get_engine("mujoco").simulate(scene, settings)
    assert ref.ok and run.ok and np.allclose(run.t, ref.t)
    return scene, run, ref, settings


def validate_values(scene, run, ref, settings) -> dict[str, float]:
    checks = check_run(scene, "mujoco", "mujoco", run, ref, settings)
    return {c.check.split(".", 1)[1]: c.value for c in checks if c.check.startswith("trajectory.")}


def test_every_tool_names_the_same_quantities():
    from harness.studies.stress.run import QUANTITIES as STRESS_BANDS
    from harness.studies.stress.run import TRAJECTORY_QUANTITIES
    from harness.tools.debug import QUANTITIES as DEBUG_QUANTITIES
    from harness.tools.debug import UNITS
    from harness.judging import checks

    names = tuple(q.name for q in quantities.TRAJECTORY)
    assert names == quantities.NAMES == ("position", "orientation", "velocity", "angular_velocity")
    assert TRAJECTORY_QUANTITIES == names and set(names) <= set(STRESS_BANDS)
    assert DEBUG_QUANTITIES[: len(names)] == names
    assert {n: UNITS[n] for n in names} == {"position": "rel", "orientation": "rad", "velocity": "rel",
                                            "angular_velocity": "rel"}
    assert checks.TRAJECTORY is quantities.TRAJECTORY  # validate judges by the same records


def test_validate_debug_stress_and_workprecision_compute_the_same_values(pair):
    from harness.studies.stress.run import Bounds, Reference, TrialSpec, evaluate
    from harness.studies.workprecision.run import errors
    from harness.tools.debug import error_series

    scene, run, ref, settings = pair
    model = scene.multibody()
    scales = compare.motion_scales(ref, model)
    judged = validate_values(scene, run, ref, settings)
    assert set(judged) == set(quantities.NAMES) and all(v > 0 for v in judged.values())
    assert judged == pytest.approx(quantities.judged_max(compare.trajectory_error(run, ref), scales), rel=1e-12)

    _, series = error_series(run, ref, model, scales)  # harness debug
    assert {q: float(np.max(series[q])) for q in quantities.NAMES} == pytest.approx(judged, rel=1e-12)

    spec = TrialSpec("v", "mujoco", settings.integrator, settings.dt, settings.t_end, settings.save_every, 1e-8, "nominal")
    band = {q: 1.0 for q in ("exact", "energy", *quantities.NAMES)}
    trial = evaluate(run, scene, spec, Reference(ref, False, band), Bounds())  # the stress study
    assert {q: trial.max_errors[q] for q in quantities.NAMES} == pytest.approx(judged, rel=1e-12)
    assert trial.error_kind == "trajectory" and trial.error == pytest.approx(max(judged.values()), rel=1e-12)

    state = errors(run, ref, model)["state_max"]  # the work-precision study
    assert state == pytest.approx(max(judged.values()), rel=1e-12)
    assert state == pytest.approx(quantities.state_error(judged), rel=1e-12)


def test_the_state_error_is_the_largest_judged_quantity():
    judged = {"position": 1e-6, "orientation": 3e-6, "velocity": 2e-6, "angular_velocity": 5e-7}
    assert quantities.state_error(judged) == 3e-6
    series = {k: np.array([v, 2 * v]) for k, v in judged.items()}
    assert np.array_equal(quantities.state_error(series), [3e-6, 6e-6])
    scales = {"length": 2.0, "velocity": 4.0, "angular_velocity": 10.0}
    raw = {"position_max": 2.0, "orientation_max": 0.1, "velocity_max": 4.0, "angular_velocity_max": 5.0}
    assert quantities.judged_max(raw, scales) == {"position": 1.0, "orientation": 0.1, "velocity": 1.0,
                                                  "angular_velocity": 0.5}
