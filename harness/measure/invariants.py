"""Energy, momentum and work recomputed from a common trajectory and the scene's mass properties.

All quantities are in the world frame W, SI units: energies in J, linear momentum in kg m/s,
angular momentum in kg m^2/s about the world origin.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from harness.model import forces, joints, rotations
from harness.model.multibody import Multibody
from harness.measure.trajectory import Failure

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory


def _inertia_world(traj: "Trajectory", model: Multibody) -> np.ndarray:
    """Inertia about each centre of mass in world frame, shape (n, nbody, 3, 3)."""
    R = rotations.matrix(traj.quat_WB.reshape(-1, 4)).reshape(traj.quat_WB.shape[:2] + (3, 3))
    I_B = np.stack([model.body(name).I_Cm_B for name in traj.body_names])
    return R @ I_B[None] @ np.swapaxes(R, -1, -2)


def _masses(traj: "Trajectory", model: Multibody) -> np.ndarray:
    return np.array([model.body(name).mass for name in traj.body_names])


def slide_coordinate(traj: "Trajectory", model: Multibody, name: str) -> np.ndarray:
    """The coordinate q (m) of body ``name``'s slide joint recovered from maximal coordinates:
    (x_c - x_p)·a_W, x_c the body's frame origin, x_p the parent's point ``p_PB_P``, a_W the
    axis in world through the parent's orientation; shape (n,) (``harness.model.joints.coordinate``)."""
    return joints.coordinate(traj, model, name)


def energies(traj: "Trajectory", model: Multibody) -> dict[str, np.ndarray]:
    """Kinetic, gravitational potential (zero at z = 0 for g along -z) and total energy, (n,).

    With force elements that store energy (``ForceType.potential`` in
    ``harness.model.forces``: joint springs, sum k (q - q_ref)^2 / 2) also ``elastic``, their
    potential, which the total ``energy`` includes (``potential`` stays the gravitational part)."""
    m = _masses(traj, model)
    I_W = _inertia_world(traj, model)
    w = traj.w_WB_W
    kin_lin = 0.5 * np.einsum("b,tbi,tbi->t", m, traj.v_WCm_W, traj.v_WCm_W)
    kin_rot = 0.5 * np.einsum("tbi,tbij,tbj->t", w, I_W, w)
    potential = -np.einsum("b,tbi,i->t", m, traj.p_WCm_W, model.gravity_W)
    kinetic = kin_lin + kin_rot
    stored = [(ft, element) for ft, element in forces.elements(model) if ft.potential is not None]
    if not stored:
        return {"kinetic": kinetic, "potential": potential, "energy": kinetic + potential}
    elastic = np.zeros(len(traj.t))
    for ft, element in stored:
        elastic += ft.potential(traj, model, element)
    return {"kinetic": kinetic, "potential": potential, "elastic": elastic, "energy": kinetic + potential + elastic}


def linear_momentum(traj: "Trajectory", model: Multibody) -> np.ndarray:
    """Total linear momentum, world frame, shape (n, 3)."""
    return np.einsum("b,tbi->ti", _masses(traj, model), traj.v_WCm_W)


def angular_momentum(traj: "Trajectory", model: Multibody) -> np.ndarray:
    """Total angular momentum about the world origin, world frame, shape (n, 3)."""
    m = _masses(traj, model)
    I_W = _inertia_world(traj, model)
    orbital = np.einsum("b,tbi->tbi", m, np.cross(traj.p_WCm_W, traj.v_WCm_W))
    spin = np.einsum("tbij,tbj->tbi", I_W, traj.w_WB_W)
    return (orbital + spin).sum(axis=1)


def power_of_forces(traj: "Trajectory", model: Multibody) -> np.ndarray:
    """Power (W) of the scene's force elements that do work (``ForceType.power`` of the elements
    that deliver it, ``ForceType.delivers``: prescribed point forces, joint torques, and the
    dampers of point springs, whose power ``-c L'^2`` is negative: the energy they dissipate)
    along the trajectory, shape (n,)."""
    power = np.zeros(len(traj.t))
    for ft, element in forces.elements(model):
        if ft.delivers(element):
            power += ft.power(traj, model, element)
    return power


def work_of_forces(traj: "Trajectory", model: Multibody) -> np.ndarray:
    """Work (J) done by the force elements that deliver power (``power_of_forces``: prescribed
    forces, torques; a damper's is negative, minus the energy it dissipated) from t[0] to each
    saved time, shape (n,).

    Cumulative Simpson quadrature of the power on the saved samples (SciPy).
    """
    from scipy.integrate import cumulative_simpson

    power = power_of_forces(traj, model)
    if len(traj.t) < 3:
        return np.zeros(len(traj.t))
    return cumulative_simpson(power, x=traj.t, initial=0.0)


def first_non_finite(traj: "Trajectory", model: Multibody) -> tuple[float, str] | None:
    """The first sample at which the run is no longer a number: ``(t, what)`` with its time (s)
    and what is non-finite there (among the state arrays ``p_WCm_W quat_WB v_WCm_W w_WB_W`` and
    the invariants recomputed from them here: ``kinetic``,
    ``potential``, ``elastic``, ``energy`` in J, linear momentum ``p`` in kg m/s, angular
    momentum ``L`` about the world origin in kg m^2/s); None when every sample is finite.
    A finite state whose energy overflows (e.g. a speed of 1e105 m/s) is a blow-up too."""
    n = len(traj.t)
    if n == 0:
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        series: dict[str, np.ndarray] = {
            "t": np.asarray(traj.t, dtype=float).reshape(n, -1),
            "position": traj.p_WCm_W.reshape(n, -1),
            "orientation": traj.quat_WB.reshape(n, -1),
            "velocity": traj.v_WCm_W.reshape(n, -1),
            "angular velocity": traj.w_WB_W.reshape(n, -1),
        }
        series.update({k: np.reshape(v, (n, -1)) for k, v in energies(traj, model).items()})
        series["linear momentum"] = linear_momentum(traj, model).reshape(n, -1)
        series["angular momentum"] = angular_momentum(traj, model).reshape(n, -1)
    bad = {k: ~np.all(np.isfinite(v), axis=1) for k, v in series.items()}
    rows = np.logical_or.reduce(list(bad.values()))
    if not rows.any():
        return None
    k = int(np.argmax(rows))
    return float(traj.t[k]), ", ".join(name for name, b in bad.items() if b[k])


def mark_non_finite(traj: "Trajectory", model: Multibody) -> "Trajectory":
    """``traj`` as judged by the harness: a run its engine reported "ok" that holds a non-finite
    value (``first_non_finite``: a state, or an invariant that overflowed) becomes a blow-up
    (``Failure.NON_FINITE``) with the message ``non-finite <what> at t = <t> s (<engine> reported ok)``, its
    samples kept; any other run (ok and finite, or already not ok) is returned unchanged. Readers
    then decide on ``traj.reason``, never on message text."""
    if not traj.ok:
        return traj
    blown = first_non_finite(traj, model)
    if blown is None:
        return traj
    t_bad, what = blown
    return replace(traj, reason=Failure.NON_FINITE, message=f"non-finite {what} at t = {t_bad:.6g} s ({traj.engine} reported ok)")
