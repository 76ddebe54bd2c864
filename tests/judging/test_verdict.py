"""``harness.judging.verdict``: a check's verdict from its error model, the scene's declared model
difference (a relative floor bound) and its requirement."""

import math
from types import SimpleNamespace

import pytest

from harness.judging.error_model import CONVERGES, DEFECT, MODEL_DIFFERENCE, NOT_JUDGED, Level, fit
from harness.judging.verdict import ModelDifference, judge, requirement

H = 1e-3
RES = 1e-12
SOFT = ModelDifference("soft loop constraints", 2e-4)


def model(error, formal=4.0, factors=(1.0, 2.0, 0.5), scale=1.0, unit="rel"):
    return fit("trajectory.position", unit, scale, "fixed", formal, [Level(f * H, float(error(f * H))) for f in factors], RES)


def floor_of(size, scale=1.0):
    """A model difference: a floor of ``size`` (the unit) under an order-4 part a tenth of it."""
    m = model(lambda h: size * (1.0 + 0.1 * (h / H) ** 4), scale=scale, unit="m")
    assert m.classification == MODEL_DIFFERENCE and m.floor == pytest.approx(size, rel=1e-6)
    return m


def test_a_converging_check_passes():
    v = judge(model(lambda h: 1e6 * h ** 4))
    assert v.passed and v.label == CONVERGES


def test_an_undeclared_floor_fails():
    v = judge(floor_of(1e-5))
    assert not v.passed
    assert v.label == MODEL_DIFFERENCE
    assert "not declared by the scene" in v.detail


def test_a_declared_floor_within_its_bound_passes():
    v = judge(floor_of(1e-5), SOFT)
    assert v.passed
    assert v.label == "model difference (declared)"
    # the whole error at the scene's step (the floor and its vanishing tenth) is held to the bound
    assert "error 1.1e-05 of scale within its bound 2e-04" in v.detail
    assert v.detail.startswith("soft loop constraints: ")


def test_a_declared_floor_is_bounded_relative_to_the_quantitys_scale():
    assert judge(floor_of(1e-3, scale=10.0), SOFT).passed         # 1e-4 of the scale
    assert not judge(floor_of(1e-3, scale=1.0), SOFT).passed      # 1e-3 of the scale


def test_a_declared_floor_above_its_bound_fails():
    v = judge(floor_of(3e-4), SOFT)
    assert not v.passed
    assert v.label == "model difference (declared)"
    assert "error 3.3e-04 of scale beyond its bound 2e-04" in v.detail


def test_an_undeclared_defect_fails():
    m = model(lambda h: 1e2 * h ** 2)  # order 2 of a fourth-order method
    assert m.classification == DEFECT
    v = judge(m)
    assert not v.passed and v.label == DEFECT


def test_a_defect_with_a_declared_model_difference_is_held_to_the_bound_by_its_error():
    # a soft model whose error's order is not the integrator's: its whole error at the scene's step
    m = model(lambda h: 1e2 * h ** 2, scale=2.0)  # 1e-4 at the scene's step: 5e-5 of the scale
    assert m.classification == DEFECT
    v = judge(m, SOFT)
    assert v.passed and v.label == "model difference (declared)"
    assert "error 5.0e-05 of scale within its bound" in v.detail
    v = judge(m, ModelDifference("soft", 1e-5))
    assert not v.passed and "error 5.0e-05 of scale beyond its bound 1e-05" in v.detail


def test_a_run_not_judged_fails():
    m = fit("exact", "rad", 1.0, "fixed", 4.0, [Level(H, 1e-6), Level(2 * H, float("nan"))], RES)
    v = judge(m, SOFT)
    assert not v.passed and v.label == NOT_JUDGED


def test_a_requirement_exceeded_fails_even_when_it_converges():
    m = model(lambda h: 1e6 * h ** 4)  # 1e-6 at the scene's step
    assert judge(m, requirement=1e-5).passed
    v = judge(m, requirement=1e-7)
    assert not v.passed and v.label == CONVERGES
    assert "beyond the requirement 1.00e-07 rel" in v.detail


def test_a_requirement_bounds_a_declared_model_difference_too():
    m = floor_of(1e-5)
    assert judge(m, SOFT, requirement=1e-4).passed
    v = judge(m, SOFT, requirement=1e-6)
    assert not v.passed and "beyond the requirement" in v.detail


@pytest.mark.parametrize("check,expected", [
    ("closure.position", 1e-9),      # its own name
    ("closure.velocity", 1e-6),      # its table's
    ("exact", 1e-7),
    ("energy_balance", 1e-8),        # energy_drift's
    ("trajectory.position", math.inf),  # none stated
])
def test_requirement_lookup(check, expected):
    scene = SimpleNamespace(requirements={"closure.position": 1e-9, "closure": 1e-6, "exact": 1e-7, "energy_drift": 1e-8})
    assert requirement(scene, check) == expected


def test_a_scene_without_requirements_requires_nothing():
    assert requirement(SimpleNamespace(), "exact") == math.inf
