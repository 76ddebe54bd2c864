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
from harness.model.scene import available_scenes
from harness.engines import load_scene


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


def test_torque_and_point_spring_sanity_rules():
    from harness.model.forces import JointTorque, PointSpring

    model = load_scene("andrews_squeezer").multibody()
    with pytest.raises(InputError, match="torque must be finite"):
        check_multibody(dataclasses.replace(model, torques=(JointTorque("body1", float("nan")),)), "test")
    sp = model.point_springs[0]
    for bad, match in ((dict(stiffness=-1.0), "finite and >= 0"), (dict(rest_length=-0.1), "finite and >= 0"),
                       (dict(body_a="nobody"), "no body named 'nobody'"), (dict(body_b=sp.body_a), "both ends on")):
        with pytest.raises(InputError, match=match):
            check_multibody(dataclasses.replace(model, point_springs=(dataclasses.replace(sp, **bad),)), "test")
    slide = load_scene("spring_pendulum").multibody()
    bob = slide.springs[0].body
    with pytest.raises(InputError, match="torques act on hinge joints only"):
        check_multibody(dataclasses.replace(slide, torques=(JointTorque(bob, 1.0),)), "test")


def test_point_spring_force_is_minus_the_gradient_of_its_potential():
    from harness.model.forces import PointSpring, spring_force

    sp = PointSpring("s", "a", np.zeros(3), None, np.zeros(3), 4530.0, 0.07785)
    x_b = np.array([0.014, 0.0, 0.072])
    for x_a in (np.array([0.0, 0.01, 0.0]), np.array([0.1, -0.02, 0.3])):
        V = lambda x: 0.5 * sp.stiffness * (np.linalg.norm(x - x_b) - sp.rest_length) ** 2  # noqa: E731
        h = 1e-7
        grad = np.array([(V(x_a + h * e) - V(x_a - h * e)) / (2 * h) for e in np.eye(3)])
        assert np.allclose(spring_force(sp, x_a, x_b), -grad, rtol=1e-6, atol=1e-6)


def test_torque_and_spring_reach_every_engine_the_same_way():
    """Under gravity, with the motor reversed and a softer spring (so none of the test set's
    values hides a sign), the in-house engine, Pinocchio, MuJoCo and Exudyn agree on a short run
    of the squeezer, and each balances the motor's work against T + V (energy check)."""
    from harness.engines import get_engine
    from harness.engines.base import RunSettings
    scene = load_scene("andrews_squeezer", {"g": 9.81, "mom": -0.02, "c0": 1000.0, "l0": 0.06})
    model = scene.multibody()
    runs = {name: get_engine(name).simulate(scene, RunSettings(0.004, 1e-5, 1e-3, integ))
            for name, integ in (("inhouse", "rk4"), ("pinocchio", "rkmk4"), ("mujoco", "RK4"), ("exudyn", "GeneralizedAlpha"))}
    for name, tr in runs.items():
        assert tr.status == "ok", (name, tr.message)
        e = invariants.energies(tr, model)["energy"] - invariants.work_of_forces(tr, model)
        assert np.max(np.abs(e - e[0])) < 1e-3 * np.max(np.abs(invariants.energies(tr, model)["kinetic"])), name
    a = np.stack([runs[n].quat_WB for n in runs])
    # 1 - |<q_a, q_b>| ~ angle^2 / 8: every pair within ~0.03 rad, in-house and Pinocchio within ~3e-7 rad
    assert np.max(np.abs(np.abs(np.einsum("ntbi,mtbi->nmtb", a, a)) - 1.0)) < 1e-4
    assert np.max(np.abs(np.abs(np.einsum("tbi,tbi->tb", a[0], a[1])) - 1.0)) < 1e-14


def test_point_spring_damper_force_power_and_work():
    """A point spring's damper: force -(k (L - L0) + c L') d / L, L' = d . (v_A - v_B) / L; the
    force's power on the ends is -dV/dt plus the damper's power -c L'^2 (``damper_power``); without
    velocities a damped spring's force is refused; a spring alone does no work (``does_work``)."""
    from harness.model.forces import POINT_SPRINGS, PointSpring, damper_power, spring_force, spring_potential

    sp = PointSpring("s", "a", np.zeros(3), None, np.zeros(3), 800.0, 0.5, damping=40.0)
    x_a, x_b = np.array([0.3, -0.1, 0.45]), np.array([0.02, 0.05, -0.01])
    v_a, v_b = np.array([0.7, 0.2, -0.4]), np.array([-0.1, 0.3, 0.05])
    d = x_a - x_b
    L = np.linalg.norm(d)
    rate = d @ (v_a - v_b) / L
    assert np.allclose(spring_force(sp, x_a, x_b, v_a, v_b), -(800.0 * (L - 0.5) + 40.0 * rate) * d / L, rtol=1e-14)
    h = 1e-7
    V = lambda s: spring_potential(sp, x_a + s * v_a, x_b + s * v_b)  # noqa: E731
    dV = (V(h) - V(-h)) / (2 * h)
    power = spring_force(sp, x_a, x_b, v_a, v_b) @ (v_a - v_b)
    assert power == pytest.approx(-dV + float(damper_power(sp, x_a, x_b, v_a, v_b)), rel=1e-7)
    assert float(damper_power(sp, x_a, x_b, v_a, v_b)) == pytest.approx(-40.0 * rate**2, rel=1e-14)
    with pytest.raises(ValueError, match="has a damper"):
        spring_force(sp, x_a, x_b)
    assert np.allclose(spring_force(dataclasses.replace(sp, damping=0.0), x_a, x_b), -800.0 * (L - 0.5) * d / L)
    assert POINT_SPRINGS.delivers(sp) and not POINT_SPRINGS.delivers(dataclasses.replace(sp, damping=0.0))
    assert forces.does_work(load_scene("flyball_governor").multibody())
    assert not forces.does_work(load_scene("flyball_governor", {"c": 0.0}).multibody())


def test_damping_sanity_rule():
    model = load_scene("flyball_governor").multibody()
    sp = model.point_springs[0]
    for bad in (-1.0, float("nan")):
        with pytest.raises(InputError, match="damping must be finite and >= 0"):
            check_multibody(dataclasses.replace(model, point_springs=(dataclasses.replace(sp, damping=bad),)), "test")


def test_damper_reaches_every_engine_the_same_way():
    """A flyball governor started moving relative to its shaft, with softer dampers (c = 400 N s/m)
    so that explicit steps of 1e-5 s resolve them, on every engine: in-house, Pinocchio, MuJoCo,
    Exudyn, Drake and PyBullet agree with the reduced equations (references/flyball_governor.py)
    over 0.02 s, each within what its method leaves at the step. An engine whose damper were
    missing would be 1.6e-4 m off in the slider's height (0.04 m/s in its rate), one with twice
    the damping 7e-5 m: far beyond every bound."""
    from harness.engines import get_engine
    from harness.engines.base import RunSettings
    from harness.references import flyball_governor as fg

    scene = load_scene("flyball_governor", {"ds0": 0.3, "dalpha0": -0.5, "c": 400.0})
    ref = fg.reference_solution(scene.params, np.linspace(0.0, 0.02, 3))
    bounds = {("inhouse", "rk4"): 1e-10, ("pinocchio", "rkmk4"): 1e-10, ("mujoco", "RK4"): 1e-10,  # measured: 1e-14
              ("exudyn", "GeneralizedAlpha"): 1e-8, ("drake", "RK5"): 1e-10,  # 7e-10 (order 2), 2e-15
              ("pybullet", "semi_implicit_euler"): 5e-6}  # 4.9e-7 (order 1)
    for (name, integ), bound in bounds.items():
        tr = get_engine(name).simulate(scene, RunSettings(0.02, 1e-5, 0.01, integ, rtol=1e-10, atol=1e-10))
        assert tr.status == "ok", (name, tr.message)
        s, alpha, _ = fg.run_coordinates(tr)
        assert np.max(np.abs(s - ref.s)) < bound, (name, np.max(np.abs(s - ref.s)))
        assert np.max(np.abs(alpha - ref.alpha)) < 10 * bound, (name, np.max(np.abs(alpha - ref.alpha)))
