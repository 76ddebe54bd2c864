"""Runge-Kutta-Munthe-Kaas (RKMK) steps of the in-house engine's state on (R^3 x SO(3))^nb x R^6nb.

The state ``y = [p_WCm_W | quat_WB | v_WCm_W | w_WB_B]`` (``model.split``, 13 entries per body)
is integrated as follows, for any explicit Butcher table (A, b, c):

* positions and velocities (``p``, ``v``, ``w``) are vectors: their stages and update are the
  Runge-Kutta ones, ``x_i = x_0 + h sum_j a_ij k_j``;
* each orientation is ``R = R_0 exp(hat(Theta))`` with ``Theta`` (rad, body frame of ``R_0``)
  integrated in the Lie algebra: stage ``i`` is at ``R_0 exp(hat(Theta_i))``,
  ``Theta_i = h sum_j a_ij k_j^Theta``, and its algebra rate is the stage's body angular velocity
  ``w_i`` mapped by the inverse differential of the exponential,
  ``k_i^Theta = dexp_{-Theta_i}^{-1}(w_i) = w_i + 1/2 Theta_i x w_i + 1/12 Theta_i x (Theta_i x w_i)``
  (the body-frame form ``R' = R hat(w)``: ``w = dexp_{-Theta}(Theta')``, so the odd terms of the
  Bernoulli series change sign against the spatial form ``w - 1/2 [Theta, w] + ...``). The series
  is truncated after the ``ad^(order-2)`` term, enough for the table's order (Munthe-Kaas, "High
  order Runge-Kutta methods on manifolds", 1999; Hairer, Lubich & Wanner, *Geometric Numerical
  Integration*, Sect. IV.8); with the first term alone RK4 drops to third order. The step ends at
  ``R_0 exp(hat(h sum_i b_i k_i^Theta))``.

The orientation stays on SO(3) (up to round-off: quaternions ``q_0 (x) exp_q(Theta)``), and a
rotation at a constant body rate ``w`` (so ``w x Theta_i = 0`` at every stage) is integrated exactly:
``Theta = h w``. The quaternion derivative the right-hand side returns is not used. With the
classic RK4 table this is RKMK4, order 4 in every component.

The per-body maps (``exp_right``, ``dexpinv``) are written on Python floats: for the 1-7 bodies
of the scenes that is several times faster than the same formulas on stacks of tiny NumPy
arrays, and the step's cost stays close to the Runge-Kutta step's (its right-hand sides).
The Hamilton product is checked against ``harness.model.rotations.multiply`` and the exponential
against ``scipy.spatial.transform.Rotation.from_rotvec`` by the tests.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

RHS = Callable[[float, np.ndarray], np.ndarray]

# Coefficients of ad_Theta^k in dexp_{-Theta}^{-1} = sum_k B_k (-1)^k / k! ad_Theta^k (B_k the
# Bernoulli numbers, B_1 = -1/2): 1, 1/2, 1/12, 0, -1/720, 0, 1/30240.
DEXPINV_SERIES = (1.0, 0.5, 1.0 / 12.0, 0.0, -1.0 / 720.0, 0.0, 1.0 / 30240.0)


def exp_right(q: Sequence[float], theta: Sequence[float]) -> tuple[float, float, float, float]:
    """``q (x) exp_q(Theta)`` (wxyz) for one unit quaternion ``q`` (wxyz) and a rotation vector
    ``theta`` (rad, in q's body frame): the rotation ``R exp(hat(Theta))``, with
    ``exp_q(Theta) = (cos(|Theta|/2), sin(|Theta|/2) Theta / |Theta|)``."""
    qw, qx, qy, qz = q
    tx, ty, tz = theta
    angle = math.sqrt(tx * tx + ty * ty + tz * tz)
    c = math.cos(0.5 * angle)
    s = math.sin(0.5 * angle) / angle if angle > 0.0 else 0.5
    ex, ey, ez = s * tx, s * ty, s * tz
    return (
        qw * c - qx * ex - qy * ey - qz * ez,
        qw * ex + c * qx + (qy * ez - qz * ey),
        qw * ey + c * qy + (qz * ex - qx * ez),
        qw * ez + c * qz + (qx * ey - qy * ex),
    )


def dexpinv(theta: Sequence[float], w: Sequence[float], order: int = 4) -> tuple[float, float, float]:
    """``dexp_{-Theta}^{-1}(w) = w + 1/2 Theta x w + 1/12 Theta x (Theta x w) - ...``: the rate of
    ``Theta`` (rad/s) in ``R = R_0 exp(hat(Theta))`` for the body angular velocity ``w`` (rad/s),
    truncated after the ``ad^(order-2)`` term, what an RKMK method of ``order`` needs; one body."""
    if order - 2 >= len(DEXPINV_SERIES):
        raise ValueError(f"dexpinv series known to ad^{len(DEXPINV_SERIES) - 1} only (order {order})")
    tx, ty, tz = theta
    ux, uy, uz = w
    ox, oy, oz = ux, uy, uz
    for coef in DEXPINV_SERIES[1 : max(order - 1, 1)]:
        ux, uy, uz = ty * uz - tz * uy, tz * ux - tx * uz, tx * uy - ty * ux  # u <- Theta x u
        if coef != 0.0:
            ox, oy, oz = ox + coef * ux, oy + coef * uy, oz + coef * uz
    return ox, oy, oz


def rkmk_step(f: RHS, t: float, y: np.ndarray, h: float, tableau, nb: int) -> np.ndarray:
    """One RKMK step of the explicit Runge-Kutta ``tableau`` (``integrators.ButcherTableau``) from
    ``(t, y)`` with step ``h`` (s) for ``nb`` bodies in the engine's state layout (module
    docstring). The returned quaternions are unit to round-off."""
    nb3, nb7, nb10 = 3 * nb, 7 * nb, 10 * nb
    order = tableau.order
    q0 = y[nb3:nb7].reshape(nb, 4).tolist()
    k: list[np.ndarray] = []  # the right-hand sides (used for the vector components)
    kth: list[list] = []  # the algebra rates k_i^Theta: per stage, per body, 3 floats (rad/s)
    for i, ci in enumerate(tableau.c):
        yi = y
        terms = []
        for aij, kj, kthj in zip(tableau.A[i][:i], k, kth):
            if aij != 0.0:
                yi = yi + (h * aij) * kj
                terms.append((h * aij, kthj))
        if not terms:  # Theta_i = 0: the stage is at q0 and dexpinv is the identity
            kth.append(y[nb10:].reshape(nb, 3).tolist())
        else:
            theta = _combine(terms, nb)
            yi[nb3:nb7] = [x for qb, tb in zip(q0, theta) for x in exp_right(qb, tb)]
            w = yi[nb10:].reshape(nb, 3).tolist()
            kth.append([dexpinv(tb, wb, order) for tb, wb in zip(theta, w)])
        k.append(f(t + ci * h, yi))
    out = y
    terms = []
    for bi, ki, kthi in zip(tableau.b, k, kth):
        if bi != 0.0:
            out = out + (h * bi) * ki
            terms.append((h * bi, kthi))
    out = out.copy() if out is y else out
    theta = _combine(terms, nb)
    out[nb3:nb7] = [x for qb, tb in zip(q0, theta) for x in exp_right(qb, tb)]
    return out


def _combine(terms: list, nb: int) -> list[tuple[float, float, float]]:
    """``sum_j c_j r_j`` per body for ``terms = [(c_j, r_j)]``, ``r_j`` per body 3 floats."""
    out = []
    for b in range(nb):
        x = y = z = 0.0
        for c, r in terms:
            rx, ry, rz = r[b]
            x, y, z = x + c * rx, y + c * ry, z + c * rz
        out.append((x, y, z))
    return out
