"""The trajectory CSV: a common ``Trajectory`` as a table with the documented columns.

Columns (one row per saved time from t = 0; SI units, world frame): ``t`` (s), ``kinetic``,
``potential``, ``energy`` (J, recomputed from the trajectory by ``harness.measure.invariants``),
``px py pz`` (kg m/s), ``Lx Ly Lz`` (kg m^2/s, about the world origin), per body B the fields of
``harness.measure.trajectory.BODY_FIELDS`` (centre of mass m, quaternion body to world ``wxyz``,
centre-of-mass velocity m/s, angular velocity rad/s world frame), then the engine's own
``engine_kinetic, engine_potential``, ``elastic`` (J) for a scene with springs, and per jointed
body the reaction fields ``REACTION_FIELDS`` (N, N m about the joint point) where asked.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from harness.measure import invariants
from harness.measure.trajectory import BODY_FIELDS, REACTION_FIELDS, Trajectory
from harness.model.multibody import Multibody


def to_frame(traj: Trajectory, model: Multibody) -> pd.DataFrame:
    """The trajectory as a table with the documented CSV columns (energies recomputed here)."""
    energy = invariants.energies(traj, model)
    p_W = invariants.linear_momentum(traj, model)
    L_W = invariants.angular_momentum(traj, model)
    cols: dict[str, np.ndarray] = {
        "t": traj.t,
        "kinetic": energy["kinetic"],
        "potential": energy["potential"],
        "energy": energy["energy"],
        "px": p_W[:, 0],
        "py": p_W[:, 1],
        "pz": p_W[:, 2],
        "Lx": L_W[:, 0],
        "Ly": L_W[:, 1],
        "Lz": L_W[:, 2],
    }
    for i, name in enumerate(traj.body_names):
        block = np.concatenate(
            [traj.p_WCm_W[:, i], traj.quat_WB[:, i], traj.v_WCm_W[:, i], traj.w_WB_W[:, i]], axis=1
        )
        for j, f in enumerate(BODY_FIELDS):
            cols[f"{name}.{f}"] = block[:, j]
    for key, values in traj.engine_energy.items():
        cols[f"engine_{key}"] = values
    if "elastic" in energy:
        cols["elastic"] = energy["elastic"]
    for name, (force, moment) in traj.reactions.items():
        block = np.concatenate([force, moment], axis=1)
        for j, f in enumerate(REACTION_FIELDS):
            cols[f"{name}.{f}"] = block[:, j]
    return pd.DataFrame(cols)
