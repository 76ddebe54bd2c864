"""Discrepancy measures between trajectories, and conservation/constraint measures of one.

Every function takes common ``Trajectory`` objects (maximal coordinates, world frame) and the
scene's ``Multibody``; none knows which engine produced them. Orientation errors are geodesic
angles on SO(3) (rad), never Euler-angle differences.
"""

from __future__ import annotations

import numpy as np

from harness.measure import invariants
from harness.model import loop_closure as closure
from harness.model import rotations
from harness.model.joints import HINGE, JOINTS, joint_frames
from harness.model.joints import angular_conditions as joints_angular_conditions
from harness.model.multibody import Multibody
from harness.measure.trajectory import Trajectory

MOMENTUM_COMPONENTS = ("px", "py", "pz", "Lx", "Ly", "Lz", "L3")


def _same_grid(a: Trajectory, b: Trajectory) -> int:
    """Number of leading samples the two trajectories share (same saved times)."""
    n = min(len(a.t), len(b.t))
    if n and not np.allclose(a.t[:n], b.t[:n], rtol=0, atol=1e-9 * max(1.0, abs(a.t[n - 1]))):
        raise ValueError("trajectories are saved at different times")
    return n


def trajectory_error(a: Trajectory, b: Trajectory) -> dict[str, float]:
    """Max and RMS (over saved samples and bodies) of the differences between ``a`` and ``b``.

    Keys: ``position_max/_rms`` (m, centre of mass), ``orientation_max/_rms`` (rad, geodesic),
    ``velocity_max/_rms`` (m/s, centre of mass), ``angular_velocity_max/_rms`` (rad/s, world).
    Errors are measured on the samples both runs reached; ``samples`` says how many.
    """
    n = _same_grid(a, b)
    if n == 0:
        return {"samples": 0}
    dp = np.linalg.norm(a.p_WCm_W[:n] - b.p_WCm_W[:n], axis=-1)
    dq = rotations.geodesic_angle(a.quat_WB[:n], b.quat_WB[:n])
    dv = np.linalg.norm(a.v_WCm_W[:n] - b.v_WCm_W[:n], axis=-1)
    dw = np.linalg.norm(a.w_WB_W[:n] - b.w_WB_W[:n], axis=-1)
    out: dict[str, float] = {"samples": n}
    for key, err in (("position", dp), ("orientation", dq), ("velocity", dv), ("angular_velocity", dw)):
        out[f"{key}_max"] = float(np.max(err))
        out[f"{key}_rms"] = float(np.sqrt(np.mean(err**2)))
    return out


#: A run whose largest angular velocity is below this fraction of the gravitational rate
#: sqrt(|g| / length) is at rest (``motion_scales``): its rates are round-off, not a scale.
AT_REST = 1e-6


def motion_scales(traj: Trajectory, model: Multibody) -> dict[str, float]:
    """Scales that make trajectory errors comparable across parameter sets.

    ``length`` (m): the largest of max_t |p_WCm_W| over bodies and every body's largest radius
    of gyration sqrt(I_max/m). ``angular_velocity`` (rad/s): max_t |w_WB_W|; for a run at rest
    (its rates below ``AT_REST`` times the gravitational rate sqrt(|g| / length): round-off, such
    as a cone standing still on its apex and rim) the gravitational rate, or 1 without gravity.
    ``velocity`` (m/s): the larger of max_t |v_WCm_W| and length x angular_velocity.
    """
    gyration = max(float(np.sqrt(np.linalg.eigvalsh(b.I_Cm_B)[-1] / b.mass)) for b in model.bodies)
    length = max(float(np.max(np.linalg.norm(traj.p_WCm_W, axis=-1), initial=0.0)), gyration)
    w = float(np.max(np.linalg.norm(traj.w_WB_W, axis=-1), initial=0.0))
    if is_at_rest(w, float(np.linalg.norm(model.gravity_W)), length):
        w = float(np.sqrt(np.linalg.norm(model.gravity_W) / length)) or 1.0
    v = max(float(np.max(np.linalg.norm(traj.v_WCm_W, axis=-1), initial=0.0)), length * w)
    return {"length": length, "velocity": v, "angular_velocity": w}


def is_at_rest(rate: float, g: float, length: float) -> bool:
    """Whether a run whose largest angular velocity is ``rate`` (rad/s) is at rest: ``rate`` is 0
    or below ``AT_REST`` times the gravitational rate sqrt(g / length) (g in m/s^2, length in m)."""
    return rate == 0.0 or rate <= AT_REST * np.sqrt(g / length)


def energy_scale(traj: Trajectory, model: Multibody) -> float:
    """Energy scale (J) for relative drifts: max kinetic energy plus the range of potential
    (gravitational plus elastic); for a run at rest (``motion_scales``; both are then round-off)
    the total mass times the square of its velocity scale (m g length under gravity), or 1."""
    e = invariants.energies(traj, model)
    scale = float(np.max(e["kinetic"]) + np.ptp(e["potential"] + e.get("elastic", 0.0)))
    g = float(np.linalg.norm(model.gravity_W))
    scales = motion_scales(traj, model)
    w = float(np.max(np.linalg.norm(traj.w_WB_W, axis=-1), initial=0.0))
    v = float(np.max(np.linalg.norm(traj.v_WCm_W, axis=-1), initial=0.0))
    if is_at_rest(w, g, scales["length"]) and v <= AT_REST * np.sqrt(g * scales["length"]):
        scale = sum(b.mass for b in model.bodies) * scales["velocity"] ** 2
    return scale if scale > 0 else 1.0


def energy_drift(traj: Trajectory, model: Multibody, scale_from: Trajectory | None = None) -> float:
    """max_t |E(t) - E(0)| / energy_scale (dimensionless), the scale from ``scale_from`` (the
    reference run of the same scene, so that an engine's own spurious motion, such as a soft
    contact settling under a body at rest, is not its yardstick) or else from ``traj``."""
    e = invariants.energies(traj, model)["energy"]
    return float(np.max(np.abs(e - e[0])) / energy_scale(traj if scale_from is None else scale_from, model))


def energy_balance(traj: Trajectory, model: Multibody) -> tuple[float, float]:
    """Energy balance of a forced run: max_t |E(t) - E(0) - W(t)| / energy_scale, where W is the
    work of the prescribed forces by Simpson quadrature of their power on the saved samples,
    Richardson-extrapolated from step 2h to h (evaluated at every other sample).

    Returns ``(balance, quadrature_error)``; the second is the estimated error of W relative
    to the same scale, so a reader can tell integration error from quadrature error.
    """
    from scipy.integrate import cumulative_simpson

    e = invariants.energies(traj, model)["energy"]
    power = invariants.power_of_forces(traj, model)
    scale = energy_scale(traj, model)
    if len(traj.t) < 5:
        w = invariants.work_of_forces(traj, model)
        return float(np.max(np.abs(e - e[0] - w)) / scale), float("nan")
    fine = cumulative_simpson(power, x=traj.t, initial=0.0)[::2]
    coarse = cumulative_simpson(power[::2], x=traj.t[::2], initial=0.0)
    work = fine + (fine - coarse) / 15.0
    balance = np.abs(e[::2] - e[0] - work)
    quadrature = np.abs(fine - coarse) / 15.0
    return float(np.max(balance) / scale), float(np.max(quadrature) / scale)


def momentum(traj: Trajectory, model: Multibody, component: str) -> np.ndarray:
    """Time series of one momentum component.

    ``px, py, pz``: total linear momentum (kg m/s); ``Lx, Ly, Lz``: total angular momentum
    about the world origin (kg m^2/s); ``L3``: the first body's spin angular momentum about
    its centre of mass along body z (the axial momentum I3 w3 of a symmetric top).
    """
    if component in ("px", "py", "pz"):
        return invariants.linear_momentum(traj, model)[:, "xyz".index(component[1])]
    if component in ("Lx", "Ly", "Lz"):
        return invariants.angular_momentum(traj, model)[:, "xyz".index(component[1])]
    if component == "L3":
        R = rotations.matrix(traj.quat_WB[:, 0])
        w_B = np.einsum("tji,tj->ti", R, traj.w_WB_W[:, 0])
        return (w_B @ model.bodies[0].I_Cm_B.T)[:, 2]
    raise ValueError(f"unknown momentum component {component!r} (known: {', '.join(MOMENTUM_COMPONENTS)})")


def momentum_scales(traj: Trajectory, model: Multibody) -> tuple[float, float]:
    """Scales for relative momentum drift: linear sqrt(2 M T_max) (kg m/s) and angular
    max_t |L(t)| (kg m^2/s); 1 where the scale vanishes (then the drift is absolute)."""
    t_max = float(np.max(invariants.energies(traj, model)["kinetic"]))
    p_scale = float(np.sqrt(2.0 * model.total_mass * t_max))
    L = invariants.angular_momentum(traj, model)
    L_scale = float(np.max(np.linalg.norm(L, axis=1)))
    return (p_scale if p_scale > 1e-300 else 1.0), (L_scale if L_scale > 1e-300 else 1.0)


def momentum_drift(traj: Trajectory, model: Multibody, components) -> dict[str, float]:
    """max_t |c(t) - c(0)| / scale for each conserved component ``c``."""
    p_scale, L_scale = momentum_scales(traj, model)
    out = {}
    for c in components:
        series = momentum(traj, model, c)
        scale = p_scale if c.startswith("p") else L_scale
        out[c] = float(np.max(np.abs(series - series[0])) / scale)
    return out


def constraint_violation(traj: Trajectory, model: Multibody) -> dict[str, float]:
    """Largest violation of the joints' conditions (``harness.model.joints``: each
    ``Condition.violation``), recomputed from maximal coordinates.

    ``position`` (m): for a joint point that must coincide (``POINT``), the max distance between
    it as located from the child and from the parent (or the world); for one that must stay on
    the axis line (``ON_AXIS``, a slide joint), the distance of the child's point from the
    parent's line. ``axis`` (rad): for axes that stay aligned (``ALIGNED``, a hinge), the max
    angle between the axis in the child and in the parent; for frames that stay parallel
    (``PARALLEL``, a slide joint), the geodesic angle of the child's orientation relative to
    the parent's. A joint without conditions (free) imposes nothing.
    """
    worst = {"position": 0.0, "axis": 0.0}
    R_all = rotations.matrix(traj.quat_WB.reshape(-1, 4)).reshape(traj.quat_WB.shape[:2] + (3, 3))
    for body in model.bodies:
        conditions = JOINTS[body.joint].conditions
        if not conditions:
            continue
        frames = joint_frames(traj, model, body.name, R_all)
        for condition in conditions:
            value = float(np.max(condition.violation(*frames, body.axis_B)))
            worst[condition.measure] = max(worst[condition.measure], value)
    return worst


def loop_closure(traj: Trajectory, model: Multibody) -> dict[str, dict[str, float]]:
    """Per cut joint (``Multibody.loops``), the largest closure residual of each kind over the
    samples, from maximal coordinates (``harness.model.loop_closure.residuals``): ``position``
    (m), ``velocity`` (m/s) and, for a hinge, ``axis`` (rad) and ``axis_rate`` (rad/s). Empty
    for a tree."""
    out = {}
    if not model.loops or len(traj.t) == 0:
        return out
    R_all = rotations.matrix(traj.quat_WB.reshape(-1, 4)).reshape(traj.quat_WB.shape[:2] + (3, 3))
    n = len(traj.t)
    for loop in model.loops:
        ends = []
        for body, p, axis in ((loop.body_a, loop.p_A, loop.axis_A), (loop.body_b, loop.p_B, loop.axis_B)):
            if body is None:
                ends.append(closure.world_end(p, axis, (n,)))
                continue
            i = traj.body_index(body)
            ends.append(closure.end(traj.p_WCm_W[:, i], R_all[:, i], traj.v_WCm_W[:, i], traj.w_WB_W[:, i],
                                         model.body(body).p_BCm_B, p, axis))
        out[loop.name] = {k: float(np.max(v)) for k, v in closure.residuals(loop, *ends).items()}
    return out


def angular_conditions(model: Multibody) -> list[str]:
    """What ``constraint_violation``'s ``axis`` measures for ``model``: "<kind> <condition>"
    per angular condition of its joint kinds (e.g. "hinge axes stay aligned"); empty when its
    joints impose none."""
    return joints_angular_conditions(b.joint for b in model.bodies)


def reaction_scales(traj: Trajectory, model: Multibody) -> tuple[float, float]:
    """Scales for relative reaction errors: force (N) the larger of max_t |F| over the joints of
    ``traj`` and the total weight M |g| (1 when both vanish), moment (N m) that force times
    ``motion_scales(...)["length"]``."""
    peak = max((float(np.max(np.linalg.norm(f, axis=-1), initial=0.0)) for f, _ in traj.reactions.values()), default=0.0)
    force = max(peak, model.total_mass * float(np.linalg.norm(model.gravity_W)))
    force = force if force > 1e-300 else 1.0
    return force, force * motion_scales(traj, model)["length"]


def plane_normal(model: Multibody) -> np.ndarray | None:
    """The unit normal (world) of a planar mechanism's plane: every joint of the tree and every
    cut joint a hinge, all axes parallel in world at the initial state; None otherwise."""
    from harness.model import kinematics

    hinge = HINGE.name
    if any(b.joint != hinge for b in model.bodies) or any(loop.kind != hinge for loop in model.loops):
        return None
    states = kinematics.forward(model, model.q0, model.v0)
    axes = [rotations.matrix(states[b.name].quat_WB) @ np.asarray(b.axis_B, float) for b in model.bodies]
    axes += [rotations.matrix(states[loop.body_a].quat_WB) @ np.asarray(loop.axis_A, float) for loop in model.loops]
    n = axes[0] / np.linalg.norm(axes[0])
    if any(np.linalg.norm(np.cross(n, x / np.linalg.norm(x))) > 1e-9 for x in axes):
        return None
    return n


def reaction_error(a: Trajectory, b: Trajectory, normal: np.ndarray | None = None) -> dict[str, float]:
    """Max over joints and shared samples of the reaction differences: ``force_max`` (N),
    ``moment_max`` (N m, about the joint point); joints are those of ``b``. A joint missing
    from ``a`` gives NaN. With a plane ``normal`` (unit, world), only the force's component in
    the plane and the moment's along the normal are compared (a planar mechanism's determinate
    part, ``plane_normal``)."""
    n = _same_grid(a, b)
    out = {"samples": n, "force_max": 0.0, "moment_max": 0.0}
    for name, (fb, mb) in b.reactions.items():
        if name not in a.reactions:
            return {"samples": n, "force_max": float("nan"), "moment_max": float("nan")}
        fa, ma = a.reactions[name]
        if normal is not None:
            fa, fb = (f - np.outer(f @ normal, normal) for f in (fa, fb))
            ma, mb = (np.outer(m @ normal, normal) for m in (ma, mb))
        if n:
            out["force_max"] = max(out["force_max"], float(np.max(np.linalg.norm(fa[:n] - fb[:n], axis=-1))))
            out["moment_max"] = max(out["moment_max"], float(np.max(np.linalg.norm(ma[:n] - mb[:n], axis=-1))))
    return out


def engine_energy_mismatch(traj: Trajectory, model: Multibody) -> float | None:
    """max_t |E_engine - E_harness| / energy_scale: the engine's own energy against the harness's
    recomputation from the common state and the scene's mass properties; None if not given."""
    if not traj.engine_energy:
        return None
    e = invariants.energies(traj, model)
    own = traj.engine_energy["kinetic"] + traj.engine_energy["potential"]
    return float(np.max(np.abs(own - e["energy"])) / energy_scale(traj, model))
