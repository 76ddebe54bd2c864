"""MuJoCo and loop (cut) joints: how a ``LoopJoint`` is written in an MJCF, and read back.

MuJoCo closes a kinematic loop with an *equality constraint*, which it solves as a soft constraint
(the ``solref``/``solimp`` of the ``<connect>``: a time constant and damping ratio of the
constraint error's own dynamics, and an impedance), so a loop in MuJoCo is never closed exactly:
the closure error is a reported quantity, not round-off (``harness.measure.compare.loop_closure``).

The MJCF states a cut joint ``<name>`` (``harness.model.multibody.LoopJoint``) as ``<connect>``
equalities between two sites, one on each body (a world end: a site in ``<worldbody>``):

* a ball: ``<connect name="<name>" site1="<name>_a" site2="<name>_b"/>`` at the joint point;
* a hinge: the same, plus ``<connect name="<name>_2" site1="<name>_a2" site2="<name>_b2"/>`` at
  the point ``hinge_span`` (m) along the hinge axis: two coinciding points fix the axis and
  leave the rotation about it free (6 rows for the hinge's 5: one along the axis is redundant).

Site-based ``connect`` (MuJoCo >= 3.2) states both points explicitly; a body-based ``connect``
(``body1`` + ``anchor``) takes the second point from ``qpos0``, where the loop of a linkage is
generally open. ``apply_loops`` rewrites the sites' positions from the scene description (the file
carries the user's ``solref``/``solimp``, which the harness reports and keeps);
``loop_discrepancies`` reads the compiled model back against the description.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.joints import keeps_axis
from harness.model.multibody import LoopJoint, Multibody


def connects(loop: LoopJoint) -> list[tuple[str, tuple[str, str | None, np.ndarray], tuple[str, str | None, np.ndarray]]]:
    """The ``<connect>`` equalities that state ``loop``: ``(equality name, (site1, body, pos),
    (site2, body, pos))`` per equality, positions in the site's body frame (m), body None for
    the world (module docstring)."""
    out = [(loop.name, (f"{loop.name}_a", loop.body_a, np.asarray(loop.p_A, float)),
            (f"{loop.name}_b", loop.body_b, np.asarray(loop.p_B, float)))]
    if keeps_axis(loop.kind):
        span = float(loop.hinge_span)
        out.append((f"{loop.name}_2",
                    (f"{loop.name}_a2", loop.body_a, np.asarray(loop.p_A, float) + span * np.asarray(loop.axis_A, float)),
                    (f"{loop.name}_b2", loop.body_b, np.asarray(loop.p_B, float) + span * np.asarray(loop.axis_B, float))))
    return out


def apply_loops(spec: mujoco.MjSpec, model: Multibody, source: Path) -> None:
    """Write each cut joint's site positions from the description; InputError naming the file when
    a site or equality is missing, on the wrong body, or not a site-based ``connect``."""
    equalities = {e.name: e for e in spec.equalities}
    for loop in model.loops:
        for eq_name, *ends in connects(loop):
            eq = equalities.get(eq_name)
            if eq is None:
                raise InputError(f"{source}: MJCF has no equality named {eq_name!r} for the loop joint {loop.name!r}")
            if eq.type != mujoco.mjtEq.mjEQ_CONNECT or eq.objtype != mujoco.mjtObj.mjOBJ_SITE:
                raise InputError(f"{source}: equality {eq_name!r} must be a <connect> between two sites (site1, site2)")
            for (site_name, body, pos), named in zip(ends, (eq.name1, eq.name2)):
                if named != site_name:
                    raise InputError(f"{source}: equality {eq_name!r} must connect site {site_name!r}, not {named!r}")
                site = spec.site(site_name)
                if site is None:
                    raise InputError(f"{source}: MJCF has no site named {site_name!r} for the loop joint {loop.name!r}")
                owner = site.parent.name if site.parent is not None else ""
                if (owner or None) != body and not (body is None and owner == "world"):
                    raise InputError(f"{source}: site {site_name!r} must be on body {body or 'world'!r}, not {owner!r}")
                site.pos = pos
                site.quat = [1.0, 0.0, 0.0, 0.0]


def settings_text(m: mujoco.MjModel) -> str:
    """One line on the model's equality constraints: count and their solref/solimp."""
    if m.neq == 0:
        return ""
    refs = sorted({tuple(np.round(m.eq_solref[i], 6)) for i in range(m.neq)})
    imps = sorted({tuple(np.round(m.eq_solimp[i, :3], 6)) for i in range(m.neq)})
    return (f"{m.neq} soft equality constraints (connect), solref {', '.join(' '.join(f'{x:g}' for x in r) for r in refs)}, "
            f"solimp {', '.join(' '.join(f'{x:g}' for x in r) for r in imps)}")


def loop_points(m: mujoco.MjModel) -> dict[str, tuple[tuple[str, np.ndarray], tuple[str, np.ndarray]]]:
    """Per site-based ``connect`` equality of a compiled model: its name and ``((body, pos),
    (body, pos))`` of its two sites, positions in the body frame (m; body "world" for the world)."""
    out = {}
    for i in range(m.neq):
        if m.eq_type[i] != mujoco.mjtEq.mjEQ_CONNECT or m.eq_objtype[i] != mujoco.mjtObj.mjOBJ_SITE:
            continue
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, i) or f"equality {i}"
        ends = []
        for sid in (m.eq_obj1id[i], m.eq_obj2id[i]):
            body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.site_bodyid[sid])) or "world"
            ends.append((body, np.array(m.site_pos[sid], dtype=float)))
        out[name] = tuple(ends)
    return out


def cut_reactions(m: mujoco.MjModel, d: mujoco.MjData, model: Multibody) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each cut joint's reaction on its body_a: force (N, world) and moment about the joint point
    (N m, world), from the constraint forces of its ``<connect>`` equalities (``mj_forward`` must
    have run on ``d``). A site-based ``connect`` has three rows along world x, y, z for the
    difference site1 - site2, and ``efc_force`` of those rows is the force on site1's body at
    site1 (its opposite acts on site2's body); the hinge's second ``connect`` adds its force at
    its own point, whose arm gives the moment."""
    rows: dict[int, list[int]] = {}
    for r in range(d.nefc):
        if d.efc_type[r] == mujoco.mjtConstraint.mjCNSTR_EQUALITY:
            rows.setdefault(int(d.efc_id[r]), []).append(r)
    out = {}
    for loop in model.loops:
        force, moment = np.zeros(3), np.zeros(3)
        origin = None
        for eq_name, (site1, _, _), _ in connects(loop):
            eq = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, eq_name)
            sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site1)
            if eq < 0 or sid < 0 or len(rows.get(eq, ())) != 3:
                force = moment = np.full(3, np.nan)
                break
            f = np.asarray(d.efc_force[rows[eq]], dtype=float)
            point = np.array(d.site_xpos[sid])
            origin = point if origin is None else origin
            force = force + f
            moment = moment + rotations.cross(point - origin, f)
        out[loop.name] = (force, moment)
    return out
