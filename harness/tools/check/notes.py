"""What the importers do differently beyond the compared quantities (``importer_notes``) and what MuJoCo's
model holds beyond the tree of joints and bodies (``not_compared``: equality constraints, tendons,
actuators)."""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pinocchio as pin

from harness.model.joints import JOINTS
from harness.tools.check.results import LOADERS, Reading
from harness.tools.check.reading import _body_joints, _few, file_format, read_mujoco_spec
from harness.tools.check.comparing import _range_text


def _first_tree_note(readings: dict[str, Reading]) -> list[str]:
    """A note when Pinocchio's reading of an MJCF is exactly the first body under ``<worldbody>``
    and its subtree (its MJCF parser stops there), the other trees missing (``Reading.partial``)."""
    mjr, pinr = readings["MuJoCo"], readings["Pinocchio"]
    if not pinr.loaded or not pinr.partial or file_format(pinr.source) != "MJCF":
        return []
    m = mjr.model
    first = next((b for b in range(1, m.nbody) if m.body_parentid[b] == 0), None)
    trees = {int(m.body_rootid[m.jnt_bodyid[j]]) for j in range(m.njnt)}
    has = {int(m.body_rootid[m.jnt_bodyid[j]]) for j, x in enumerate(mjr.bodies) if x.joint not in pinr.partial}
    if first is None or has != {first}:
        return []
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, first) or f"body{first}"
    return [f"Pinocchio's MJCF parser reads only the first body under <worldbody> ({name!r}) and its subtree: the "
            f"{len(trees) - 1} other kinematic tree(s) of the file, with the joints {_few(pinr.partial, 8)}, are not in "
            "its reading"]


def importer_notes(readings: dict[str, Reading]) -> list[str]:
    """What the importers do differently beyond the compared quantities (not counted as failures)."""
    mjr, pinr, drr = (readings[k] for k in LOADERS[:3])
    m, mj_file = mjr.model, mjr.source
    notes = []
    if pinr.loaded:
        pmodel = pinr.model
        mj_bodies = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)}
        pin_links = [f.name for f in pmodel.frames if f.type == pin.FrameType.BODY]
        fused = [n for n in pin_links if n not in mj_bodies]
        if fused and file_format(mj_file) == "URDF":
            notes.append(f"MuJoCo fused {len(fused)} link(s) without a moving joint into their parent body (fusestatic; "
                         f"their mass is merged, as Pinocchio and Drake merge it into the parent joint's body): "
                         f"{', '.join(fused)}")
            massless = [b.name for b in read_mujoco_spec(mj_file).bodies if b.name in fused and b.explicitinertial
                        and b.mass == 0.0 and (np.any(np.asarray(b.inertia) != 0)
                                               or np.any(np.nan_to_num(np.asarray(b.fullinertia, dtype=float)) != 0))]
            if massless:
                notes.append(f"link(s) with mass 0 but a non-zero rotational inertia: {', '.join(massless)}. MuJoCo's "
                             "fusestatic drops that inertia when it merges the link into its parent; Pinocchio adds it "
                             "to the parent joint's inertia (with --keep-static-links MuJoCo keeps it)")
        composites = [pmodel.names[jid] for jid in sorted({s.jid for s in pinr.slots.values() if s.sub >= 0})]
        if composites:
            notes.append(f"Pinocchio's MJCF parser made the joints of {len(composites)} body(ies) with several joints one "
                         f"composite joint each ({', '.join(composites)}); compared here split back into the file's "
                         "joints, in order")
        friction = []
        for x in mjr.bodies:
            s = pinr.slots.get(x.joint)
            if s is None or JOINTS[x.kind].axis is None:
                continue
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, x.joint)
            mj_val, pin_val = m.dof_frictionloss[m.jnt_dofadr[j]], pmodel.friction[s.idx_v]
            if mj_val != 0.0 or pin_val != 0.0:
                friction.append(f"{x.joint} {mj_val:g} / {pin_val:g}")
        if friction:
            notes.append("dry friction, MuJoCo frictionloss / Pinocchio friction (only MuJoCo applies it; Drake's "
                         "parsers do not read it): " + "; ".join(friction) + " (compared as `friction loss`, never counted)")
    if file_format(mj_file) == "URDF":
        notes.append(f"MuJoCo's URDF import: options not in URDF take MuJoCo's defaults (timestep {m.opt.timestep:g} s, "
                     f"integrator {mujoco.mjtIntegrator(m.opt.integrator).name[6:]}, gravity {np.round(m.opt.gravity, 6).tolist()} "
                     "m/s^2); visual geometry is discarded (discardvisual), collision geometry kept")
    limited = [(x, d) for x, d in zip(mjr.bodies, mjr.details) if d.limits is not None]
    if limited:
        notes.append("joint limits (MuJoCo enforces them as constraints; Pinocchio stores them, aba ignores them; "
                     "Drake stores them): " + "; ".join(f"{x.joint} {_range_text(d.limits, x.kind)}" for x, d in limited)
                     + " (compared as `range`)")
    damped = [(x, d) for x, d in zip(mjr.bodies, mjr.details) if d.damping]
    if damped:
        notes.append("joint damping (MuJoCo and Drake apply it as a passive force; Pinocchio's aba ignores it; "
                     "not in the dynamics terms below): " + "; ".join(f"{x.joint} {d.damping:g}" for x, d in damped)
                     + " (compared as `damping`)")
    if mjr.geom_masses:
        two = len({r.source for r in readings.values() if r.loaded}) > 1
        notes.append(f"masses derived from geoms vs given: {len(mjr.geom_masses)} body(ies) whose mass MuJoCo derives from "
                     "their geoms (a geom's mass, else its density times its volume); every other body's mass is given by "
                     "its <inertial>" + (" (Pinocchio and Drake read the URDF's <inertial> elements)" if two else "") + ": "
                     + "; ".join(text.removeprefix("MuJoCo derives the mass of ") for text in mjr.geom_masses.values()))
    several = {b: js for b, js in _body_joints(m).items() if len(js) > 1}
    if several and drr.loaded and file_format(drr.source) == "MJCF":
        notes.append(f"{len(several)} body(ies) with several joints (" + _few(f"{b}: {', '.join(js)}" for b, js in
                                                                             several.items()) + "): Drake's MJCF parser "
                     "gives each a chain of massless bodies, one joint each (<body>0, <body>1, ...), compared here as "
                     "the one body MuJoCo moves by its joints in order")
    if m.neq and file_format(mj_file) == "URDF":
        notes.append("MuJoCo turns a URDF <mimic> into an equality constraint (listed under Not compared); Pinocchio's "
                     "default URDF import treats a mimic joint as an independent joint")
    if drr.loaded and drr.parser:
        counts: dict[str, list[str]] = {}
        for line in drr.parser:
            match = re.match(r"line (\d+): (?:warning: )?(.*)", line)
            where, text = (match.group(1), match.group(2)) if match else ("?", line)
            text = re.sub(r"\b(geom|body|joint|motor|mesh|site|material) \S+ (specified|has|uses|does)", r"\1 <name> \2", text)
            counts.setdefault(text, []).append(where)
        notes.append(f"Drake's parser warned {len(drr.parser)} time(s) (what it ignores): " + "; ".join(
            f"{text} (x{len(lines)})" for text, lines in counts.items()))
    for r in readings.values():
        if r.loaded and r.dynamics:
            notes.append(f"{r.loader}'s dynamics terms are not compared: {r.dynamics}")
    return notes


_EQ_OBJECTS = {"connect": mujoco.mjtObj.mjOBJ_BODY, "weld": mujoco.mjtObj.mjOBJ_BODY, "joint": mujoco.mjtObj.mjOBJ_JOINT,
               "tendon": mujoco.mjtObj.mjOBJ_TENDON, "flex": mujoco.mjtObj.mjOBJ_FLEX}

_TRANSMISSIONS = {mujoco.mjtTrn.mjTRN_JOINT: ("joint", mujoco.mjtObj.mjOBJ_JOINT),
                  mujoco.mjtTrn.mjTRN_JOINTINPARENT: ("joint", mujoco.mjtObj.mjOBJ_JOINT),
                  mujoco.mjtTrn.mjTRN_TENDON: ("tendon", mujoco.mjtObj.mjOBJ_TENDON),
                  mujoco.mjtTrn.mjTRN_SITE: ("site", mujoco.mjtObj.mjOBJ_SITE),
                  mujoco.mjtTrn.mjTRN_BODY: ("body", mujoco.mjtObj.mjOBJ_BODY),
                  mujoco.mjtTrn.mjTRN_SLIDERCRANK: ("slider-crank at site", mujoco.mjtObj.mjOBJ_SITE)}


def not_compared(m: mujoco.MjModel) -> list[str]:
    """What MuJoCo's model holds beyond the tree of joints and bodies, which the check does not
    compare: its equality constraints, tendons and actuators, one line per kind with the count and
    each element's name (or kind and index), e.g. ``1 equality constraint: weld world-cylinder``.
    The dynamics terms leave them out (M, bias and gravity of the tree alone) and so does MuJoCo's
    rigid free motion (constraints and actuators off)."""
    def name(obj, i: int, fallback: str) -> str:
        return (mujoco.mj_id2name(m, obj, int(i)) or fallback) if i >= 0 else "world"

    out = []
    if m.neq:
        items = []
        objtypes = getattr(m, "eq_objtype", None)
        for i in range(m.neq):
            kind = mujoco.mjtEq(m.eq_type[i]).name[5:].lower()
            obj = _EQ_OBJECTS.get(kind, mujoco.mjtObj.mjOBJ_BODY)
            if objtypes is not None and kind in ("connect", "weld") and int(objtypes[i]) == int(mujoco.mjtObj.mjOBJ_SITE):
                obj = mujoco.mjtObj.mjOBJ_SITE
            what = obj.name[6:].lower()
            ends = [name(obj, int(o), f"{what}{int(o)}") for o in (m.eq_obj1id[i], m.eq_obj2id[i])
                    if not (kind in ("joint", "tendon") and int(o) < 0)]
            own = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, i)
            items.append(f"{own + ': ' if own else ''}{kind} {'-'.join(ends)}")
        out.append(f"{m.neq} equality constraint{'s' if m.neq != 1 else ''}: {_few(items)}")
    if m.ntendon:
        items = []
        for t in range(m.ntendon):
            first = int(m.wrap_type[m.tendon_adr[t]]) if m.tendon_num[t] else -1
            kind = "fixed" if first == int(mujoco.mjtWrap.mjWRAP_JOINT) else "spatial"
            items.append(f"{name(mujoco.mjtObj.mjOBJ_TENDON, t, f'tendon{t}')} ({kind})")
        out.append(f"{m.ntendon} tendon{'s' if m.ntendon != 1 else ''}: {_few(items)}")
    if m.nu:
        items = []
        for a in range(m.nu):
            what, obj = _TRANSMISSIONS.get(mujoco.mjtTrn(m.actuator_trntype[a]), ("target", None))
            target = name(obj, int(m.actuator_trnid[a, 0]), f"{what}{int(m.actuator_trnid[a, 0])}") if obj else "?"
            gear = np.asarray(m.actuator_gear[a], dtype=float)
            gear_text = f"{gear[0]:g}" if not np.any(gear[1:]) else "[" + " ".join(f"{g:g}" for g in gear) + "]"
            items.append(f"{name(mujoco.mjtObj.mjOBJ_ACTUATOR, a, f'actuator{a}')} ({what} {target}, gear {gear_text})")
        out.append(f"{m.nu} actuator{'s' if m.nu != 1 else ''}: {_few(items)}")
    return out

