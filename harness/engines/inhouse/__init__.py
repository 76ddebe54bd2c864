"""The in-house engine: Newton-Euler equations of rigid bodies in maximal coordinates with
joints as constraint forces (KKT system), integrated by our fixed-step Runge-Kutta methods or
SciPy's ``solve_ivp`` methods.

Two forms of the same physics, one engine (``InhouseEngine.simulate`` dispatches on the
integrator's name; ``integrators.METHODS`` lists every method):

* per-state, the readable oracle (``harness validate`` runs it): ``algebra`` (3-vector and
  quaternion algebra), ``model`` (constant model data, state layout), ``constraints`` (joint
  constraints, projection), ``newton_euler`` (equations of motion, reactions), ``rolling``
  (rolling contacts), ``integrators`` (time stepping); every model the harness has;
* compiled (``compiled``: the same equations as Numba kernels, ``rk4_compiled``, ``rkmk4_compiled``
  and ``dop853_compiled``; ``compiled.solver.run_batch`` for many initial states): every model the
  per-state form builds (loop joints and rolling contacts included; dependent rows by Cholesky with
  diagonal pivoting, least-squares multipliers as the per-state pseudo-inverse), except a prescribed force whose time law is only a Python function, which
  kernels cannot call (``harness.model.forces.HarmonicForce``, ``PointForce.harmonic``, gives one
  they can): a run of such a model is an "unsupported" trajectory saying so: not run, not failed.
  Tested against the per-state form on every scene (``tests/engines/inhouse/compiled``). Numba is
  imported only when a compiled method runs.

Drift control (documented choice, with the measurements that decided it):

* Fixed-step methods (``rk4``, ``euler``): after every step the state is projected back onto the
  constraint manifold (mass-weighted Gauss-Newton on positions, then mass-weighted orthogonal
  projection of the velocities; ``constraints.project``) and quaternions are renormalised. No
  Baumgarte terms then: inside the Runge-Kutta stages they act on the O(h^2) stage errors and
  spoil the method's accuracy (heavy_top, rk4 at its default dt: relative energy drift 7e-7 with
  Baumgarte at omega_b = 0.1/dt plus projection, 3e-11 with projection alone).
* Adaptive methods (SciPy) cannot be projected inside their steps: Baumgarte stabilisation in the
  right-hand side, natural frequency ``omega_b = baumgarte_ratio * omega_char`` (rad/s) and
  damping ratio ``baumgarte_zeta`` (default 1, critical). ``omega_char`` is the scene's fastest
  physical rate at t = 0 (``characteristic_rate``): the largest body angular speed and the
  compound-pendulum frequencies ``sqrt(m |g| d / (I_min + m d^2))`` of jointed bodies (d the
  joint-to-centre-of-mass distance), at least 2 pi / t_end. It does not depend on dt (the
  validation reference runs with dt = save_every). The default ratio 0.2 gives omega_b = 10 rad/s
  on heavy_top (spin 50 rad/s) and 0.77 rad/s on double_pendulum: slow against the motion, so
  the right-hand side stays non-stiff (heavy_top DOP853 rtol 1e-12: 1100 steps; 1030 without
  Baumgarte, 1864 at omega_b = 40 rad/s), and fast against the horizon, so drift stays bounded
  (heavy_top tip error 9e-14 m instead of 5e-11 m without Baumgarte). Quaternions are
  renormalised on output (the RHS uses q/|q|).
* A model with loop joints (``NEModel.redundant``) takes ``loop_baumgarte_ratio`` (default 2.0)
  instead: with 0.2 the adaptive reference drifts out of the plane of a planar loop (four_bar,
  DOP853 at rtol 1e-12 over 5 s: hinge axes 2.1e-6 rad apart, bar angles 1.3e-7 rad from the exact
  motion), with 2.0 it holds 1.4e-12 rad and 8.1e-9 rad (5.0: 8.2e-13 and 2.5e-9, at 1.7 times the
  steps).
* With ``project=False`` the fixed-step methods get the Baumgarte terms too.
* The compiled methods always project after each step (and the initial state), adaptive or not,
  and never use Baumgarte terms; ``project`` and the Baumgarte settings do not apply to them.
  ``dop853_compiled`` caps its steps at the save interval, as the per-state adaptive methods do:
  uncapped, its dense output between long steps is the weak point (rotating_plate's reference at
  rtol 1e-12: 33 steps over 2 s, samples 1e-10 rad off in orientation, and the hinge moment
  1.1e-10 N m off; capped, the validation's 1e-11 reaction checks hold as with the per-state
  reference).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from harness.engines.base import EngineBase, RunSettings, check_settings, first_blowup, reason_of
from harness.engines.inhouse import algebra
from harness.engines.inhouse.constraints import DynamicsError, project, projection_tolerance, violation
from harness.engines.inhouse.integrators import COMPILED, COMPILED_TWIN, FIXED_STEP, LIE_GROUP, METHODS, Result, integrate
from harness.engines.inhouse.model import SPARSE_ROWS, NEModel, build, from_trajectory, initial_state, split, state_at, to_trajectory
from harness.engines.inhouse.newton_euler import (Baumgarte, contact_force_series, make_dynamics, make_rhs, reaction_series,
                                                  reactions)
from harness.model.multibody import Multibody
from harness.model.scene import Scene
from harness.measure.trajectory import Failure, Trajectory, failed, unsupported


__all__ = [
    "COMPILED_KERNEL",
    "ENGINE",
    "Baumgarte",
    "DynamicsError",
    "InhouseEngine",
    "NEModel",
    "announce_compilation",
    "build",
    "characteristic_rate",
    "fast_method",
    "load_compiled",
    "run_method",
    "from_trajectory",
    "initial_state",
    "make_rhs",
    "project",
    "projection_tolerance",
    "reaction_series",
    "reactions",
    "to_trajectory",
    "violation",
]


class InhouseEngine(EngineBase):
    """The in-house Newton-Euler engine (see the module docstring).

    Args:
        baumgarte_ratio: ``omega_b / omega_char`` (dimensionless), >= 0; 0 turns Baumgarte off.
        baumgarte_zeta: damping ratio of the constraint-error dynamics.
        project: project onto the constraints after each fixed step.
        loop_baumgarte_ratio: ``omega_b / omega_char`` for a model with loop joints (module
            docstring), >= 0.
    """

    name = "inhouse"
    integrators = METHODS

    def __init__(self, baumgarte_ratio: float = 0.2, baumgarte_zeta: float = 1.0, project: bool = True,
                 loop_baumgarte_ratio: float = 2.0) -> None:
        self.baumgarte_ratio = float(baumgarte_ratio)
        self.loop_baumgarte_ratio = float(loop_baumgarte_ratio)
        self.baumgarte_zeta = float(baumgarte_zeta)
        self.project = bool(project)

    def gains(self, nem: NEModel, y0: np.ndarray, gravity_W: np.ndarray, settings: RunSettings) -> Baumgarte:
        """Baumgarte gains of a run: ``omega_b = baumgarte_ratio * characteristic_rate(...)``
        (rad/s; ``loop_baumgarte_ratio`` for a model with loop joints), or none for a fixed-step
        method with projection."""
        if (self.project and not METHODS[settings.integrator].adaptive) or nem.nc == 0:
            return Baumgarte(omega=0.0, zeta=self.baumgarte_zeta)
        ratio = self.loop_baumgarte_ratio if nem.redundant else self.baumgarte_ratio
        omega = ratio * characteristic_rate(nem, y0, gravity_W, settings.t_end)
        return Baumgarte(omega=omega, zeta=self.baumgarte_zeta)

    def accelerations(self, scene: Scene, model: Multibody, q, v, t: float = 0.0) -> tuple[dict, dict]:
        """The registry's hook (``harness.engines.accelerations``): each body's centre-of-mass
        acceleration (m/s^2) and angular acceleration (rad/s^2), world, per body name, at joint
        coordinates ``q, v`` (per body name) and time ``t`` (s): the per-state Newton-Euler
        equations with every constraint (joints, loops, rolling contacts), without Baumgarte
        terms (the state is taken to satisfy the constraints), ``alpha_W = R dw_B/dt``."""
        nem = build(model)
        y = state_at(model, q, v, nem)
        ydot, _ = make_dynamics(nem)(float(t), y)
        _, quat, _, _ = split(nem, y)
        _, _, acc, wdot_B = split(nem, ydot)
        R = algebra.quat_matrix(algebra.normalized(quat))
        alpha = (R @ wdot_B[:, :, None])[:, :, 0]
        return ({name: acc[i].copy() for i, name in enumerate(nem.body_names)},
                {name: alpha[i].copy() for i, name in enumerate(nem.body_names)})

    def run(self, scene: Scene, settings: RunSettings) -> Trajectory:
        """Run ``scene`` with ``settings``; see ``simulate_model``."""
        return self.simulate_model(scene.multibody(), settings, reactions="reaction" in scene.checks)

    def simulate_model(self, model: Multibody, settings: RunSettings, *, reactions: bool = False) -> Trajectory:
        """Integrate ``model`` from its initial state; samples at ``t = k * save_every``.

        Returns the trajectory in maximal coordinates (positions of the centres of mass in m,
        body -> world quaternions ``wxyz``, velocities of the centres of mass in m/s, WORLD-frame
        angular velocities in rad/s) with ``stats = {"steps", "rhs_evals", "wall_s",
        "settings"}`` (``wall_s``: the whole run here; for the compiled methods the integration
        alone, compilation done before the clock starts). A numerical failure gives status
        "failed" or "blowup" with a one-line message and the samples before it; a model the
        compiled form (or the engine) does not cover gives status "unsupported" with the reason
        and no samples (``harness.measure.trajectory.unsupported``); it never raises, except
        InputError from ``check_settings`` for bad settings. With ``reactions`` the trajectory carries the joint reactions at every
        sample (the constraint multipliers, ``reaction_series``).
        """
        check_settings(settings, self.integrators, self.name)
        if settings.integrator in COMPILED:
            return self._simulate_compiled(model, settings, reactions=reactions)
        start = time.perf_counter()
        names = tuple(model.body_names)
        try:
            nem = build(model)
            y0 = initial_state(model, nem)
            gains = self.gains(nem, y0, model.gravity_W, settings)
            tol = projection_tolerance(nem)
            if nem.loops and self.project and not METHODS[settings.integrator].adaptive:
                rhs = projected_stages(nem, gains)
            else:
                rhs = make_rhs(nem, gains)
            t_save = np.arange(settings.n_saves + 1) * settings.save_every
            if self.project:
                post = lambda y: project(nem, y, tol=tol)  # noqa: E731
            else:
                post = lambda y: normalize_quaternions(nem, y)  # noqa: E731
            res = integrate(
                rhs,
                y0,
                t_save,
                settings.integrator,
                steps_per_save=settings.steps_per_save,
                rtol=settings.rtol,
                atol=settings.atol,
                first_step=settings.dt,
                post_step=post,
                bodies=nem.nb,
                max_step=settings.max_step,
            )
            res = stop_at_blowup(nem, res)
        except NotImplementedError as err:  # a joint or force kind the engine has no equations for
            return unsupported(self.name, settings.integrator, names, str(err))
        except Exception as err:  # a numerical failure must come back as a trajectory
            return failed(self.name, settings.integrator, names, reason_of(err), f"{type(err).__name__}: {err}")
        traj = to_trajectory(nem, res.t, res.y, self.name, settings.integrator)
        if reactions and len(res.t):
            try:
                traj = replace(traj, reactions=reaction_series(nem, res.t, res.y, gains))
            except Exception as err:  # a numerical failure must come back as a trajectory
                return failed(self.name, settings.integrator, names, reason_of(err), f"reactions: {type(err).__name__}: {err}")
        if nem.contacts and len(res.t):  # rolling contacts: the force at the contact, always (``rolling``)
            try:
                traj = replace(traj, reactions={**traj.reactions, **contact_force_series(nem, res.t, res.y, gains)})
            except Exception as err:  # a numerical failure must come back as a trajectory
                return failed(self.name, settings.integrator, names, reason_of(err), f"contact force: {type(err).__name__}: {err}")
        stats = {
            "steps": res.steps,
            "rhs_evals": res.rhs_evals,
            "wall_s": time.perf_counter() - start,
            "settings": self.describe(settings, gains),
        }
        return replace(traj, stats=stats, reason=res.reason, message=res.message)

    def _simulate_compiled(self, model: Multibody, settings: RunSettings, *, reactions: bool) -> Trajectory:
        """``simulate_model`` for the compiled methods (``compiled.solver``): the same outputs;
        ``wall_s`` is the integration alone (the kernel is compiled, or loaded from Numba's cache,
        before the clock starts)."""
        names = tuple(model.body_names)
        method = settings.integrator
        gains = Baumgarte(omega=0.0, zeta=self.baumgarte_zeta)  # projection, no Baumgarte terms
        try:
            from harness.engines.inhouse.compiled import solver as compiled  # Numba only when asked

            nem = build(model)
            dense_rows(nem)
            packed = compiled.pack(nem)
            y0 = initial_state(model, nem)
            t_save = np.arange(settings.n_saves + 1) * settings.save_every
            multipliers = bool(reactions or nem.contacts)  # the reactions' source, computed in the kernel
            if METHODS[method].adaptive:
                res = compiled.integrate_dop853(packed, y0, t_save, rtol=settings.rtol, atol=settings.atol,
                                                first_step=settings.dt, max_step=largest_step(settings),
                                                proj_tol=projection_tolerance(nem), multipliers=multipliers)
            else:
                res = compiled.integrate_fixed(packed, y0, t_save, FIXED_STEP[method],
                                               steps_per_save=settings.steps_per_save, proj_tol=projection_tolerance(nem),
                                               lie_group=method in LIE_GROUP, multipliers=multipliers)
            res = stop_at_blowup(nem, res)
        except NotImplementedError as err:  # outside the compiled form's scope: not run, not failed
            return unsupported(self.name, method, names, f"{method}: {err} (the per-state methods do)")
        except Exception as err:  # a numerical failure must come back as a trajectory
            return failed(self.name, method, names, reason_of(err), f"{type(err).__name__}: {err}")
        traj = to_trajectory(nem, res.t, res.y, self.name, method)
        if reactions and len(res.t):
            try:
                traj = replace(traj, reactions=reaction_series(nem, res.t, res.y, gains, res.lam))
            except Exception as err:  # a numerical failure must come back as a trajectory
                return failed(self.name, method, names, reason_of(err), f"reactions: {type(err).__name__}: {err}")
        if nem.contacts and len(res.t):  # rolling contacts: the force at the contact, always (as simulate_model)
            try:
                traj = replace(traj, reactions={**traj.reactions,
                                                **contact_force_series(nem, res.t, res.y, gains, res.lam)})
            except Exception as err:  # a numerical failure must come back as a trajectory
                return failed(self.name, method, names, reason_of(err), f"contact force: {type(err).__name__}: {err}")
        stats = {"steps": res.steps, "rhs_evals": res.rhs_evals, "wall_s": res.wall_s,
                 "settings": self.describe(settings, gains)}
        return replace(traj, stats=stats, reason=res.reason, message=res.message)

    def fast_method(self, method: str, model: Multibody) -> str:
        """The registry's hook (``harness.engines.fast_method``): ``fast_method`` below."""
        return fast_method(method, model)

    def prepare(self, runs) -> None:
        """The registry's hook (``harness.engines.prepare``): ``load_compiled`` below."""
        load_compiled(runs)

    def describe(self, settings: RunSettings, gains: Baumgarte) -> str:
        """One line on how a run integrates and holds its constraints."""
        method = settings.integrator
        compiled = method in COMPILED
        if not METHODS[method].adaptive:
            text = f"{method}, dt={settings.dt:g} s"
        elif compiled:
            text = f"{method}, rtol={settings.rtol:g}, atol={settings.atol:g}, max_step={largest_step(settings):g} s"
        else:
            text = f"scipy {method}, rtol={settings.rtol:g}, atol={settings.atol:g}, max_step={largest_step(settings):g} s"
        if compiled:
            text += ", compiled (Numba)"
        if compiled or (self.project and not METHODS[method].adaptive):
            text += ", constraint projection after each step"
        if gains.omega > 0.0:
            text += f", Baumgarte omega={gains.omega:.4g} rad/s zeta={gains.zeta:g}"
        return text


COMPILED_KERNEL = {"rk4_compiled": "erk", "dop853_compiled": "dop853", "rkmk4_compiled": "erk"}  # the Numba kernel each method runs


def announce_compilation(runs) -> bool:
    """Before starting worker processes that make the in-house ``runs`` (``(integrator name,
    Multibody)`` pairs; other methods are ignored): when a compiled method among them needs a
    kernel Numba's cache does not hold, say so once, here in the parent
    (``compiled.solver.announce_cold``), instead of once per worker. A model the compiled form
    does not cover (its run is "unsupported") compiles nothing and is ignored. Numba is imported
    only when a compiled method is among the runs. Returns whether a kernel will be compiled."""
    runs = [(m, model) for m, model in runs if m in COMPILED_KERNEL]
    if not runs:
        return False
    from harness.engines.inhouse.compiled import solver as compiled

    kernels = set()
    for method, model in runs:
        try:
            compiled.pack(build(model))
        except NotImplementedError:  # not run: nothing to compile for it
            continue
        kernels.add(COMPILED_KERNEL[method])
    return compiled.announce_cold(sorted(kernels))


def load_compiled(runs) -> None:
    """Before forking worker processes that make the in-house ``runs`` (``(integrator name,
    Multibody)`` pairs, as ``announce_compilation`` takes them): load (or, with a cold cache,
    compile) the kernels their compiled methods need here, in the parent, so that every forked
    worker starts with them (loading them from Numba's cache costs 0.3-0.4 s per process, paid
    by each case otherwise). A cold compilation is announced first, once for all the kernels
    (``announce_compilation``). Nothing is imported or loaded when no compiled method is among
    the runs; a model outside the compiled form's scope is skipped."""
    runs = [(m, model) for m, model in runs if m in COMPILED_KERNEL]
    if not runs:
        return
    announce_compilation(runs)
    from harness.engines.inhouse.compiled import solver as compiled

    for method, model in runs:
        kernel = COMPILED_KERNEL[method]
        if kernel in compiled.warm_kernels():
            continue
        try:
            nem = build(model)
            packed = compiled.pack(nem)
        except Exception:  # not run (unsupported) or a model that does not build: its run says why
            continue
        compiled.warm_up(packed, initial_state(model, nem), kernel)


def fast_method(method: str, model: Multibody) -> str:
    """The method a fast run of the in-house ``method`` uses on ``model``: its compiled twin
    (``integrators.COMPILED_TWIN``: ``rk4`` -> ``rk4_compiled``, ``rkmk4`` -> ``rkmk4_compiled``,
    ``DOP853`` -> ``dop853_compiled``) when the compiled form models ``model`` (``compiled.solver.pack``
    accepts it), else ``method`` itself (no twin, or a model outside the compiled form's scope: the
    per-state method runs, never an "unsupported" run). Numba is imported only for a method with a
    twin; a model that does not build is left to the run to report."""
    twin = COMPILED_TWIN.get(method)
    if twin is None:
        return method
    from harness.engines.inhouse.compiled import solver as compiled

    try:
        nem = build(model)
        compiled.pack(nem)
        dense_rows(nem)
    except Exception:  # outside the compiled form's scope, or a model that does not build (its run says why)
        return method
    return twin


def dense_rows(nem: NEModel) -> None:
    """NotImplementedError for a model of ``SPARSE_ROWS`` constraint rows or more: the compiled
    kernels form and factor J M^-1 J^T as a dense matrix (O(nc^3) a factorisation, several a step),
    where the per-state form solves it sparse (``constraints.RowSystem``). Measured on
    four_bar_chain at N = 40 (605 rows): the dense compiled rk4 took 0.11 s a step, the per-state
    sparse one ~10 ms."""
    if nem.Minv_sparse is not None:
        raise NotImplementedError(f"{nem.nc} constraint rows (from {SPARSE_ROWS} on, the compiled kernels' dense "
                                  "factor of J M^-1 J^T is the slow way; the per-state form solves them sparse)")


def run_method(engine: str, method: str | None, scene: Scene, fast: bool = True) -> str | None:
    """The method a run of ``engine`` takes for ``method`` on ``scene``: for the in-house engine
    with ``fast``, its compiled twin where the compiled form models the scene (``fast_method``),
    as validate, the stress map and the loop study run it; otherwise ``method`` itself (None, a
    scene that names no method, stays None). The scene's model is built only for the in-house
    engine."""
    if method is None or not fast or engine != InhouseEngine.name:
        return method
    return fast_method(method, scene.multibody())


def characteristic_rate(nem: NEModel, y0: np.ndarray, gravity_W: np.ndarray, t_end: float) -> float:
    """The fastest physical rate (rad/s) of a model at its initial state ``y0``: the largest body
    angular speed, an upper bound ``sqrt(m |g| d / (I_min + m d^2))`` of the compound-pendulum
    frequency of each jointed body about its joint (d: joint point to centre of mass, m;
    I_min: smallest principal moment about the centre of mass, kg m^2; |g| in m/s^2), and
    ``2 pi / t_end`` (t_end in s) as a floor; a spring on a slide joint adds sqrt(k / m) of its
    child body (k in N/m, m in kg)."""
    W = split(nem, np.asarray(y0, dtype=float))[3]
    rates = [2.0 * np.pi / t_end, float(np.max(np.linalg.norm(W, axis=1), initial=0.0))]
    g = float(np.linalg.norm(gravity_W))
    for j in range(nem.nj):
        i = int(nem.ends[j])
        d = float(np.linalg.norm(nem.D_end[j, :, 0]))
        m, I_min = float(nem.mass[i]), float(np.linalg.eigvalsh(nem.I_B[i])[0])
        rates.append(np.sqrt(m * g * d / (I_min + m * d * d)))
    for sp in nem.springs:  # a spring on a slide joint: sqrt(k / m_child), an upper bound
        rates.append(np.sqrt(sp.k / float(nem.mass[nem.slides[sp.slide].child])))
    return float(max(rates))


def stop_at_blowup(nem: NEModel, res: Result) -> Result:
    """``res`` cut before its first blown-up sample (``harness.engines.base.first_blowup``: a
    non-finite state, or a speed beyond ``BLOWUP_SPEED``, every engine's bound), ending with that
    reason and a one-line message (time and what), keeping the samples before it; an earlier
    failure or blow-up the integrator reported is kept when it comes first. ``res`` unchanged
    when every sample is sound."""
    y = np.asarray(res.y, dtype=float)
    if y.shape[0] == 0:
        return res
    with np.errstate(over="ignore", invalid="ignore"):
        p, _, v, w = split(nem, y)
        k, reason, what = first_blowup(p, v, w, res.t)
        if k < 0 and not np.all(np.isfinite(y)):  # a non-finite quaternion with a finite position
            k = int(np.argmax(~np.all(np.isfinite(y), axis=1)))
            reason, what = Failure.NON_FINITE, f"non-finite state at t = {float(res.t[k]):.6g} s"
    if k < 0:
        return res
    lam = None if res.lam is None else res.lam[:k].copy()
    return replace(res, t=res.t[:k].copy(), y=y[:k].copy(), reason=reason, message=what, lam=lam)


def largest_step(settings: RunSettings) -> float:
    """The largest step (s) of an error-controlled run: ``settings.max_step``, at most the save
    interval."""
    return min(settings.save_every, settings.max_step or settings.save_every)


def projected_stages(nem: NEModel, gains: Baumgarte):
    """The right-hand side evaluated at the projection of its state onto the constraint manifold
    (``constraints.project_stage``: Gauss-Newton on the positions to the projection tolerance,
    then the velocities at them): how a model with loop joints evaluates every Runge-Kutta stage
    (the compiled kernels do the same).

    A stage state lies off the manifold by O(h^2) in position and O(h) in velocity. The
    accelerations hold ``d2C/dt2 = 0`` there, so a row's error stays what it was: ``dC/dt = c``.
    Near a flat position of a parallelogram (a window of four_bar_chain) the folding row reads
    ``dC/dt = theta v_fold``, so a stage's c became a folding velocity ``c / theta``: a kick to a
    step that landed near flat, which the projection after the step did not undo. Measured on
    four_bar_chain (N = 2, per-state rk4 over 20 s, error of the crank tips against the exact motion):
    without it 1.4e-8 / 1.7e-9 / 3.2e-5 m at dt 2e-3 / 1e-3 / 5e-4 s (energy jumps of 2.6e-9 to
    2.3e-5 J at flat passages at 5e-4 s); with it 1.6e-8 / 2.0e-9 / 1.5e-9 m. The exact motion is
    on the manifold, where the projection is the identity. It costs a second factorisation of the
    rows per stage off the manifold (compiled: 1.2-1.8 times the run time on the loop scenes). It
    changes the error constant, not the order, and not always for the better: four_bar's crank
    angle at 2 dt / dt / dt/2 (rk4, against its exact motion) 2.0e-5 / 4.1e-7 / 1.3e-8 rad before,
    6.1e-5 / 2.6e-6 / 1.3e-7 rad with it; four_bar_near_singular 2.5e-5 / 9.2e-7 / 3.8e-8 rad
    before, 5.8e-6 / 1.7e-7 / 5.7e-9 rad with it.

    A stage that lands within about 1e-5 rad of a flat position loses the windows' rows there
    (below the rank cut-off, ``constraints.RANK_RTOL``, scaled, or the sparse solve's
    regularisation), an O(1) force (their multipliers grow as 1/theta while J^T lambda stays
    finite); kept instead (a cut-off of 1e-13) the 1/theta^2 amplification of round-off is worse.
    Such a stage is recognised by the residual of its rows' acceleration equation and takes the
    mean of its two neighbours along its own motion (``newton_euler.SINGULAR_RESIDUAL``,
    ``across_singular_position``). Measured on four_bar_chain at N = 40, per-state rk4 at 1 ms over
    20 s: the stage of 8.58 s lands 1.3e-5 rad from flat; without the neighbours it lost 1.1e-2 J
    there and the crank tips ended 4.1e-3 m from the exact motion; with them the largest error
    over the run is 1.4e-7 m (210 s a run). At N = 8 (a stage placed 1e-7 to 3e-5 rad from flat,
    0.1 s): 3.2e-10 m without, 3.2e-11 to 7.7e-11 m with them (1.9e-12 m with the stage 1e-4 rad
    away, where nothing is dropped)."""
    return make_rhs(nem, gains, stage_tol=projection_tolerance(nem))


def normalize_quaternions(nem: NEModel, y: np.ndarray) -> np.ndarray:
    """A copy of state vector ``y`` with unit quaternions."""
    y = np.array(y, dtype=float)
    nb = nem.nb
    y[3 * nb : 7 * nb] = algebra.normalized(y[3 * nb : 7 * nb].reshape(nb, 4)).ravel()
    return y


ENGINE = InhouseEngine()


