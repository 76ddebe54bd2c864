"""The compiled in-house solver: the Numba kernels of ``kernels`` behind plain Python calls.

The methods themselves are named and described once, as ``Integrator`` records of the in-house
engine (``harness.engines.inhouse.integrators.METHODS``: ``rk4_compiled``, ``rkmk4_compiled``,
``dop853_compiled``),
and run through its ``simulate``; this module only drives the kernels:

* ``integrate_fixed``: any explicit Runge-Kutta method given as a Butcher table
  (``integrators.ButcherTableau``; ``rk4_compiled`` is ``integrators.RK4``), ``steps_per_save``
  equal steps between save times. A new explicit method is a new table, not new code. With
  ``lie_group`` the table runs in Runge-Kutta-Munthe-Kaas form, orientations on SO(3)
  (``rkmk4_compiled``: the per-state ``lie_group.rkmk_step``), in the same kernel.
* ``integrate_dop853``: DOP853 with SciPy's coefficient tables and step-size control, 7th-order
  dense output at the save times, ``rtol``/``atol``.
* ``run_batch``: many initial states at once (``mujoco.rollout``'s use case): the scalar
  fixed-step kernel runs one trajectory after another on each of ``threads`` threads (the
  kernels release the GIL), each thread on a contiguous block of rows. A trajectory that fails
  stops alone: its row is NaN with its own status, the others are unaffected.

Every method projects onto the joint constraints after each accepted step (and the initial
state), with no Baumgarte terms, as the per-state engine's fixed-step methods do. A model with
loop joints also evaluates every stage at its projection onto the constraints (``kernels.rhs``,
``pack``'s ``stage_tol``), as the per-state fixed-step methods do (``projected_stages``), in
every compiled method: dop853_compiled too, which without it stalls at a flat position of
four_bar_chain (step size underflow; the per-state DOP853, with Baumgarte terms, does not project). State vectors
are the per-state engine's (``harness.engines.inhouse.model``: ``[p_WCm_W | quat_WB (wxyz) |
v_WCm_W | w_WB_B]``, SI units, body-frame angular velocity); times in s.

Scope: every model the per-state engine builds (free, ball, hinge and slide joints, loop joints,
rolling contacts, gravity, springs on slide joints, hinge torques, point springs, prescribed point
forces; ``kernels`` states how), except a prescribed force whose time law is only a Python
function: ``pack`` raises NotImplementedError for it (the engine turns that into an "unsupported"
trajectory: not run, rather than failed); a force built with ``PointForce.harmonic`` (a
``harness.model.forces.HarmonicForce``) is covered.

The first call in a fresh environment compiles the kernel it needs (``warm_up``); later
processes load it from Numba's on-disk cache. ``Result.wall_s`` never includes compilation:
every driver warms its kernel up before it starts the clock. Before the first compilation in a
process (a kernel that Numba's cache does not hold for this CPU and source), one line on stderr
says so, with the time the last compilation took on this machine (recorded in the cache folder,
``compile_seconds.json``); ``harness.io.progress.set_quiet(True)`` (``--quiet``) silences it.
A command that runs the kernels in worker processes (``harness stress``, ``harness validate``)
calls ``announce_cold(kernels)`` in the parent before it starts them: the parent prints the line
once for the whole run and its forked workers inherit the mark, so none of them prints it again.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop

from harness.engines.inhouse.compiled import kernels
from harness.engines.inhouse.constraints import RANK_RTOL, projection_tolerance
from harness.engines.inhouse.integrators import RK4, ButcherTableau, Result
from harness.engines.inhouse.lie_group import DEXPINV_SERIES
from harness.engines.inhouse.model import NEModel
from harness.model.forces import HarmonicForce
from harness.measure.trajectory import Failure
from harness.model.rolling_contact import FLAT

__all__ = ["KERNELS", "MAX_ADAPTIVE_STEPS", "STATUS", "announce_cold", "default_threads", "integrate_dop853",
           "integrate_fixed", "pack", "run_batch", "tableau_arrays", "warm_kernels", "warm_up"]

MAX_ADAPTIVE_STEPS = 200_000  # accepted + rejected steps before an adaptive run is declared failed

STATUS = {  # the kernels' status codes: the run's reason and why
    kernels.OK: (Failure.NONE, ""),
    kernels.NONFINITE: (Failure.NON_FINITE, "non-finite state"),
    kernels.SINGULAR: (Failure.SINGULAR, "singular constraint (KKT) matrix"),
    kernels.NO_PROJECTION: (Failure.PROJECTION, "position projection did not converge"),
    kernels.UNDERFLOW: (Failure.SOLVER, "DOP853 step size underflow"),
    kernels.TOO_MANY_STEPS: (Failure.SOLVER, f"more than {MAX_ADAPTIVE_STEPS} steps: step size collapsed"),
    kernels.BAD_ERROR: (Failure.NON_FINITE, "non-finite DOP853 error estimate (a stage overflowed)"),
    kernels.FLAT_DISK: (Failure.SINGULAR, "rolling contact: the disk lies flat, the contact point is undefined"),
}

_DOP853 = tuple(np.ascontiguousarray(a, dtype=float) for a in (_dop.A, _dop.B, _dop.C, _dop.E3, _dop.E5, _dop.D))


def pack(nem: NEModel) -> tuple:
    """The model tuple of ``kernels`` (its module docstring lists the entries; ``stage_tol``, the
    last, is ``projection_tolerance(nem)`` for a model with loop joints, whose every stage the
    kernels evaluate at its projection, and 0 otherwise).
    Raises NotImplementedError for a model outside the compiled solver's scope: a prescribed
    force whose time law is only a Python function."""
    for i, _, law in nem.forces:
        if not isinstance(law, HarmonicForce):
            raise NotImplementedError(f"the compiled in-house solver cannot evaluate the prescribed force on "
                                      f"{nem.body_names[i]!r}: its time law is a Python function, not a "
                                      "HarmonicForce (PointForce.harmonic)")
    nj = nem.nj
    hinge = np.array([t == "hinge" for t in nem.joint_types], dtype=np.int64)
    rows = 3 + 2 * hinge
    row = np.concatenate([[0], np.cumsum(rows)[:-1]]).astype(np.int64) if nj else np.zeros(0, dtype=np.int64)
    n_fast = int(rows.sum())
    if n_fast != nem.nc_fast:
        raise NotImplementedError(f"the compiled in-house solver expects {n_fast} ball/hinge rows, the model has {nem.nc_fast}")
    nc = n_fast + 5 * len(nem.slides) + 3 * len(nem.contacts)
    if nc != nem.nc:
        raise NotImplementedError(f"the compiled in-house solver expects {nc} constraint rows, the model has {nem.nc}")
    D = nem.D_end
    vectors = lambda a: np.ascontiguousarray(a, dtype=float).reshape(-1, 3)  # noqa: E731
    indices = lambda a: np.asarray(a, dtype=np.int64).reshape(-1)  # noqa: E731
    slides, springs = nem.slides, nem.springs
    return (
        np.ascontiguousarray(nem.mass, dtype=float),
        np.ascontiguousarray(nem.I_B, dtype=float),
        np.ascontiguousarray(nem.Iinv_B, dtype=float),
        np.ascontiguousarray(nem.weight_W / nem.mass[:, None], dtype=float),
        indices(nem.ends[:nj]),
        indices(nem.ends[nj:]),
        vectors(D[:nj, :, 0]),
        vectors(D[nj:, :, 0]),
        hinge,
        vectors(D[:nj, :, 1]),
        vectors(D[nj:, :, 1]),
        vectors(D[nj:, :, 2]),
        row,
        int(nc),
        indices([sl.child for sl in slides]),
        indices([sl.parent for sl in slides]),
        vectors([sl.r_c for sl in slides]),
        vectors([sl.r_p for sl in slides]),
        vectors([sl.b[0] for sl in slides]),
        vectors([sl.b[1] for sl in slides]),
        vectors([sl.axis for sl in slides]),
        indices(n_fast + 5 * np.arange(len(slides))),
        indices([sp.slide for sp in springs]),
        np.array([sp.k for sp in springs], dtype=float),
        np.array([sp.q_ref for sp in springs], dtype=float),
        float(RANK_RTOL) if nem.redundant else 0.0,
        float(FLAT),
        *_elements(nem, nc),
        int(nc - 3 * len(nem.contacts)),
        float(projection_tolerance(nem)) if nem.loops else 0.0,
    )


def _elements(nem: NEModel, nc: int) -> tuple[np.ndarray, np.ndarray]:
    """The element table of ``kernels`` (elem (ne, 3) int, edata (ne, 13) float): prescribed
    forces, hinge torques, point springs, then rolling contacts (rows: the last 3 per contact)."""
    nb, first = nem.nb, nc - 3 * len(nem.contacts)
    elem, edata = [], []

    def add(kind, a, b, *numbers):
        elem.append((kind, a, b))
        edata.append(np.concatenate([np.ravel(np.asarray(x, dtype=float)) for x in numbers] + [np.zeros(13)])[:13])

    for i, r_B, law in nem.forces:
        add(kernels.FORCE, i, nb, r_B, law.f_const_W, law.f_cos_W, law.f_sin_W, law.omega)
    for tq in nem.torques:
        add(kernels.TORQUE, tq.child, tq.parent, tq.axis_B, tq.torque)
    for ps in nem.point_springs:
        add(kernels.POINT_SPRING, ps.body_a, ps.body_b, ps.r_a, ps.r_b, ps.k, ps.rest_length, ps.c)
    for k, c in enumerate(nem.contacts):
        add(kernels.ROLLING, c.body, first + 3 * k, c.radius, c.half_thickness,
            0.0 if c.circle_z is None else c.circle_z, float(c.circle_z is not None))
    return (np.asarray(elem, dtype=np.int64).reshape(-1, 3),
            np.ascontiguousarray(np.asarray(edata, dtype=float).reshape(-1, 13)))


def tableau_arrays(tableau: ButcherTableau) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, b, c)`` of an explicit Runge-Kutta method as the kernels take them (float arrays,
    A s x s strictly lower triangular). ValueError for an implicit or inconsistent table."""
    A = np.ascontiguousarray(tableau.A, dtype=float)
    b = np.ascontiguousarray(tableau.b, dtype=float)
    c = np.ascontiguousarray(tableau.c, dtype=float)
    s = len(b)
    if A.shape != (s, s) or c.shape != (s,) or np.any(np.triu(A) != 0.0):
        raise ValueError(f"{tableau.name}: not an explicit Butcher table (A {A.shape}, b {b.shape}, c {c.shape})")
    return A, b, c


def dexpinv_series(tableau: ButcherTableau | None) -> np.ndarray:
    """The ``dexp^-1`` coefficients the kernels take: for the Runge-Kutta-Munthe-Kaas form of
    ``tableau`` those to ``ad^(order-2)`` (as ``lie_group.dexpinv`` truncates them); empty (the
    plain Runge-Kutta method) for None."""
    if tableau is None:
        return np.zeros(0)
    n = max(tableau.order - 1, 1)
    if n > len(DEXPINV_SERIES):
        raise ValueError(f"{tableau.name}: dexpinv series known to ad^{len(DEXPINV_SERIES) - 1} only")
    return np.ascontiguousarray(DEXPINV_SERIES[:n], dtype=float)


def _state(y0: np.ndarray) -> np.ndarray:
    y0 = np.asarray(y0, dtype=float)
    if y0.ndim == 2 and y0.shape[0] == 1:
        y0 = y0[0]
    if y0.ndim != 1:
        raise ValueError(f"the compiled integrators take one state (ny,), got shape {y0.shape}")
    return np.ascontiguousarray(y0)


def _result(status: int, t_save: np.ndarray, out: np.ndarray, n: int, steps: int, evals: int, wall: float,
            lam: np.ndarray) -> Result:
    reason, why = STATUS.get(int(status), (Failure.SOLVER, f"status {status}"))
    n = int(n)
    message = "" if reason is Failure.NONE else f"{why} (t = {t_save[min(n, len(t_save) - 1)]:.6g} s, after {steps} steps)"
    return Result(t_save[:n].copy(), out[:n].copy(), int(steps), int(evals), wall, reason, message,
                  lam[:n].copy() if len(lam) else None)


def _multiplier_rows(model: tuple, n_save: int, multipliers: bool) -> np.ndarray:
    """The kernels' ``lam_out``: (n_save, nc) to fill with ``multipliers``, else no rows."""
    return np.full((n_save if multipliers else 0, max(int(model[13]), 1)), np.nan)


def integrate_fixed(model: tuple, y0: np.ndarray, t_save: np.ndarray, tableau: ButcherTableau = RK4, *,
                    steps_per_save: int = 1, proj_tol: float = 1e-13, lie_group: bool = False,
                    multipliers: bool = False) -> Result:
    """Integrate one state ``y0`` (ny,) of the packed ``model`` with the explicit Runge-Kutta
    method ``tableau``: ``steps_per_save`` equal steps between consecutive save times
    ``t_save`` (s), projection (to ``proj_tol``, m) after each step; with ``lie_group`` in
    Runge-Kutta-Munthe-Kaas form (orientations on SO(3)). With ``multipliers``, ``Result.lam``
    holds the constraint multipliers at each sample (the reactions' source). ``wall_s`` covers
    the integration alone (and the multipliers); ``rhs_evals`` = stages x steps."""
    y0 = _state(y0)
    A, b, c = tableau_arrays(tableau)
    series = dexpinv_series(tableau if lie_group else None)
    t_save = np.ascontiguousarray(t_save, dtype=float)
    out = np.full((len(t_save), len(y0)), np.nan)
    lam = _multiplier_rows(model, len(t_save), multipliers)
    warm_up(model, y0, "erk")
    start = time.perf_counter()
    status, n, steps = kernels.erk(model, y0, t_save, int(steps_per_save), float(proj_tol), out, A, b, c, series, lam)
    wall = time.perf_counter() - start
    return _result(status, t_save, out, n, steps, len(b) * steps, wall, lam)


def integrate_dop853(model: tuple, y0: np.ndarray, t_save: np.ndarray, *, rtol: float = 1e-10, atol: float = 1e-12,
                     first_step: float | None = None, max_step: float | None = None,
                     proj_tol: float = 1e-13, multipliers: bool = False) -> Result:
    """Integrate one state ``y0`` (ny,) of the packed ``model`` with DOP853 at ``rtol``/``atol``
    from ``t_save[0]``, sampling at ``t_save`` (s); ``first_step`` (s) is the first step tried
    (None: SciPy's choice); ``max_step`` (s) caps every step (None: no cap); ``multipliers`` as
    ``integrate_fixed``. ``wall_s`` covers the integration alone (and the multipliers)."""
    y0 = _state(y0)
    t_save = np.ascontiguousarray(t_save, dtype=float)
    out = np.full((len(t_save), len(y0)), np.nan)
    lam = _multiplier_rows(model, len(t_save), multipliers)
    h0 = float(first_step) if first_step else 0.0
    warm_up(model, y0, "dop853")
    start = time.perf_counter()
    h_max = float(max_step) if max_step else 0.0
    status, n, steps, _rejected, evals = kernels.dop853(model, y0, t_save, float(rtol), float(atol), h0, h_max,
                                                        float(proj_tol), MAX_ADAPTIVE_STEPS, out, _DOP853, lam)
    wall = time.perf_counter() - start
    return _result(status, t_save, out, n, steps, evals, wall, lam)


def default_threads() -> int:
    """Threads of ``run_batch``: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def run_batch(model: tuple, Y0: np.ndarray, nstep: int, dt: float, tableau: ButcherTableau = RK4, *,
              threads: int | None = None, proj_tol: float = 1e-13, lie_group: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The explicit Runge-Kutta method ``tableau`` (default RK4; with ``lie_group`` in
    Runge-Kutta-Munthe-Kaas form, as ``integrate_fixed``) from each initial state of
    ``Y0`` (nbatch x ny) for ``nstep`` steps of ``dt`` s from t = 0, projection after each step;
    the rows split into ``threads`` (default: the cores) contiguous blocks run side by side.
    Returns the final states (nbatch x ny; NaN rows for trajectories that did not finish) and a
    status word per row (``STATUS``: "ok", "blowup" for a non-finite state, "failed")."""
    Y0 = np.ascontiguousarray(Y0, dtype=float)
    A, b, c = tableau_arrays(tableau)
    nbatch = Y0.shape[0]
    Yend = np.full_like(Y0, np.nan)
    status = np.zeros(nbatch, dtype=np.int64)
    if nbatch:
        warm_up(model, Y0[0], "erk_rows")
    threads = max(1, min(threads or default_threads(), nbatch))
    bounds = np.linspace(0, nbatch, threads + 1).astype(int)
    args = (model, Y0, int(nstep), float(dt), float(proj_tol), A, b, c, dexpinv_series(tableau if lie_group else None),
            Yend, status)
    if threads == 1:
        kernels.erk_rows(*args, 0, nbatch)
    else:
        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(lambda k: kernels.erk_rows(*args, int(bounds[k]), int(bounds[k + 1])), range(threads)))
    return Yend, np.array([STATUS.get(int(s), (Failure.SOLVER, ""))[0].status for s in status])


_warm: set[str] = set()
_announced = False  # the compile notice was printed by this process or by the parent that forked it
KERNELS = ("erk", "dop853", "erk_rows")  # what warm_up compiles
_TIMES_FILE = "compile_seconds.json"


def is_cached(kernel: str) -> bool | None:
    """Whether Numba's on-disk cache holds ``kernel`` compiled for this CPU from the current
    source (its index is discarded when the source file changes); None when it cannot tell."""
    try:
        disp = getattr(kernels, kernel)
        index = disp._cache._cache_file._load_index()
        magic = disp.targetctx.codegen().magic_tuple()
        return any(key[1] == magic for key in index)
    except Exception:  # Numba internals moved, or no cache: do not guess
        return None


def _times_path(kernel: str):
    try:
        return os.path.join(getattr(kernels, kernel)._cache._cache_path, _TIMES_FILE)
    except Exception:
        return None


def _recorded_times(kernel: str) -> dict[str, float]:
    """``{kernel: seconds}`` the last compilations took on this machine (empty if unknown)."""
    path = _times_path(kernel)
    try:
        with open(path) as f:
            return {k: float(v) for k, v in json.load(f).items()}
    except Exception:
        return {}


def _record_time(kernel: str, seconds: float) -> None:
    path = _times_path(kernel)
    if path is None:
        return
    times = _recorded_times(kernel) | {kernel: round(seconds, 1)}
    try:
        tmp = f"{path}.{os.getpid()}.tmp"
        with open(tmp, "w") as f:
            json.dump(times, f)
        os.replace(tmp, path)
    except OSError:  # a read-only cache folder: no estimate next time, nothing worse
        pass


def announce_cold(kernels_needed=KERNELS) -> bool:
    """In a parent process, before it starts workers that run ``kernels_needed`` (names of
    ``KERNELS``): when Numba's cache lacks one of them (``is_cached`` false), print the compile
    notice now (``_announce``, once per process) and mark it printed, so that the workers forked
    afterwards, which inherit the mark, do not print it once each. Returns whether a kernel is
    cold. Nothing is compiled here."""
    cold = [k for k in kernels_needed if k not in _warm and is_cached(k) is False]
    if cold:
        _announce(cold[0])
    return bool(cold)


def _announce(kernel: str) -> None:
    """One line on stderr, once per process (and its forked workers, ``announce_cold``), before
    the first compilation."""
    global _announced
    if _announced:
        return
    _announced = True
    from harness.io.progress import note

    seconds = _recorded_times(kernel).get(kernel)
    how_long = f"about {seconds:.0f} s on this machine" if seconds else "a minute or so"
    note(f"compiling the in-house kernels (once; {how_long}, then cached)")


def warm_kernels() -> frozenset[str]:
    """The kernels this process has compiled or loaded (``warm_up``)."""
    return frozenset(_warm)


def warm_up(model: tuple, y0: np.ndarray, kernel: str) -> None:
    """Compile (or load from the cache) ``kernel`` ("erk", "dop853" or "erk_rows") by running it
    for one step of ``model`` from ``y0``, so that timed runs never include compilation (once
    per kernel and process: every packed model and table has the same types). A compilation
    (``is_cached`` false) is announced on stderr first (``_announce``) and its duration (s,
    wall clock) recorded for the next announcement's estimate. Processes compiling at the same
    time take turns (``_compile_lock``): the others load the first one's result."""
    if kernel in _warm:
        return
    with _compile_lock(kernel):
        _warm_up(model, y0, kernel)
    _warm.add(kernel)


@contextlib.contextmanager
def _compile_lock(kernel: str):
    """Held while a process compiles or loads a kernel when the cache lacks it: a second process
    that needs the same kernel at the same time (workers of one ``validate``, two test workers)
    waits, then loads what the first compiled instead of compiling it again (an exclusive
    ``flock`` on a file in Numba's cache folder, released by the kernel when a process dies).
    No lock where the cache folder cannot be written or ``fcntl`` is missing."""
    if is_cached(kernel) is not False:
        yield
        return
    try:
        import fcntl

        folder = getattr(kernels, kernel)._cache._cache_path
        os.makedirs(folder, exist_ok=True)
        handle = open(os.path.join(folder, "compile.lock"), "a")
    except Exception:  # no fcntl (Windows), Numba internals moved, or a read-only cache folder
        yield
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _warm_up(model: tuple, y0: np.ndarray, kernel: str) -> None:
    compiling = is_cached(kernel) is False  # again: another process may have compiled it meanwhile
    if compiling:
        _announce(kernel)
    start = time.perf_counter()
    y0 = np.ascontiguousarray(y0, dtype=float)
    t = np.array([0.0, 1e-3])
    out = np.empty((2, len(y0)))
    A, b, c = tableau_arrays(RK4)
    if kernel == "erk":
        kernels.erk(model, y0, t, 1, 1e-13, out, A, b, c, dexpinv_series(None), _multiplier_rows(model, 2, True))
    elif kernel == "dop853":
        kernels.dop853(model, y0, t, 1e-6, 1e-6, 1e-3, 0.0, 1e-13, 1, out, _DOP853, _multiplier_rows(model, 2, True))
    elif kernel == "erk_rows":
        kernels.erk_rows(model, y0[None], 1, 1e-3, 1e-13, A, b, c, dexpinv_series(None), out[:1],
                         np.zeros(1, dtype=np.int64), 0, 1)
    else:
        raise ValueError(f"unknown kernel {kernel!r}")
    if compiling:
        _record_time(kernel, time.perf_counter() - start)
