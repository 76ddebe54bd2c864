"""The force table (``harness.model.forces``): every type names a real Multibody field, its energy
and generalised force agree, its sanity rules hold, and every engine knows every type."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from harness.engines.inhouse.model import build
from harness.engines.mujoco.model import MJCF_WRITERS
from harness.measure import invariants
from harness.model import forces
from harness.model.errors import InputError
from harness.model.forces import FORCES, JOINT_SPRINGS, POINT_FORCES, JointSpring
from harness.model.joints import JOINTS
from harness.model.multibody import Multibody
from harness.model.sanity import check_multibody
from harness.model.scene import available_scenes, load_scene


def test_every_type_names_a_multibody_field_of_its_elements():
    fields = {f.name: f for f in dataclasses.fields(Multibody)}
    for ft in FORCES.values():
        assert ft.field in fields, ft.name
        assert ft.element.__name__ in str(fields[ft.field].type), (ft.name, fields[ft.field].type)
        assert ft.joints is None or set(ft.joints) <= set(JOINTS)
        assert (ft.joint_force is None) == (ft.joints is None)
        assert ft.potential is not None or ft.power is not None  # it shows in the energy or its balance


def test_every_engine_knows_every_type():
    """MuJoCo has a writer for each type an MJCF expresses; the in-house model accepts each."""
    assert set(MJCF_WRITERS) == {ft.name for ft in FORCES.values() if ft.mjcf}
    for name in available_scenes():
        build(load_scene(name).multibody())  # raises NotImplementedError for an unmodelled type


def test_elements_and_does_work():
    spring = load_scene("spring_pendulum").multibody()
    assert [ft for ft, _ in forces.elements(spring)] == [JOINT_SPRINGS] and not forces.does_work(spring)
    forced = load_scene("double_pendulum", {"F0": 1.0, "omega_f": 2.0}).multibody()
    assert [ft for ft, _ in forces.elements(forced)] == [POINT_FORCES] and forces.does_work(forced)
    assert not forces.does_work(load_scene("double_pendulum").multibody())


def test_spring_generalised_force_is_minus_the_gradient_of_its_potential():
    sp = JointSpring("b", 75.0, 0.3)
    for q in (-0.2, 0.31, 1.4):
        h = 1e-6
        grad = (JOINT_SPRINGS.joint_potential(sp, q + h) - JOINT_SPRINGS.joint_potential(sp, q - h)) / (2 * h)
        assert JOINT_SPRINGS.joint_force(sp, q, 0.0) == pytest.approx(-grad, rel=1e-8)


def test_elastic_energy_is_the_sum_of_the_table_potentials():
    from harness.engines import get_engine
    from harness.engines.base import RunSettings

    scene = load_scene("spring_pendulum")
    model = scene.multibody()
    traj = get_engine("mujoco").simulate(scene, RunSettings(0.05, 1e-3, 0.01, "RK4"))
    expected = sum(ft.potential(traj, model, el) for ft, el in forces.elements(model) if ft.potential)
    assert np.array_equal(invariants.energies(traj, model)["elastic"], expected)
    q = invariants.slide_coordinate(traj, model, "bob")
    joint_energy = [JOINT_SPRINGS.joint_potential(sp, qk) for qk in q for sp in model.springs]
    assert np.allclose(expected, joint_energy, rtol=1e-14, atol=0)


def test_sanity_rules_come_from_the_table():
    model = load_scene("spring_pendulum").multibody()
    hinge_body = next(b.name for b in model.bodies if b.joint == JOINTS["hinge"].name)
    with pytest.raises(InputError, match="springs act on slide joints only"):
        check_multibody(dataclasses.replace(model, springs=(JointSpring(hinge_body, 1.0, 0.0),)), "test")
    bob = model.springs[0].body
    with pytest.raises(InputError, match="stiffness must be finite and >= 0"):
        check_multibody(dataclasses.replace(model, springs=(JointSpring(bob, -1.0, 0.0),)), "test")
