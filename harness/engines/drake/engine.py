"""Drake engine: the scene's URDF in a continuous-time MultibodyPlant, Drake's own integrators.

Drake reads the scene's URDF with its own parser (a third importer beside MuJoCo's and
Pinocchio's) and integrates the plant's state (reduced coordinates) with the integrators of
Drake's ``Simulator``, selected as Drake's ``ResetIntegratorFromFlags`` names them
(``harness.engines.drake.integrators``): error-controlled ones at a target accuracy (the run's
``rtol``), the way Drake's users run it, with the run's ``dt`` (s) as their maximum step, and
fixed-step ones at ``dt``. The model and the
scene's physics: ``harness.engines.drake.model``.

Maximal coordinates at every saved sample come from Drake's kinematics
(``EvalBodyPoseInWorld``, ``EvalBodySpatialVelocityInWorld``: the body frame, world), moved to the
centre of mass; the energies are Drake's own (``CalcKineticEnergy``, ``CalcPotentialEnergy``:
gravity and springs). Joint reactions (``[checks.reaction]``) are Drake's reaction-force output
port: per joint, the spatial force on the child body at the joint's child frame origin (the
child's body frame origin), in world.

Not modelled: closed loops and the ideal rolling contact (the registry's declaration says why:
``harness.engines.DECLARATIONS``; those scenes are not run).
"""

from __future__ import annotations

import time

import numpy as np

from harness.engines.base import EngineBase, RunSettings, sample_run
from harness.engines.drake.integrators import METHODS, SCHEMES
from harness.engines.drake.model import build, captured_drake_log
from harness.measure.trajectory import Failure, RunStop, SampleBuffer, Trajectory, unsupported
from harness.model import rotations
from harness.model.joints import JOINTS
from harness.model.scene import Scene


class DrakeEngine(EngineBase):
    """Runs a scene in Drake from its URDF file."""

    name = "drake"
    integrators = METHODS

    def load_model_file(self, scene: Scene, model) -> None:
        """Parse the scene's URDF (its MJCF where it names only one) into a plant, as a run does
        (``parse``): InputError where Drake cannot (``harness.engines.load_model_file``)."""
        from harness.engines.drake.model import parse

        parse(scene.urdf, scene.urdf_root_joint, model)

    def preload(self) -> None:
        """Import the pydrake modules a run imports at its start (ImportError without Drake), for
        a parent about to fork one worker per run: the workers then share them instead of each
        importing them again (~0.3-0.5 s of every Drake run; ``harness.engines.preload``)."""
        import pydrake.common.eigen_geometry  # noqa: F401
        import pydrake.common.value  # noqa: F401
        import pydrake.math  # noqa: F401
        import pydrake.multibody.math  # noqa: F401
        import pydrake.multibody.parsing  # noqa: F401
        import pydrake.multibody.plant  # noqa: F401
        import pydrake.multibody.tree  # noqa: F401
        import pydrake.systems.analysis  # noqa: F401
        import pydrake.systems.framework  # noqa: F401

    def capture(self):
        """Drake's log messages during a run (``captured_drake_log``)."""
        return captured_drake_log()

    def run(self, scene: Scene, settings: RunSettings) -> Trajectory:
        model = scene.multibody()
        names = tuple(model.body_names)
        method = settings.integrator
        start = time.perf_counter()
        try:
            dm = build(scene, model)
        except NotImplementedError as err:
            return unsupported(self.name, method, names, f"{method}: {err}")
        from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator

        system, context = (dm.diagram, dm.diagram_context) if dm.diagram is not None else (dm.plant, dm.context)
        simulator = Simulator(system, context)
        spec = METHODS[method]
        # the maximum step of an error-controlled method and the step of a fixed one: the run's dt, never the save
        # interval (``harness.engines.drake.integrators``)
        integ = ResetIntegratorFromFlags(simulator, SCHEMES[method], settings.dt)
        if spec.adaptive:  # dt is not passed as an initial step: see ``harness.engines.drake.integrators``
            integ.set_target_accuracy(settings.rtol)
        else:
            integ.set_fixed_step_mode(True)
        simulator.Initialize()
        jointed = [(b.name, dm.joints[b.name]) for b in model.bodies
                   if JOINTS[b.joint].constrained and dm.joints[b.name] is not None] if "reaction" in scene.checks else []
        buf = SampleBuffer(settings.n_saves + 1, len(names), [name for name, _ in jointed])

        def advance(k: int) -> None:
            simulator.AdvanceTo(k * settings.save_every)

        def read(k: int) -> None:
            _read(dm, model, k, buf)
            if jointed:
                forces = dm.plant.get_reaction_forces_output_port().Eval(dm.context)
                for name, joint in jointed:
                    buf.set_reaction(name, k, *joint_reaction(dm, joint, forces[int(joint.index())]))

        done = sample_run(settings, buf, advance, read, {RuntimeError: Failure.SOLVER})  # Drake's integrator failures
        stats = {"steps": integ.get_num_steps_taken(), "rhs_evals": integ.get_num_derivative_evaluations(),
                 "wall_s": time.perf_counter() - start, "wall_integrate_s": done.wall_s,
                 "settings": _describe(method, settings, scene)}
        message = f"{method}: Drake stopped: {done.message}" if done.reason is Failure.SOLVER else done.message
        return buf.trajectory(self.name, method, names, settings.save_every, done.saved, stats, done.reason, message)


def joint_reaction(dm, joint, F_CJc_Jc) -> tuple[np.ndarray, np.ndarray]:
    """``(force_W, moment_W)`` (N, N m): Drake's reaction output ``F_CJc_Jc`` (the spatial force
    on the child at the joint's child frame Jc, expressed in Jc) rotated to world, without its
    component along a 1-dof joint's free direction (the force of a spring on that coordinate,
    which Drake's port includes; an ideal joint's constraint force has none)."""
    plant, ctx = dm.plant, dm.context
    frame = joint.frame_on_child()
    R_WJc = plant.EvalBodyPoseInWorld(ctx, joint.child_body()).rotation().matrix() @ \
        frame.CalcPoseInBodyFrame(ctx).rotation().matrix()
    f, m = R_WJc @ F_CJc_Jc.translational(), R_WJc @ F_CJc_Jc.rotational()
    if joint.num_velocities() == 1:
        axis_W = R_WJc @ np.asarray(_joint_axis(joint), dtype=float)
        if joint.type_name() == "prismatic":
            f = f - (f @ axis_W) * axis_W
        else:
            m = m - (m @ axis_W) * axis_W
    return f, m


def _joint_axis(joint) -> np.ndarray:
    """A 1-dof joint's unit axis in its frames (revolute: ``revolute_axis``, prismatic:
    ``translation_axis``)."""
    return joint.revolute_axis() if joint.type_name() == "revolute" else joint.translation_axis()


def _describe(method: str, settings: RunSettings, scene: Scene) -> str:
    spec = METHODS[method]
    how = (f"target accuracy {settings.rtol:g}, max step {settings.dt:g} s" if spec.adaptive
           else f"fixed step {settings.dt:g} s")
    return f"Drake {SCHEMES[method]} ({how}) on the continuous MultibodyPlant of {scene.urdf.name}"


def context_time(ctx) -> float:
    """The time (s) of a plant's context."""
    return float(ctx.get_time())


def _read(dm, model, k: int, buf: SampleBuffer) -> None:
    """Fill sample ``k`` of ``buf`` (centre-of-mass position and velocity, orientation, world
    angular velocity, Drake's energies)."""
    plant, ctx = dm.plant, dm.context
    for i, body in enumerate(model.bodies):
        b = dm.bodies[body.name]
        X = plant.EvalBodyPoseInWorld(ctx, b)
        V = plant.EvalBodySpatialVelocityInWorld(ctx, b)
        R = X.rotation().matrix()
        if not np.all(np.isfinite(R)):  # a blown-up state: no orientation to read (its SVD fails)
            raise RunStop(Failure.NON_FINITE, f"non-finite state by t = {context_time(ctx):.6g} s")
        w = V.rotational()
        r = R @ b.CalcCenterOfMassInBodyFrame(ctx)
        buf.p_WCm_W[k, i] = X.translation() + r
        buf.quat_WB[k, i] = rotations.from_matrix(R)
        buf.v_WCm_W[k, i] = V.translational() + rotations.cross(w, r)
        buf.w_WB_W[k, i] = w
    buf.kinetic[k] = plant.CalcKineticEnergy(ctx)
    buf.potential[k] = plant.CalcPotentialEnergy(ctx)


ENGINE = DrakeEngine()
