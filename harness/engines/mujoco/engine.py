"""MuJoCo engine: the scene's MJCF stepped with ``mj_step``, read back in maximal coordinates.

Notes on reading state: after ``mj_step`` the kinematic quantities in ``MjData`` (``xipos``,
``xquat``, energy) belong to the state *before* the step (with RK4, to an intermediate stage),
so every sample is read after ``mj_forward`` on the current ``qpos``/``qvel``.

Prescribed forces act through the MJCF's motors ``<name>_fx/_fy/_fz`` (site transmission with a
world reference site); their controls are set from ``mjcb_control`` at every evaluation of the
dynamics, so RK4 sees the force at its stage times, not a zero-order hold.

Joint reactions (when the scene asks, ``[checks.reaction]``): MuJoCo has no joint-reaction
output; ``mj_rnePostConstraint`` after ``mj_forward`` gives ``cfrc_int[b]``, the spatial force
[moment; force] that the parent exerts on the subtree of body b, in world axes about the centre
of mass of b's kinematic tree (``subtree_com[body_rootid[b]]``). It is Newton-Euler of the
subtree, "inertial minus ``cfrc_ext``", so it also carries what MuJoCo does not hold as an
external Cartesian force: the joint's own passive force (its spring and damper along its world
axis), an actuator acting on the joint (a motor torque) and the prescribed point forces, which
reach MuJoCo as motor (generalised) forces. They are removed here (``joint_reaction``), so the
reaction is the joint's constraint force alone, with the moment taken about the joint point
(``xpos``). A cut joint's reaction comes from the constraint forces of its ``<connect>``
equalities (``loops.cut_reactions``).

MuJoCo's warnings (e.g. "Nan, Inf or huge value in QACC at DOF 1. The simulation is
unstable.") are not printed: while a run steps, ``warning_capture.captured_warnings`` routes
MuJoCo's warning handler (``mujoco.set_mju_user_warning``) into a list, stored in the trajectory
as ``stats["warnings"] = {"count": n, "first": first message or ""}``. The blow-up guards are read
from ``MjData.warning`` counters as before (MuJoCo counts a warning whoever handles its text).
"""

from __future__ import annotations


import mujoco
import numpy as np

from harness.engines.base import EngineBase, RunSettings, sample_run
from harness.engines.mujoco.integrators import INTEGRATOR_METHODS
from harness.engines.mujoco.loops import cut_reactions
from harness.engines.mujoco.loops import settings_text as loop_settings
from harness.engines.mujoco.model import joint_type, load_mjcf, set_initial_state
from harness.engines.mujoco.rolling import ContactForceReader, describe_contact
from harness.engines.mujoco.warning_capture import captured_warnings
from harness.model import rotations
from harness.model.errors import InputError
from harness.model.forces import POINT_FORCES
from harness.model.joints import JOINTS, ROTATIONAL, TRANSLATIONAL
from harness.model.scene import Scene
from harness.measure.trajectory import Failure, RunStop, SampleBuffer, Trajectory

# MuJoCo's own blow-up guards: each resets the state (mj_resetData), so a run that trips one
# would otherwise go on from qpos0 with finite numbers.
_BAD_WARNINGS = ("mjWARN_BADQACC", "mjWARN_BADQVEL", "mjWARN_BADQPOS")


class MujocoEngine(EngineBase):
    """Runs a scene in MuJoCo from its MJCF file."""

    name = "mujoco"
    integrators = INTEGRATOR_METHODS

    def load_model_file(self, scene: Scene, model) -> None:
        """Compile the scene's MJCF (its URDF where it names only one) with ``model``'s physics,
        as a run does (``load_mjcf``): InputError where MuJoCo cannot (``harness.engines.load_model_file``)."""
        load_mjcf(scene.mjcf, model)

    def capture(self):
        """MuJoCo's own warnings (``mju_user_warning``) during a run (``warning_capture``)."""
        return captured_warnings()

    def run(self, scene: Scene, settings: RunSettings) -> Trajectory:
        model = scene.multibody()
        m = load_mjcf(scene.mjcf, model, dt=settings.dt, integrator=settings.integrator)
        d = mujoco.MjData(m)
        set_initial_state(m, d, model, scene.mjcf)
        body_ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b.name) for b in model.bodies]
        control = _force_controller(m, model, scene)
        rolling = ContactForceReader(m, model) if model.contacts else None  # mujoco_rolling
        jointed = [(b.name, bid) for b, bid in zip(model.bodies, body_ids) if JOINTS[b.joint].constrained] if "reaction" in scene.checks else []
        force_sites = _force_sites(m, model) if jointed else []
        cuts = [loop.name for loop in model.loops] if jointed else []
        buf = SampleBuffer(settings.n_saves + 1, len(body_ids),
                           [name for name, _ in jointed] + cuts + (rolling.names if rolling is not None else []))
        res6 = np.zeros(6)

        def advance(k: int) -> None:
            mujoco.mj_step(m, d, settings.steps_per_save)  # MuJoCo's own loop: one call per saved sample
            mujoco.mj_forward(m, d)
            bad = [w for w in _BAD_WARNINGS if d.warning[getattr(mujoco.mjtWarning, w)].number]
            if bad:  # after a reset d.time restarts from 0: report the sample's own time
                raise RunStop(Failure.ENGINE_GUARD, f"bad acceleration/state, MuJoCo warning {', '.join(bad)} "
                                                    f"by t = {k * settings.save_every:.6g} s (MuJoCo reset the state)")

        def read(k: int) -> None:
            if k == 0:
                mujoco.mj_forward(m, d)
            for i, bid in enumerate(body_ids):
                buf.p_WCm_W[k, i] = d.xipos[bid]
                buf.quat_WB[k, i] = d.xquat[bid]
                mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, bid, res6, 0)
                buf.w_WB_W[k, i] = res6[:3]
                buf.v_WCm_W[k, i] = res6[3:]
            buf.potential[k], buf.kinetic[k] = d.energy[0], d.energy[1]
            if jointed:
                mujoco.mj_rnePostConstraint(m, d)
                for name, bid in jointed:
                    buf.set_reaction(name, k, *joint_reaction(m, d, bid, force_sites))
                for name, (force, moment) in cut_reactions(m, d, model).items():
                    buf.set_reaction(name, k, force, moment)
            if rolling is not None:
                rolling.read(m, d, k, buf)

        mujoco.set_mjcb_control(control)
        try:
            done = sample_run(settings, buf, advance, read)
        finally:
            mujoco.set_mjcb_control(None)
        stats = {"steps": max(done.saved - 1, 0) * settings.steps_per_save, "wall_s": done.wall_s,
                 "settings": _describe(m)}
        traj = buf.trajectory(self.name, settings.integrator, [b.name for b in model.bodies], settings.save_every,
                              done.saved, stats, done.reason, done.message)
        if rolling is not None:
            stats["settings"] += ", " + describe_contact(m)
        if model.loops:  # cut joints: soft <connect> equalities (``loops``)
            stats["settings"] += ", " + loop_settings(m)
        return traj


def joint_reaction(m: mujoco.MjModel, d: mujoco.MjData, bid: int, force_sites=()) -> tuple[np.ndarray, np.ndarray]:
    """Constraint reaction that the parent exerts on body ``bid`` through its single joint:
    force (N) and moment about the joint point (N m), world frame, from ``cfrc_int``
    (``mj_rnePostConstraint`` must have run on ``d``). ``force_sites``: ``(site id, body id,
    force_W)`` of the prescribed point forces, which reach MuJoCo as motor forces
    (``_force_sites``); those acting in the body's subtree are removed, as are the joint's own
    passive force (its spring and damper) and the force of an actuator on the joint (a motor)
    (see the module docstring). A tendon spring needs nothing: ``cfrc_int`` already leaves it
    out of the joint's reaction (measured on the Andrews squeezer: the hinge's moment about
    its axis is zero to round-off, and its force agrees with the in-house multipliers)."""
    c = d.subtree_com[m.body_rootid[bid]]
    force = d.cfrc_int[bid][3:].copy()
    p_joint = d.xpos[bid]
    moment = d.cfrc_int[bid][:3] + rotations.cross(c - p_joint, force)
    jid = m.body_jntadr[bid]
    own = _joint_own_force(m, d, jid)
    jt = joint_type(m, jid)
    axis = jt.axis if jt is not None else None  # a passive force along a joint axis: a force or a moment
    if axis == TRANSLATIONAL:
        force -= own * d.xaxis[jid]
    elif axis == ROTATIONAL:
        moment -= own * d.xaxis[jid]
    for site, body, f_of in force_sites:
        if _in_subtree(m, body, bid):
            f = f_of(d)
            force -= f
            moment -= rotations.cross(d.site_xpos[site] - p_joint, f)
    return force, moment


def _joint_own_force(m: mujoco.MjModel, d: mujoco.MjData, jid: int) -> float:
    """The generalised force of joint ``jid``'s own elements on its single dof: its spring
    ``-stiffness (q - springref)``, its damper ``-damping q'`` and the actuators that act on it
    through a joint transmission (force times gear); not the tendons' share of ``qfrc_passive``
    (a tendon spring is a Cartesian force, ``_spring_sites``)."""
    dof, qadr = m.jnt_dofadr[jid], m.jnt_qposadr[jid]  # the joint has one dof (``body_joint``)
    k = float(np.atleast_1d(m.jnt_stiffness[jid])[0])
    own = -k * (d.qpos[qadr] - m.qpos_spring[qadr]) - float(np.atleast_1d(m.dof_damping[dof])[0]) * d.qvel[dof]
    for a in range(m.nu):
        if m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and m.actuator_trnid[a, 0] == jid:
            own += d.actuator_force[a] * m.actuator_gear[a, 0]
    return float(own)


def _in_subtree(m: mujoco.MjModel, body: int, root: int) -> bool:
    """Whether ``body`` is ``root`` or one of its descendants."""
    while body > 0:
        if body == root:
            return True
        body = m.body_parentid[body]
    return False


def _force_sites(m: mujoco.MjModel, model) -> list:
    """``(site id, body id, force_W(d))`` of each prescribed force: its three motors
    ``<name>_fx/_fy/_fz`` (gear 1 along world x, y, z, reference site at the world origin)."""
    out = []
    for force in POINT_FORCES.elements(model):
        site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, force.name)
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{force.name}_f{a}") for a in "xyz"]
        if site >= 0 and min(ids) >= 0:
            out.append((site, int(m.site_bodyid[site]), lambda d, ids=ids: d.actuator_force[ids].copy()))
    return out


def _describe(m: mujoco.MjModel) -> str:
    """The integrator and solver options this run used, for the report's provenance."""
    o = m.opt
    contact = "off" if o.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT else "on"
    return (f"mj_step {mujoco.mjtIntegrator(o.integrator).name[6:]}, timestep {o.timestep:g} s, "
            f"solver {mujoco.mjtSolver(o.solver).name[6:]} (iterations {o.iterations}, tolerance {o.tolerance:g}), "
            f"cone {mujoco.mjtCone(o.cone).name[7:]}, contact {contact}")


def _force_controller(m: mujoco.MjModel, model, scene: Scene):
    """A ``mjcb_control`` callback setting each force's three motors to ``force_W(d.time)``."""
    if not POINT_FORCES.elements(model):
        return None
    slots = []
    for force in POINT_FORCES.elements(model):
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{force.name}_f{a}") for a in "xyz"]
        if min(ids) < 0:
            raise InputError(f"{scene.mjcf}: MJCF needs motors {force.name}_fx, _fy, _fz for the force at {force.name!r}")
        slots.append((ids, force.force_W))

    def control(m_, d_):
        for ids, force_W in slots:
            d_.ctrl[ids] = force_W(d_.time)

    return control


ENGINE = MujocoEngine()
