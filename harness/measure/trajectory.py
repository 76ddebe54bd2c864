"""The common trajectory: every engine's run in maximal coordinates, and its CSV schema.

Arrays are indexed ``[time, body, component]``; frames and units as in ``harness.model.kinematics``.
CSV columns (one row per saved time, starting at t = 0):
``t, kinetic, potential, energy, px, py, pz, Lx, Ly, Lz`` then, per body B,
``B.x B.y B.z B.qw B.qx B.qy B.qz B.vx B.vy B.vz B.wx B.wy B.wz``,
then optional engine-reported columns ``engine_kinetic, engine_potential``, then, only for a
scene with springs, ``elastic`` (J, spring potential; ``energy`` includes it), and only for a
scene that asks for joint reactions (``[checks.reaction]``), per jointed body B
``B.Fx B.Fy B.Fz B.Mx B.My B.Mz``: the force (N) and the moment about the joint point (N m),
world frame, that the parent (or the world) exerts on B through B's joint.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


UNSUPPORTED = "unsupported"  # Trajectory.status of a run the engine/integrator cannot make (see Trajectory)
STATUSES = ("ok", "failed", "blowup", UNSUPPORTED)

BODY_FIELDS = ("x", "y", "z", "qw", "qx", "qy", "qz", "vx", "vy", "vz", "wx", "wy", "wz")
REACTION_FIELDS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")


@dataclass(frozen=True)
class Trajectory:
    """One run of one engine on one scene, in maximal coordinates.

    Attributes:
        engine, integrator: what produced it.
        body_names: order of the body axis.
        t: saved times (s), shape (n,).
        p_WCm_W, v_WCm_W, w_WB_W: shape (n, nbody, 3); quat_WB: (n, nbody, 4) ``wxyz``.
        engine_energy: energies as the engine itself reports them, ``{"kinetic": (n,),
            "potential": (n,)}`` (J), or empty where the engine gives none.
        stats: counters of the run (``steps``, ``rhs_evals``, ``wall_s``, ...).
        status: ``"ok"``; ``"failed"`` (a numerical failure of the run) or ``"blowup"`` (its
            state diverged), each with ``message`` saying why and keeping what was computed up to
            the failure; or ``"unsupported"``: the engine/integrator does not model this scene
            (e.g. the compiled in-house integrators and a rolling contact), so the run was not
            made: ``message`` says why, there are no samples. An unsupported run is not a
            failure of the method: the studies report it as "not run", never as unstable.
        reactions: joint reactions, only when the scene asks for them (``[checks.reaction]``),
            else empty: per jointed body B (free joints excluded) ``(force_W, moment_W)``, each
            (n, 3): the force (N) and the moment about the joint point (B's body-frame origin,
            N m), world frame, that the parent (or the world) exerts on B through the joint:
            the joint's constraint reaction, without the joint's own spring force along its
            free direction. Each engine computes them its own way (in-house: the constraint
            multipliers; MuJoCo: ``cfrc_int`` after ``mj_rnePostConstraint``; Pinocchio:
            ``data.f`` after ``rnea`` at the acceleration of ``aba``). A scene with rolling
            contacts (``Multibody.contacts``) always has, keyed by the contact's name, the force
            the plane exerts on the body at the contact point and the moment about that point
            (``harness.measure.contact_metrics``).
    """

    engine: str
    integrator: str
    body_names: tuple[str, ...]
    t: np.ndarray
    p_WCm_W: np.ndarray
    quat_WB: np.ndarray
    v_WCm_W: np.ndarray
    w_WB_W: np.ndarray
    engine_energy: dict[str, np.ndarray] = field(default_factory=dict)
    stats: dict[str, Any] = field(default_factory=dict)
    status: str = "ok"
    message: str = ""
    reactions: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def unsupported(self) -> bool:
        """True when the engine/integrator does not model the scene (status ``"unsupported"``)."""
        return self.status == UNSUPPORTED

    def body_index(self, name: str) -> int:
        return self.body_names.index(name)


class SampleBuffer:
    """Preallocated storage an engine fills sample by sample, then turns into a ``Trajectory``.

    ``n`` samples of ``nbody`` bodies; unfilled samples are NaN and dropped by ``trajectory``.
    """

    def __init__(self, n: int, nbody: int):
        self.p_WCm_W = np.full((n, nbody, 3), np.nan)
        self.quat_WB = np.full((n, nbody, 4), np.nan)
        self.v_WCm_W = np.full((n, nbody, 3), np.nan)
        self.w_WB_W = np.full((n, nbody, 3), np.nan)
        self.kinetic = np.full(n, np.nan)
        self.potential = np.full(n, np.nan)

    def trajectory(self, engine: str, integrator: str, body_names, save_every: float, saved: int,
                   stats: dict, status: str = "ok", message: str = "") -> Trajectory:
        """The first ``saved`` samples, at times ``k * save_every``, as a Trajectory."""
        return Trajectory(
            engine=engine,
            integrator=integrator,
            body_names=tuple(body_names),
            t=np.arange(saved) * save_every,
            p_WCm_W=self.p_WCm_W[:saved],
            quat_WB=self.quat_WB[:saved],
            v_WCm_W=self.v_WCm_W[:saved],
            w_WB_W=self.w_WB_W[:saved],
            engine_energy={"kinetic": self.kinetic[:saved], "potential": self.potential[:saved]},
            stats=stats,
            status=status,
            message=message,
        )


def failed(engine: str, integrator: str, body_names, status: str, message: str) -> Trajectory:
    """An empty trajectory that records why a run produced nothing (``status`` one of
    ``STATUSES`` other than "ok")."""
    nb = len(body_names)
    return Trajectory(
        engine=engine,
        integrator=integrator,
        body_names=tuple(body_names),
        t=np.zeros(0),
        p_WCm_W=np.zeros((0, nb, 3)),
        quat_WB=np.zeros((0, nb, 4)),
        v_WCm_W=np.zeros((0, nb, 3)),
        w_WB_W=np.zeros((0, nb, 3)),
        status=status,
        message=message,
    )


def unsupported(engine: str, integrator: str, body_names, message: str) -> Trajectory:
    """The trajectory of a run ``engine``/``integrator`` cannot make because it does not model
    the scene (status ``"unsupported"``, no samples); ``message`` says why in one line, e.g.
    which element of the scene it lacks."""
    return failed(engine, integrator, body_names, UNSUPPORTED, message)
