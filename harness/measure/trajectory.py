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
from enum import Enum
from typing import Any

import numpy as np


UNSUPPORTED = "unsupported"  # Trajectory.status of a run the engine/integrator cannot make (see Trajectory)
STATUSES = ("ok", "failed", "blowup", UNSUPPORTED)


class Failure(Enum):
    """Why a run ended before its horizon, as every engine states it (``Trajectory.reason``) and
    the studies read it: never recovered from a message's text. Its ``status`` is the family a
    report counts it in: "blowup" (the state diverged), "failed" (a numerical failure of the
    method), "unsupported" (not run: the engine or integrator does not model the scene).

    Members: ``NONE`` (the run reached its horizon), ``NON_FINITE`` (a non-finite state),
    ``SPEED`` (a speed beyond ``harness.engines.base.BLOWUP_SPEED``: every engine's guard),
    ``ENGINE_GUARD`` (the engine's own guard tripped and reset the state: MuJoCo's
    ``mjWARN_BADQACC``), ``SINGULAR`` (a singular constraint matrix; a rolling disk lying flat),
    ``PROJECTION`` (a position projection onto the constraints did not converge: constraint
    drift), ``SOLVER`` (the integrator or its solver stopped: a step size that collapsed, a
    Newton iteration that failed, an error the engine raised), ``UNSUPPORTED``.
    """

    NONE = "none"
    NON_FINITE = "non-finite state"
    SPEED = "speed guard"
    ENGINE_GUARD = "engine guard"
    SINGULAR = "singular constraint"
    PROJECTION = "constraint drift"
    SOLVER = "solver failure"
    UNSUPPORTED = "unsupported"

    @property
    def status(self) -> str:
        """The family: "ok", "blowup", "failed" or "unsupported" (``STATUSES``)."""
        if self is Failure.NONE:
            return "ok"
        if self is Failure.UNSUPPORTED:
            return UNSUPPORTED
        return "blowup" if self in (Failure.NON_FINITE, Failure.SPEED, Failure.ENGINE_GUARD) else "failed"


class RunStop(Exception):
    """Raised where a run must end early (an engine's step or read, an integrator): ``reason``
    (a ``Failure``) and a one-line ``message`` (what, and the time in s where known). The
    engines' sampling loop (``harness.engines.base.sample_run``) and the in-house integrators
    turn it into the trajectory's ``reason`` and ``message``."""

    def __init__(self, reason: Failure, message: str):
        super().__init__(message)
        self.reason = reason
        self.message = message

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
        reason: why the run ended before its horizon (``Failure``; ``Failure.NONE`` when it did
            not), with ``message`` saying why in one line and the samples computed up to the
            failure. ``Failure.UNSUPPORTED``: the engine/integrator does not model this scene
            (e.g. the compiled in-house integrators and a rolling contact), so the run was not
            made: no samples. An unsupported run is not a failure of the method: the studies
            report it as "not run", never as unstable. ``status`` is its family: "ok",
            "failed" (a numerical failure), "blowup" (the state diverged) or "unsupported".
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
    reason: Failure = Failure.NONE
    message: str = ""
    reactions: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    @property
    def status(self) -> str:
        """"ok", "failed", "blowup" or "unsupported": the family of ``reason``."""
        return self.reason.status

    @property
    def ok(self) -> bool:
        return self.reason is Failure.NONE

    @property
    def unsupported(self) -> bool:
        """True when the engine/integrator does not model the scene (status ``"unsupported"``)."""
        return self.reason is Failure.UNSUPPORTED

    def body_index(self, name: str) -> int:
        return self.body_names.index(name)


class SampleBuffer:
    """Preallocated storage an engine fills sample by sample, then turns into a ``Trajectory``.

    ``n`` samples of ``nbody`` bodies; unfilled samples are NaN and dropped by ``trajectory``.
    ``reactions``: the names whose reactions the run records (``Trajectory.reactions``), each a
    ``(force_W, moment_W)`` pair of (n, 3) arrays filled by ``set_reaction``.
    """

    def __init__(self, n: int, nbody: int, reactions=()):
        self.p_WCm_W = np.full((n, nbody, 3), np.nan)
        self.quat_WB = np.full((n, nbody, 4), np.nan)
        self.v_WCm_W = np.full((n, nbody, 3), np.nan)
        self.w_WB_W = np.full((n, nbody, 3), np.nan)
        self.kinetic = np.full(n, np.nan)
        self.potential = np.full(n, np.nan)
        self.reactions = {name: (np.full((n, 3), np.nan), np.full((n, 3), np.nan)) for name in reactions}

    def set_reaction(self, name: str, k: int, force_W, moment_W) -> None:
        """Sample ``k`` of reaction ``name``: force (N) and moment (N m), world frame."""
        self.reactions[name][0][k], self.reactions[name][1][k] = force_W, moment_W

    def trajectory(self, engine: str, integrator: str, body_names, save_every: float, saved: int,
                   stats: dict, reason: Failure = Failure.NONE, message: str = "") -> Trajectory:
        """The first ``saved`` samples, at times ``k * save_every``, with their reactions, as a
        Trajectory."""
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
            reason=reason,
            message=message,
            reactions={name: (f[:saved], m[:saved]) for name, (f, m) in self.reactions.items()},
        )


def failed(engine: str, integrator: str, body_names, reason: Failure, message: str) -> Trajectory:
    """An empty trajectory that records why a run produced nothing (``reason`` other than
    ``Failure.NONE``)."""
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
        reason=reason,
        message=message,
    )


def unsupported(engine: str, integrator: str, body_names, message: str) -> Trajectory:
    """The trajectory of a run ``engine``/``integrator`` cannot make because it does not model
    the scene (status ``"unsupported"``, no samples); ``message`` says why in one line, e.g.
    which element of the scene it lacks."""
    return failed(engine, integrator, body_names, Failure.UNSUPPORTED, message)
