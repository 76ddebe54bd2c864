"""The compiled in-house solver: ``compiled_kernels`` behind the batched solver's interface.

Methods (``METHODS``; fixed step: ``steps_per_save`` equal steps between save times;
adaptive: ``rtol``/``atol``; projection onto the joint constraints after each accepted step,
no Baumgarte terms, as the per-state engine's fixed-step methods):

================ ======= ==================================================================
name             order   what
================ ======= ==================================================================
rk4_compiled     4       classic RK4, fixed step
dop853_compiled  8       DOP853 (SciPy's coefficient tables and step-size control), 7th-order
                         dense output at the save times
================ ======= ==================================================================

``run_batch`` advances many initial states with RK4 (``compiled_lanes``: up to ``LANES``
trajectories side by side in SIMD registers), split over threads (the kernels release the GIL),
as ``mujoco.rollout`` does with its thread pool. Single trajectories use the scalar kernels
(``compiled_kernels``): with one lane the lane loops cost more than they save, with 64 lanes
they pay several times over. Both are tested against the per-state engine and each other.

Scope: free, ball, hinge and slide joints, springs on slide joints and gravity; ``pack`` raises
NotImplementedError for rolling contacts and prescribed forces, which a work-precision sweep
records as a failed point.

The first call in a fresh environment compiles the kernels (tens of seconds; ``warm_up``),
later processes load them from Numba's on-disk cache. Timings in ``BatchResult.wall_s`` never
include compilation: ``integrate`` compiles before it starts the clock.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop

from harness.engines.inhouse.compiled import kernels
from harness.engines.inhouse.compiled import lanes
from harness.engines.inhouse.batched_integrators import MAX_ADAPTIVE_STEPS, BatchResult
from harness.engines.inhouse.model import NEModel

__all__ = ["METHODS", "FIXED", "ADAPTIVE", "NOMINAL_ORDER", "STATUS", "pack", "integrate", "run_batch", "warm_up"]

FIXED = ("rk4_compiled",)
ADAPTIVE = ("dop853_compiled",)
METHODS = FIXED + ADAPTIVE
NOMINAL_ORDER = {"rk4_compiled": 4, "dop853_compiled": 8}

STATUS = {
    kernels.OK: ("ok", ""),
    kernels.NONFINITE: ("blowup", "non-finite state"),
    kernels.SINGULAR: ("failed", "singular constraint (KKT) matrix"),
    kernels.NO_PROJECTION: ("failed", "position projection did not converge"),
    kernels.UNDERFLOW: ("failed", "DOP853 step size underflow"),
    kernels.TOO_MANY_STEPS: ("failed", f"more than {MAX_ADAPTIVE_STEPS} steps: step size collapsed"),
    kernels.BAD_ERROR: ("failed", "non-finite DOP853 error estimate"),
}

LANES = 64  # most trajectories advanced side by side per thread (measured best of 1..64)

_DOP853 = tuple(np.ascontiguousarray(a, dtype=float) for a in (_dop.A, _dop.B, _dop.C, _dop.E3, _dop.E5, _dop.D))


def pack(nem: NEModel) -> tuple:
    """The model tuple of ``compiled_kernels`` (its module docstring lists the entries).
    Raises NotImplementedError for a model outside the compiled solver's scope."""
    if nem.contacts:
        raise NotImplementedError("the compiled in-house solver does not model rolling contacts")
    if nem.forces:
        raise NotImplementedError("the compiled in-house solver does not model prescribed forces")
    nj = nem.nj
    hinge = np.array([t == "hinge" for t in nem.joint_types], dtype=np.int64)
    rows = 3 + 2 * hinge
    row = np.concatenate([[0], np.cumsum(rows)[:-1]]).astype(np.int64) if nj else np.zeros(0, dtype=np.int64)
    n_fast = int(rows.sum())
    if n_fast != nem.nc_fast:
        raise NotImplementedError(f"the compiled in-house solver expects {n_fast} ball/hinge rows, the model has {nem.nc_fast}")
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
        int(n_fast + 5 * len(slides)),
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
    )


def _result(status: int, t_save: np.ndarray, out: np.ndarray, n: int, steps: int, rejected: int, evals: int,
            wall: float) -> BatchResult:
    word, why = STATUS.get(int(status), ("failed", f"status {status}"))
    n = int(n)
    message = "" if word == "ok" else f"{why} (t = {t_save[min(n, len(t_save) - 1)]:.6g} s, after {steps} steps)"
    return BatchResult(t_save[:n].copy(), out[:n, None, :].copy(), int(steps), int(rejected), int(evals), int(evals),
                       wall, word, message)


def integrate(model: tuple, y0: np.ndarray, t_save: np.ndarray, method: str, *, steps_per_save: int = 1,
              rtol: float = 1e-10, atol: float = 1e-12, first_step: float | None = None,
              proj_tol: float = 1e-13) -> BatchResult:
    """Integrate one state ``y0`` (ny,) of the packed ``model`` from ``t_save[0]``, sampling at
    ``t_save`` (s). ``wall_s`` covers the integration alone (compiled beforehand)."""
    if method not in METHODS:
        raise ValueError(f"unknown compiled integrator {method!r} (known: {', '.join(METHODS)})")
    y0 = np.asarray(y0, dtype=float)
    if y0.ndim == 2 and y0.shape[0] == 1:
        y0 = y0[0]
    if y0.ndim != 1:
        raise ValueError(f"the compiled integrators take one state (ny,), got shape {y0.shape}")
    y0 = np.ascontiguousarray(y0)
    warm_up(model, len(y0))
    t_save = np.ascontiguousarray(t_save, dtype=float)
    out = np.full((len(t_save), len(y0)), np.nan)
    if method == "rk4_compiled":
        start = time.perf_counter()
        status, n, steps = kernels.rk4(model, y0, t_save, int(steps_per_save), float(proj_tol), out)
        wall = time.perf_counter() - start
        return _result(status, t_save, out, n, steps, 0, 4 * steps, wall)
    h0 = float(first_step) if first_step else 0.0
    start = time.perf_counter()
    status, n, steps, rejected, evals = kernels.dop853(model, y0, t_save, float(rtol), float(atol), h0, float(proj_tol),
                                                       MAX_ADAPTIVE_STEPS, out, _DOP853)
    wall = time.perf_counter() - start
    return _result(status, t_save, out, n, steps, rejected, evals, wall)


def default_threads() -> int:
    """Threads of ``run_batch``: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def run_batch(model: tuple, Y0: np.ndarray, nstep: int, dt: float, *, threads: int | None = None,
              proj_tol: float = 1e-13, lanes_per_group: int = LANES) -> tuple[np.ndarray, np.ndarray]:
    """RK4 over the initial states ``Y0`` (nbatch x ny) for ``nstep`` steps of ``dt`` s from
    t = 0, projection after each step; the rows split into ``threads`` contiguous chunks run
    side by side, each advanced ``lanes_per_group`` at a time. Returns the final states
    (nbatch x ny) and a status word per row (``STATUS``)."""
    Y0 = np.ascontiguousarray(Y0, dtype=float)
    warm_up(model, Y0.shape[1])
    nbatch = Y0.shape[0]
    Yend = np.full_like(Y0, np.nan)
    status = np.zeros(nbatch, dtype=np.int64)
    threads = max(1, min(threads or default_threads(), nbatch))
    bounds = np.linspace(0, nbatch, threads + 1).astype(int)
    L = int(max(1, min(lanes_per_group, int(np.max(np.diff(bounds))))))
    args = (model, Y0, int(nstep), float(dt), float(proj_tol), Yend, status)
    if threads == 1:
        lanes.rk4_batch(*args, 0, nbatch, L)
    else:
        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(lambda k: lanes.rk4_batch(*args, int(bounds[k]), int(bounds[k + 1]), L), range(threads)))
    return Yend, np.array([STATUS.get(int(s), ("failed", ""))[0] for s in status])


_compiled = False


def warm_up(model: tuple, ny: int) -> None:
    """Compile (or load from the cache) every kernel for ``model``'s types, so that timed runs
    never include compilation (once per process: every packed model has the same types)."""
    global _compiled
    if _compiled:
        return
    _compiled = True
    y0 = np.zeros(ny)
    nb = ny // 13
    y0[3 * nb::4][:nb] = 1.0
    t = np.array([0.0, 1e-3])
    out = np.empty((2, ny))
    kernels.rk4(model, y0, t, 1, 1e-13, out)
    kernels.dop853(model, y0, t, 1e-6, 1e-6, 1e-3, 1e-13, 10, out, _DOP853)
    lanes.rk4_batch(model, y0[None], 1, 1e-3, 1e-13, np.empty((1, ny)), np.zeros(1, dtype=np.int64), 0, 1, 1)
