"""The joint table (``harness.model.joints``): every engine agrees with it on every scene, its
per-joint physics is self-consistent, and no module outside the allowed files spells a joint
kind, a MuJoCo joint type or a force class by name (so a new joint or force type touches few
files: see the lists in ``ALLOWED_KIND_LITERALS`` and ``ALLOWED_FORCE_NAMES``)."""

from __future__ import annotations

import ast
import subprocess
import sys
import xml.etree.ElementTree as ET
from fnmatch import fnmatch
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

import harness
from harness.engines.inhouse.model import build
from harness.engines.mujoco.model import joint_type as mujoco_joint_type
from harness.engines.mujoco.model import load_mjcf
from harness.engines.pinocchio.model import (
    ROOT_JOINTS,
    from_pinocchio,
    load_urdf,
    root_joint_model,
    to_pinocchio,
)
from harness.engines.pinocchio.model import joint_type as pin_joint_type
from harness.measure import compare
from harness.model import kinematics
from harness.model.joints import (
    BALL,
    CONDITIONS,
    FREE,
    HINGE,
    JOINTS,
    ROTATIONAL,
    SLIDE,
    TRANSLATIONAL,
    angular_conditions,
    by_mujoco,
    by_pinocchio,
    by_urdf_root,
)
from harness.model.multibody import Body, Multibody
from harness.model.scene import available_scenes
from harness.engines import load_scene

HARNESS = Path(harness.__file__).resolve().parent
SCENES = available_scenes()

# Files (relative to the repository, globs allowed) that may spell a joint kind ("free", "ball",
# "hinge", "slide") as a string literal, and why. Everything else reads the joint table.
ALLOWED_KIND_LITERALS = {
    "harness/model/joints.py": "the joint table itself",
    "harness/model/builders/*.py": "builders describe systems: they name the kinds of their joints",
    "harness/engines/inhouse/compiled/solver.py": "the compiled kernel packs the hinge rows (per-joint physics)",
}
# Files that may name a force element class (PointForce, JointSpring), and why.
ALLOWED_FORCE_NAMES = {
    "harness/model/forces.py": "the force table itself",
    "harness/model/multibody.py": "Multibody's fields, and the re-export the builders import",
    "harness/model/builders/*.py": "builders describe systems: they create their force elements",
    "harness/engines/mujoco/model.py": "the MJCF writer of each force type",
}
# Files that may read a Multibody's force fields (.forces, .springs) directly instead of through
# the force table (``ForceType.elements``, ``forces.elements``, ``forces.does_work``), and why.
ALLOWED_FORCE_FIELDS = {
    "harness/model/forces.py": "the force table itself",
    "harness/model/multibody.py": "the fields",
    "harness/engines/mujoco/rollout.py": "batched MuJoCo rollouts refuse forces: to read the table (pending)",
}
# Files that may name MuJoCo joint types (mjJNT_*): the table, which maps them to kinds.
ALLOWED_MJ_JOINT_NAMES = {"harness/model/joints.py": "the joint table itself"}


def _sources():
    root = HARNESS.parent
    for path in sorted(HARNESS.rglob("*.py")):
        yield path.relative_to(root).as_posix(), ast.parse(path.read_text(), filename=str(path))


def _allowed(rel: str, allowed: dict[str, str]) -> bool:
    return any(fnmatch(rel, pattern) for pattern in allowed)


def test_no_joint_kind_literal_outside_the_allowed_files():
    kinds = set(JOINTS)
    offenders = [f"{rel}:{node.lineno}: {node.value!r}" for rel, tree in _sources() if not _allowed(rel, ALLOWED_KIND_LITERALS)
                 for node in ast.walk(tree) if isinstance(node, ast.Constant) and node.value in kinds]
    assert offenders == [], "joint kinds spelt as strings (read harness.model.joints instead):\n" + "\n".join(offenders)


def test_no_mujoco_joint_type_outside_the_table():
    offenders = []
    for rel, tree in _sources():
        if _allowed(rel, ALLOWED_MJ_JOINT_NAMES):
            continue
        for node in ast.walk(tree):
            name = (node.attr if isinstance(node, ast.Attribute) else node.id if isinstance(node, ast.Name)
                    else node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else "")
            if name.startswith("mjJNT_"):
                offenders.append(f"{rel}:{node.lineno}: {name}")
    assert offenders == [], "MuJoCo joint types named outside the joint table:\n" + "\n".join(offenders)


def test_no_force_class_outside_the_allowed_files():
    names = {"PointForce", "JointSpring"}
    offenders = []
    for rel, tree in _sources():
        if _allowed(rel, ALLOWED_FORCE_NAMES):
            continue
        for node in ast.walk(tree):
            name = (node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute) else "")
            if name in names:
                offenders.append(f"{rel}:{node.lineno}: {name}")
            if isinstance(node, ast.ImportFrom):
                offenders += [f"{rel}:{node.lineno}: import {a.name}" for a in node.names if a.name in names]
    assert offenders == [], "force classes named outside the force table:\n" + "\n".join(offenders)


def test_multibody_force_fields_are_read_through_the_force_table():
    def is_multibody(node) -> bool:  # model.<field> or <...>.multibody().<field>
        return ((isinstance(node, ast.Name) and node.id in ("model", "multibody"))
                or (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "multibody"))

    offenders = [f"{rel}:{node.lineno}: .{node.attr}" for rel, tree in _sources() if not _allowed(rel, ALLOWED_FORCE_FIELDS)
                 for node in ast.walk(tree)
                 if isinstance(node, ast.Attribute) and node.attr in ("forces", "springs") and is_multibody(node.value)]
    assert offenders == [], "Multibody force fields read by name (use harness.model.forces):\n" + "\n".join(offenders)


def test_the_model_layer_imports_no_engine_tool_or_measure(tmp_path):
    code = ("import sys, harness.model.joints, harness.model.forces, harness.model.multibody, harness.model.sanity, "
            "harness.model.kinematics, harness.model.scene, harness.model.rolling_contact\n"
            "bad = sorted(m for m in sys.modules if m.startswith(('harness.engines', 'harness.tools', 'harness.measure')))\n"
            "assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path)  # not the checkout: the installed package


# --------------------------------------------------------------------------- the table


def test_table_entries():
    assert list(JOINTS) == ["free", "ball", "hinge", "slide"]
    assert {name: (jt.nq, jt.nv, jt.rows) for name, jt in JOINTS.items()} == {
        "free": (7, 6, 0), "ball": (4, 3, 3), "hinge": (1, 1, 5), "slide": (1, 1, 5)}
    for jt in JOINTS.values():
        assert jt.rows == 6 - jt.nv  # a joint removes what it does not leave free
        assert set(jt.conditions) <= set(CONDITIONS)
        assert jt.constrained == (not jt.root_only)
        assert (jt.axis is None) == (jt.nq != 1)
        assert getattr(mujoco.mjtJoint, jt.mujoco) is not None and by_mujoco(jt.mujoco) is jt
        assert (jt.pinocchio_root is None) == bool(jt.urdf) and (jt.urdf_root is None) == (jt.pinocchio_root is None)
    assert HINGE.axis == ROTATIONAL and SLIDE.axis == TRANSLATIONAL
    assert FREE.root_only and FREE.world_linear_velocity and FREE.quat_at == 3 and BALL.quat_at == 0


def test_pinocchio_joint_models_map_to_the_table():
    cases = {pin.JointModelFreeFlyer(): FREE, pin.JointModelSpherical(): BALL, pin.JointModelRX(): HINGE,
             pin.JointModelRUBZ(): HINGE, pin.JointModelRevoluteUnaligned(np.array([1.0, 0.0, 0.0])): HINGE,
             pin.JointModelPY(): SLIDE, pin.JointModelPrismaticUnaligned(np.array([0.0, 0.0, 1.0])): SLIDE,
             pin.JointModelPlanar(): None, pin.JointModelSphericalZYX(): None}
    for jm, jt in cases.items():
        assert pin_joint_type(jm) is jt and by_pinocchio(jm.shortname()) is jt, jm.shortname()
        if jt is not None and jt.nq == jm.nq:
            assert jm.nv == jt.nv
    assert ROOT_JOINTS == {"free": pin.JointModelFreeFlyer, "spherical": pin.JointModelSpherical, "none": None}
    assert by_urdf_root("spherical") is BALL and by_urdf_root("none") is None
    assert root_joint_model(FREE)().shortname() == "JointModelFreeFlyer"


def test_angular_conditions():
    assert angular_conditions(["free", "hinge", "slide", "hinge"]) == ["hinge axes stay aligned", "slide frames stay parallel"]
    assert angular_conditions(["free", "ball"]) == []


@pytest.mark.parametrize("name", SCENES)
def test_table_agrees_with_mujoco_pinocchio_and_the_inhouse_model(name):
    scene = load_scene(name)
    model = scene.multibody()
    m = load_mjcf(scene.mjcf, model)
    pmodel, ids = load_urdf(scene.urdf, scene.urdf_root_joint, model)
    q_end = list(m.jnt_qposadr[1:]) + [m.nq]
    v_end = list(m.jnt_dofadr[1:]) + [m.nv]
    for body, jid in zip(model.bodies, ids):
        jt = JOINTS[body.joint]
        j = m.body_jntadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body.name)]
        assert mujoco_joint_type(m, j) is jt
        assert (q_end[j] - m.jnt_qposadr[j], v_end[j] - m.jnt_dofadr[j]) == (jt.nq, jt.nv)
        jm = pmodel.joints[jid]
        assert pin_joint_type(jm) is jt
        assert (jm.nq, jm.nv) == (jt.nq, jt.nv)
        # the engine conversions round-trip the scene's initial state
        qp, vp = to_pinocchio(jt, model.q0[body.name], model.v0[body.name], jm.nq)
        q, v = from_pinocchio(jt, qp, vp)
        assert np.allclose(q, model.q0[body.name], atol=1e-14) and np.allclose(v, model.v0[body.name], atol=1e-14)
    assert sum(JOINTS[b.joint].nq for b in model.bodies) == m.nq == pmodel.nq
    assert sum(JOINTS[b.joint].nv for b in model.bodies) == m.nv == pmodel.nv
    # the in-house model removes the table's rows (plus 3 per rolling contact)
    assert build(model).nc == (sum(JOINTS[b.joint].rows for b in model.bodies) + 3 * len(model.contacts)
                               + sum(JOINTS[lp.kind].rows for lp in model.loops))


@pytest.mark.parametrize("name", SCENES)
def test_urdf_joint_types_agree_with_the_table(name):
    scene = load_scene(name)
    model = scene.multibody()
    kinds = {b.name: b.joint for b in model.bodies}
    urdf = ET.parse(scene.urdf).getroot()
    stated = set()
    for joint in urdf.iter("joint"):
        child = joint.find("child").get("link")
        if child in kinds:
            assert joint.get("type") in JOINTS[kinds[child]].urdf, (child, joint.get("type"))
            stated.add(child)
    for body in model.bodies:  # a body the URDF cannot state gets its kind as Pinocchio's root joint
        if body.name not in stated:
            assert body.parent is None and by_urdf_root(scene.urdf_root_joint) is JOINTS[body.joint]


def _one_body(kind: str) -> Multibody:
    jt = JOINTS[kind]
    axis = np.array([0.3, -0.4, 0.5]) / np.linalg.norm([0.3, -0.4, 0.5])
    body = Body("b", None, kind, np.array([0.1, 0.2, -0.3]), axis, 1.3, np.array([0.05, -0.02, 0.1]),
                np.diag([0.1, 0.2, 0.25]))
    return Multibody((body,), np.array([0.0, 0.0, -9.81]), {"b": np.zeros(jt.nq)}, {"b": np.zeros(jt.nv)})


@pytest.mark.parametrize("kind", list(JOINTS))
def test_motion_is_the_derivative_of_the_retraction(kind):
    """Velocity coordinates v move the configuration as ``retract`` says (central differences of
    the forward kinematics), ``distance`` vanishes on equal configurations and measures the step."""
    jt = JOINTS[kind]
    model = _one_body(kind)
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, v = jt.draw(rng, None)
        assert q.shape == (jt.nq,) and v.shape == (jt.nv,)
        h = 1e-6
        ahead = kinematics.forward(model, {"b": jt.retract(q, h * v)}, {"b": v})["b"]
        behind = kinematics.forward(model, {"b": jt.retract(q, -h * v)}, {"b": v})["b"]
        now = kinematics.forward(model, {"b": q}, {"b": v})["b"]
        assert np.allclose((ahead.p_WCm_W - behind.p_WCm_W) / (2 * h), now.v_WCm_W, atol=1e-7)
        dR = kinematics.rotations.matrix(ahead.quat_WB) @ kinematics.rotations.matrix(behind.quat_WB).T
        w = np.array([dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]]) / (4 * h)
        assert np.allclose(w, now.w_WB_W, atol=1e-7)
        step = {FREE: max(np.linalg.norm(v[:3]), np.linalg.norm(v[3:])), BALL: np.linalg.norm(v)}.get(jt, abs(v[0]))
        assert jt.distance(q, q) == 0.0
        assert jt.distance(q, jt.retract(q, h * v)) == pytest.approx(h * step, rel=1e-6)


@pytest.mark.parametrize("kind", list(JOINTS))
def test_constraint_violation_measures_the_table_conditions(kind):
    """A joint that is exactly satisfied shows no violation; the axis measure is reported iff
    the kind imposes an angular condition."""
    from harness.measure.trajectory import Trajectory

    jt = JOINTS[kind]
    model = _one_body(kind)
    rng = np.random.default_rng(5)
    states = [kinematics.forward(model, {"b": q}, {"b": v})["b"] for q, v in (jt.draw(rng, None) for _ in range(4))]
    stack = lambda attr: np.stack([getattr(s, attr) for s in states])[:, None]  # noqa: E731
    traj = Trajectory("test", "-", ("b",), np.arange(4.0), stack("p_WCm_W"), stack("quat_WB"), stack("v_WCm_W"),
                      stack("w_WB_W"))
    viol = compare.constraint_violation(traj, model)
    assert viol["position"] < 1e-14 and viol["axis"] < 1e-7
    assert bool(compare.angular_conditions(model)) == any(c.measure == "axis" for c in jt.conditions)
