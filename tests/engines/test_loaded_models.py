"""Mass, centre of mass, inertia and joints as each engine sees them match the scene description,
for the model files as written (defaults) and after parameter overrides; MuJoCo's per-joint
bodies at zero joint coordinates."""

import mujoco
import numpy as np
import pytest

from harness.engines.mujoco.model import load_mjcf, read_spec
from harness.engines.pinocchio.model import load_urdf, read_urdf
from harness.engines.loaded_models import (compare_bodies, mujoco_bodies, mujoco_force_discrepancies,
                                           mujoco_joint_bodies, mujoco_loop_discrepancies, pinocchio_bodies)
from harness.model.scene import available_scenes
from harness.engines import load_scene

SCENES = available_scenes()

OVERRIDES = {
    "torque_free": {"mass": 2.5, "I1": 0.7, "I2": 1.1, "I3": 1.5},
    "torque_free_symmetric": {"mass": 0.5, "I1": 0.3, "I3": 0.5},
    "heavy_top": {"mass": 0.3, "l": 0.05, "I1": 0.001, "I3": 0.0015},
    "double_pendulum": {"m": 0.4, "L": 0.7, "r": 0.02},
    "plate_pendulum": {"m": 0.7, "a": 0.15, "b": 0.4, "h": 0.02},
    "pendulum": {"m": 0.6, "L": 0.45, "r": 0.03},
    "cart_pendulum": {"M": 3.5, "m": 0.4, "L": 0.6, "r": 0.03},
    "rolling_disk": {"mass": 0.02, "R": 0.03, "h": 0.004},
    "rolling_cylinder_bar": {"M": 2.0, "m": 0.7, "R": 0.15, "h": 0.08, "L": 0.5, "a": 0.01},
    "rolling_cone": {"mass": 2.0, "L": 0.3, "beta": 0.45},
    "spring_pendulum": {"m": 0.5, "k": 90.0, "L": 0.3, "rb": 0.03, "m_hub": 0.2, "r_hub": 0.02},
    "rotating_plate": {"m": 2.0, "a": 0.3, "h": 0.02, "phi": 0.9},
    "four_bar": {"a": 0.15, "b": 0.55, "c": 0.35, "d": 0.5, "m_coupler": 1.7, "theta0": 2.0},
    "four_bar_near_singular": {"a": 0.25, "c": 0.31, "m_rocker": 0.3, "branch": -1.0},
    "slider_crank": {"a": 0.12, "b": 0.4, "e": 0.03, "w": 0.08, "m_slider": 2.0},
    "bricard": {"L": 0.7, "s": 0.05, "m": 2.5, "dq0": 0.4},
    "rocking_semicylinder": {"m": 3.0, "R": 0.15, "w": 0.05, "phi0": -0.7},
    "andrews_squeezer": {"m3": 0.03, "i5": 2e-5, "sa": 0.02, "mom": -0.05, "c0": 3000.0, "l0": 0.07, "theta0": 0.3},
    "three_link_chain": {"m1": 1.3, "m3": 0.7, "c3": "0.01,0,-0.2", "I3": "0.005,0.0048,0.0003", "g": 9.7},
    "bicycle": {"w": 1.1, "c": 0.06, "lam": 0.3, "rF": 0.33, "mB": 80.0, "xB": 0.35, "IBxz": 2.0, "IHxz": -0.005,
                "tyre": 2e-5},
    "flyball_governor": {"L_shaft": 1.2, "L_rod": 0.8, "m_ball": 3.0, "a_slider": 0.12, "x_AB": 0.14, "l_attach": 0.4,
                         "k": 5e5, "c": 2e4, "l0": 0.45},
    "four_bar_chain": {"N": 3, "L": 0.8, "m": 1.3, "r": 0.01, "theta0": 1.0},  # its files written for these
}


@pytest.mark.parametrize("name", SCENES)
def test_mjcf_as_written_matches_scene_defaults(name):
    scene = load_scene(name)
    m = read_spec(scene.mjcf).compile()
    assert compare_bodies(mujoco_bodies(m, scene.multibody()), scene.multibody(), rtol=1e-6) == []


@pytest.mark.parametrize("name", SCENES)
def test_urdf_as_written_matches_scene_defaults(name):
    scene = load_scene(name)
    pmodel = read_urdf(scene.urdf, scene.urdf_root_joint)
    assert compare_bodies(pinocchio_bodies(pmodel, scene.multibody()), scene.multibody(), rtol=1e-6) == []


@pytest.mark.parametrize("name", SCENES)
def test_overrides_reach_mujoco_and_pinocchio(name):
    scene = load_scene(name, OVERRIDES[name])
    model = scene.multibody()
    m = load_mjcf(scene.mjcf, model)
    pmodel, _ = load_urdf(scene.urdf, scene.urdf_root_joint, model)
    assert compare_bodies(mujoco_bodies(m, model), model) == []
    assert compare_bodies(pinocchio_bodies(pmodel, model), model) == []
    assert [d.message for d in mujoco_loop_discrepancies(m, model) if not d.passed] == []
    assert [d.message for d in mujoco_force_discrepancies(m, model) if not d.passed] == []


def test_a_loop_site_moved_in_the_mjcf_is_named():
    """A cut joint's <connect> site off its point in the file, or an equality missing, fails the
    as-written check, naming it."""
    scene = load_scene("four_bar")
    model = scene.multibody()
    spec = read_spec(scene.mjcf)
    spec.site("cut_b").pos = [0.41, 0.0, 0.0]
    found = [d for d in mujoco_loop_discrepancies(spec.compile(), model) if not d.passed]
    assert [(d.body, d.quantity) for d in found] == [("cut", "site2")]
    assert "0.41" in found[0].message and "scene says [0.4, 0.0, 0.0]" in found[0].message
    spec = read_spec(scene.mjcf)
    next(e for e in spec.equalities if e.name == "cut_2").name = "renamed"
    found = [d for d in mujoco_loop_discrepancies(spec.compile(), model) if not d.passed]
    assert [(d.body, d.quantity) for d in found] == [("cut_2", "present")] and "'cut_2'" in found[0].message


def test_compare_bodies_names_a_wrong_inertia():
    scene = load_scene("heavy_top")
    model = scene.multibody()
    m = read_spec(scene.mjcf).compile()
    m.body_inertia[1, 2] *= 1.01
    problems = compare_bodies(mujoco_bodies(m, model), model)
    assert len(problems) == 1 and "top: inertia" in problems[0]


def test_full_inertia_tensor_reaches_mujoco():
    """A non-diagonal inertia goes through MjSpec as principal moments plus iquat."""
    from dataclasses import replace

    scene = load_scene("torque_free")
    model = scene.multibody()
    I = np.array([[2.0, 0.2, -0.1], [0.2, 2.5, 0.3], [-0.1, 0.3, 3.0]])
    model = replace(model, bodies=(replace(model.bodies[0], I_Cm_B=I),))
    m = load_mjcf(scene.mjcf, model)
    assert compare_bodies(mujoco_bodies(m, model), model) == []


def test_a_motor_or_spring_changed_in_the_mjcf_is_named():
    """A tendon spring's stiffness or site, or the motor's torque, off in the file fails the
    as-written check, naming the element and the quantity."""
    scene = load_scene("andrews_squeezer")
    model = scene.multibody()
    spec = read_spec(scene.mjcf)
    spec.tendon("spring").stiffness = [4000.0, 0.0, 0.0]
    spec.site("spring_b").pos = [0.014, 0.0, 0.07]
    spec.actuator("motor").biasprm = [0.05] + [0.0] * 9
    found = [d for d in mujoco_force_discrepancies(spec.compile(), model) if not d.passed]
    assert sorted((d.body, d.quantity) for d in found) == [("motor", "torque"), ("spring", "site_b"), ("spring", "stiffness")]
    assert [d for d in mujoco_force_discrepancies(load_mjcf(scene.mjcf, model), model) if not d.passed] == []


def test_a_damper_changed_in_the_mjcf_is_named():
    """A spring's damper (its tendon's ``damping``) off in the file, or missing, fails the
    as-written check, naming the spring; the scene's damping reaches the loaded model."""
    scene = load_scene("flyball_governor")
    model = scene.multibody()
    spec = read_spec(scene.mjcf)
    spec.tendon("spring2").damping = [3e4, 0.0, 0.0]
    found = [d for d in mujoco_force_discrepancies(spec.compile(), model) if not d.passed]
    assert [(d.body, d.quantity) for d in found] == [("spring2", "damping")] and "30000 N s/m" in found[0].message
    over = load_scene("flyball_governor", {"c": 1234.5}).multibody()
    m = load_mjcf(scene.mjcf, over)
    assert np.allclose(np.atleast_1d(m.tendon_damping).ravel()[:2], 1234.5)
    assert [d for d in mujoco_force_discrepancies(m, over) if not d.passed] == []


def test_mujoco_at_zero_coordinates_turns_a_joint_with_ref():
    """MuJoCo turns a hinge by q - ref: at q = 0 a hinge with ref = 0.5 rad about y stands turned by
    -0.5 rad about y from the pose the file writes (the pose at ``qpos0``)."""
    m = mujoco.MjModel.from_xml_string("""<mujoco model="ref"><compiler angle="radian"/><worldbody>
      <body name="a" pos="0 0 1"><joint name="h" axis="0 1 0" ref="0.5"/><geom size=".1" mass="1"/></body>
      </worldbody></mujoco>""")
    (x,) = mujoco_joint_bodies(m, np.zeros(m.nq))  # the hinge at 0 (qpos0 holds its ref)
    c, s = np.cos(-0.5), np.sin(-0.5)
    assert np.allclose(x.R_PB, [[c, 0, s], [0, 1, 0], [-s, 0, c]])
