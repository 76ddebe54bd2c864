"""The fast in-house solver: the batched Newton-Euler equations (``batched``) with the batched
integrators (``batched_integrators``), behind the same ``simulate(scene, settings)`` contract as
the per-state engine, plus ``simulate_batch`` for many initial states at once.

Design choice (documented here rather than by registering the methods in ``InhouseEngine``): the
fast methods are a separate engine object, ``FAST_ENGINE`` (name ``"inhouse"``, integrators
``rk4_batched``, ``euler_batched``, ``rkmk4``, ``dop853_fast``, ``gbs_parallel``, and the
compiled ``rk4_compiled``, ``dop853_compiled`` of ``compiled``), used by ``harness workprecision``. The per-state engine (``harness.engines.inhouse.ENGINE``) is left
untouched: it stays the slow, transparent oracle the fast paths are tested against.

Constraint handling: every method projects onto the joint constraints after each accepted step
(``BatchedModel.project``, the same projection as the per-state fixed-step methods) and uses no
Baumgarte terms.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from harness.engines.base import RunSettings, check_settings
from harness.engines.inhouse.compiled import solver as compiled
from harness.engines.inhouse.batched import BatchedModel, batched_model
from harness.engines.inhouse.batched_integrators import ADAPTIVE as BATCHED_ADAPTIVE
from harness.engines.inhouse.batched_integrators import METHODS as BATCHED_METHODS
from harness.engines.inhouse.batched_integrators import NOMINAL_ORDER as BATCHED_ORDER
from harness.engines.inhouse.batched_integrators import BatchResult, integrate_batch
from harness.engines.inhouse.model import NEModel, build, initial_state, to_trajectory
from harness.model.multibody import Multibody
from harness.model.scene import Scene
from harness.measure.trajectory import Trajectory, failed

__all__ = ["ADAPTIVE", "FAST_ENGINE", "FastInhouseEngine", "METHODS", "NOMINAL_ORDER", "projection_tolerance"]

METHODS = BATCHED_METHODS + compiled.METHODS
ADAPTIVE = BATCHED_ADAPTIVE + compiled.ADAPTIVE
NOMINAL_ORDER = {**BATCHED_ORDER, **compiled.NOMINAL_ORDER}


def projection_tolerance(nem: NEModel) -> float:
    """As the per-state engine: 1e-13 of the largest joint-point offset (at least 1 m)."""
    return 1e-13 * max(1.0, float(np.max(np.abs(nem.D_end[:, :, 0]), initial=0.0)))


class FastInhouseEngine:
    """Batched, vectorized in-house solver (see the module docstring)."""

    name = "inhouse"
    integrators = METHODS

    def prepare(self, model: Multibody, integrator: str = "rk4_batched") -> tuple[NEModel, BatchedModel | tuple, np.ndarray]:
        """Model data, the equations ``integrator`` runs on (``BatchedModel``, or for a compiled
        method the packed model of ``compiled.pack``) and the initial state vector of ``model``.
        Raises NotImplementedError for a model outside that solver's scope."""
        nem = build(model)
        solver = compiled.pack(nem) if integrator in compiled.METHODS else batched_model(nem)
        return nem, solver, initial_state(model, nem)

    def simulate(self, scene: Scene, settings: RunSettings) -> Trajectory:
        """Run ``scene`` from its initial state (one trajectory); same contract as the other
        engines. ``stats``: ``steps``, ``rejected``, ``rhs_evals``, ``rhs_calls``, ``wall_s``
        (the integration alone), ``settings``."""
        check_settings(settings, self.integrators, self.name)
        model = scene.multibody()
        try:
            nem, bm, y0 = self.prepare(model, settings.integrator)
        except Exception as err:  # a numerical failure must come back as a trajectory
            return failed(self.name, settings.integrator, model.body_names, "failed", f"{type(err).__name__}: {err}")
        res = self.integrate(nem, bm, y0, settings)
        return self.trajectory(nem, res, settings)

    def integrate(self, nem: NEModel, bm: BatchedModel | tuple, Y0: np.ndarray, settings: RunSettings) -> BatchResult:
        """Integrate the states ``Y0`` (nbatch x ny or (ny,)) with ``settings`` on the
        equations ``bm`` that ``prepare`` made for its integrator (the compiled methods take
        one state)."""
        t_save = np.arange(settings.n_saves + 1) * settings.save_every
        if settings.integrator in compiled.METHODS:
            return compiled.integrate(bm, Y0, t_save, settings.integrator,
                                      steps_per_save=settings.steps_per_save, rtol=settings.rtol, atol=settings.atol,
                                      proj_tol=projection_tolerance(nem))
        return integrate_batch(bm, Y0, t_save, settings.integrator, steps_per_save=settings.steps_per_save,
                               rtol=settings.rtol, atol=settings.atol,
                               first_step=None if settings.integrator in ADAPTIVE else settings.dt,
                               proj_tol=projection_tolerance(nem))

    def simulate_batch(self, model: Multibody, Y0: np.ndarray, settings: RunSettings) -> BatchResult:
        """Integrate the in-house state vectors ``Y0`` (nbatch x 13 nb, bodies in ``model``
        order; see ``harness.engines.inhouse.model``) of ``model``; samples ``nsave x nbatch x ny``."""
        check_settings(settings, self.integrators, self.name)
        nem, solver, _ = self.prepare(model, settings.integrator)
        return self.integrate(nem, solver, Y0, settings)

    def trajectory(self, nem: NEModel, res: BatchResult, settings: RunSettings, column: int = 0) -> Trajectory:
        """One column of a batched result as a ``Trajectory`` (with the run's counters)."""
        traj = to_trajectory(nem, res.t, res.Y[:, column], self.name, settings.integrator)
        what = (f"{settings.integrator}, rtol={settings.rtol:g}, atol={settings.atol:g}" if settings.integrator in ADAPTIVE
                else f"{settings.integrator}, dt={settings.dt:g} s")
        kind = "compiled" if settings.integrator in compiled.METHODS else "batched"
        stats = {"steps": res.steps, "rejected": res.rejected, "rhs_evals": res.rhs_evals, "rhs_calls": res.rhs_calls,
                 "wall_s": res.wall_s, "settings": f"{kind} in-house {what}, constraint projection after each step"}
        return replace(traj, stats=stats, status=res.status, message=res.message)


FAST_ENGINE = FastInhouseEngine()

