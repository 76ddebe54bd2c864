"""Which further runs measure a run's error model, and the judging run on their sample grid.

A fixed-step run at step ``h`` is repeated at ``2 h`` (cheaper than refining) or, where that
level cannot be made (its step does not divide the horizon) or fails (a coarse step beyond the
method's stability), at ``h / 2``; where the finest two levels leave a check's class undecided
(``error_model.needs_finer_level``), at the next finer step. An error-controlled run is repeated
at ``LOOSER`` times its tolerances.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from harness.engines.base import RunSettings
from harness.judging.error_model import LOOSER
from harness.measure.trajectory import Trajectory


def _whole(ratio: float) -> bool:
    return round(ratio) >= 1 and abs(ratio - round(ratio)) <= 1e-6 * max(1.0, ratio)


def scaled_step(settings: RunSettings, factor: float) -> RunSettings | None:
    """``settings`` at step ``factor * dt`` (s), saved at the smallest multiple of its save
    interval that is a whole number of new steps and divides the horizon (else at every new
    step); None where the new step does not divide the horizon."""
    dt = settings.dt * factor
    if not _whole(settings.t_end / dt):
        return None
    # the save interval: the original one's smallest multiple that the new step divides (its
    # samples then lie on the judging run's grid), else the new step
    save = next((k * settings.save_every for k in range(1, 9) if _whole(k * settings.save_every / dt)
                 and _whole(settings.t_end / (k * settings.save_every))), dt)
    return replace(settings, dt=dt, save_every=save)


def looser(settings: RunSettings) -> RunSettings:
    """``settings`` with its tolerances ``LOOSER`` times looser (an error-controlled run's second level)."""
    return replace(settings, rtol=settings.rtol * LOOSER, atol=settings.atol * LOOSER)


def level_of(settings: RunSettings, adaptive: bool) -> float:
    """The level a run is at: its tolerance (error-controlled) or its step (s)."""
    return settings.rtol if adaptive else settings.dt


def on_grid(judge: Trajectory | None, times: np.ndarray) -> Trajectory | None:
    """``judge`` (the reference run) restricted to the saved ``times`` of another level's run
    (a coarser level saves at the judge's times or a subset of them); None where ``judge`` is
    None, not ok, or lacks one of the times."""
    if judge is None or not judge.ok:
        return judge
    if len(judge.t) == len(times) and np.allclose(judge.t, times, rtol=0, atol=1e-9 * max(1.0, float(judge.t[-1]))):
        return judge
    idx = np.searchsorted(judge.t, times - 1e-9 * max(1.0, float(judge.t[-1])))
    if np.any(idx >= len(judge.t)) or not np.allclose(judge.t[np.minimum(idx, len(judge.t) - 1)], times, rtol=0,
                                                       atol=1e-9 * max(1.0, float(judge.t[-1]))):
        return None
    return replace(judge, t=judge.t[idx], p_WCm_W=judge.p_WCm_W[idx], quat_WB=judge.quat_WB[idx],
                   v_WCm_W=judge.v_WCm_W[idx], w_WB_W=judge.w_WB_W[idx],
                   engine_energy={k: v[idx] for k, v in judge.engine_energy.items()},
                   reactions={n: (f[idx], m[idx]) for n, (f, m) in judge.reactions.items()})


def richardson(fine: Trajectory, coarse: Trajectory, rate: float) -> Trajectory | None:
    """The run extrapolated to zero step, sample by sample, from its runs at two levels: ``x0 =
    x_f + (x_f - x_c) / (rate - 1)`` for positions and velocities (m, m/s, rad/s), and on SO(3)
    for orientations (the rotation from the coarse to the fine run, scaled by ``1 / (rate - 1)``
    as a rotation vector, applied after the fine one). ``rate``: how much the error shrinks
    from the coarse level to the fine one (``2^p`` for a step halved at order p, ``LOOSER`` for
    an error-controlled run). On the coarse run's saved times; None where the fine run lacks one
    of them or ``rate`` <= 1."""
    from scipy.spatial.transform import Rotation

    fine = on_grid(fine, coarse.t)
    if fine is None or not fine.ok or not coarse.ok or rate <= 1.0:
        return None
    c = 1.0 / (rate - 1.0)
    shape = fine.quat_WB.shape
    qf = fine.quat_WB.reshape(-1, 4)[:, [1, 2, 3, 0]]  # wxyz -> SciPy's xyzw
    qc = coarse.quat_WB.reshape(-1, 4)[:, [1, 2, 3, 0]]
    Rf, Rc = Rotation.from_quat(qf), Rotation.from_quat(qc)
    step = Rotation.from_rotvec((Rf * Rc.inv()).as_rotvec() * c)  # world-frame correction
    q0 = (step * Rf).as_quat()[:, [3, 0, 1, 2]].reshape(shape)
    return replace(fine, p_WCm_W=fine.p_WCm_W + c * (fine.p_WCm_W - coarse.p_WCm_W), quat_WB=q0,
                   v_WCm_W=fine.v_WCm_W + c * (fine.v_WCm_W - coarse.v_WCm_W),
                   w_WB_W=fine.w_WB_W + c * (fine.w_WB_W - coarse.w_WB_W), reactions={}, engine_energy={})
