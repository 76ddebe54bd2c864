"""Pinocchio engine: the scene's URDF, forward dynamics by ``aba``, our Lie-group integrators.

Maximal coordinates are read from Pinocchio's own kinematics (``forwardKinematics``, joint
placements ``oMi`` and ``getVelocity`` in the LOCAL_WORLD_ALIGNED frame); energies from
``computeKineticEnergy``/``computePotentialEnergy`` plus the potential of the force elements
Pinocchio does not model. The scene's forces enter ``aba`` as ``tau`` and ``fext``, and joint
reactions (when the scene asks, ``[checks.reaction]``) come from ``rnea`` at each saved sample:
both in ``forces``, which the rolling and loop runs share.

Scenes with rolling contacts run in ``rolling`` (``simulate_rolling``); scenes with closed
kinematic loops (``Multibody.loops``, cut joints the URDF cannot state) in ``loops``
(``simulate_loops``: Pinocchio's ``RigidConstraintModel``s and ``constraintDynamics``).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from harness.model.joints import JOINTS
from harness.engines.base import EngineBase, RunSettings, sample_run
from harness.engines.pinocchio.forces import applied_function, joint_slots, point_spring_energy, rnea_reactions, spring_energy
from harness.engines.pinocchio.lie_group_integrators import METHODS, stepper
from harness.engines.pinocchio.model import (RUN_ERRORS, MaximalReader, advance_function, configuration,
                                             initial_configuration, load_urdf, maximal_accelerations)
from harness.engines.pinocchio.loops import simulate_loops
from harness.engines.pinocchio.rolling import rolling_accelerations, simulate_rolling
from harness.model.scene import Scene
from harness.measure.trajectory import SampleBuffer, Trajectory


class PinocchioEngine(EngineBase):
    """Runs a scene in Pinocchio from its URDF file."""

    name = "pinocchio"
    integrators = METHODS

    def load_model_file(self, scene: Scene, model) -> None:
        """Load the scene's URDF (its MJCF where it names only one) with ``model``'s physics, as a
        run does (``load_urdf``): InputError where Pinocchio cannot (``harness.engines.load_model_file``)."""
        load_urdf(scene.urdf, scene.urdf_root_joint, model)

    def accelerations(self, scene: Scene, model, q, v, t: float = 0.0) -> tuple[dict, dict]:
        """The registry's hook (``harness.engines.accelerations``): each body's centre-of-mass
        acceleration (m/s^2) and angular acceleration (rad/s^2), world, per body name, at joint
        coordinates ``q, v`` (per body name) and time ``t`` (s), as a run's right-hand side
        computes them: ``aba`` with the scene's forces, or ``forwardDynamics`` with the rolling
        rows (``rolling``). NotImplementedError for a scene with loops."""
        if getattr(model, "contacts", ()):
            return rolling_accelerations(scene, model, q, v)
        if getattr(model, "loops", ()):
            raise NotImplementedError("Pinocchio's accelerations at a state of a loop scene are not available here")
        pmodel, ids = load_urdf(scene.urdf, scene.urdf_root_joint, model)
        data = pmodel.createData()
        qp, vp = configuration(pmodel, ids, model, q, v)
        a = _accel_function(pmodel, data, ids, model)(t, qp, vp)
        return maximal_accelerations(pmodel, data, ids, [b.name for b in model.bodies], qp, vp, a)

    def run(self, scene: Scene, settings: RunSettings) -> Trajectory:
        model = scene.multibody()
        if getattr(model, "contacts", ()):  # rolling contacts: constrained forward dynamics (pinocchio_rolling)
            return simulate_rolling(self, scene, settings, model)
        if getattr(model, "loops", ()):  # cut joints: Pinocchio's loop-constraint models (``loops``)
            return simulate_loops(self, scene, settings, model)
        pmodel, ids = load_urdf(scene.urdf, scene.urdf_root_joint, model)
        data = pmodel.createData()
        state = list(initial_configuration(pmodel, ids, model))
        applied = applied_function(pmodel, data, ids, model)
        slots = joint_slots(pmodel, ids, model)
        accel = _accel_function(pmodel, data, ids, model, applied)
        step = stepper(settings.integrator, pmodel)
        jointed = [(b.name, jid) for b, jid in zip(model.bodies, ids) if JOINTS[b.joint].constrained] if "reaction" in scene.checks else []
        h, per = settings.dt, settings.steps_per_save
        buf = SampleBuffer(settings.n_saves + 1, len(ids), [name for name, _ in jointed])
        reader = MaximalReader(pmodel, data, ids, buf)

        advance = advance_function(state, step, accel, h, per)

        def read(k: int) -> None:
            q, v = state
            reader.read(q, v, k)
            buf.kinetic[k] = pin.computeKineticEnergy(pmodel, data, q, v)
            buf.potential[k] = (pin.computePotentialEnergy(pmodel, data, q) + spring_energy(slots, q)
                                + point_spring_energy(pmodel, data, ids, model, q))
            if jointed:
                tau, fext = applied(k * per * h, q, v)
                a = _aba(pmodel, data, q, v, tau, fext)
                for name, (force, moment) in rnea_reactions(pmodel, data, jointed, tau, fext, q, v, a).items():
                    buf.set_reaction(name, k, force, moment)

        done = sample_run(settings, buf, advance, read, RUN_ERRORS)
        reader.finish(done.saved)
        stats = {"steps": max(done.saved - 1, 0) * per, "wall_s": done.wall_s,
                 "settings": f"aba, {settings.integrator} on the configuration Lie group (integrate/dIntegrate), "
                             f"step {h:g} s, root joint {scene.urdf_root_joint}"}
        return buf.trajectory(self.name, settings.integrator, [b.name for b in model.bodies], settings.save_every,
                              done.saved, stats, done.reason, done.message)


def _accel_function(pmodel, data, ids, model, applied=None):
    """``a(t, q, v)`` by ``aba`` with the forces of ``applied`` (default: the scene's)."""
    applied = applied or applied_function(pmodel, data, ids, model)

    def accel(t, q, v):
        tau, fext = applied(t, q, v)
        if fext is None:
            return pin.aba(pmodel, data, q, v, tau).copy()
        return pin.aba(pmodel, data, q, v, tau, fext).copy()

    return accel


def _aba(pmodel, data, q, v, tau, fext) -> np.ndarray:
    return (pin.aba(pmodel, data, q, v, tau) if fext is None else pin.aba(pmodel, data, q, v, tau, fext)).copy()


ENGINE = PinocchioEngine()
