"""Pinocchio engine: the scene's URDF, forward dynamics by ``aba``, our Lie-group integrators.

Maximal coordinates are read from Pinocchio's own kinematics (``forwardKinematics``, joint
placements ``oMi`` and ``getVelocity`` in the LOCAL_WORLD_ALIGNED frame); energies from
``computeKineticEnergy``/``computePotentialEnergy``. Prescribed point forces enter ``aba`` as
external forces ``fext`` expressed in the local frame of the joint that moves the body.
"""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin

from harness import rotations
from harness.engines.base import RunSettings, check_settings
from harness.engines.lie_group_integrators import STEPPERS
from harness.engines.pinocchio_model import initial_configuration, load_urdf
from harness.scene import Scene
from harness.trajectory import SampleBuffer, Trajectory

BLOWUP_SPEED = 1e8


class PinocchioEngine:
    """Runs a scene in Pinocchio from its URDF file."""

    name = "pinocchio"
    integrators = tuple(STEPPERS)

    def simulate(self, scene: Scene, settings: RunSettings) -> Trajectory:
        check_settings(settings, self.integrators, self.name)
        model = scene.multibody()
        pmodel, ids = load_urdf(scene.urdf, scene.urdf_root_joint, model)
        data = pmodel.createData()
        q, v = initial_configuration(pmodel, ids, model)
        accel = _accel_function(pmodel, data, ids, model)
        step = STEPPERS[settings.integrator]
        h = settings.dt

        n = settings.n_saves + 1
        buf = SampleBuffer(n, len(ids))
        status, message, saved, steps = "ok", "", 0, 0
        t0 = time.perf_counter()
        try:
            for k in range(n):
                if k > 0:
                    for _ in range(settings.steps_per_save):
                        q, v = step(pmodel, accel, steps * h, q, v, h)
                        steps += 1
                if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
                    status, message = "blowup", f"non-finite state at t = {steps * h:.6g} s"
                    break
                if np.max(np.abs(v), initial=0.0) > BLOWUP_SPEED:
                    status, message = "blowup", f"velocity beyond {BLOWUP_SPEED:g} at t = {steps * h:.6g} s"
                    break
                _read_maximal(pmodel, data, ids, model, q, v, k, buf)
                buf.kinetic[k] = pin.computeKineticEnergy(pmodel, data, q, v)
                buf.potential[k] = pin.computePotentialEnergy(pmodel, data, q)
                saved = k + 1
        except (RuntimeError, ValueError, np.linalg.LinAlgError) as err:
            status, message = "failed", f"{type(err).__name__} at t = {steps * h:.6g} s: {err}"
        stats = {"steps": steps, "wall_s": time.perf_counter() - t0,
                 "settings": f"aba, {settings.integrator} on the configuration Lie group (integrate/dIntegrate), "
                             f"step {h:g} s, root joint {scene.urdf_root_joint}"}
        return buf.trajectory(self.name, settings.integrator, [b.name for b in model.bodies], settings.save_every,
                              saved, stats, status, message)


def _accel_function(pmodel, data, ids, model):
    """``a(t, q, v)`` by ``aba`` with the scene's prescribed forces as ``fext``."""
    tau = np.zeros(pmodel.nv)
    if not model.forces:
        return lambda t, q, v: pin.aba(pmodel, data, q, v, tau).copy()
    body_index = {b.name: i for i, b in enumerate(model.bodies)}

    def accel(t, q, v):
        pin.forwardKinematics(pmodel, data, q)
        fext = [pin.Force.Zero() for _ in range(pmodel.njoints)]
        for force in model.forces:
            jid = ids[body_index[force.body]]
            f_L = data.oMi[jid].rotation.T @ force.force_W(t)
            fext[jid] += pin.Force(f_L, np.cross(force.p_BQ_B, f_L))
        return pin.aba(pmodel, data, q, v, tau, fext).copy()

    return accel


def _read_maximal(pmodel, data, ids, model, q, v, k, buf: SampleBuffer) -> None:
    """Fill sample ``k`` of ``buf`` with each body's world pose and twist (centre of mass)."""
    pin.forwardKinematics(pmodel, data, q, v)
    for i, (body, jid) in enumerate(zip(model.bodies, ids)):
        oMi = data.oMi[jid]
        r_W = oMi.rotation @ pmodel.inertias[jid].lever
        vel = pin.getVelocity(pmodel, data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        buf.p_WCm_W[k, i] = oMi.translation + r_W
        buf.quat_WB[k, i] = rotations.from_matrix(oMi.rotation)
        buf.w_WB_W[k, i] = vel.angular
        buf.v_WCm_W[k, i] = vel.linear + np.cross(vel.angular, r_W)


ENGINE = PinocchioEngine()
