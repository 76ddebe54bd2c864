"""How well a run keeps a rolling contact: slip speed, contact height, contact force.

Computed from the common trajectory (maximal coordinates), whatever engine made it, for the
scene's ``RollingContact``s (``harness.model.multibody``): the contact point C is the lowest point of
the lower rim edge, or of the contact's one rolling circle (``RollingContact.circle_z``;
``harness.model.rolling_contact``), r = r_AC its offset from the centre A.

* slip velocity: the velocity of the body's material point at C, ``v_A + w x r`` (m/s, world);
  its horizontal part is the slip (zero for rolling without slip), its vertical part the rate of
  the contact height.
* contact height: z of C (m); negative is penetration (MuJoCo's soft contact sinks into the
  floor), positive a gap (the disk hops).
* contact force: the force the plane exerts on the body (N, world), summed over the engine's
  contact points; each engine reports it in ``Trajectory.reactions[<contact name>]``.

Checks (``[checks.slip]``, ``[checks.contact_height]``, ``[checks.contact_force]`` in
``scene.toml``, per engine): ``slip`` = max_t |slip_xy| / speed scale, the speed scale being
the largest of max_t |v_A| and R max_t |w| (``speed_scale``); ``contact_height`` = max_t |z_C| / R;
``contact_force`` = max_t |F - F_ref| / force scale against the in-house reference run's
(``compare.reaction_scales``: the larger of the peak force and the weight), over t > 0: MuJoCo's
soft contact is not active before the rim penetrates the floor, so at t = 0 (the disk placed
exactly on the plane) it reports no force while the disk starts to fall into the floor.
"""

from __future__ import annotations

import numpy as np

from harness.measure import compare
from harness.model import rotations
from harness.model.multibody import Multibody, RollingContact
from harness.model.rolling_contact import contact_offset, is_flat
from harness.measure.trajectory import Trajectory


def contact_series(traj: Trajectory, contact: RollingContact) -> dict[str, np.ndarray]:
    """Per sample: ``height`` (n,) m, ``slip`` (n, 3) m/s (material point velocity at C),
    ``r`` (n, 3) m (offset A -> C, world); NaN where the disk lies flat."""
    i = traj.body_index(contact.body)
    R = rotations.matrix(traj.quat_WB[:, i].reshape(-1, 4)).reshape(-1, 3, 3)
    r = contact_offset(R, contact.radius, contact.half_thickness, contact.circle_z)
    flat = is_flat(R)
    r[flat] = np.nan
    height = traj.p_WCm_W[:, i, 2] + r[:, 2]
    slip = traj.v_WCm_W[:, i] + np.cross(traj.w_WB_W[:, i], r)
    return {"height": height, "slip": slip, "r": r}


def speed_scale(traj: Trajectory, contact: RollingContact, g: float = 0.0) -> float:
    """Speed scale (m/s) of slip: the larger of max_t |v_A| and R max_t |w|; for a body at rest
    (both below ``compare.AT_REST`` times sqrt(g R), g in m/s^2: round-off) sqrt(g R), or 1."""
    i = traj.body_index(contact.body)
    v = float(np.max(np.linalg.norm(traj.v_WCm_W[:, i], axis=-1), initial=0.0))
    w = float(np.max(np.linalg.norm(traj.w_WB_W[:, i], axis=-1), initial=0.0))
    scale = max(v, contact.radius * w)
    rest = float(np.sqrt(abs(g) * contact.radius))
    if scale <= compare.AT_REST * rest:
        scale = rest
    return scale if scale > 0.0 else 1.0


def summary(traj: Trajectory, model: Multibody) -> dict[str, float]:
    """Worst values over the scene's contacts and the samples: ``slip_max`` (m/s, horizontal),
    ``slip_rms`` (m/s), ``slip_rel`` (over ``speed_scale``), ``height_max`` (max |z_C|, m),
    ``penetration_max`` (max -z_C, m, >= 0), ``gap_max`` (max z_C, m, >= 0), ``height_rel``
    (height_max / R). NaN when a sample has the disk flat."""
    out = {"slip_max": 0.0, "slip_rms": 0.0, "slip_rel": 0.0, "height_max": 0.0, "penetration_max": 0.0,
           "gap_max": 0.0, "height_rel": 0.0}
    for contact in model.contacts:
        s = contact_series(traj, contact)
        slip = np.linalg.norm(s["slip"][:, :2], axis=-1)
        z = s["height"]
        if len(z) == 0:
            continue
        out["slip_max"] = max(out["slip_max"], float(np.max(slip)))
        out["slip_rms"] = max(out["slip_rms"], float(np.sqrt(np.mean(slip**2))))
        out["slip_rel"] = max(out["slip_rel"], float(np.max(slip)) / speed_scale(traj, contact,
                                                                               float(np.linalg.norm(model.gravity_W))))
        out["height_max"] = max(out["height_max"], float(np.max(np.abs(z))))
        out["penetration_max"] = max(out["penetration_max"], float(np.max(-z, initial=0.0)))
        out["gap_max"] = max(out["gap_max"], float(np.max(z, initial=0.0)))
        out["height_rel"] = max(out["height_rel"], float(np.max(np.abs(z))) / contact.radius)
    return out


def add_checks(scene, traj: Trajectory, ref: Trajectory | None, model: Multibody, add) -> None:
    """Add the scene's ``slip``, ``contact_height`` and ``contact_force`` checks of one run via
    ``add(check, value, unit, detail)`` (``harness.judging.checks.check_run``)."""
    checks = scene.checks
    s = summary(traj, model)
    if "slip" in checks:
        add("slip", s["slip_rel"], "rel",
            f"max slip speed {s['slip_max']:.2e} m/s (rms {s['slip_rms']:.1e}) over the speed scale; "
            "horizontal velocity of the material point at the contact")
    if "contact_height" in checks:
        add("contact_height", s["height_rel"], "rel",
            f"max |z_C| {s['height_max']:.2e} m over R (penetration {s['penetration_max']:.2e} m, gap {s['gap_max']:.2e} m)")
    if "contact_force" in checks:
        names = [c.name for c in model.contacts]
        if not all(name in traj.reactions for name in names):
            add("contact_force", float("nan"), "", f"{traj.engine} gave no contact force")
            return
        if ref is None or not ref.ok or not all(name in ref.reactions for name in names):
            return
        own = _contacts_only(traj, names, skip_first=True)
        other = _contacts_only(ref, names, skip_first=True)
        f_scale, _ = compare.reaction_scales(other, model)
        err = compare.reaction_error(own, other)
        add("contact_force", err["force_max"] / f_scale, "rel",
            f"{err['force_max']:.2e} N over force scale {f_scale:.3g} N; vs the reference's multipliers (t > 0)")


def _contacts_only(traj: Trajectory, names: list[str], skip_first: bool = False) -> Trajectory:
    """``traj`` with only the contacts' reactions; without the sample at t = 0 if asked."""
    from dataclasses import replace

    k = 1 if skip_first else 0
    return replace(traj, t=traj.t[k:], p_WCm_W=traj.p_WCm_W[k:], quat_WB=traj.quat_WB[k:], v_WCm_W=traj.v_WCm_W[k:],
                   w_WB_W=traj.w_WB_W[k:], reactions={n: (traj.reactions[n][0][k:], traj.reactions[n][1][k:]) for n in names})
