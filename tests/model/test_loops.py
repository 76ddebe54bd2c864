"""Loop joints in the description: the sanity rules (names, kinds, unit axes, an initial state
that closes the loop) and the closure residuals of ``harness.model.loop_closure``."""

from dataclasses import replace

import numpy as np
import pytest

from harness.model.errors import InputError
from harness.model.joints import keeps_axis, loop_kinds
from harness.model.loop_closure import initial_residuals
from harness.model.sanity import check_multibody
from harness.engines import load_scene


def four_bar():
    return load_scene("four_bar").multibody()


def test_loop_kinds_come_from_the_joint_table():
    assert set(loop_kinds()) == {"ball", "hinge"}
    assert keeps_axis("hinge") and not keeps_axis("ball")


@pytest.mark.parametrize("name", ["four_bar", "four_bar_near_singular", "slider_crank"])
def test_the_builders_assemble_closed_loops(name):
    model = load_scene(name).multibody()
    for res in initial_residuals(model).values():
        assert max(res.values()) < 1e-12


@pytest.mark.parametrize("change, fragment", [
    (dict(body_b="nowhere"), "unknown body 'nowhere'"),
    (dict(kind="slide"), "kind must be one of"),
    (dict(axis_A=np.array([0.0, -2.0, 0.0])), "axis_A must be a unit vector"),
    (dict(p_B=np.array([0.4, 0.0, 0.001])), "does not close the loop (position residual 0.001"),
    (dict(p_A=np.array([np.nan, 0.0, 0.0])), "p_A must be three finite numbers"),
    (dict(body_b="coupler"), "both ends on body 'coupler'"),
])
def test_a_bad_loop_joint_is_one_clear_line(change, fragment):
    model = four_bar()
    bad = replace(model, loops=(replace(model.loops[0], **change),))
    with pytest.raises(InputError, match=None) as err:
        check_multibody(bad, "scene.toml")
    assert fragment in str(err.value) and "\n" not in str(err.value)


def test_an_initial_velocity_that_opens_the_loop_is_refused():
    model = four_bar()
    v0 = dict(model.v0, rocker=model.v0["rocker"] + 0.1)
    with pytest.raises(InputError, match="velocity residual"):
        check_multibody(replace(model, v0=v0), "scene.toml")


@pytest.mark.parametrize("params, fragment", [
    ({"d": 2.0}, "cannot close"),
    ({"branch": 0.5}, r"branch must be \+1 or -1"),
])
def test_four_bar_parameters_that_cannot_assemble_are_refused(params, fragment):
    with pytest.raises(InputError, match=fragment):
        load_scene("four_bar", params).multibody()


def test_slider_crank_whose_crank_cannot_turn_is_refused():
    with pytest.raises(InputError, match="a \\+ \\|e\\| < b"):
        load_scene("slider_crank", {"a": 0.35}).multibody()
