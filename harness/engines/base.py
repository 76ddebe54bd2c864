"""The engine contract: run a scene with given settings, return a common ``Trajectory``.

Every engine of the registry (``harness.engines.DECLARATIONS``) is an ``EngineBase``: it states
its ``name`` and ``integrators`` (``Integrator`` records: kind, order, stages) and implements
``run(scene, settings)``; ``EngineBase.simulate`` around it checks the settings, returns a scene
the engine does not run (the scene's ``[not_run]``, which the registry fills from the engine's
declared capabilities: ``harness.engines.check_scene``) as "unsupported", and captures the
engine's own warnings once (``capture``) into ``stats["warnings"]``. An engine that steps
plugs its step and its read of one sample into ``sample_run``: the one sampling loop, with the
one blow-up check (``first_blowup``) and the failure reasons (``Failure``) the studies read; an
engine that integrates the whole horizon at once (in-house, Exudyn) applies ``first_blowup``
to what it returns. Saved samples are at ``t = k * save_every`` for k = 0 .. round(t_end /
save_every); fixed-step methods take ``round(save_every / dt)`` steps between samples.
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from harness.model.errors import InputError
from harness.model.scene import Scene, check_steps
from harness.measure.trajectory import Failure, RunStop, SampleBuffer, Trajectory, unsupported


#: Speed (m/s, or rad/s for rotation) beyond which every engine declares its run a blow-up.
BLOWUP_SPEED = 1e8

#: Target accuracy (``RunSettings.rtol``, relative) of an error-controlled method where a run does
#: not set one: every engine's default, in ``validate`` and in ``simulate`` (whose ``--rtol``
#: default it is) alike, so that ``simulate`` gives the answers ``validate`` judges. The defaults
#: that are error-controlled are Drake's RK5; fixed-step methods ignore it. Drake's error control
#: does not bound the global error by it: at 1e-10 its RK5 held every scene's tolerances at the
#: defaults (worst margin 0.25) but left them up to 300x at other initial states (plate_pendulum at
#: theta0 = 2.5 rad: 6.1e-7 rad of orientation against 2e-9); at 1e-13 its worst margin at the
#: defaults is 0.11, those states pass, and its runs take 8.3 s in all instead of 4.7 s
#: (validate --engines drake).
ERROR_CONTROL_TOL = 1e-13
#: Absolute tolerance (``RunSettings.atol``, SI units of the state) of an error-controlled method
#: where a run does not set one (``validate``'s runs, ``simulate``'s ``--atol`` default).
ERROR_CONTROL_ATOL = 1e-12


def first_blowup(p_WCm_W, v_WCm_W, w_WB_W, t) -> tuple[int, Failure, str]:
    """The first sample that counts as a blow-up, among samples ``[sample, body, 3]`` of the
    bodies' centre-of-mass positions (m) and velocities (m/s) and angular velocities (rad/s),
    world frame, at times ``t`` (s): a non-finite value (``Failure.NON_FINITE``), or a speed
    (the norm of a body's velocity or angular velocity) beyond ``BLOWUP_SPEED``
    (``Failure.SPEED``). Returns ``(index, reason, message)``, the message with the time;
    ``(-1, Failure.NONE, "")`` when every sample is sound. Every engine's one blow-up check."""
    p, v, w = (np.asarray(a, dtype=float) for a in (p_WCm_W, v_WCm_W, w_WB_W))
    n = p.shape[0]
    if n == 0:
        return -1, Failure.NONE, ""
    with np.errstate(over="ignore", invalid="ignore"):
        finite = np.isfinite(p.reshape(n, -1)).all(1) & np.isfinite(v.reshape(n, -1)).all(1) & \
            np.isfinite(w.reshape(n, -1)).all(1)
        speed = np.linalg.norm(v, axis=-1).max(axis=-1, initial=0.0)
        spin = np.linalg.norm(w, axis=-1).max(axis=-1, initial=0.0)
    bad = ~finite | (speed > BLOWUP_SPEED) | (spin > BLOWUP_SPEED)
    if not bad.any():
        return -1, Failure.NONE, ""
    k = int(np.argmax(bad))
    at = f"at t = {float(np.asarray(t)[k]):.6g} s"
    if not finite[k]:
        return k, Failure.NON_FINITE, f"non-finite state {at}"
    if speed[k] > BLOWUP_SPEED:
        return k, Failure.SPEED, f"speed {speed[k]:.3g} m/s beyond {BLOWUP_SPEED:g} {at}"
    return k, Failure.SPEED, f"angular speed {spin[k]:.3g} rad/s beyond {BLOWUP_SPEED:g} {at}"


def warning_stats(messages: list[str]) -> dict:
    """An engine's own warnings of a run, as ``stats["warnings"]`` holds them: ``{"count": number
    of warnings, "first": the first message on one line, or ""}``."""
    return {"count": len(messages), "first": " ".join(messages[0].split()) if messages else ""}


@dataclass(frozen=True)
class Integrator:
    """One integration method of one engine.

    Attributes:
        name: the name ``--integrator`` takes (as the engine or library spells it).
        kind: ``"fixed"`` (a fixed step ``dt``) or ``"adaptive"`` (error-controlled at
            ``rtol``/``atol``; ``dt`` is only the first-step hint).
        order: nominal order of convergence (global error ~ dt^order, or ~ tol for adaptive
            methods whose error follows the tolerance).
        stages: right-hand-side evaluations per step (None where a step has no fixed count:
            implicit, multistep or extrapolation methods).
        doc: one line on the method and its constraint handling.
        reaction_order: the order of its constraint forces (joint reactions, contact forces, the
            Lagrange multipliers) where it is lower than the states' (an index-3 DAE method's
            multipliers: order 1 for generalized-alpha without perturbed starting values; Arnold
            & Bruls 2007); None where they converge at ``order``. The judging reads it
            (``harness.judging``).
    """

    name: str
    kind: str
    order: int
    stages: int | None
    doc: str = ""
    reaction_order: int | None = None

    def order_of(self, check: str) -> int:
        """The order at which ``check``'s error falls: ``reaction_order`` for the constraint
        forces (``reaction.*``, ``contact_force``) where set, else ``order``."""
        if self.reaction_order is not None and check.startswith(("reaction.", "contact_force")):
            return self.reaction_order
        return self.order

    @property
    def adaptive(self) -> bool:
        return self.kind == "adaptive"


def integrator_table(*methods: Integrator) -> dict[str, Integrator]:
    """``{name: Integrator}`` in the given order (an engine's ``integrators``)."""
    return {m.name: m for m in methods}


@dataclass(frozen=True)
class RunSettings:
    """How to run a scene.

    Attributes:
        t_end: horizon (s), > 0.
        dt: fixed step (s), > 0; for adaptive methods, the initial step hint (Drake's: the
            maximum step).
        save_every: interval between saved samples (s); a whole multiple of ``dt``.
        integrator: name from the engine's ``integrators``.
        rtol, atol: tolerances of adaptive methods (ignored by fixed-step ones); by default
            ``ERROR_CONTROL_TOL`` and ``ERROR_CONTROL_ATOL``, as validate and simulate run.
        max_step: the largest step (s) of the in-house error-controlled methods (None: the save
            interval); validate's reference caps its steps at the scene's step (Drake's
            error-controlled methods take ``dt`` as their largest step).
    """

    t_end: float
    dt: float
    save_every: float
    integrator: str
    rtol: float = ERROR_CONTROL_TOL
    atol: float = ERROR_CONTROL_ATOL
    max_step: float | None = None

    @property
    def n_saves(self) -> int:
        """Number of saved intervals (samples are n_saves + 1, including t = 0)."""
        return int(round(self.t_end / self.save_every))

    @property
    def steps_per_save(self) -> int:
        return int(round(self.save_every / self.dt))


def check_settings(settings: RunSettings, integrators, engine: str) -> None:
    """Raise InputError for a non-positive or non-finite step/horizon, more integration steps
    than ``harness.model.scene.MAX_STEPS`` (``check_steps``), an incommensurate save interval, or
    an integrator the engine does not have."""
    for label in ("t_end", "dt", "save_every"):
        value = getattr(settings, label)
        if not (math.isfinite(value) and value > 0.0):
            name = {"t_end": "horizon t_end", "dt": "timestep dt", "save_every": "save interval"}[label]
            raise InputError(f"{name} must be positive and finite, got {value:g}")
    check_steps(settings.t_end, settings.dt, "horizon t_end and step dt")
    ratio = settings.save_every / settings.dt
    if abs(ratio - round(ratio)) > 1e-6 * max(1.0, ratio) or round(ratio) < 1:
        raise InputError(f"save interval {settings.save_every:g} s is not a whole multiple of dt {settings.dt:g} s")
    ratio = settings.t_end / settings.save_every
    if abs(ratio - round(ratio)) > 1e-6 * max(1.0, ratio) or round(ratio) < 1:
        raise InputError(f"horizon {settings.t_end:g} s is not a whole multiple of the save interval {settings.save_every:g} s")
    if settings.integrator not in integrators:
        raise InputError(f"unknown integrator {settings.integrator!r} for engine {engine} (known: {', '.join(integrators)})")


def reason_of(err: BaseException) -> Failure:
    """The ``Failure`` of an exception that ended a run: its own ``reason`` where it states one
    (``RunStop``, the in-house engine's ``DynamicsError``), ``Failure.SINGULAR`` for a singular
    linear solve (``numpy.linalg.LinAlgError``), else ``Failure.SOLVER``."""
    reason = getattr(err, "reason", None)
    if isinstance(reason, Failure):
        return reason
    return Failure.SINGULAR if isinstance(err, np.linalg.LinAlgError) else Failure.SOLVER


@dataclass(frozen=True)
class Sampled:
    """How ``sample_run`` ended: ``saved`` samples (0 .. saved - 1) filled, ``reason`` and
    ``message`` (``Failure.NONE`` and "" when it reached the horizon), and the loop's wall time
    (s)."""

    saved: int
    reason: Failure
    message: str
    wall_s: float


def sample_run(settings: RunSettings, buf: SampleBuffer, advance: Callable[[int], None],
               read: Callable[[int], None], errors: dict[type, Failure] | None = None) -> Sampled:
    """The one sampling loop of every engine that steps: sample ``k`` is at ``t_k = k *
    save_every`` for k = 0 .. ``settings.n_saves``. For k >= 1, ``advance(k)`` takes the engine
    from ``t_{k-1}`` to ``t_k`` (its ``steps_per_save`` steps, or one call of the engine's own
    loop); ``read(k)`` writes sample k into ``buf`` (poses, twists, energies, reactions); then
    ``first_blowup`` judges the sample. The run ends early, keeping the samples before, on a
    blow-up (sample k dropped), on ``RunStop`` raised by ``advance`` or ``read`` (its reason), or
    on an exception of a class in ``errors`` (``{class: Failure}``, the first that matches; its
    message with the time reached). Any other exception is a bug and propagates."""
    errors = errors or {}
    caught = tuple(errors)
    t0 = time.perf_counter()
    saved, h = 0, settings.save_every
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            for k in range(settings.n_saves + 1):
                if k > 0:
                    advance(k)
                read(k)
                bad, reason, message = first_blowup(buf.p_WCm_W[k:k + 1], buf.v_WCm_W[k:k + 1], buf.w_WB_W[k:k + 1],
                                                    [k * h])
                if bad >= 0:
                    return Sampled(saved, reason, message, time.perf_counter() - t0)
                saved = k + 1
    except RunStop as stop:
        return Sampled(saved, stop.reason, stop.message, time.perf_counter() - t0)
    except caught as err:
        reason = next(r for cls, r in errors.items() if isinstance(err, cls))
        what = " ".join(str(err).split())[:300]
        return Sampled(saved, reason, f"{type(err).__name__} by t = {saved * h:.6g} s: {what}", time.perf_counter() - t0)
    return Sampled(saved, Failure.NONE, "", time.perf_counter() - t0)


class _NoCapture:
    """An engine that prints no warnings of its own: nothing to capture."""

    messages: list[str] = []


class EngineBase:
    """What every engine provides (the contract; the module docstring).

    Attributes:
        name: the registered name (``harness.engines.DECLARATIONS``).
        integrators: ``{name: Integrator}`` in the engine's order (``integrator_table``).

    An engine implements ``run(scene, settings)``; it overrides ``capture`` where the engine
    prints warnings of its own (MuJoCo's ``mju_user_warning``, Drake's log).
    """

    name: str = ""
    integrators: dict[str, Integrator] = {}

    def simulate(self, scene: Scene, settings: RunSettings) -> Trajectory:
        """Run ``scene`` and return its trajectory in maximal coordinates.

        A numerical failure (non-finite state, solver failure) is returned as a trajectory with
        its ``reason`` (``Failure``), not raised; a scene the engine does not run (its
        ``[not_run]``) or the integrator does not model (e.g. a joint kind it has no equations
        for) as an empty trajectory with reason ``Failure.UNSUPPORTED`` and why
        (``harness.measure.trajectory.unsupported``); bad input raises ``InputError``. The
        engine's own warnings during the run are in ``stats["warnings"]`` (``warning_stats``).
        """
        check_settings(settings, self.integrators, self.name)
        from harness.engines import declaration

        why = scene.not_run.get(self.name) or declaration(self.name).why_not(scene.multibody())
        if why:
            return unsupported(self.name, settings.integrator, tuple(scene.multibody().body_names),
                               f"{settings.integrator}: {why}")
        with self.capture() as log:
            traj = self.run(scene, settings)
        if not (traj.unsupported or isinstance(log, _NoCapture)):  # an engine without warnings reports none
            traj.stats["warnings"] = warning_stats(log.messages)
        return traj

    def run(self, scene: Scene, settings: RunSettings) -> Trajectory:  # pragma: no cover - every engine has one
        raise NotImplementedError

    def capture(self):
        """A context manager collecting the engine's own warnings in its ``messages``."""
        return contextlib.nullcontext(_NoCapture())
