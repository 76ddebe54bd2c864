"""MuJoCo engine: the scene's MJCF stepped with ``mj_step``, read back in maximal coordinates.

Notes on reading state: after ``mj_step`` the kinematic quantities in ``MjData`` (``xipos``,
``xquat``, energy) belong to the state *before* the step (with RK4, to an intermediate stage),
so every sample is read after ``mj_forward`` on the current ``qpos``/``qvel``.

Prescribed forces act through the MJCF's motors ``<name>_fx/_fy/_fz`` (site transmission with a
world reference site); their controls are set from ``mjcb_control`` at every evaluation of the
dynamics, so RK4 sees the force at its stage times, not a zero-order hold.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np

from harness.engines.base import RunSettings, check_settings
from harness.engines.mujoco_model import INTEGRATORS, load_mjcf, set_initial_state
from harness.errors import InputError
from harness.scene import Scene
from harness.trajectory import SampleBuffer, Trajectory

BLOWUP_SPEED = 1e8  # m/s or rad/s: beyond this a run is declared a blow-up


class MujocoEngine:
    """Runs a scene in MuJoCo from its MJCF file."""

    name = "mujoco"
    integrators = tuple(INTEGRATORS)

    def simulate(self, scene: Scene, settings: RunSettings) -> Trajectory:
        check_settings(settings, self.integrators, self.name)
        model = scene.multibody()
        m = load_mjcf(scene.mjcf, model, dt=settings.dt, integrator=settings.integrator)
        d = mujoco.MjData(m)
        set_initial_state(m, d, model, scene.mjcf)
        body_ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b.name) for b in model.bodies]
        control = _force_controller(m, model, scene)

        n = settings.n_saves + 1
        buf = SampleBuffer(n, len(body_ids))
        res6 = np.zeros(6)
        status, message, saved = "ok", "", 0
        t0 = time.perf_counter()
        mujoco.set_mjcb_control(control)
        try:
            for k in range(n):
                if k > 0:
                    for _ in range(settings.steps_per_save):
                        mujoco.mj_step(m, d)
                mujoco.mj_forward(m, d)
                bad = d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number
                if bad or not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
                    status, message = "blowup", f"non-finite or bad acceleration at t = {d.time:.6g} s (MuJoCo reset the state)"
                    break
                if np.max(np.abs(d.qvel), initial=0.0) > BLOWUP_SPEED:
                    status, message = "blowup", f"velocity beyond {BLOWUP_SPEED:g} at t = {d.time:.6g} s"
                    break
                for i, bid in enumerate(body_ids):
                    buf.p_WCm_W[k, i] = d.xipos[bid]
                    buf.quat_WB[k, i] = d.xquat[bid]
                    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, bid, res6, 0)
                    buf.w_WB_W[k, i] = res6[:3]
                    buf.v_WCm_W[k, i] = res6[3:]
                buf.potential[k], buf.kinetic[k] = d.energy[0], d.energy[1]
                saved = k + 1
        finally:
            mujoco.set_mjcb_control(None)
        stats = {"steps": settings.n_saves * settings.steps_per_save, "wall_s": time.perf_counter() - t0,
                 "settings": _describe(m)}
        return buf.trajectory(self.name, settings.integrator, [b.name for b in model.bodies], settings.save_every,
                              saved, stats, status, message)


def _describe(m: mujoco.MjModel) -> str:
    """The integrator and solver options this run used, for the report's provenance."""
    o = m.opt
    contact = "off" if o.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT else "on"
    return (f"mj_step {mujoco.mjtIntegrator(o.integrator).name[6:]}, timestep {o.timestep:g} s, "
            f"solver {mujoco.mjtSolver(o.solver).name[6:]} (iterations {o.iterations}, tolerance {o.tolerance:g}), "
            f"cone {mujoco.mjtCone(o.cone).name[7:]}, contact {contact}")


def _force_controller(m: mujoco.MjModel, model, scene: Scene):
    """A ``mjcb_control`` callback setting each force's three motors to ``force_W(d.time)``."""
    if not model.forces:
        return None
    slots = []
    for force in model.forces:
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{force.name}_f{a}") for a in "xyz"]
        if min(ids) < 0:
            raise InputError(f"{scene.mjcf}: MJCF needs motors {force.name}_fx, _fy, _fz for the force at {force.name!r}")
        slots.append((ids, force.force_W))

    def control(m_, d_):
        for ids, force_W in slots:
            d_.ctrl[ids] = force_W(d_.time)

    return control


ENGINE = MujocoEngine()
