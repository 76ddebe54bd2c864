"""The engine contract: run a scene with given settings, return a common ``Trajectory``.

Every engine of the registry (``harness.engines.ENGINE_MODULES``: in-house, MuJoCo, Pinocchio,
Exudyn, Drake) implements ``simulate``. Saved samples are at ``t = k * save_every`` for
k = 0 .. round(t_end / save_every); fixed-step methods take ``round(save_every / dt)`` steps
between samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from harness.model.errors import InputError
from harness.model.scene import Scene, check_steps
from harness.measure.trajectory import Trajectory


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


def maximal_blowup(p_WCm_W, quat_WB, v_WCm_W, w_WB_W) -> str:
    """Why one sample of a trajectory in maximal coordinates (arrays ``[body, component]``: m,
    ``wxyz``, m/s, rad/s) counts as a blow-up: a non-finite state, or a speed (linear or
    angular) beyond ``BLOWUP_SPEED``; "" when it does not."""
    state = np.concatenate([np.ravel(p_WCm_W), np.ravel(quat_WB), np.ravel(v_WCm_W), np.ravel(w_WB_W)])
    if not np.all(np.isfinite(state)):
        return "non-finite state"
    speed = max(np.abs(v_WCm_W).max(initial=0.0), np.abs(w_WB_W).max(initial=0.0))
    if speed > BLOWUP_SPEED:
        return f"speed {speed:.3g} beyond {BLOWUP_SPEED:g}"
    return ""


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
    """

    t_end: float
    dt: float
    save_every: float
    integrator: str
    rtol: float = ERROR_CONTROL_TOL
    atol: float = ERROR_CONTROL_ATOL

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


class Engine(Protocol):
    """What every engine provides."""

    name: str
    integrators: dict[str, Integrator]  # by name, in the engine's order (``integrator_table``)

    def simulate(self, scene: Scene, settings: RunSettings) -> Trajectory:
        """Run ``scene`` and return its trajectory in maximal coordinates.

        A numerical failure (non-finite state, solver failure) is returned as a trajectory with
        ``status`` "failed" or "blowup", not raised; a scene the engine/integrator does not model
        (e.g. a joint kind it has no equations for) as an empty trajectory with status
        "unsupported" and the reason (``harness.measure.trajectory.unsupported``); bad input
        raises ``InputError``.
        """
        ...
