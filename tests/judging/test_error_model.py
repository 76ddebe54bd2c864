"""``harness.judging.error_model``: the error model of synthetic levels (errors of known form at
steps h, 2h and h/2, or at an error-controlled run's tolerance and a looser one) and its class."""

import math

import pytest

from harness.judging import error_model
from harness.judging.error_model import (CONVERGES, DEFECT, LOOSER, MODEL_DIFFERENCE, NOISE, NOT_JUDGED, Level,
                                         fit, needs_finer_level)

H = 1e-3          # s, the scene's step
RES = 1e-12       # the resolution of the synthetic quantities (rel)


def levels(error, factors=(1.0, 2.0)):
    """Levels at ``factor * H`` (the scene's step first) of ``error(step)``."""
    return [Level(f * H, float(error(f * H))) for f in factors]


def fixed(error, formal=4.0, factors=(1.0, 2.0), resolution=RES, scale=1.0):
    return fit("trajectory.position", "rel", scale, "fixed", formal, levels(error, factors), resolution)


def test_an_order_four_error_converges_at_order_four():
    m = fixed(lambda h: 1e6 * h ** 4)  # 1e-6 at the scene's step
    assert m.classification == CONVERGES
    assert m.observed_order == pytest.approx(4.0, abs=1e-9)
    assert m.floor == 0.0 and m.error == pytest.approx(1e-6)
    assert "order 4.00" in m.reason


def test_an_order_two_error_converges_for_a_second_order_method():
    m = fixed(lambda h: 1e2 * h ** 2, formal=2.0)
    assert m.classification == CONVERGES
    assert m.observed_order == pytest.approx(2.0, abs=1e-9)


def test_an_order_two_error_is_a_defect_of_a_fourth_order_method():
    error = lambda h: 1e2 * h ** 2  # noqa: E731
    # the scene's and the coarser level leave it undecided: the finer level is run ...
    assert needs_finer_level(levels(error), 4.0, RES)
    # ... and with it the error falls at order 2 all the way: no floor, a defect (a dropped stage)
    m = fixed(error, factors=(1.0, 2.0, 0.5))
    assert m.classification == DEFECT, m.reason
    assert m.observed_order == pytest.approx(2.0, abs=1e-9)
    assert m.floor == 0.0
    assert "order 2.00 where the method's is 4" in m.reason


@pytest.mark.parametrize("factors", [(1.0, 2.0), (1.0, 2.0, 0.5)])
def test_a_floor_under_an_order_four_error_is_a_model_difference_of_its_size(factors):
    floor = 1e-5  # well above the resolution, 10x the vanishing part at the scene's step
    m = fixed(lambda h: 1e6 * h ** 4 + floor, factors=factors)
    assert m.classification == MODEL_DIFFERENCE, m.reason
    assert m.floor == pytest.approx(floor, rel=0.1)
    assert m.vanishing == pytest.approx(1e-6, rel=0.1)
    assert "does not shrink with the step" in m.reason


def test_a_floor_under_an_order_two_part_is_still_found_with_three_levels():
    floor = 1e-4  # as large as the vanishing part at the scene's step
    m = fixed(lambda h: 1e2 * h ** 2 + floor, factors=(1.0, 2.0, 0.5))
    assert m.classification == MODEL_DIFFERENCE, m.reason
    assert m.floor == pytest.approx(floor, rel=0.1)


def test_a_floor_is_relative_to_the_quantitys_scale():
    m = fixed(lambda h: 1e6 * h ** 4 + 1e-5, scale=10.0)
    assert m.relative_floor == pytest.approx(m.floor / 10.0)


def test_an_error_at_the_resolution_converges_at_the_resolution():
    m = fixed(lambda h: 0.5 * RES)
    assert m.classification == CONVERGES
    assert "at the resolution" in m.reason
    assert m.floor == 0.0 and math.isnan(m.observed_order)


def test_an_error_within_noise_of_the_resolution_converges():
    m = fixed(lambda h: 3 * RES * (1.0 + h / H) / 2, factors=(1.0, 2.0, 0.5))  # order < 1, but a few RES
    assert m.classification == CONVERGES
    assert f"within {NOISE:g}x the resolution" in m.reason


def test_an_error_growing_with_refinement_is_a_defect():
    m = fixed(lambda h: 1e-12 / h ** 2)  # 1e-6 at the scene's step, a quarter of that at 2h
    assert m.classification == DEFECT
    assert "grows with refinement" in m.reason


def test_a_non_finite_error_at_the_scenes_step_is_a_defect():
    m = fit("exact", "rad", 1.0, "fixed", 4.0, [Level(H, float("nan")), Level(2 * H, 1e-6)], RES)
    assert m.classification == DEFECT
    assert "non-finite" in m.reason


def test_no_other_level_leaves_it_not_judged():
    m = fit("exact", "rad", 1.0, "fixed", 4.0, [Level(H, 1e-6), Level(2 * H, float("nan"))], RES)
    assert m.classification == NOT_JUDGED


def test_a_coarse_pre_asymptotic_level_is_overruled_by_a_finer_one():
    # order 4 between h and h/2; 2h is pre-asymptotic (only 1.5x the error at h)
    lv = [Level(H, 1.6e-6), Level(2 * H, 2.4e-6), Level(H / 2, 1e-7)]
    assert needs_finer_level(lv[:2], 4.0, RES)
    m = fit("trajectory.position", "rel", 1.0, "fixed", 4.0, lv, RES)
    assert m.classification == CONVERGES, m.reason
    assert m.observed_order == pytest.approx(4.0, abs=1e-9)


@pytest.mark.parametrize("q", [1.0, 0.7])
def test_an_adaptive_error_following_its_tolerance_converges(q):
    tol = 1e-8
    m = fit("exact", "rad", 1.0, "adaptive", 1.0, [Level(tol, 1e-2 * tol ** q), Level(tol * LOOSER, 1e-2 * (tol * LOOSER) ** q)],
            RES)
    assert m.classification == CONVERGES
    assert m.observed_order == pytest.approx(q, abs=1e-9)
    assert "follows its tolerance" in m.reason


def test_an_adaptive_error_flat_in_the_tolerance_is_a_model_difference():
    tol = 1e-8
    m = fit("exact", "rad", 1.0, "adaptive", 1.0, [Level(tol, 1e-5), Level(tol * LOOSER, 1.01e-5)], RES)
    assert m.classification == MODEL_DIFFERENCE
    assert m.floor == pytest.approx(1e-5, rel=0.1)
    assert "does not follow the tolerance" in m.reason


@pytest.mark.parametrize("errors,formal,resolution,expected", [
    ((1e-6, 16e-6), 4.0, RES, False),          # order 4: decided
    ((1e-6, 12e-6), 4.0, RES, False),          # order 3.58: within ORDER_DOUBT of 4
    ((1e-6, 4e-6), 4.0, RES, True),            # order 2 of a fourth-order method: a finer level decides
    ((1e-6, 1.1e-6), 4.0, RES, True),          # flat: floor or defect, a finer level decides
    ((1e-6, 4e-6), 2.0, RES, False),           # order 2 of a second-order method
    ((0.5e-12, 3e-12), 4.0, RES, False),       # at the resolution
    ((5e-12, 6e-12), 4.0, RES, False),         # within NOISE times the resolution
    ((float("nan"), 1e-6), 4.0, RES, False),   # non-finite at the scene's step: a defect already
    ((1e-6, float("nan")), 4.0, RES, False),   # one finite level: nothing to compare
])
def test_needs_finer_level(errors, formal, resolution, expected):
    lv = [Level(H, errors[0]), Level(2 * H, errors[1])]
    assert needs_finer_level(lv, formal, resolution) is expected


def test_needs_finer_level_reads_the_finest_two():
    # h/2 already ran: the finest pair (h/2, h) is of order 4, the coarse 2h is pre-asymptotic
    lv = [Level(H, 1.6e-6), Level(2 * H, 2.4e-6), Level(H / 2, 1e-7)]
    assert not needs_finer_level(lv, 4.0, RES)


def test_roundoff_is_steps_times_eps_times_scale():
    assert error_model.roundoff(1000, 2.0) == pytest.approx(1000 * error_model.EPS * 2.0)
    assert error_model.roundoff(0) == error_model.EPS  # at least one step


def test_judge_refinement_measures_a_finer_level_where_the_coarse_one_diverged():
    """A pair of runs at the base step h and at 2 h, the coarse one gone non-finite (a stiff motion
    past its stability limit): the pair runs once more at h / 2 and the fourth-order fall decides."""
    calls = []

    def measure(h):
        calls.append(h)
        return {"x": float("nan") if h > 1.5e-3 else 1e-2 * (h / 1e-3) ** 4}

    (model,) = error_model.judge_refinement(measure, (1e-3, 2e-3), 4.0, {"x": ("m", 1.0)}, 1000).values()
    assert calls == [1e-3, 2e-3, 5e-4]
    assert model.classification == error_model.CONVERGES and model.observed_order == pytest.approx(4.0)
