"""Joint reactions as a compared quantity: the three engines agree, the CSV gains the columns
only when the scene asks, and the MuJoCo and Pinocchio readings handle couples and point
forces."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from harness.measure import compare
from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.engines import load_scene
from harness.io.trajectory_csv import to_frame
from harness.measure.trajectory import REACTION_FIELDS

#: The engines compared here at one fixed tolerance, each at a method of order 2 or more. PyBullet
#: (semi-implicit Euler, order 1; joint forces from its sensors) is judged by how its error converges,
#: in validate (tests/engines/pybullet/), not at a fixed tolerance set for the others.
DEFAULT = {"inhouse": "rk4", "mujoco": "RK4", "pinocchio": "rkmk4", "exudyn": "GeneralizedAlpha", "drake": "RK5"}


def with_reactions(scene):
    return replace(scene, checks={**scene.checks, "reaction": {e: 1.0 for e in DEFAULT}})


def runs(scene, t_end=1.0, dt=1e-3, save=0.01):
    out = {}
    for e in DEFAULT:
        tr = get_engine(e).simulate(scene, RunSettings(t_end, dt, save, DEFAULT[e]))
        assert tr.ok, tr.message
        out[e] = tr
    return out


def test_csv_gains_reaction_columns_only_when_the_scene_asks():
    asked = load_scene("plate_pendulum")
    assert "reaction" in asked.checks
    tr = get_engine("mujoco").simulate(asked, RunSettings(0.05, 1e-3, 0.01, "RK4"))
    cols = list(to_frame(tr, asked.multibody()).columns)
    assert cols[-6:] == [f"plate.{f}" for f in REACTION_FIELDS]
    plain = load_scene("torque_free")
    tr = get_engine("mujoco").simulate(plain, RunSettings(0.05, 1e-3, 0.01, "RK4"))
    assert not tr.reactions and not any(c.endswith(".Fx") for c in to_frame(tr, plain.multibody()).columns)


def test_engines_agree_on_a_hinge_couple(monkeypatch):
    """A plate whose centre of mass is off its mid-plane and whose inertia has products about
    the hinge: the hinge must exert a couple perpendicular to its axis; all three engines
    give the same force and couple (MuJoCo from cfrc_int, Pinocchio from rnea's data.f, Exudyn
    from its joint's multipliers)."""
    import harness.model.builders.plate_pendulum as system

    build = system.build

    def skewed(params):
        model = build(params)
        body = model.bodies[0]
        I = body.I_Cm_B + np.array([[0.0, 0.002, 0.003], [0.002, 0.0, -0.002], [0.003, -0.002, 0.0]])
        body = replace(body, p_BCm_B=np.array([0.3, 0.05, -0.2]), I_Cm_B=I)
        return replace(model, bodies=(body,), v0={"plate": np.array([3.0])})

    monkeypatch.setattr(system, "build", skewed)
    tr = runs(load_scene("plate_pendulum", {"h": 0.2}))
    ref = tr["inhouse"]
    f_scale, m_scale = compare.reaction_scales(ref, load_scene("plate_pendulum", {"h": 0.2}).multibody())
    couple = np.max(np.linalg.norm(ref.reactions["plate"][1], axis=-1))
    assert couple > 0.05 * m_scale  # a real couple, not round-off
    axis = np.array([0.0, -1.0, 0.0])
    assert np.abs(ref.reactions["plate"][1] @ axis).max() < 1e-12 * m_scale  # perpendicular to the hinge
    for e in ("mujoco", "pinocchio"):
        err = compare.reaction_error(tr[e], ref)
        assert err["force_max"] < 1e-8 * f_scale and err["moment_max"] < 1e-8 * m_scale, (e, err)
    # Exudyn: generalized-alpha (order 2) at the same step; measured 3.8e-6 and 4.8e-7 of the scales
    err = compare.reaction_error(tr["exudyn"], ref)
    assert err["force_max"] < 1e-4 * f_scale and err["moment_max"] < 1e-4 * m_scale, err
    # Drake: RK5 at target accuracy 1e-10, its reaction port
    err = compare.reaction_error(tr["drake"], ref)
    assert err["force_max"] < 1e-6 * f_scale and err["moment_max"] < 1e-6 * m_scale, err


def test_engines_agree_with_a_force_at_the_pin():
    """Forced double pendulum: MuJoCo applies the pin force through site motors (generalised
    forces), which cfrc_int counts as transmitted; the harness removes it. Both joints agree."""
    scene = with_reactions(load_scene("double_pendulum", {"F0": 5.0, "omega_f": 3.0}))
    tr = runs(scene)
    ref = tr["inhouse"]
    assert set(ref.reactions) == {"bar1", "bar2"}
    f_scale, m_scale = compare.reaction_scales(ref, scene.multibody())
    for e in ("mujoco", "pinocchio"):
        err = compare.reaction_error(tr[e], ref)
        assert err["force_max"] < 1e-8 * f_scale and err["moment_max"] < 1e-8 * m_scale, (e, err)
    # Exudyn (the pin force a CreateForce with a load user function): order 2, measured 6.4e-6
    err = compare.reaction_error(tr["exudyn"], ref)
    assert err["force_max"] < 1e-4 * f_scale and err["moment_max"] < 1e-4 * m_scale, err
    # Drake (the pin force through the plant's applied-spatial-force port), RK5 at 1e-10
    err = compare.reaction_error(tr["drake"], ref)
    assert err["force_max"] < 1e-6 * f_scale and err["moment_max"] < 1e-6 * m_scale, err


def test_reaction_balances_newton_for_the_whole_chain():
    """Double pendulum: the world's force on bar1 equals the total rate of momentum minus the
    weight (finite differences of the run's own momentum)."""
    scene = with_reactions(load_scene("double_pendulum"))
    tr = get_engine("inhouse").simulate(scene, RunSettings(1.0, 1e-3, 1e-3, "rk4"))
    model = scene.multibody()
    p = compare.momentum(tr, model, "px"), compare.momentum(tr, model, "pz")
    h = tr.t[1] - tr.t[0]
    # fourth-order central differences (truncation ~ h^4 p^(5) / 30)
    dp = np.stack([(c[:-4] - 8 * c[1:-3] + 8 * c[3:-1] - c[4:]) / (12 * h) for c in p], axis=1)
    F = tr.reactions["bar1"][0][2:-2][:, [0, 2]]
    weight = model.total_mass * model.gravity_W[[0, 2]]
    assert np.abs(dp - weight - F).max() < 1e-6 * model.total_mass * 9.81


def test_loop_engines_agree_on_the_determinate_part_of_every_reaction():
    """On the Andrews squeezer (three cut hinges, a motor, a tendon spring) every engine that
    runs loops reports every tree joint and cut joint; their in-plane forces agree with the
    in-house multipliers and the moments about the plane normal vanish (a hinge transmits none:
    MuJoCo's motor torque and Pinocchio's applied torque are taken out), while the out-of-plane
    parts differ between engines (indeterminate: the loops' redundant rows)."""
    scene = with_reactions(load_scene("andrews_squeezer"))
    model = scene.multibody()
    normal = compare.plane_normal(model)
    assert np.allclose(np.abs(normal), [0.0, 1.0, 0.0])
    names = {b.name for b in model.bodies} | {loop.name for loop in model.loops}
    got = {}
    for e in ("inhouse", "mujoco", "pinocchio", "exudyn"):
        tr = get_engine(e).simulate(scene, RunSettings(0.004, 1e-5, 1e-3, DEFAULT[e]))
        assert tr.ok, tr.message
        assert set(tr.reactions) == names, e
        got[e] = tr
    scale = compare.reaction_scales(got["inhouse"], model)[0]
    for e, tr in got.items():
        err = compare.reaction_error(tr, got["inhouse"], normal)
        assert err["force_max"] < 1e-3 * scale and err["moment_max"] < 1e-9 * scale, (e, err)
        for name in names:
            assert np.max(np.abs(tr.reactions[name][1] @ normal)) < 1e-9 * scale, (e, name)
    full = compare.reaction_error(got["mujoco"], got["inhouse"])  # all components: the indeterminate part differs
    assert full["moment_max"] > 1e3 * compare.reaction_error(got["mujoco"], got["inhouse"], normal)["moment_max"]


def test_a_non_planar_or_tree_model_has_no_plane_normal():
    assert compare.plane_normal(load_scene("bricard").multibody()) is None
    assert compare.plane_normal(load_scene("cart_pendulum").multibody()) is None  # a slide joint
    assert np.allclose(np.abs(compare.plane_normal(load_scene("four_bar").multibody())), [0.0, 1.0, 0.0])
