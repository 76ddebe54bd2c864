"""Which rolling contacts add rows that repeat others (``harness.model.rolling_contact.dependent_rows``):
a body the world holds through joints alone, or two contacts on one body; a body on a chain with a
free joint (a rolling disk, a bicycle's wheels three joints deep) adds independent rows. What the
sanity check (``harness.model.sanity.check_contacts``) refuses."""

from dataclasses import replace

import numpy as np
import pytest

from harness.engines import load_scene
from harness.model.errors import InputError
from harness.model.multibody import RollingContact
from harness.model.rolling_contact import anchored, dependent_rows
from harness.model.sanity import check_multibody


def test_a_body_held_by_joints_alone_is_anchored():
    cone = load_scene("rolling_cone").multibody()
    assert anchored(cone, cone.bodies[0].name) and dependent_rows(cone)


def test_a_body_on_a_chain_with_a_free_joint_is_not():
    bike = load_scene("bicycle").multibody()
    assert [b.name for b in bike.bodies] == ["B", "R", "H", "F"]
    assert not any(anchored(bike, b) for b in ("B", "R", "H", "F"))
    assert not dependent_rows(bike)
    disk = load_scene("rolling_disk").multibody()
    assert not dependent_rows(disk)


def test_two_contacts_on_one_body_may_repeat_rows():
    disk = load_scene("rolling_disk").multibody()
    twice = replace(disk, contacts=disk.contacts + (RollingContact(disk.bodies[0].name, 0.01, 0.0, name="other"),))
    assert dependent_rows(twice)


def test_the_bicycle_rows_are_independent_in_every_engine_that_solves_them():
    """The in-house KKT matrix of the bicycle is positive definite (Cholesky, no pseudo-inverse)
    and Pinocchio keeps all six rolling rows."""
    from harness.engines.inhouse.constraints import evaluate, frames
    from harness.engines.inhouse.model import build, initial_state

    scene = load_scene("bicycle")
    nem = build(scene.multibody())
    assert not nem.redundant
    y = initial_state(scene.multibody(), nem)
    _, R_ext, P_ext, w_ext = frames(nem.nb, y)
    _, J, _ = evaluate(nem, P_ext, R_ext, w_ext, None)
    assert J.shape == (21, 24) and np.linalg.matrix_rank(J) == 21  # 3 hinges x 5 + 2 contacts x 3: 3 dof left


@pytest.mark.parametrize("change, message", [
    ({"body": "nobody"}, "unknown body 'nobody'"),
    ({"radius": 0.0}, "radius must be positive"),
    ({"half_thickness": -1e-3}, "half_thickness must be >= 0"),
    ({"circle_z": float("nan")}, "circle_z must be finite"),
    ({"name": "rear_contact"}, "name used twice"),
])
def test_sanity_refuses_a_contact_it_cannot_run(change, message):
    """Any body may roll (the front wheel, three joints deep, passes); a contact naming no body,
    with no radius, or named twice is refused before any engine sees it."""
    bike = load_scene("bicycle").multibody()
    check_multibody(bike, "bicycle")
    front = replace(bike.contacts[1], **change)
    with pytest.raises(InputError, match=message):
        check_multibody(replace(bike, contacts=(bike.contacts[0], front)), "bicycle")
