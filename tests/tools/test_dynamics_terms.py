"""Mass matrix, bias and gravity terms of MuJoCo, Pinocchio and the in-house model agree in common
coordinates; the free-joint velocity map is right; a wrong inertia frame shows at once."""

from dataclasses import replace

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from harness.tools import dynamics_terms as dc
from harness.engines.mujoco.model import load_mjcf
from harness.engines.pinocchio.model import load_urdf
from harness.model.scene import available_scenes
from harness.engines import load_scene


# Scenes compared at other parameters than their defaults: four_bar_chain at 2 windows, not 40
# (81 bodies: the in-house finite-difference terms take minutes).
SMALL = {"four_bar_chain": {"N": 2}}


def loaded(name, model=None):
    scene = load_scene(name, SMALL.get(name))
    model = model or scene.multibody()
    m = load_mjcf(scene.mjcf, model)
    pmodel, _ = load_urdf(scene.urdf, scene.urdf_root_joint, model)
    return model, m, pmodel


def terms(model, m, pmodel, n=3, seed=0):
    jmap = dc.scene_joint_map(model, m, pmodel)
    states = dc.random_states(jmap, n, seed)
    return jmap, states, dc.evaluate(dc.scene_sources(model, m, pmodel, jmap), states)


def offset_free_body():
    """torque_free with the centre of mass off the body origin, a full inertia tensor and a
    tilted gravity: every coupling of the free-joint velocity map is exercised."""
    model = load_scene("torque_free").multibody()
    body = replace(model.bodies[0], p_BCm_B=np.array([0.1, -0.2, 0.3]),
                   I_Cm_B=np.array([[2.0, 0.2, -0.1], [0.2, 2.5, 0.3], [-0.1, 0.3, 3.0]]))
    return replace(model, bodies=(body,), gravity_W=np.array([0.3, -0.5, -9.81]))


@pytest.mark.parametrize("name", available_scenes())
def test_three_sources_agree_on_every_scene(name):
    _, _, results = terms(*loaded(name))
    diffs = dc.compare_terms(results)
    assert len(diffs) == 9
    assert all(d.passed for d in diffs), dc.format_diffs(diffs)
    for d in diffs:  # the engines to rounding; the in-house finite differences to ~1e-11
        assert d.max_rel < (1e-13 if "inhouse" not in (d.a, d.b) else 1e-10), d


def test_free_joint_velocity_map_with_offset_centre_of_mass():
    model = offset_free_body()
    _, m, pmodel = loaded("torque_free", model)
    jmap, states, results = terms(model, m, pmodel, n=4, seed=3)
    assert all(d.passed for d in dc.compare_terms(results))
    # Independent check of v = T v_pin and a = T a_pin + dT v_pin: MuJoCo's forward dynamics
    # against Pinocchio's ABA mapped to common coordinates.
    d, data = mujoco.MjData(m), pmodel.createData()
    for q, v in states:
        d.qpos[:], d.qvel[:] = dc.mujoco_state(m, jmap, q, v)
        mujoco.mj_forward(m, d)
        qp, vp = dc.pinocchio_state(pmodel, jmap, q, v)
        T, Tdot_v = dc.velocity_map(jmap, q, v)
        assert np.allclose(T @ vp, v, atol=1e-14)
        a_pin = pin.aba(pmodel, data, qp, vp, np.zeros(pmodel.nv))
        assert np.allclose(T @ a_pin + Tdot_v, d.qacc, rtol=0, atol=1e-12)
    # Without the dT/dt term the bias would not match: the term is needed, not cosmetic.
    q, v = states[0]
    qp, vp = dc.pinocchio_state(pmodel, jmap, q, v)
    T, _ = dc.velocity_map(jmap, q, v)
    naive = T @ (pin.nonLinearEffects(pmodel, data, qp, vp) - pin.computeGeneralizedGravity(pmodel, data, qp))
    assert np.max(np.abs(naive - results["mujoco"][0].bias)) > 1e-2


def test_inertia_about_the_joint_shows_in_the_mass_matrix():
    model, m, pmodel = loaded("double_pendulum")
    jid = pmodel.getJointId("bar2_hinge")
    bar2 = model.body("bar2")
    c = bar2.p_BCm_B
    wrong = bar2.I_Cm_B + bar2.mass * (c @ c * np.eye(3) - np.outer(c, c))  # about the joint, not the CoM
    pmodel.inertias[jid] = pin.Inertia(bar2.mass, c, wrong)
    diffs = {(d.a, d.b, d.term): d for d in dc.compare_terms(terms(model, m, pmodel)[2])}
    assert diffs[("mujoco", "pinocchio", "M")].max_rel > 1e-2
    assert diffs[("pinocchio", "inhouse", "M")].max_rel > 1e-2
    assert diffs[("mujoco", "inhouse", "M")].passed


def test_rotated_inertia_shows_in_the_mass_matrix():
    model, m, pmodel = loaded("heavy_top")
    top = model.body("top")
    R = pin.utils.rotate("x", np.pi / 2)
    pmodel.inertias[1] = pin.Inertia(top.mass, top.p_BCm_B, R @ top.I_Cm_B @ R.T)
    diffs = {(d.a, d.b, d.term): d for d in dc.compare_terms(terms(model, m, pmodel)[2])}
    assert diffs[("mujoco", "pinocchio", "M")].max_rel > 1e-2
    assert not diffs[("mujoco", "pinocchio", "bias")].passed


def test_random_states_are_seeded_and_respect_limits():
    model, m, pmodel = loaded("double_pendulum")
    jmap = dc.scene_joint_map(model, m, pmodel)
    a, b = dc.random_states(jmap, 3, 7), dc.random_states(jmap, 3, 7)
    assert all(np.array_equal(x[0], y[0]) and np.array_equal(x[1], y[1]) for x, y in zip(a, b))
    limited = replace(jmap, slots=tuple(replace(s, limits=(0.1, 0.2)) for s in jmap.slots))
    for q, _ in dc.random_states(limited, 5, 0):
        assert np.all((q >= 0.1) & (q <= 0.2))
    wide = replace(jmap, slots=tuple(replace(s, limits=(-1e16, 1e16)) for s in jmap.slots))
    for q, _ in dc.random_states(wide, 5, 0):
        assert np.all(np.abs(q) <= np.pi)


def test_retract_is_the_zero_acceleration_flow():
    model, m, pmodel = loaded("heavy_top")
    jmap = dc.scene_joint_map(model, m, pmodel)
    q, v = dc.random_states(jmap, 1, 0)[0]
    half = dc.retract(jmap, dc.retract(jmap, q, 0.5 * v), 0.5 * v)
    assert np.allclose(half, dc.retract(jmap, q, v), atol=1e-14)


def test_joint_type_mismatch_is_a_mapping_error():
    scene = load_scene("heavy_top")
    model = scene.multibody()
    pmodel, _ = load_urdf(scene.urdf, "free", replace(model, bodies=(replace(model.bodies[0], joint="free"),)))
    with pytest.raises(dc.MappingError, match="free"):
        dc.scene_joint_map(model, None, pmodel)


def test_one_body_to_joint_lookup_for_the_engine_and_the_tools(monkeypatch):
    """``body_joint`` is the one MuJoCo body -> joint lookup: the engine's initial state and the
    tools' joint map both go through it and report the same problem their own way."""
    from harness.engines.mujoco import model as mj_model
    from harness.model.errors import InputError

    model, m, _ = loaded("double_pendulum")
    for body in model.bodies:
        jid = mj_model.body_joint(m, body.name)
        assert m.jnt_bodyid[jid] == mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body.name)
    two = mujoco.MjModel.from_xml_string('<mujoco><worldbody><body name="b"><joint type="hinge"/>'
                                         '<joint type="slide"/><geom size=".1"/></body></worldbody></mujoco>')
    with pytest.raises(LookupError, match="no body named 'x'"):
        mj_model.body_joint(two, "x")
    with pytest.raises(LookupError, match="body 'b' has 2 joints, not one"):
        mj_model.body_joint(two, "b")
    calls = []
    real = mj_model.body_joint

    def counted(m_, name):
        calls.append(name)
        return real(m_, name)

    with monkeypatch.context() as mp:
        mp.setattr(mj_model, "body_joint", counted)
        mp.setattr(dc, "body_joint", counted)
        dc.scene_joint_map(model, m, None)
        mj_model.set_initial_state(m, mujoco.MjData(m), model, "double_pendulum.xml")
    assert calls == [b.name for b in model.bodies] * 2
    bad = replace(model, bodies=(replace(model.bodies[0], name="b"),))
    with pytest.raises(dc.MappingError, match="MuJoCo model: body 'b' has 2 joints, not one"):
        dc.scene_joint_map(bad, two, None)
    with pytest.raises(InputError, match="x.xml: MJCF: body 'b' has 2 joints, not one"):
        mj_model.set_initial_state(two, mujoco.MjData(two), bad, "x.xml")
