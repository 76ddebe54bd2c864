"""An engine's dynamics linearised about a state, by central differences of its accelerations.

A system whose motion near a reference motion is described by n independent coordinates s and
their rates s' (the others, and every dependent velocity, fixed by the constraints) has the
first-order form x' = f(x), x = (s, s'), f = (s', s''(x)). Its state matrix about x0 is::

    A = [[0, I], [d s''/d x]]                                              (2n x 2n, 1/s, 1/s^2)

The lower block is what an engine's dynamics give: for each x the ``Coordinates`` (a builder's:
``joint_state(x)`` puts the system on its constraints, ``accelerations(states, a, alpha)``
reads s'' from the bodies' maximal-coordinate accelerations) and the engine's accelerations at
that joint state (``harness.engines.accelerations``: its right-hand side, the same equations a
run integrates). Each column is a central difference ``(f(x0 + h e_k) - f(x0 - h e_k)) / 2h``
at the steps h, h/2, ..., h/2^(levels-1), extrapolated to h -> 0 by Richardson's table in h^2
(``richardson``): the truncation error falls as h^(2 levels), the round-off of the engine's
accelerations (1e-14 of g on the bicycle) is divided by h, so a large first step with three
levels gives twelve digits on the bicycle where a lone central difference gives seven.

Nothing here names a scene or an engine: the coordinates come from the caller (e.g. the
benchmark coordinates of ``harness/model/builders/bicycle.py``), the engine by its registered
name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from harness.engines import accelerations
from harness.model import kinematics
from harness.model.multibody import Multibody

STEP = 0.02  # the first difference step, in the coordinates' units (rad, rad/s on the bicycle)
LEVELS = 3  # Richardson levels: steps STEP, STEP/2, STEP/4


class Coordinates(Protocol):
    """Independent coordinates of a system on its constraints (a builder provides them).

    Attributes:
        model: the system (``Multibody``).
        n: number of independent positions; states are x = (s (n), s' (n)).
    """

    model: Multibody
    n: int

    def joint_state(self, x) -> tuple[dict, dict]:
        """Joint coordinates ``(q, v)`` per body name at x, on the constraints."""

    def accelerations(self, states, a_WCm_W: dict, alpha_WB_W: dict) -> np.ndarray:
        """s'' (n,) from maximal-coordinate states (``kinematics.BodyState`` per body name) and the
        bodies' centre-of-mass and angular accelerations (world, per body name)."""


@dataclass(frozen=True)
class Linearization:
    """An engine's linearisation about x0.

    Attributes:
        engine: the engine's registered name.
        x0: the state (2n,) linearised about.
        A: the state matrix (2n, 2n).
        residual: s'' at x0 (n,): zero at an equilibrium or steady motion, up to round-off.
        error: per entry of the lower block (n, 2n), Richardson's conservative estimate of A's
            error there (``richardson``).
        step, levels: the first step and the number of Richardson levels.
    """

    engine: str
    x0: np.ndarray
    A: np.ndarray
    residual: np.ndarray
    error: np.ndarray
    step: np.ndarray
    levels: int

    @property
    def eigenvalues(self) -> np.ndarray:
        """The eigenvalues of A, sorted by real part, then imaginary part (complex, 1/s)."""
        return np.sort_complex(np.linalg.eigvals(self.A).astype(complex))


def second_derivatives(engine: str, scene, coordinates: Coordinates, x) -> np.ndarray:
    """s'' (n,) at state ``x`` (2n,) as ``engine``'s dynamics give it (module docstring)."""
    model = coordinates.model
    q, v = coordinates.joint_state(np.asarray(x, dtype=float))
    acc, alpha = accelerations(engine, scene, model, q, v)
    return np.asarray(coordinates.accelerations(kinematics.forward(model, q, v), acc, alpha), dtype=float)


def richardson(values: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Richardson's extrapolation of central differences at steps h, h/2, h/4, ... (``values``,
    in that order; error even in h): ``(estimate, error)``, the last entry of the table and its
    difference from the entry before it in the same row (one order of extrapolation fewer; zero
    for one value): a conservative estimate, four orders of magnitude above the error on the
    bicycle."""
    table: list[list[np.ndarray]] = []
    for j, value in enumerate(values):
        row = [np.asarray(value, dtype=float)]
        for m in range(1, j + 1):
            row.append(row[m - 1] + (row[m - 1] - table[j - 1][m - 1]) / (4.0**m - 1.0))
        table.append(row)
    last = table[-1]
    return last[-1], (np.abs(last[-1] - last[-2]) if len(last) > 1 else np.zeros_like(last[-1]))


def linearize(engine: str, scene, coordinates: Coordinates, x0=None, *, step=STEP, levels: int = LEVELS) -> Linearization:
    """``engine``'s state matrix about ``x0`` (default: zero) in ``coordinates`` (module
    docstring): central differences of its s'' at the steps ``step`` (a number, or one per
    coordinate of x, in its unit), ``step``/2, ... (``levels`` of them), Richardson-extrapolated."""
    n = int(coordinates.n)
    x0 = np.zeros(2 * n) if x0 is None else np.asarray(x0, dtype=float)
    steps = np.broadcast_to(np.asarray(step, dtype=float), (2 * n,)).copy()
    if not (np.all(np.isfinite(steps)) and np.all(steps > 0.0)) or levels < 1:
        raise ValueError(f"linearize: steps must be positive and levels >= 1, got {steps.tolist()}, {levels}")
    lower = np.zeros((n, 2 * n))
    error = np.zeros((n, 2 * n))
    for k in range(2 * n):
        diffs = []
        for j in range(levels):
            h = steps[k] / 2.0**j
            e = np.zeros(2 * n)
            e[k] = h
            diffs.append((second_derivatives(engine, scene, coordinates, x0 + e)
                          - second_derivatives(engine, scene, coordinates, x0 - e)) / (2.0 * h))
        lower[:, k], error[:, k] = richardson(diffs)
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:] = lower
    residual = second_derivatives(engine, scene, coordinates, x0)
    return Linearization(engine, x0, A, residual, error, steps, levels)
