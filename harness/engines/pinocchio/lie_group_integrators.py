"""Fixed-step integrators on a Pinocchio configuration Lie group.

The state is ``(q, v)`` with ``q`` on the configuration manifold and ``v`` in its tangent space;
``accel(t, q, v)`` returns the acceleration ``a = dv/dt``.

* ``rkmk4``: classical RK4 in Runge-Kutta-Munthe-Kaas form. Stage configurations are
  ``q_i = integrate(q0, Theta_i)`` with ``Theta_i = h * sum_j a_ij k_j`` in the tangent space at
  ``q0``; each stage velocity is mapped back to that tangent space with the inverse of
  ``dIntegrate`` (the right-trivialised dexp), ``k_i = dIntegrate(q0, Theta_i)^-1 v_i``.
  Fourth order in configuration and velocity. A naive version that combines the stage
  velocities without this map is only second order in orientation.
* ``euler``: semi-implicit (symplectic) Euler, ``v+ = v + h a(q, v)``, ``q+ = integrate(q, h v+)``.

``stepper(name, model)`` returns ``step(accel, t, q, v, h) -> (q, v)`` for one model
(``rkmk4_step``/``euler_step`` take the model at each call). The RK4 tableau (``RK4_A``, ``RK4_B``,
``RK4_C``) is written out stage by stage: ``a_ij`` is zero but on the subdiagonal, so
``Theta_i = h a_i,i-1 k_i-1``, and the weights are summed in the order ``b_1 k_1 + ... + b_4 k_4``.
``dIntegrate`` is solved only on the joints whose configuration space is curved (free flyer,
spherical, ...): a joint with ``nq == nv`` is a vector space (revolute, prismatic, ...), whose
``dIntegrate`` block is the identity, so ``k_i = v_i`` there (``curved_blocks``). Each solve is
LAPACK's ``dgesv`` on the block, the routine behind ``np.linalg.solve``. The numbers are those of
the tableau sums with ``np.linalg.solve`` on the whole ``dIntegrate`` matrix, to round-off (an
LU of a block-diagonal matrix factors each block on its own, and ``dIntegrate`` at Theta = 0 is
exactly the identity; SciPy's and NumPy's bundled LAPACK builds may differ in the last bits).
"""

from __future__ import annotations

import weakref
from typing import Callable

import numpy as np
import pinocchio as pin
from scipy.linalg.lapack import dgesv

from harness.engines.base import Integrator, integrator_table

Accel = Callable[[float, np.ndarray, np.ndarray], np.ndarray]

RK4_A = ((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))
RK4_B = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)
RK4_C = (0.0, 0.5, 0.5, 1.0)
ARG1 = pin.ArgumentPosition.ARG1
_BLOCKS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # model -> curved_blocks(model), for rkmk4_step


def rkmk4_step(model: pin.Model, accel: Accel, t: float, q: np.ndarray, v: np.ndarray, h: float):
    """One RKMK4 step of size ``h`` (s) from ``(q, v)`` at time ``t``; returns ``(q, v)``."""
    blocks = _BLOCKS.get(model)
    if blocks is None:
        blocks = _BLOCKS[model] = curved_blocks(model)
    return _rkmk4_stepper(model, blocks)(accel, t, q, v, h)


def euler_step(model: pin.Model, accel: Accel, t: float, q: np.ndarray, v: np.ndarray, h: float):
    """One semi-implicit Euler step; returns ``(q, v)``."""
    v_next = v + h * accel(t, q, v)
    return pin.integrate(model, q, h * v_next), v_next


def curved_blocks(model: pin.Model) -> list[tuple[int, int]]:
    """Tangent-space index ranges ``(start, stop)`` of the joints whose ``dIntegrate`` block is not
    the identity: every joint with ``nq != nv`` (free flyer, spherical, planar, unbounded revolute);
    a joint with ``nq == nv`` is a vector space. Checked once on the model at a non-zero tangent
    vector; if the identity blocks are not exactly that, the whole tangent space is one block."""
    blocks = [(jm.idx_v, jm.idx_v + jm.nv) for jm in model.joints[1:] if jm.nq != jm.nv and jm.nv > 0]
    if model.nv == 0:
        return []
    flat = np.ones(model.nv, bool)
    for a, b in blocks:
        flat[a:b] = False
    if flat.any():
        theta = 0.3 * np.cos(np.arange(1, model.nv + 1))
        J = pin.dIntegrate(model, pin.neutral(model), theta, ARG1)
        if not (np.array_equal(J[flat][:, flat], np.eye(int(flat.sum()))) and not J[flat][:, ~flat].any()
                and not J[~flat][:, flat].any()):
            return [(0, model.nv)]
    return blocks


def _rkmk4_stepper(model: pin.Model, blocks: list[tuple[int, int]] | None = None):
    """``step(accel, t, q, v, h)``: one RKMK4 step on ``model`` (module docstring); ``blocks``:
    ``curved_blocks(model)`` when known."""
    integrate, dIntegrate = pin.integrate, pin.dIntegrate
    blocks = curved_blocks(model) if blocks is None else blocks
    whole = blocks == [(0, model.nv)]
    nv = model.nv
    zero = np.zeros(nv)
    b0, b1, b2, b3 = RK4_B

    def solve(J, b):
        _, _, x, info = dgesv(J, b)
        if info > 0:
            raise np.linalg.LinAlgError("Singular matrix")
        return x

    def tangent(q, theta, v_i):
        """``dIntegrate(q, theta)^-1 v_i``: v_i itself on the flat joints (the identity block; it
        is also the identity, exactly, at theta = 0)."""
        if not blocks:
            return v_i
        J = dIntegrate(model, q, theta, ARG1)
        if whole:
            return solve(J, v_i)
        k = v_i.copy()
        for a, b in blocks:
            k[a:b] = solve(J[a:b, a:b], v_i[a:b])
        return k

    def step(accel, t, q, v, h):
        # K[i] = [kq_i; kv_i]: one array operation forms both the configuration and the velocity
        # parts of a stage (elementwise: the same numbers as two)
        K = np.empty((4, 2, nv))
        half = 0.5 * h  # h (0.5 k) = (0.5 h) k exactly
        K[0, 0] = v
        K[0, 1] = accel(t, integrate(model, q, zero), v)
        for i, (c, a) in enumerate(((half, half), (half, half), (h, h)), start=1):
            S = a * K[i - 1]  # [Theta_i; h sum_j a_ij kv_j] (a_ij zero but the subdiagonal)
            theta, v_i = S[0], v + S[1]
            K[i, 0] = tangent(q, theta, v_i)
            K[i, 1] = accel(t + c, integrate(model, q, theta), v_i)
        S = b0 * K[0]
        S += b1 * K[1]
        S += b2 * K[2]
        S += b3 * K[3]
        S *= h
        return integrate(model, q, S[0]), S[1] + v

    return step


def _euler_stepper(model: pin.Model):
    return lambda accel, t, q, v, h: euler_step(model, accel, t, q, v, h)


def stepper(name: str, model: pin.Model):
    """``step(accel, t, q, v, h) -> (q, v)``: integrator ``name`` (``METHODS``) on ``model``."""
    return _STEPPER_FACTORIES[name](model)


_STEPPER_FACTORIES = {"rkmk4": _rkmk4_stepper, "euler": _euler_stepper}
STEPPERS = {"rkmk4": rkmk4_step, "euler": euler_step}
METHODS = integrator_table(
    Integrator("rkmk4", "fixed", 4, 4, "Runge-Kutta-Munthe-Kaas RK4 on the configuration Lie group (pin.integrate, dIntegrate)"),
    Integrator("euler", "fixed", 1, 1, "semi-implicit Euler on the Lie group"),
)
