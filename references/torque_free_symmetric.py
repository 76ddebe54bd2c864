"""The free symmetric body (I1 = I2 about body x and y, I3 about the symmetry axis z): the
exact check of its runs.

Textbook location
-----------------
Boström, *Rigid body dynamics*, §4.7, Eqs. (4.66)-(4.73) (text lines ~2339-2385): ω_perp turns
at the rate γ ω3, γ = (I3 − I1)/I1, about the symmetry axis; the body cone (half-angle α_b
about the symmetry axis) rolls on the space cone (half-angle α_s about L).

The closed forms are those of ``harness.references.torque_free`` (``omega_body`` with
I = (I1, I1, I3), ``cone_angles``, ``symmetric_precession_rate``), derived and tested there; this
module only judges runs of the symmetric scene with them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from harness.model import rotations
from harness.references.torque_free import cone_angles, omega_body, symmetric_precession_rate

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = ["EXACT_NEEDS_RUNS", "exact_error", "exact_error_series"]

EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs


def _deviations(scene: "Scene", traj: "Trajectory") -> dict:
    """Per sample: the largest component of w_B - w_B_exact over |omega0| (``w``, relative), the
    body cone's half-angle (``body``, rad: w from the symmetry axis) and the space cone's
    (``space``, rad: w from L), with the exact half-angles and the scale."""
    p = scene.params
    I1, I3 = p["I1"], p["I3"]
    model = scene.multibody()
    R = rotations.matrix(traj.quat_WB[:, 0])
    w_W = traj.w_WB_W[:, 0]
    w_B = np.einsum("tji,tj->ti", R, w_W)
    w0 = np.asarray(p["omega0"], dtype=float)
    scale = float(np.linalg.norm(w0)) or 1.0
    w_dev = np.abs(w_B - omega_body(traj.t, (I1, I1, I3), w0))
    # cones: angle of w from the symmetry axis (body) and from L (space); w3 < 0 mirrors them
    sign = 1.0 if w0[2] >= 0 else -1.0
    alpha_b, _, alpha_s = cone_angles(I1, I3, float(np.hypot(w0[0], w0[1])), abs(w0[2]))
    body = np.arctan2(np.hypot(w_B[:, 0], w_B[:, 1]), sign * w_B[:, 2])
    L_W = (R @ model.bodies[0].I_Cm_B @ w_B[..., None])[..., 0]
    space = np.arctan2(np.linalg.norm(np.cross(w_W, L_W), axis=1), np.einsum("ti,ti->t", w_W, L_W))
    return {"w_dev": w_dev, "scale": scale, "body": np.abs(body - alpha_b), "space": np.abs(space - alpha_s),
            "alpha_b": alpha_b, "alpha_s": alpha_s, "w3": w0[2]}


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """max(|w_B - w_B_exact|_max / |w0|, |body-cone angle - alpha_b|, |space-cone angle - alpha_s|)
    per sample (relative and rad, as ``exact_error``, which is the maximum of this series)."""
    d = _deviations(scene, traj)
    return np.maximum(np.max(d["w_dev"], axis=1) / d["scale"], np.maximum(d["body"], d["space"]))


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """The larger of: max |w_B(t) - w_B_exact(t)| / |omega0| (largest component, relative; ω_perp
    turning at γ ω3) and the largest deviation (rad) of the body-cone and space-cone half-angles
    from Eqs. 4.70-4.73. ``settings`` and ``run`` are unused (no extra runs)."""
    d = _deviations(scene, traj)
    w_err = float(np.max(d["w_dev"])) / d["scale"]
    cone_err = float(max(np.max(d["body"]), np.max(d["space"])))
    p = scene.params
    rate = symmetric_precession_rate(p["I1"], p["I3"], d["w3"])
    return (max(w_err, cone_err), "",
            f"w_B vs closed form {w_err:.1e} (rel); cones alpha_b = {d['alpha_b']:.6f}, alpha_s = {d['alpha_s']:.6f} rad "
            f"held to {cone_err:.1e} rad; w_perp turns at gamma w3 = {rate:.6f} rad/s")
