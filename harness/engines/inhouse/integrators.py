"""Time integrators of the in-house engine, independent of the physics.

A right-hand side is ``f(t, y) -> dy/dt`` on a flat float array. The methods (``METHODS``: one
``Integrator`` record each, the one list of names, kinds and orders) come in two forms:

* per-state (this module, the readable oracle): our own fixed-step explicit Runge-Kutta methods,
  given as Butcher tables (``"rk4"``: classic fourth order; ``"euler"``: explicit Euler), with an
  optional ``post_step(y) -> y`` after every step (the engine renormalises quaternions and
  projects onto the joint constraints there); and SciPy's adaptive/implicit methods ``"RK45"``,
  ``"DOP853"``, ``"Radau"``, ``"BDF"``, ``"LSODA"`` (the ``solve_ivp`` methods, spelt as SciPy
  spells them), driven step by step with the same loop as ``scipy.integrate.solve_ivp`` and its
  dense output at the save times, so that steps are counted and the samples computed before a
  failure are kept. Their steps are capped at the save interval (see ``integrate_adaptive``);
  and ``"rkmk4"``, the ``RK4`` table in Runge-Kutta-Munthe-Kaas form (``lie_group``): positions
  and velocities as vectors, each orientation advanced on SO(3) by ``R exp(hat(Theta))``, so a
  rotation at a constant body rate is integrated exactly (``LIE_GROUP``: the methods that step
  this way; same ``post_step``);
* compiled (``harness.engines.inhouse.compiled``, Numba; ``COMPILED``): ``"rk4_compiled"``, the
  same ``RK4`` table run by the compiled explicit Runge-Kutta stepper (any table in
  ``FIXED_STEP`` would run there unchanged), ``"rkmk4_compiled"``, the same table in
  Runge-Kutta-Munthe-Kaas form (``compiled.lie_group``, tested against ``"rkmk4"``), and
  ``"dop853_compiled"``, DOP853 with SciPy's coefficient tables. The engine
  (``InhouseEngine.simulate``) dispatches between the forms.

Results are sampled at given save times ``t_save`` (s, starting at the initial time). A run
never raises on a numerical failure: the result carries its ``reason`` (a ``Failure``: a non-finite state,
the ``reason`` of a ``DynamicsError`` from the right-hand side, a singular solve, a solver
failure) and a ``message``, with the samples up to the failure.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK45, Radau

from harness.engines.base import Integrator, integrator_table, reason_of
from harness.measure.trajectory import Failure
from harness.engines.inhouse.lie_group import rkmk_step

RHS = Callable[[float, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class ButcherTableau:
    """An explicit Runge-Kutta method: ``A`` strictly lower triangular (s x s), weights ``b``
    (s,), nodes ``c`` (s,), classical order ``order``."""

    name: str
    A: tuple[tuple[float, ...], ...]
    b: tuple[float, ...]
    c: tuple[float, ...]
    order: int


RK4 = ButcherTableau(
    name="rk4",
    A=((0.0, 0.0, 0.0, 0.0), (0.5, 0.0, 0.0, 0.0), (0.0, 0.5, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0)),
    b=(1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0),
    c=(0.0, 0.5, 0.5, 1.0),
    order=4,
)
EULER = ButcherTableau(name="euler", A=((0.0,),), b=(1.0,), c=(0.0,), order=1)

# How each method is computed (its name, kind and order are its ``METHODS`` record):
# the Butcher table of every fixed-step method, either form ...
FIXED_STEP: dict[str, ButcherTableau] = {"rk4": RK4, "euler": EULER, "rk4_compiled": RK4, "rkmk4": RK4,
                                         "rkmk4_compiled": RK4}
# ... the fixed-step methods whose table runs in Runge-Kutta-Munthe-Kaas form on the rotations
# (``lie_group.rkmk_step``; the others add the table's increments to the quaternions) ...
LIE_GROUP = frozenset({"rkmk4", "rkmk4_compiled"})
# ... the SciPy solver of every per-state adaptive method ...
ADAPTIVE = {"RK45": RK45, "DOP853": DOP853, "Radau": Radau, "BDF": BDF, "LSODA": LSODA}
# ... and the methods the compiled form runs (``harness.engines.inhouse.compiled``).
COMPILED = frozenset({"rk4_compiled", "dop853_compiled", "rkmk4_compiled"})
# The compiled twin of each per-state method that has one: the same Butcher table or coefficients
# and step control, compiled. ``harness validate`` (unless ``--per-state``) and ``--fast`` run the
# twin wherever the compiled form models the scene (``harness.engines.inhouse.fast_method``). The
# twin of ``DOP853`` projects after each step instead of using Baumgarte terms.
COMPILED_TWIN = {"rk4": "rk4_compiled", "rkmk4": "rkmk4_compiled", "DOP853": "dop853_compiled"}

METHODS = integrator_table(
    Integrator("rk4", "fixed", RK4.order, len(RK4.b),
               "classic RK4; quaternions renormalised and joint constraints projected after each step"),
    Integrator("euler", "fixed", EULER.order, len(EULER.b), "explicit Euler; projected after each step"),
    Integrator("rkmk4", "fixed", RK4.order, len(RK4.b),
               "RK4 in Runge-Kutta-Munthe-Kaas form: orientations on SO(3) (exponential map, dexp^-1 to "
               "second order), exact for constant-rate rotation; joint constraints projected after each step"),
    Integrator("RK45", "adaptive", 5, 6,
               "SciPy Dormand-Prince 5(4), advancing the fifth-order solution; Baumgarte stabilisation, no projection"),
    Integrator("DOP853", "adaptive", 8, 12, "SciPy DOP853; Baumgarte stabilisation, no projection"),
    Integrator("Radau", "adaptive", 5, None, "SciPy Radau IIA (implicit); Baumgarte stabilisation"),
    Integrator("BDF", "adaptive", 1, None, "SciPy BDF, orders 1-5 (implicit multistep); Baumgarte stabilisation"),
    Integrator("LSODA", "adaptive", 1, None, "SciPy LSODA (Adams/BDF switching); Baumgarte stabilisation"),
    Integrator("rk4_compiled", "fixed", RK4.order, len(RK4.b),
               "the RK4 table compiled (Numba); projected after each step; every scene (not a force given only "
               "as a function)"),
    Integrator("rkmk4_compiled", "fixed", RK4.order, len(RK4.b),
               "rkmk4 compiled (Numba); projected after each step; every scene (not a force given only as a "
               "function)"),
    Integrator("dop853_compiled", "adaptive", 8, 12,
               "DOP853 compiled (Numba; SciPy's coefficients and step control, 7th-order dense output); projected "
               "after each step, no Baumgarte; every scene (not a force given only as a function)"),
)

_NUMERICAL_ERRORS = (ArithmeticError, np.linalg.LinAlgError)


@dataclass
class Result:
    """Samples of one integration.

    Attributes:
        t: (n,) times reached among the save times (s); n < len(t_save) after a failure.
        y: (n, ny) states at those times.
        steps: accepted steps; rhs_evals: right-hand-side evaluations (including those of
            finite-difference Jacobians of implicit methods); wall_s: wall time (s).
        reason: why it ended before the last save time (``Failure``; ``Failure.NONE`` when it
            did not); message: why, when it did; ``status``: the reason's family.
        lam: (n, nc) constraint multipliers at those samples, where the integrator gives them
            (the compiled ones when asked), else None.
    """

    t: np.ndarray
    y: np.ndarray
    steps: int
    rhs_evals: int
    wall_s: float
    reason: Failure = Failure.NONE
    message: str = ""
    lam: np.ndarray | None = None

    @property
    def status(self) -> str:
        return self.reason.status


class _Counted:
    """Wrap a RHS to count its evaluations."""

    def __init__(self, f: RHS) -> None:
        self.f = f
        self.n = 0

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        self.n += 1
        return self.f(t, y)


def rk_step(f: RHS, t: float, y: np.ndarray, h: float, tableau: ButcherTableau) -> np.ndarray:
    """One step of an explicit Runge-Kutta method from (t, y) with step h (s)."""
    k: list[np.ndarray] = []
    for i, ci in enumerate(tableau.c):
        yi = y
        for aij, kj in zip(tableau.A[i][:i], k):
            if aij != 0.0:
                yi = yi + (h * aij) * kj
        k.append(f(t + ci * h, yi))
    out = y
    for bi, ki in zip(tableau.b, k):
        if bi != 0.0:
            out = out + (h * bi) * ki
    return out


def integrate_fixed(
    f: RHS,
    y0: np.ndarray,
    t_save: np.ndarray,
    steps_per_save: int,
    tableau: ButcherTableau,
    post_step: Callable[[np.ndarray], np.ndarray] | None = None,
    bodies: int | None = None,
) -> Result:
    """Fixed-step integration: ``steps_per_save`` equal steps of ``h = (t_save[k+1] -
    t_save[k]) / steps_per_save`` between consecutive save times, ``post_step`` after each.
    With ``bodies`` (the number of bodies of the engine's state layout, 13 entries each) the
    table runs in Runge-Kutta-Munthe-Kaas form (``lie_group.rkmk_step``); otherwise as an
    ordinary Runge-Kutta method on the flat state (``rk_step``)."""
    start = time.perf_counter()
    fc = _Counted(f)
    y = np.array(y0, dtype=float)
    t_save = np.asarray(t_save, dtype=float)
    ys = np.empty((len(t_save), y.size))
    ys[0] = y
    steps, n_done = 0, 1
    reason, message = Failure.NONE, ""
    try:
        with np.errstate(all="ignore"):
            for k in range(1, len(t_save)):
                t0 = t_save[k - 1]
                h = (t_save[k] - t0) / steps_per_save
                for j in range(steps_per_save):
                    if bodies is None:
                        y = rk_step(fc, t0 + j * h, y, h, tableau)
                    else:
                        y = rkmk_step(fc, t0 + j * h, y, h, tableau, bodies)
                    if post_step is not None:
                        y = post_step(y)
                    steps += 1
                    if not np.all(np.isfinite(y)):
                        reason = Failure.NON_FINITE
                        message = f"non-finite state after step {steps} (t = {t0 + (j + 1) * h:.6g} s)"
                        break
                if reason is not Failure.NONE:
                    break
                ys[k] = y
                n_done = k + 1
    except _NUMERICAL_ERRORS as err:
        reason = reason_of(err)
        message = f"{type(err).__name__} at step {steps + 1}: {err}"
    return Result(t_save[:n_done].copy(), ys[:n_done].copy(), steps, fc.n, time.perf_counter() - start, reason, message)


def integrate_adaptive(
    f: RHS,
    y0: np.ndarray,
    t_save: np.ndarray,
    method: str,
    rtol: float,
    atol: float,
    first_step: float | None = None,
    max_step: float | None = None,
) -> Result:
    """Integrate with a SciPy ``OdeSolver`` (``method`` from ``ADAPTIVE``) from ``t_save[0]``
    to ``t_save[-1]``, sampling at ``t_save`` with the solver's dense output (or its exact
    step end where they coincide). ``first_step`` (s) is the initial step hint; steps are at
    most the smallest save interval (``max_step``) so that interpolation stays within the
    tolerance."""
    start = time.perf_counter()
    fc = _Counted(f)
    t_save = np.asarray(t_save, dtype=float)
    y0 = np.array(y0, dtype=float)
    ys = np.empty((len(t_save), y0.size))
    ys[0] = y0
    n_done, steps = 1, 0
    reason, message = Failure.NONE, ""
    span = t_save[-1] - t_save[0]
    kwargs = {"rtol": rtol, "atol": atol}
    if len(t_save) > 1:
        # Steps no longer than the save interval: the dense output interpolants are of lower
        # order than the methods (DOP853: 7 vs 8) and over long steps their error exceeds the
        # tolerance (torque_free, rtol 1e-12: 1e-11 relative energy error at 0.23 s steps).
        kwargs["max_step"] = float(np.min(np.diff(t_save)))
    if max_step is not None:  # a cap below the save interval (``RunSettings.max_step``)
        kwargs["max_step"] = min(kwargs.get("max_step", max_step), max_step)
    if first_step is not None:
        kwargs["first_step"] = min(first_step, span)
    try:
        with np.errstate(all="ignore"):
            solver = ADAPTIVE[method](fc, t_save[0], y0, t_save[-1], **kwargs)
            while solver.status == "running":
                msg = solver.step()
                if solver.status == "failed":
                    reason, message = Failure.SOLVER, f"{method}: {msg} (t = {solver.t:.6g} s)"
                    break
                steps += 1
                if not np.all(np.isfinite(solver.y)):
                    reason, message = Failure.NON_FINITE, f"non-finite state at t = {solver.t:.6g} s"
                    break
                t_new = solver.t
                k_end = int(np.searchsorted(t_save, t_new, side="right"))
                if k_end > n_done:
                    sol = solver.dense_output()
                    ts = t_save[n_done:k_end]
                    ys[n_done:k_end] = sol(ts).T
                    if ts[-1] == t_new:
                        ys[k_end - 1] = solver.y
                    n_done = k_end
    except _NUMERICAL_ERRORS as err:
        reason, message = reason_of(err), f"{type(err).__name__} in {method} after {steps} steps: {err}"
    if reason is Failure.NONE and n_done < len(t_save):  # pragma: no cover - the solver stops at t_bound
        reason, message = Failure.SOLVER, f"{method} stopped at t = {t_save[n_done - 1]:.6g} s before the horizon"
    out_t, out_y = t_save[:n_done].copy(), ys[:n_done].copy()
    if not np.all(np.isfinite(out_y)):
        bad = int(np.argmax(~np.all(np.isfinite(out_y), axis=1)))
        out_t, out_y = out_t[:bad], out_y[:bad]
        reason, message = Failure.NON_FINITE, message or f"non-finite sample at t = {t_save[bad]:.6g} s"
    return Result(out_t, out_y, steps, fc.n, time.perf_counter() - start, reason, message)


def integrate(
    f: RHS,
    y0: np.ndarray,
    t_save: np.ndarray,
    method: str,
    *,
    steps_per_save: int = 1,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    first_step: float | None = None,
    post_step: Callable[[np.ndarray], np.ndarray] | None = None,
    bodies: int | None = None,
    max_step: float | None = None,
) -> Result:
    """Integrate with the per-state ``method`` (one of ``METHODS`` outside ``COMPILED``); see
    ``integrate_fixed`` and ``integrate_adaptive`` for what the keywords mean to each family
    (``post_step`` only applies to fixed-step methods, ``rtol``/``atol``/``first_step``/``max_step`` only to
    adaptive ones; ``bodies``, the number of bodies, only to the Lie-group methods ``LIE_GROUP``,
    whose state must be the engine's layout, 13 entries per body: default ``y0.size // 13``).
    The compiled methods run on a packed model, not a Python right-hand side:
    ``InhouseEngine.simulate`` runs them."""
    if method in COMPILED:
        raise ValueError(f"{method!r} runs in the compiled form (InhouseEngine.simulate), not on a Python right-hand side")
    if method in LIE_GROUP:
        size = np.size(y0)
        nb = size // 13 if bodies is None else int(bodies)
        if nb < 1 or size != 13 * nb:
            raise ValueError(f"{method!r} needs the engine's state layout (13 entries per body), got {size} entries"
                             + ("" if bodies is None else f" for {bodies} bodies"))
        return integrate_fixed(f, y0, t_save, steps_per_save, FIXED_STEP[method], post_step, bodies=nb)
    if method in FIXED_STEP:
        return integrate_fixed(f, y0, t_save, steps_per_save, FIXED_STEP[method], post_step)
    if method in ADAPTIVE:
        return integrate_adaptive(f, y0, t_save, method, rtol, atol, first_step, max_step)
    raise ValueError(f"unknown integrator {method!r} (known: {', '.join(METHODS)})")
