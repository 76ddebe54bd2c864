"""What the loaders' differences come from (``diagnose``, ``diagnose_dynamics``): each cause is named only
when putting it back reconciles the readings within the tolerance (an inertial frame one reading
applies, a fixed child's mass properties, an armature, a joint placed at the parent's origin)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np

from harness.model.input_files import parse_xml
from harness.tools import dynamics_terms as dc
from harness.model.errors import InputError
from harness.model.joints import JOINTS
from harness.tools.loaded_models import (
    JointBody,
)
from harness.tools.check.results import Finding, Reading, Vote
from harness.tools.check.comparing import QUANTITIES, _fmt, _geom_mass_hint, _reading, _rotvec, _unit, _who
from harness.tools.check.reading import _zero_qpos, file_format


# --------------------------------------------------------------------------- what the differences come from
#
# Each finding is tested, not guessed: a cause is named only when putting it back reconciles the
# readings within the check's tolerance (rotating the tensor by the URDF's rpy, swapping one fixed
# child's part between two readings, taking the armature off M's diagonal).

_MASS_QUANTITIES = ("mass", "centre of mass", "inertia about the centre of mass")


def _urdf_links(path: Path) -> list:
    """The ``<link>`` elements of a URDF; none for a file that does not parse as XML."""

    try:
        return parse_xml(path, "URDF").findall("link")
    except (ET.ParseError, OSError, InputError):
        return []


def urdf_inertial_frames(path: Path) -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """Link name -> (the ``rpy`` of its ``<inertial><origin>`` as written, R: the inertial frame's
    orientation in the link frame (fixed-axis roll, pitch, yaw: R = Rz(y) Ry(p) Rx(r)), the
    ``<inertia>`` tensor as written, in the inertial frame (kg m^2)), for the links whose
    inertial frame is rotated. Empty for a file that does not parse as a URDF."""
    from scipy.spatial.transform import Rotation

    out = {}
    for link in _urdf_links(path):
        inertial = link.find("inertial")
        origin = inertial.find("origin") if inertial is not None else None
        tensor = inertial.find("inertia") if inertial is not None else None
        if origin is None or tensor is None or not origin.get("rpy"):
            continue
        try:
            rpy = [float(c) for c in origin.get("rpy").split()]
            c = {k: float(tensor.get(k, "0")) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
        except ValueError:
            continue
        if len(rpy) != 3 or not any(rpy):
            continue
        I0 = np.array([[c["ixx"], c["ixy"], c["ixz"]], [c["ixy"], c["iyy"], c["iyz"]], [c["ixz"], c["iyz"], c["izz"]]])
        out[link.get("name")] = (" ".join(origin.get("rpy").split()), Rotation.from_euler("xyz", rpy).as_matrix(), I0)
    return out


def _inertial_rotation(readings: dict[str, Reading], joint: str, body: str, rest: list[str], majority: list[str],
                       bodies, rtol: float) -> Finding | None:
    """A URDF ``<inertial><origin rpy>`` that one group of loaders (``rest`` or ``majority``) applies
    and the other does not: the difference between the two readings of the joint's body is exactly
    the rotation's contribution R I0 R^T - I0 of the link's tensor I0 (within ``rtol`` of the
    largest entry)."""
    y, x = majority[0], rest[0]
    Iy, Ix = bodies[y][joint].I_Cm_B, bodies[x][joint].I_Cm_B
    scale = max(float(np.abs(Ix).max()), float(np.abs(Iy).max()), 1e-300)
    for source in dict.fromkeys(readings[k].source for k in (y, x) if file_format(readings[k].source) == "URDF"):
        frames = urdf_inertial_frames(source)
        if body not in frames:
            continue
        rpy, R, I0 = frames[body]
        turn = R @ I0 @ R.T - I0
        for sign, rotated, plain in ((+1, x, y), (-1, y, x)):   # Ix - Iy = +turn: x rotates, y does not
            residual = float(np.abs(Ix - Iy - sign * turn).max())
            if residual > rtol * scale:
                continue
            rot = majority if rotated == y else rest
            unrot = majority if plain == y else rest
            diff = float(np.abs(Ix - Iy).max())
            angle = float(np.linalg.norm(_rotvec(R)))
            text = (f"joint {joint!r} (body {body!r}): inertia about the centre of mass differs by up to {diff:.3g} "
                    f"kg m^2 in an entry ({100 * diff / scale:.3g}% of the largest entry). Cause: the URDF's inertial-frame "
                    f"rotation (rpy): link {body!r} has <inertial><origin rpy=\"{rpy}\"> (a rotation of {angle:.3g} rad); "
                    f"{_reading(readings, rot)} has the tensor rotated by it, {_reading(readings, unrot)} has it "
                    f"unrotated: rotating the unrotated tensor by that rpy reconciles the readings (to {residual:.1e} "
                    "kg m^2). Check which file states the inertial frame as intended")
            return Finding("inertial rotation", joint, body,
                           f"inertial frame of link {body!r} rotated by the URDF's rpy=\"{rpy}\" "
                           f"(not in {_who(unrot)}'s reading)", text)
    return None


def _same_body(x: JointBody, mass: float, com: np.ndarray, inertia: np.ndarray, rtol: float) -> bool:
    """Whether (mass, com, inertia) is the body ``x`` within the check's tolerance (``QUANTITIES``)."""
    from dataclasses import replace

    y = replace(x, mass=mass, p_BCm_B=com, I_Cm_B=inertia)
    return all(bool(QUANTITIES[q][1](x, y, None, None, rtol)) for q in _MASS_QUANTITIES)


def urdf_link_masses(path: Path) -> dict[str, float]:
    """Link name -> the ``<inertial><mass value>`` a URDF states (kg); empty for a file that does
    not parse as a URDF."""
    out = {}
    for link in _urdf_links(path):
        mass = link.find("inertial/mass")
        try:
            out[link.get("name")] = float(mass.get("value")) if mass is not None else 0.0
        except (TypeError, ValueError):
            continue
    return out


def _fixed_child(readings: dict[str, Reading], joint: str, body: str, xs: list[str], ys: list[str], bodies,
                 rtol: float) -> Finding | None:
    """One fixed child whose mass properties account for the difference between the readings
    ``xs`` and ``ys`` (each a group of loaders that agree) of a joint's merged body: a reading of
    ``ys`` with that child's part taken from the ``xs`` reading (or removed, where that reading
    has no such part) is the ``xs`` reading exactly (within ``rtol``)."""
    from harness.tools.loaded_models import _composite

    x = bodies[xs[0]][joint]
    x_parts = {p.name: p for p in x.parts}
    for y_name in ys:
        y = bodies[y_name][joint]
        if not y.parts:
            continue
        y_parts = {p.name: p for p in y.parts}
        for child in [n for n in dict.fromkeys(list(y_parts) + list(x_parts)) if n not in (x.body, y.body)]:
            swapped = [p for p in y.parts if p.name != child] + ([x_parts[child]] if child in x_parts else [])
            if not swapped or not _same_body(x, *_composite(swapped), rtol):
                continue
            m_x = x_parts[child].mass if child in x_parts else 0.0
            m_y = y_parts[child].mass if child in y_parts else 0.0
            state_x = f"{m_x:.6g} kg" if child in x_parts else "absent"
            state_y = f"{m_y:.6g} kg" if child in y_parts else "absent"
            (heavy, m_heavy), light = ((xs, m_x), ys) if m_x > m_y else ((ys, m_y), xs)
            m_light = min(m_x, m_y)
            dm = abs(x.mass - y.mass)
            stated, file_mass = "", None
            for k in dict.fromkeys(xs + ys):
                if file_format(readings[k].source) == "URDF":
                    file_mass = urdf_link_masses(readings[k].source).get(child)
                    if file_mass is not None:
                        stated = f"; the URDF states <mass value=\"{file_mass:g}\"> for link {child!r}"
                        break
            where = f"link {child!r}, on a fixed joint below {body!r},"
            tol_m = rtol * max(x.mass, y.mass, 1e-300)
            if dm > tol_m and m_light == 0.0 and file_mass is not None and abs(file_mass - m_light) <= tol_m:
                text = (f"joint {joint!r} (body {body!r}): the merged body's mass differs by {dm:.6g} kg. Cause: a fixed "
                        f"child's mass that the file does not state: {where} weighs {m_heavy:.6g} kg in "
                        f"{_reading(readings, heavy)}, where the URDF states <mass value=\"{file_mass:g}\"> for it, as "
                        f"{_reading(readings, light)} has it; the mass difference equals that {m_heavy:.6g} kg, and with "
                        "the child's part swapped the readings agree")
                short = (f"fixed child {child!r} of body {body!r} given {m_heavy:.6g} kg by {_who(heavy)} "
                         f"(the URDF states {file_mass:g} kg)")
            elif dm > tol_m and m_light == 0.0:
                text = (f"joint {joint!r} (body {body!r}): the merged body's mass differs by {dm:.6g} kg. Cause: a fixed "
                        f"child's inertia is missing in {_reading(readings, light)}: {where} weighs {m_heavy:.6g} kg "
                        f"in {_reading(readings, heavy)} and 0 kg in {_reading(readings, light)}; the mass "
                        f"difference equals the child's mass, and with the child's part put back the readings agree{stated}")
                short = f"fixed child {child!r} of body {body!r} missing in {_who(light)}'s reading ({m_heavy:.6g} kg)"
            elif dm > tol_m:
                text = (f"joint {joint!r} (body {body!r}): the merged body's mass differs by {dm:.6g} kg. Cause: the fixed "
                        f"child {child!r} (on a fixed joint below {body!r}) weighs {state_x} in "
                        f"{_reading(readings, xs)} and {state_y} in {_reading(readings, ys)}; with its part swapped the "
                        f"readings agree{stated}")
                short = f"fixed child {child!r} of body {body!r} read differently by {_who(xs)}"
            else:
                I_x = x_parts[child].I_Cm_B if child in x_parts else None
                I_y = y_parts[child].I_Cm_B if child in y_parts else None
                lacking = xs if I_x is None or not np.any(I_x) else (ys if I_y is None or not np.any(I_y) else None)
                mj = bodies.get("MuJoCo", {}).get(joint)
                fused = (" (MuJoCo fused the link into its parent: fusestatic)"
                         if lacking is not None and "MuJoCo" in lacking and mj is not None
                         and child not in {p.name for p in mj.parts} else "")
                if lacking is not None:
                    has = ys if lacking is xs else xs
                    I_has = I_y if lacking is xs else I_x
                    text = (f"joint {joint!r} (body {body!r}): the merged body's inertia differs, its mass does not. Cause: "
                            f"a fixed child's inertia is missing in {_reading(readings, lacking)}: {where} of mass "
                            f"{max(m_x, m_y):.6g} kg, has the rotational inertia {_fmt(I_has, 'kg m^2')} in "
                            f"{_reading(readings, has)} and none in {_reading(readings, lacking)}{fused}; with its part put "
                            f"back the readings agree{stated}")
                    short = f"inertia of fixed child {child!r} of body {body!r} missing in {_who(lacking)}'s reading"
                else:
                    text = (f"joint {joint!r} (body {body!r}): the merged body's inertia differs, its mass does not. Cause: "
                            f"the fixed child {child!r}'s rotational inertia: {_fmt(I_x, 'kg m^2')} in "
                            f"{_reading(readings, xs)}, {_fmt(I_y, 'kg m^2')} in {_reading(readings, ys)}{stated}")
                    short = f"inertia of fixed child {child!r} of body {body!r} read differently by {_who(xs)}"
            hint = _geom_mass_hint(readings, {k: bodies[k][joint] for k in xs + ys}, xs + ys)
            return Finding("fixed child", joint, body, short, text + (f"; {hint}" if hint else ""))
    return None


def _armature_finding(readings: dict[str, Reading], v: Vote, details) -> Finding | None:
    """A joint's armature that some loaders read and others do not (0: a URDF cannot state one),
    with what it adds to M's diagonal entry of the joint (MuJoCo's M at zero joint coordinates)."""
    values = {k: details[k][v.joint].armature for k in v.values}
    nonzero = [k for k, a in values.items() if a]
    zero = [k for k, a in values.items() if not a]
    if not nonzero or not zero or any(set(nonzero) - set(g) and set(nonzero) & set(g) for g in v.groups):
        return None   # nothing read as 0, or the loaders that read an armature read different ones
    kind = next(x.kind for x in readings[nonzero[0]].bodies if x.joint == v.joint)
    unit = _unit("armature", kind)
    arm = values[nonzero[0]]
    urdf_zero = all(file_format(readings[k].source) == "URDF" for k in zero)
    zeros = f"{_who(zero)} read{'s' if len(zero) == 1 else ''} 0"
    only = "only one loader reads it" if len(nonzero) == 1 else f"only {_who(nonzero)} read it"
    text = (f"joint {v.joint!r} (body {v.body!r}): armature: {_who(nonzero)} read{'s' if len(nonzero) == 1 else ''} "
            f"{arm:.6g} {unit}, " + (f"the URDF has no armature ({zeros} — {only})" if urdf_zero else f"{zeros}: {only}"))
    mjr = readings["MuJoCo"]
    jid = mujoco.mj_name2id(mjr.model, mujoco.mjtObj.mjOBJ_JOINT, v.joint)
    if jid >= 0:
        m = mjr.model
        d = mujoco.MjData(m)
        d.qpos[:] = _zero_qpos(m)
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        dof = int(m.jnt_dofadr[jid])
        rigid = float(M[dof, dof]) - float(m.dof_armature[dof])
        text += (f"; it adds {arm:.6g} {unit} to the diagonal entry of {v.joint!r} in the mass matrix M: "
                 f"{rigid + arm:.6g} {unit} with it, {rigid:.6g} {unit} without, at zero joint coordinates "
                 f"(+{100 * arm / rigid:.3g}%)" if rigid > 0 else "")
    return Finding("armature", v.joint, v.body, f"armature of joint {v.joint!r} only in {_who(nonzero)} ({arm:.6g} {unit})",
                   text, f"armature only in {_who(nonzero)}")


def _first_joint_at_parent(readings: dict[str, Reading], v: Vote, details, rtol: float) -> Finding | None:
    """The odd one out's joint point of the first joint of a MuJoCo body with several joints
    lying at the origin of the body's parent (across the axis, within ``rtol`` of the body's
    size): the importer puts that joint at the parent's origin instead of the body's (Drake's
    MJCF parser, which gives such a body a chain of massless bodies, one joint each)."""
    mjr = readings["MuJoCo"]
    m = mjr.model
    j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, v.joint)
    if j < 0 and v.joint.startswith("joint") and v.joint[5:].isdigit():
        j = int(v.joint[5:])
    if j < 0 or j >= m.njnt:
        return None
    b = int(m.jnt_bodyid[j])
    if m.body_jntnum[b] < 2 or m.body_jntadr[b] != j:
        return None
    d = mujoco.MjData(m)
    d.qpos[:] = _zero_qpos(m)
    mujoco.mj_kinematics(m, d)
    parent = int(m.body_parentid[b])
    R_WB = d.xmat[b].reshape(3, 3)
    origin = R_WB.T @ (d.xpos[parent] - d.xpos[b])   # the parent's origin in B
    x = next(y for y in mjr.bodies if y.joint == v.joint)
    odd = details[v.odd][v.joint]
    gap = odd.point_B - origin
    if JOINTS[x.kind].axis is not None:
        gap = gap - (gap @ x.axis_B) * x.axis_B
    size = max(float(np.linalg.norm(origin)), 1e-3)
    if float(np.linalg.norm(gap)) > rtol * size:
        return None
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, k) or f"joint{k}"
             for k in range(int(m.body_jntadr[b]), int(m.body_jntadr[b] + m.body_jntnum[b]))]
    parent_name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, parent) or ("world" if parent == 0 else f"body{parent}")
    others = [k for k in v.values if k != v.odd]
    far = float(np.linalg.norm(details[others[0]][v.joint].point_B - odd.point_B))
    text = (f"joint {v.joint!r} (body {v.body!r}): joint point: {v.odd} puts the first of the body's {len(names)} joints "
            f"({', '.join(names)}) at the origin of the parent body {parent_name!r}, {far:.3g} m from where "
            f"{_who(others)} put it (at the body, as the file places its joints); the body turns about an axis through "
            "the parent's origin there, so its M, bias and gravity differ too"
            + (" (Drake's MJCF parser gives a body with several joints a chain of massless bodies, one joint each)"
               if v.odd == "Drake" else ""))
    return Finding("several joints", v.joint, v.body,
                   f"{v.odd} puts the first joint of body {v.body!r} ({v.joint}) at its parent's origin", text,
                   f"{v.odd} puts a body's first joint at its parent's origin")


def diagnose(readings: dict[str, Reading], votes: list[Vote], rtol: float) -> list[Finding]:
    """What the model disagreements come from, per joint: a fixed child's mass properties, a
    rotated URDF inertial frame, an armature only some loaders read, the first of a body's several
    joints placed at the parent's origin (see ``Finding``). Each
    group of agreeing loaders of a disagreeing vote is compared with each earlier group, the
    majority first; a cause is named only when it reconciles the two readings within ``rtol``,
    and a pair of readings of a joint is explained once."""
    loaded = [r for r in readings.values() if r.loaded]
    bodies = {r.loader: {x.joint: x for x in r.bodies} for r in loaded}
    details = {r.loader: {x.joint: x for x in r.details} for r in loaded}
    out: list[Finding] = []
    explained: set[tuple[str, str, str]] = set()   # (joint, loader, loader) pairs a finding covers
    for v in votes:
        if v.agree or not v.joint:
            continue
        if v.quantity == "armature":
            f = _armature_finding(readings, v, details)
            if f is not None:
                out.append(f)
            continue
        if v.quantity == "joint point" and v.odd is not None:
            f = _first_joint_at_parent(readings, v, details, rtol)
            if f is not None:
                out.append(f)
            continue
        if v.quantity not in _MASS_QUANTITIES:
            continue
        for i, xs in enumerate(v.groups[1:], start=1):
            for ys in v.groups[:i]:
                pairs = {(v.joint, a, b) for a in xs for b in ys} | {(v.joint, b, a) for a in xs for b in ys}
                if pairs <= explained:
                    continue
                xs_, ys_ = list(xs), list(ys)
                f = _fixed_child(readings, v.joint, v.body, xs_, ys_, bodies, rtol)
                if f is None and v.quantity == "inertia about the centre of mass":
                    f = _inertial_rotation(readings, v.joint, v.body, xs_, ys_, bodies, rtol)
                if f is not None:
                    out.append(f)
                    explained |= pairs
    return out


def diagnose_dynamics(readings: dict[str, Reading], jmap: dc.JointMap, terms: dict[str, list], diffs, rtol: float) -> list[Finding]:
    """M differing between two sources by exactly their armature difference on the diagonal (at
    every state, within ``rtol`` of M's largest entry) while bias and gravity agree."""
    failed = [d for d in diffs if d.term == "M" and not d.passed]
    if not failed:
        return []
    arm = {}
    for k in terms:
        det = {x.joint: x for x in readings[k].details}
        a = np.zeros(jmap.nv)
        for s in jmap.slots:
            if s.joint.nv == 1 and s.name in det and det[s.name].armature:
                a[s.vc] = det[s.name].armature
        arm[k] = a
    explained, worst = [], 0.0
    for d in failed:
        delta = arm[d.a] - arm[d.b]
        if not np.any(delta):
            continue
        scale = max(float(np.max(np.abs(t.M))) for k in (d.a, d.b) for t in terms[k])
        residual = max(float(np.max(np.abs(ta.M - tb.M - np.diag(delta)))) for ta, tb in zip(terms[d.a], terms[d.b]))
        if residual <= rtol * scale:
            explained.append(d)
            worst = max(worst, residual / scale)
    if not explained:
        return []
    first = explained[0]
    delta = arm[first.a] - arm[first.b]
    entries = "; ".join(f"{s.name} {delta[s.vc]:+.6g} {_unit('armature', s.kind)}" for s in jmap.slots
                        if s.joint.nv == 1 and delta[s.vc])
    pairs = " and ".join(f"M_{d.a} - M_{d.b}" for d in explained)
    involved = {e.a for e in explained} | {e.b for e in explained}
    others = [d for d in diffs if d.term != "M" and not d.passed and {d.a, d.b} & involved]
    text = (f"dynamics M: {pairs} {'is' if len(explained) == 1 else 'are'} exactly the armature difference on M's "
            f"diagonal at every state ({entries}); with it taken off, M agrees to {worst:.1e} relative"
            + ("" if others else "; bias and gravity agree: the armature is the whole difference in the dynamics terms"))
    return [Finding("dynamics armature", "", "", "dynamics M differ by the armature on the diagonal", text)]

